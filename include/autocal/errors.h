// Typed errors of the autocal core. The core throws them with a message a user can act on; a node
// or command catches them once, logs, stops the wheels, reports FAILED and exits non-zero.
#pragma once

#include <stdexcept>
#include <string>

namespace autocal {

/// Base of every error the core throws on purpose.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(what) {}
};

/// A configuration file or parameter is missing, malformed or out of range.
class ConfigError : public Error {
 public:
  using Error::Error;
};

/// Input data (images, bags, measurements) cannot be used.
class InputError : public Error {
 public:
  using Error::Error;
};

/// A calibration ran but its result failed the quality gate or is not determined by the data.
class CalibrationError : public Error {
 public:
  using Error::Error;
};

/// Reading or writing a file failed.
class IoError : public Error {
 public:
  using Error::Error;
};

/// Throws ConfigError "<key>: <what>" unless `ok`: how an options struct's validate() names the
/// first bad key.
inline void checkConfig(bool ok, const std::string& key, const std::string& what) {
  if (!ok) throw ConfigError(key + ": " + what);
}

/// A command was called with options it does not understand (exit code 64).
class UsageError : public Error {
 public:
  using Error::Error;
};

}  // namespace autocal
