// The one table of exit codes of every autocal node and command (doc/calibration_run.md "Exit
// codes"): each typed error of the core maps to one code, so that a launch file, a CI script or a
// person can tell a refused calibration from bad input or a bad parameter without reading the log.
#pragma once

#include <exception>
#include <functional>
#include <string>

namespace autocal {

enum class ExitCode : int {
  kOk = 0,                 ///< the result was written (or the node ended as asked)
  kCalibrationFailed = 1,  ///< CalibrationError: not determined by the data, or refused by the gate
  kBadInput = 2,           ///< InputError: unusable images, bags, measurements, silent sensors
  kBadConfig = 3,          ///< ConfigError: a bad or missing parameter or configuration file
  kIoError = 4,            ///< IoError: a file could not be read or written
  kUsage = 64,             ///< UsageError: bad command line (sysexits EX_USAGE)
  kInternal = 70,          ///< any other exception: a bug (sysexits EX_SOFTWARE)
  kInterrupted = 130,      ///< SIGINT or SIGTERM before the end (128 + SIGINT)
};

/// The code of an exception (by its autocal::Error type; kInternal for anything else).
ExitCode exitCodeFor(const std::exception& error);

/// One word for the code, as doc/calibration_run.md's table and log lines name it ("calibration
/// failed").
std::string exitCodeMeaning(ExitCode code);

inline int toInt(ExitCode code) { return static_cast<int>(code); }

/// Runs a command's body and catches every exception once: prints "<name>: <meaning>: <what>" on
/// stderr (and `usage` after a UsageError) and returns the code of the table; otherwise returns
/// what the body returns.
int runCommand(const std::string& name, const std::function<int()>& body,
               const std::string& usage = "");

}  // namespace autocal
