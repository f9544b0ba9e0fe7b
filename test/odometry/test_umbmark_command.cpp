// The `umbmark` command, run as a process: good input prints the YAML result and writes the
// odometry file; bad input gives a clear message, a non-zero exit and leaves the file alone.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "autocal/exit_codes.h"
#include "autocal/io/atomic_file.h"
#include "autocal/odometry/umbmark.h"

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

// What the command prints and writes are the core's numbers for the same input (each field by
// name: swapped c_L and c_R would fail).
TEST_F(UmbmarkCommand, PrintsAndWritesTheCoresNumbers) {
  const std::string out = (dir_ / "odometry" / "testbot.yaml").string();
  const Result r =
      run("--errors " + example_ + " --side 1.0 --wheelbase 0.102 --out " + out + " --veh testbot");
  ASSERT_EQ(r.exit_code, 0) << r.output;

  using namespace autocal::odometry;
  std::vector<ReturnError> cw, ccw;
  loadUmbmarkErrors(example_, &cw, &ccw);
  UmbmarkOptions options;
  options.side_m = 1.0;
  options.wheelbase_m = 0.102;
  const UmbmarkResult expected = computeUmbmark(cw, ccw, options);
  ASSERT_GT(std::abs(expected.left_pulse_factor - expected.right_pulse_factor), 1e-4)
      << "the example must tell the wheels apart";

  const YAML::Node printed = YAML::Load(r.output);
  EXPECT_EQ(printed["expressions"].as<std::string>(), "corrected");
  EXPECT_EQ(printed["runs_cw"].as<int>(), static_cast<int>(cw.size()));
  const double tol = 1e-8;
  EXPECT_NEAR(printed["Ed"].as<double>(), expected.Ed, tol);
  EXPECT_NEAR(printed["Eb"].as<double>(), expected.Eb, tol);
  EXPECT_NEAR(printed["alpha_rad"].as<double>(), expected.alpha_rad, tol);
  EXPECT_NEAR(printed["beta_rad"].as<double>(), expected.beta_rad, tol);
  EXPECT_NEAR(printed["E_max_syst_m"].as<double>(), expected.E_max_syst_m, tol);
  EXPECT_NEAR(printed["c_L"].as<double>(), expected.left_pulse_factor, tol);
  EXPECT_NEAR(printed["c_R"].as<double>(), expected.right_pulse_factor, tol);
  EXPECT_NEAR(printed["left_wheel_radius_multiplier"].as<double>(), expected.left_pulse_factor,
              tol);
  EXPECT_NEAR(printed["right_wheel_radius_multiplier"].as<double>(), expected.right_pulse_factor,
              tol);
  EXPECT_NEAR(printed["wheel_separation_multiplier"].as<double>(), expected.Eb, tol);
  EXPECT_EQ(printed["written"].as<std::string>(), out);

  const YAML::Node written = YAML::LoadFile(out);
  EXPECT_EQ(written["method"].as<std::string>(), "umbmark");
  EXPECT_EQ(written["vehicle"].as<std::string>(), "testbot");
  EXPECT_NEAR(written["Ed"].as<double>(), expected.Ed, tol);
  EXPECT_NEAR(written["b"].as<double>(), expected.wheelbase_actual_m, tol);
  EXPECT_NEAR(written["b_nominal"].as<double>(), 0.102, tol);
  EXPECT_NEAR(written["c_L"].as<double>(), expected.left_pulse_factor, tol);
  EXPECT_NEAR(written["c_R"].as<double>(), expected.right_pulse_factor, tol);
  EXPECT_NEAR(written["inputs"]["side_m"].as<double>(), 1.0, tol);
  EXPECT_FALSE(written["date"].as<std::string>().empty());
}

TEST_F(UmbmarkCommand, OriginalExpressionsAreSelectable) {
  const Result r = run("--errors " + example_ +
                       " --side 1.0 --wheelbase 0.102 --expressions "
                       "original");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(YAML::Load(r.output)["expressions"].as<std::string>(), "original") << r.output;
}

TEST_F(UmbmarkCommand, BadInputFailsClearlyAndKeepsTheGoodFile) {
  const std::string out = (dir_ / "odometry" / "testbot.yaml").string();
  fs::create_directories(dir_ / "odometry");
  std::ofstream(out) << "good: file\n";
  const std::string tail = " --out " + out + " --veh testbot";
  struct Case {
    std::string args, needle;
    autocal::ExitCode code;
  };
  using autocal::ExitCode;
  const Case cases[] = {
      {"--errors " + file("empty.yaml", "cw: []\nccw: [[0.01, 0.02]]\n") +
           " --side 1 --wheelbase 0.1",
       "cw: the list is empty", ExitCode::kBadInput},
      {"--errors " + file("onesided.yaml", "cw: [[0.01, 0.02]]\n") + " --side 1 --wheelbase 0.1",
       "ccw: missing", ExitCode::kBadInput},
      {"--errors " + file("nonnum.yaml", "cw: [[0.01, x]]\nccw: [[0.01, 0.02]]\n") +
           " --side 1 --wheelbase 0.1",
       "cw[0][1]: expected a number, got 'x'", ExitCode::kBadInput},
      {"--errors " + file("triple.yaml", "cw: [[0.01, 0.02, 0.03]]\nccw: [[0.01, 0.02]]\n") +
           " --side 1 --wheelbase 0.1",
       "expected a pair", ExitCode::kBadInput},
      {"--errors " + example_ + " --side 0 --wheelbase 0.1", "side_m", ExitCode::kBadConfig},
      {"--errors " + example_ + " --side 1 --wheelbase -0.1", "wheelbase_m", ExitCode::kBadConfig},
      // A unit slip: the option, the range and the likely unit.
      {"--errors " + example_ + " --side 1 --wheelbase 102",
       "--wheelbase 102: the wheelbase of a robot of this size is 0.05-0.5 m; 102 looks like "
       "millimetres (0.102 m)",
       ExitCode::kBadConfig},
      {"--errors " + example_ + " --side 100 --wheelbase 0.1", "100 looks like centimetres (1 m)",
       ExitCode::kBadConfig},
      {"--errors " + example_ + " --side abc --wheelbase 0.1", "--side: expected a number",
       ExitCode::kUsage},
      {"--errors " + example_ + " --side 1", "--wheelbase", ExitCode::kUsage},
      {"--errors " + file("beta0.yaml", "cw: [[-0.05, -0.05]]\nccw: [[-0.05, 0.05]]\n") +
           " --side 1 --wheelbase 0.1",
       "unbounded", ExitCode::kCalibrationFailed},
      {"--errors " + (dir_ / "missing.yaml").string() + " --side 1 --wheelbase 0.1", "cannot open",
       ExitCode::kBadInput},
      {"--errors " + example_ + " --side 1 --wheelbase 0.1 --expressions new", "expressions",
       ExitCode::kBadConfig},
  };
  for (const Case& c : cases) {
    const Result r = run(c.args + tail);
    EXPECT_EQ(r.exit_code, autocal::toInt(c.code)) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.needle), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_EQ(autocal::readFile(out), "good: file\n") << c.args;
  }
}

}  // namespace
