#include "autocal/exit_codes.h"

#include <iostream>

#include "autocal/errors.h"

namespace autocal {

ExitCode exitCodeFor(const std::exception& error) {
  if (dynamic_cast<const UsageError*>(&error)) return ExitCode::kUsage;
  if (dynamic_cast<const CalibrationError*>(&error)) return ExitCode::kCalibrationFailed;
  if (dynamic_cast<const InputError*>(&error)) return ExitCode::kBadInput;
  if (dynamic_cast<const ConfigError*>(&error)) return ExitCode::kBadConfig;
  if (dynamic_cast<const IoError*>(&error)) return ExitCode::kIoError;
  return ExitCode::kInternal;
}

std::string exitCodeMeaning(ExitCode code) {
  switch (code) {
    case ExitCode::kOk:
      return "success";
    case ExitCode::kCalibrationFailed:
      return "calibration failed";
    case ExitCode::kBadInput:
      return "bad input";
    case ExitCode::kBadConfig:
      return "bad configuration";
    case ExitCode::kIoError:
      return "file error";
    case ExitCode::kUsage:
      return "bad command line";
    case ExitCode::kInternal:
      return "internal error";
    case ExitCode::kInterrupted:
      return "interrupted";
  }
  return "unknown";
}

int runCommand(const std::string& name, const std::function<int()>& body,
               const std::string& usage) {
  try {
    return body();
  } catch (const std::exception& e) {
    const ExitCode code = exitCodeFor(e);
    std::cerr << name << ": " << exitCodeMeaning(code) << ": " << e.what() << "\n";
    if (code == ExitCode::kUsage) std::cerr << usage;
    return toInt(code);
  } catch (...) {
    std::cerr << name << ": " << exitCodeMeaning(ExitCode::kInternal) << ": unknown exception\n";
    return toInt(ExitCode::kInternal);
  }
}

}  // namespace autocal
