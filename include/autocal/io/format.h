// Numbers as text, the same way in every file, message and printout of autocal.
#pragma once

#include <string>
#include <vector>

namespace autocal {

/// `value` with `significant_digits` significant digits, shortest form (no trailing zeros), as
/// YAML reads it back ("0.1026645779", "1e-09", "nan", "inf").
std::string formatNumber(double value, int significant_digits = 10);

/// The current UTC time as ISO 8601, e.g. "2026-01-31T12:00:00Z" (a file's calibration date).
std::string utcNowIso8601();

/// "a, b,c" → {"a", "b", "c"}: the items of a comma-separated list, blanks trimmed, empty ones
/// dropped (list parameters given as one string, e.g. ~stages, ~vehicles).
std::vector<std::string> splitCommaList(const std::string& text);

/// A command-line option's value as a finite number; throws UsageError "<flag>: expected a
/// number, got '<text>'".
double parseNumberArg(const std::string& flag, const std::string& text);
/// The same for an integer (|value| <= 1e6).
int parseIntArg(const std::string& flag, const std::string& text);

}  // namespace autocal
