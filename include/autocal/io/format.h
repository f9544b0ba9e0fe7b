// Numbers as text, the same way in every file, message and printout of autocal.
#pragma once

#include <string>

namespace autocal {

/// `value` with `significant_digits` significant digits, shortest form (no trailing zeros), as
/// YAML reads it back ("0.1026645779", "1e-09", "nan", "inf").
std::string formatNumber(double value, int significant_digits = 10);

}  // namespace autocal
