#include "autocal/io/format.h"

#include <cmath>
#include <ctime>
#include <sstream>

#include "autocal/errors.h"

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

double parseNumberArg(const std::string& flag, const std::string& text) {
  size_t used = 0;
  double v = NAN;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !std::isfinite(v)) {
    throw UsageError(flag + ": expected a number, got '" + text + "'");
  }
  return v;
}

int parseIntArg(const std::string& flag, const std::string& text) {
  const double v = parseNumberArg(flag, text);
  if (v != std::floor(v) || std::abs(v) > 1e6) {
    throw UsageError(flag + ": expected an integer, got '" + text + "'");
  }
  return static_cast<int>(v);
}

std::string utcNowIso8601() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace autocal
