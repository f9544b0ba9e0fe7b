#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <thread>

#include "autocal/errors.h"
#include "autocal/io/atomic_file.h"

namespace fs = std::filesystem;

namespace {

class AtomicFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("autocal_atomic_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(AtomicFileTest, WritesNewFileCreatingDirectories) {
  const std::string path = (dir_ / "a" / "b" / "x.yaml").string();
  autocal::writeFileAtomically(path, "hello\n");
  EXPECT_EQ(autocal::readFile(path), "hello\n");
  EXPECT_FALSE(fs::exists(path + ".prev"));
}

TEST_F(AtomicFileTest, KeepsPreviousVersionAndLeavesNoTemporaryFiles) {
  const std::string path = (dir_ / "x.yaml").string();
  autocal::writeFileAtomically(path, "one");
  autocal::writeFileAtomically(path, "two");
  EXPECT_EQ(autocal::readFile(path), "two");
  EXPECT_EQ(autocal::readFile(path + ".prev"), "one");
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 2);
}

TEST_F(AtomicFileTest, UnwritableDirectoryThrowsAndKeepsTarget) {
  if (::geteuid() == 0) {
    // root ignores directory permissions; use a path whose parent is a regular file instead.
    fs::create_directories(dir_);
    autocal::writeFileAtomically((dir_ / "file").string(), "x");
    EXPECT_THROW(autocal::writeFileAtomically((dir_ / "file" / "y.yaml").string(), "y"),
                 autocal::IoError);
    EXPECT_EQ(autocal::readFile((dir_ / "file").string()), "x");
    return;
  }
  fs::create_directories(dir_);
  const std::string path = (dir_ / "x.yaml").string();
  autocal::writeFileAtomically(path, "good");
  ::chmod(dir_.c_str(), 0555);
  EXPECT_THROW(autocal::writeFileAtomically(path, "bad"), autocal::IoError);
  ::chmod(dir_.c_str(), 0755);
  EXPECT_EQ(autocal::readFile(path), "good");
}

TEST_F(AtomicFileTest, AFolderAsTheTargetIsNamed) {
  fs::create_directories(dir_ / "cal");
  try {
    autocal::writeFileAtomically((dir_ / "cal").string(), "x");
    FAIL() << "no error";
  } catch (const autocal::IoError& e) {
    EXPECT_NE(std::string(e.what()).find("it is a folder"), std::string::npos) << e.what();
  }
}

TEST_F(AtomicFileTest, WritableFolderCheckLeavesNothing) {
  const fs::path out = dir_ / "cal" / "kinematics";
  fs::create_directories(dir_);
  autocal::checkWritableFolder(out.string());
  EXPECT_FALSE(fs::exists(dir_ / "cal")) << "the folders the check created are gone";
  fs::create_directories(out);
  autocal::checkWritableFolder(out.string());
  EXPECT_TRUE(fs::is_directory(out)) << "a folder that was there stays";
  EXPECT_TRUE(fs::is_empty(out));
  // Folders no one can write, even root: under /proc, and under a regular file.
  fs::create_directories(dir_);
  autocal::writeFileAtomically((dir_ / "file").string(), "x");
  for (const std::string& bad :
       {std::string("/proc/autocal_check/kinematics"), (dir_ / "file" / "kinematics").string()}) {
    try {
      autocal::checkWritableFolder(bad);
      FAIL() << bad << ": no error";
    } catch (const autocal::IoError& e) {
      EXPECT_NE(std::string(e.what()).find(bad + ": cannot write here"), std::string::npos)
          << e.what();
    }
  }
}

// Two stages start together and check their folders under one root that does not exist yet
// (replay.test's cut replay: the camera and wheel nodes, calibration_root removed just before):
// one check removes the root it created while the other is creating its folder in it.
TEST_F(AtomicFileTest, TwoChecksUnderOneMissingRootBothPass) {
  const std::filesystem::path root = dir_ / "race";
  for (int round = 0; round < 200; ++round) {
    std::filesystem::remove_all(root);
    std::string failure;
    std::thread other([&] {
      try {
        autocal::checkWritableFolder((root / "camera_intrinsic").string());
      } catch (const std::exception& e) {
        failure = e.what();
      }
    });
    EXPECT_NO_THROW(autocal::checkWritableFolder((root / "kinematics").string()));
    other.join();
    EXPECT_EQ(failure, "");
  }
  // The root may stay: a check leaves a folder it created that the other one filled meanwhile.
}

TEST_F(AtomicFileTest, ReadMissingFileThrows) {
  EXPECT_THROW(autocal::readFile((dir_ / "missing").string()), autocal::IoError);
}

}  // namespace
