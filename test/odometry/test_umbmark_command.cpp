// The `umbmark` command, run as a process: good input prints the YAML result and writes the
// odometry file; bad input gives a clear message, a non-zero exit and leaves the file alone.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "autocal/io/atomic_file.h"

namespace fs = std::filesystem;

namespace {

struct Result {
  int exit_code;
  std::string output;  // stdout and stderr
};

Result run(const std::string& args) {
  const std::string command = std::string(UMBMARK_BINARY) + " " + args + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return {-1, "popen failed"};
  std::string out;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) out.append(buf.data(), n);
  const int status = ::pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

class UmbmarkCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("autocal_umbmark_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string file(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }
  fs::path dir_;
  const std::string example_ =
      std::string(AUTOCAL_SOURCE_DIR) + "/config/umbmark_errors_example.yaml";
};

TEST_F(UmbmarkCommand, PrintsYamlAndWritesTheOdometryFile) {
  const std::string out = (dir_ / "odometry" / "testbot.yaml").string();
  const Result r =
      run("--errors " + example_ + " --side 1.0 --wheelbase 0.102 --out " + out + " --veh testbot");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* key :
       {"expressions: corrected", "Ed: ", "Eb: ", "alpha_rad: ", "beta_rad: ", "R_m: ",
        "E_max_syst_m: ", "c_L: ", "c_R: ", "wheel_separation_multiplier: ", "written: "}) {
    EXPECT_NE(r.output.find(key), std::string::npos) << key << "\n" << r.output;
  }
  const std::string written = autocal::readFile(out);
  for (const char* key :
       {"method: umbmark", "vehicle: testbot", "Ed: ", "Eb: ", "b: ", "c_L: ", "c_R: ",
        "left_wheel_radius_multiplier: ", "date: ", "inputs:", "side_m: 1"}) {
    EXPECT_NE(written.find(key), std::string::npos) << key << "\n" << written;
  }
}

TEST_F(UmbmarkCommand, OriginalExpressionsAreSelectable) {
  const Result r = run("--errors " + example_ +
                       " --side 1.0 --wheelbase 0.102 --expressions "
                       "original");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("expressions: original"), std::string::npos) << r.output;
}

TEST_F(UmbmarkCommand, BadInputFailsClearlyAndKeepsTheGoodFile) {
  const std::string out = (dir_ / "odometry" / "testbot.yaml").string();
  fs::create_directories(dir_ / "odometry");
  std::ofstream(out) << "good: file\n";
  const std::string tail = " --out " + out + " --veh testbot";
  struct Case {
    std::string args, needle;
  };
  const Case cases[] = {
      {"--errors " + file("empty.yaml", "cw: []\nccw: [[0.01, 0.02]]\n") +
           " --side 1 --wheelbase 0.1",
       "cw: the list is empty"},
      {"--errors " + file("onesided.yaml", "cw: [[0.01, 0.02]]\n") + " --side 1 --wheelbase 0.1",
       "ccw: missing"},
      {"--errors " + file("nonnum.yaml", "cw: [[0.01, x]]\nccw: [[0.01, 0.02]]\n") +
           " --side 1 --wheelbase 0.1",
       "expected numbers, got 'x'"},
      {"--errors " + example_ + " --side 0 --wheelbase 0.1", "side"},
      {"--errors " + example_ + " --side 1 --wheelbase -0.1", "wheelbase"},
      {"--errors " + example_ + " --side abc --wheelbase 0.1", "--side: expected a number"},
      {"--errors " + file("beta0.yaml", "cw: [[-0.05, -0.05]]\nccw: [[-0.05, 0.05]]\n") +
           " --side 1 --wheelbase 0.1",
       "unbounded"},
      {"--errors " + (dir_ / "missing.yaml").string() + " --side 1 --wheelbase 0.1", "cannot open"},
      {"--errors " + example_ + " --side 1 --wheelbase 0.1 --expressions new", "expressions"},
  };
  for (const Case& c : cases) {
    const Result r = run(c.args + tail);
    EXPECT_NE(r.exit_code, 0) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.needle), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_EQ(autocal::readFile(out), "good: file\n") << c.args;
  }
}

}  // namespace
