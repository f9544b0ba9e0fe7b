#include "autocal/io/format.h"

#include <sstream>

namespace autocal {

std::string formatNumber(double value, int significant_digits) {
  std::ostringstream ss;
  ss.precision(significant_digits);
  ss << value;
  return ss.str();
}

std::vector<std::string> splitCommaList(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

}  // namespace autocal
