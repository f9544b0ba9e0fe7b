#include "autocal/physical_range.h"

#include <cmath>

#include "autocal/io/format.h"

namespace autocal {

std::string outOfRange(const std::string& option, double value_m, const PhysicalRange& range) {
  if (!std::isfinite(value_m) || value_m <= 0) return {};
  if (value_m >= range.min_m && value_m <= range.max_m) return {};
  std::string text = option + " " + formatNumber(value_m, 6) + ": " + range.what +
                     " of a robot of this size is " + formatNumber(range.min_m, 3) + "-" +
                     formatNumber(range.max_m, 3) + " m";
  struct Unit {
    double per_m;
    const char* name;
  };
  for (const Unit u :
       {Unit{1000, "millimetres"}, Unit{100, "centimetres"}, Unit{10, "decimetres"}}) {
    const double m = value_m / u.per_m;
    if (m >= range.min_m && m <= range.max_m) {
      return text + "; " + formatNumber(value_m, 6) + " looks like " + u.name + " (" +
             formatNumber(m, 6) + " m): give metres";
    }
  }
  return text;
}

}  // namespace autocal
