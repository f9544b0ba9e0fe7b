#include "autocal/io/format.h"

#include <sstream>

namespace autocal {

std::string formatNumber(double value, int significant_digits) {
  std::ostringstream ss;
  ss.precision(significant_digits);
  ss << value;
  return ss.str();
}

}  // namespace autocal
