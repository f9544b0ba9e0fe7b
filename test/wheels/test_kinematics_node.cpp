// kinematics_node end to end (test/wheels/kinematics_node.test): the test writes a kinematics file,
// starts the node binary on it in a namespace of its own, and checks wheels_cmd against
// Duckietown's closed form, a ~trim set at run time (and a bad one refused), ~save_calibration
// (the file read back; a failing write answers false), the NaN drop, the wheels' stop and exit 0
// on SIGTERM, the defaults without a file, and exit code 3 for a malformed file. Every wait is on a
// condition; the wall-clock budgets only guard against a hung node.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <signal.h>
#include <spawn.h>
#include <std_srvs/Empty.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "autocal/exit_codes.h"
#include "autocal/io/atomic_file.h"
#include "autocal/io/format.h"
#include "autocal/wheels/kinematics.h"
#include "autocal_ros/msg_conversion.h"
#include "autocal_ros/msgs.h"
#include "support/ros_wait.h"
#include "support/test_params.h"

extern char** environ;

namespace fs = std::filesystem;
using autocal::test::spinUntil;
using autocal::test::testParam;

namespace {

constexpr double kBudgetS = 30.0;  // guard against a hung node only

/// Duckietown's inverse kinematics, written out (default baseline, radius, k; no clipping needed
/// for the commands used here).
double closedFormRight(double gain, double trim, double v, double w) {
  return (gain + trim) * (v + w * 0.1 / 2) / (0.0318 * 27.0);
}
double closedFormLeft(double gain, double trim, double v, double w) {
  return (gain - trim) * (v - w * 0.1 / 2) / (0.0318 * 27.0);
}

std::string readAll(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

fs::path tempDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("autocal_kin_node_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

/// The node binary as a child process, its output in a log file.
class NodeProcess {
 public:
  NodeProcess(const std::vector<std::string>& args, std::string log) : log_(std::move(log)) {
    std::vector<std::string> argv_s{KINEMATICS_NODE_BIN};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    if (posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~NodeProcess() {
    if (pid_ > 0 && !exited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  bool started() const { return pid_ > 0; }
  void terminate() { ::kill(pid_, SIGTERM); }
  /// True once the process has exited (then exitCode() is valid). Never blocks.
  bool exited() {
    if (exited_) return true;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      exited_ = true;
      exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }
    return exited_;
  }
  int exitCode() const { return exit_code_; }
  std::string output() const { return readAll(log_); }

 private:
  std::string log_;
  pid_t pid_ = -1;
  bool exited_ = false;
  int exit_code_ = -1;
};

/// A node under test in namespace /<veh>: the car_cmd publisher, the wheels_cmd log, the service.
class KinematicsNodeTest : public ::testing::Test {
 protected:
  void start(const std::string& veh, const fs::path& root) {
    veh_ = veh;
    root_ = root;
    node_.reset(new NodeProcess({"__ns:=/" + veh, "__name:=kinematics_node", "_veh:=" + veh,
                                 "_calibration_root:=" + root.string(), "_param_poll_s:=0.1"},
                                (root / "node.log").string()));
    ASSERT_TRUE(node_->started());
    ros::NodeHandle nh("/" + veh);
    wheels_sub_ = nh.subscribe<autocal::dtmsg::WheelsCmdStamped>(
        "wheels_driver_node/wheels_cmd", 100,
        [this](const autocal::dtmsg::WheelsCmdStamped::ConstPtr& m) { wheels_.push_back(*m); });
    car_pub_ = nh.advertise<autocal::dtmsg::Twist2DStamped>("kinematics_node/car_cmd", 10);
    ASSERT_TRUE(spinUntil(
        [&] {
          return car_pub_.getNumSubscribers() > 0 && wheels_sub_.getNumPublishers() > 0 &&
                 ros::service::exists(param("save_calibration"), false);
        },
        kBudgetS))
        << node_->output();
  }

  void TearDown() override {
    if (node_ && !node_->exited()) {
      node_->terminate();
      spinUntil([&] { return node_->exited(); }, kBudgetS);
    }
    if (HasFailure() && node_) std::cout << "---- node output:\n" << node_->output();
    if (!root_.empty()) fs::remove_all(root_);
  }

  std::string param(const std::string& name) const {
    return "/" + veh_ + "/kinematics_node/" + name;
  }

  /// Sends (v, ω) stamped `stamp` until the node answers it; the answer's duties.
  autocal::WheelDuties command(double v, double w) {
    const ros::Time stamp(++stamp_s_);
    const autocal::dtmsg::Twist2DStamped msg = autocal::ros_layer::toCarCmd({v, w}, stamp);
    const autocal::dtmsg::WheelsCmdStamped* answer = nullptr;
    ros::WallTime next_send;
    spinUntil(
        [&] {
          for (const auto& m : wheels_)
            if (m.header.stamp == stamp) answer = &m;
          if (!answer && ros::WallTime::now() >= next_send) {
            car_pub_.publish(msg);  // again: the first may go before the connection is complete
            next_send = ros::WallTime::now() + ros::WallDuration(0.2);
          }
          return answer != nullptr;
        },
        kBudgetS);
    if (!answer) {
      ADD_FAILURE() << "no wheels_cmd answered car_cmd " << v << ", " << w;
      return {NAN, NAN};
    }
    return autocal::ros_layer::fromWheelsCmd(*answer);
  }

  /// Sends (v, ω) until the duties are Duckietown's for gain and trim (a parameter set at run
  /// time applies at the next poll); false when the budget runs out.
  bool commandUntilClosedForm(double v, double w, double gain, double trim, double tol,
                              autocal::WheelDuties* last) {
    return spinUntil(
        [&] {
          *last = command(v, w);
          return std::abs(last->right - closedFormRight(gain, trim, v, w)) <= tol &&
                 std::abs(last->left - closedFormLeft(gain, trim, v, w)) <= tol;
        },
        kBudgetS);
  }

  bool save() {
    std_srvs::Empty srv;
    return ros::service::call(param("save_calibration"), srv);
  }

  std::string veh_;
  fs::path root_;
  std::unique_ptr<NodeProcess> node_;
  ros::Subscriber wheels_sub_;
  ros::Publisher car_pub_;
  std::vector<autocal::dtmsg::WheelsCmdStamped> wheels_;
  double stamp_s_ = 100.0;
};

TEST_F(KinematicsNodeTest, FileTrimRunTimeTrimSaveAndStop) {
  const double gain = testParam<double>("file_gain"), trim = testParam<double>("file_trim");
  const double new_trim = testParam<double>("new_trim"), tol = testParam<double>("duty_tolerance");
  const fs::path root = tempDir("main");
  const std::string path = autocal::wheels::kinematicsPath(root.string(), "kintest");
  fs::create_directories(fs::path(path).parent_path());
  // A Duckietown file: their keys only, as a 2017 robot has it.
  std::ofstream(path) << "baseline: 0.1\ncalibration_time: 1999-09-25-16-58-23\ngain: " << gain
                      << "\nk: 27.0\nlimit: 1.0\nradius: 0.0318\ntrim: " << trim << "\n";
  start("kintest", root);

  // The file's values are the parameters.
  double value = 0;
  ASSERT_TRUE(ros::param::get(param("trim"), value));
  EXPECT_DOUBLE_EQ(value, trim);
  ASSERT_TRUE(ros::param::get(param("omega_max"), value));
  EXPECT_DOUBLE_EQ(value, 8.0) << "a key the file lacks keeps its default";

  // car_cmd -> wheels_cmd: Duckietown's closed form with the file's trim.
  for (const auto& vw :
       {std::make_pair(0.2, 0.0), std::make_pair(0.15, 1.0), std::make_pair(-0.1, -2.0)}) {
    const autocal::WheelDuties d = command(vw.first, vw.second);
    EXPECT_NEAR(d.right, closedFormRight(gain, trim, vw.first, vw.second), tol);
    EXPECT_NEAR(d.left, closedFormLeft(gain, trim, vw.first, vw.second), tol);
  }
  EXPECT_GT(command(0.2, 0.0).right, command(0.2, 0.0).left) << "trim > 0: right faster";

  // A NaN car_cmd is dropped: the next valid one is answered, the NaN one never.
  const size_t before_nan = wheels_.size();
  const ros::Time nan_stamp(++stamp_s_);
  car_pub_.publish(autocal::ros_layer::toCarCmd({NAN, 0.0}, nan_stamp));
  command(0.1, 0.0);
  for (size_t i = before_nan; i < wheels_.size(); ++i) {
    EXPECT_NE(wheels_[i].header.stamp, nan_stamp);
    EXPECT_TRUE(std::isfinite(wheels_[i].vel_left) && std::isfinite(wheels_[i].vel_right));
  }

  // ~trim set at run time applies.
  ros::param::set(param("trim"), new_trim);
  autocal::WheelDuties d;
  EXPECT_TRUE(commandUntilClosedForm(0.2, 0.5, gain, new_trim, tol, &d))
      << "the new trim never applied: " << d.left << ", " << d.right;

  // A bad value is refused and set back; the trim in use stays.
  ros::param::set(param("trim"), 1.5);  // |trim| >= gain
  EXPECT_TRUE(spinUntil([&] { return ros::param::get(param("trim"), value) && value == new_trim; },
                        kBudgetS))
      << value;
  d = command(0.2, 0.5);
  EXPECT_NEAR(d.right, closedFormRight(gain, new_trim, 0.2, 0.5), tol);
  ros::param::set(param("k"), std::string("fast"));  // not a number
  EXPECT_TRUE(
      spinUntil([&] { return ros::param::get(param("k"), value) && value == 27.0; }, kBudgetS));

  // ~save_calibration writes the values in use, with calibration_time; the old file is kept.
  ASSERT_TRUE(save());
  const autocal::wheels::KinematicsParams saved = autocal::wheels::readKinematicsFile(path);
  EXPECT_DOUBLE_EQ(saved.trim, new_trim);
  EXPECT_DOUBLE_EQ(saved.gain, gain);
  EXPECT_TRUE(std::regex_search(
      autocal::readFile(path), std::regex(R"(calibration_time: \d{4}-\d\d-\d\d-\d\d-\d\d-\d\d\n)")))
      << autocal::readFile(path);
  EXPECT_DOUBLE_EQ(autocal::wheels::readKinematicsFile(path + ".prev").trim, trim);

  // A write that fails (the folder is now a file) answers false and leaves the node running.
  fs::remove_all(fs::path(path).parent_path());
  std::ofstream(fs::path(path).parent_path().string()) << "not a folder\n";
  EXPECT_FALSE(save());
  d = command(0.2, 0.0);
  EXPECT_NEAR(d.right, closedFormRight(gain, new_trim, 0.2, 0.0), tol);
  EXPECT_NE(node_->output().find("~save_calibration failed"), std::string::npos);

  // SIGTERM: the wheels are stopped and the node exits 0.
  ASSERT_GT(command(0.3, 0.0).left, 0.0);
  const size_t before_stop = wheels_.size();
  node_->terminate();
  EXPECT_TRUE(spinUntil(
      [&] {
        bool stopped = false;
        for (size_t i = before_stop; i < wheels_.size(); ++i)
          stopped = stopped || (wheels_[i].vel_left == 0.0f && wheels_[i].vel_right == 0.0f);
        return stopped && node_->exited();
      },
      kBudgetS));
  EXPECT_EQ(node_->exitCode(), 0);
  EXPECT_NE(node_->output().find("~trim = " + autocal::formatNumber(new_trim)), std::string::npos)
      << "the change is echoed";
}

TEST_F(KinematicsNodeTest, WithoutAFileTheDefaults) {
  const fs::path root = tempDir("nofile");
  start("kinnofile", root);
  double value = -1;
  ASSERT_TRUE(ros::param::get(param("trim"), value));
  EXPECT_EQ(value, 0.0);
  ASSERT_TRUE(ros::param::get(param("gain"), value));
  EXPECT_EQ(value, 1.0);
  const double tol = testParam<double>("duty_tolerance");
  const autocal::WheelDuties d = command(0.2, 1.0);
  EXPECT_NEAR(d.right, closedFormRight(1.0, 0.0, 0.2, 1.0), tol);
  EXPECT_NEAR(d.left, closedFormLeft(1.0, 0.0, 0.2, 1.0), tol);
  EXPECT_NE(node_->output().find("no kinematics file"), std::string::npos) << "a warning";
  EXPECT_FALSE(fs::exists(autocal::wheels::kinematicsPath(root.string(), "kinnofile")))
      << "starting never writes the file";
}

/// Runs the node to its end; its exit status and output.
int runToEnd(const std::vector<std::string>& args, const fs::path& log, std::string* out) {
  NodeProcess node(args, log.string());
  if (!node.started()) return -1;
  spinUntil([&] { return node.exited(); }, kBudgetS);
  *out = node.output();
  return node.exited() ? node.exitCode() : -1;
}

TEST(KinematicsNodeExit, MalformedFileOrParameterExitsWithBadConfiguration) {
  const int bad_config = autocal::toInt(autocal::ExitCode::kBadConfig);
  const fs::path root = tempDir("malformed");
  struct Case {
    std::string name, text, must_mention;
  };
  const std::vector<Case> cases{{"badyaml", "gain: [1.0,\n", "not valid YAML"},
                                {"unknown", "gain: 1.0\ntrimm: 0.1\n", "trimm: unknown key"},
                                {"trim", "gain: 0.5\ntrim: -0.5\n", "trim: |trim| must be < gain"}};
  for (const Case& c : cases) {
    const std::string path = autocal::wheels::kinematicsPath(root.string(), c.name);
    fs::create_directories(fs::path(path).parent_path());
    std::ofstream(path) << c.text;
    const std::string before = readAll(path);
    std::string out;
    EXPECT_EQ(runToEnd({"__ns:=/" + c.name, "__name:=kinematics_node", "_veh:=" + c.name,
                        "_calibration_root:=" + root.string()},
                       root / (c.name + ".log"), &out),
              bad_config)
        << c.name << ": " << out;
    EXPECT_NE(out.find(path), std::string::npos) << c.name << ": " << out;
    EXPECT_NE(out.find(c.must_mention), std::string::npos) << c.name << ": " << out;
    EXPECT_EQ(readAll(path), before) << "a malformed file is never replaced";
  }
  std::string out;
  EXPECT_EQ(runToEnd({"__ns:=/badpoll", "__name:=kinematics_node",
                      "_calibration_root:=" + root.string(), "_param_poll_s:=0"},
                     root / "badpoll.log", &out),
            bad_config)
      << out;
  EXPECT_NE(out.find("~param_poll_s"), std::string::npos) << out;
  fs::remove_all(root);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_kinematics_node", ros::init_options::AnonymousName);
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
