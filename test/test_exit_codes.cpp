// The one exit-code table: each typed error maps to its own code, and runCommand catches every
// exception once.
#include <gtest/gtest.h>

#include <set>
#include <stdexcept>

#include "autocal/errors.h"
#include "autocal/exit_codes.h"

using namespace autocal;

TEST(ExitCodes, EachErrorTypeHasItsOwnCode) {
  EXPECT_EQ(exitCodeFor(CalibrationError("x")), ExitCode::kCalibrationFailed);
  EXPECT_EQ(exitCodeFor(InputError("x")), ExitCode::kBadInput);
  EXPECT_EQ(exitCodeFor(ConfigError("x")), ExitCode::kBadConfig);
  EXPECT_EQ(exitCodeFor(IoError("x")), ExitCode::kIoError);
  EXPECT_EQ(exitCodeFor(UsageError("x")), ExitCode::kUsage);
  EXPECT_EQ(exitCodeFor(std::runtime_error("x")), ExitCode::kInternal);
  std::set<int> codes;
  for (ExitCode c :
       {ExitCode::kOk, ExitCode::kCalibrationFailed, ExitCode::kBadInput, ExitCode::kBadConfig,
        ExitCode::kIoError, ExitCode::kUsage, ExitCode::kInternal, ExitCode::kInterrupted}) {
    EXPECT_TRUE(codes.insert(toInt(c)).second) << exitCodeMeaning(c);
    EXPECT_NE(exitCodeMeaning(c), "unknown");
  }
}

TEST(ExitCodes, RunCommandCatchesOnceAndReturnsTheCode) {
  EXPECT_EQ(runCommand("t", [] { return 0; }), 0);
  EXPECT_EQ(runCommand("t", []() -> int { throw InputError("corrupt"); }), 2);
  EXPECT_EQ(runCommand(
                "t", []() -> int { throw UsageError("--x"); }, "usage\n"),
            64);
  EXPECT_EQ(runCommand("t", []() -> int { throw std::logic_error("bug"); }), 70);
  EXPECT_EQ(runCommand("t", []() -> int { throw 42; }), 70);
}
