#include "autocal/io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "autocal/errors.h"

namespace autocal {
namespace fs = std::filesystem;

namespace {
std::string errnoText() { return std::strerror(errno); }
}  // namespace

void writeFileAtomically(const std::string& path, const std::string& contents,
                         const AtomicWriteOptions& options) {
  const fs::path target(path);
  if (target.filename().empty()) throw IoError("cannot write '" + path + "': not a file name");
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (fs::is_directory(target, ec))
    throw IoError("cannot write '" + path + "': it is a folder (give a file name in it)");
  if (options.create_directories) {
    fs::create_directories(dir, ec);
    if (ec) throw IoError("cannot create directory '" + dir.string() + "': " + ec.message());
  }
  std::string tmpl = (dir / ("." + target.filename().string() + ".tmpXXXXXX")).string();
  const int fd = ::mkstemp(tmpl.data());
  if (fd < 0)
    throw IoError("cannot create a temporary file in '" + dir.string() + "': " + errnoText());
  const std::string tmp = tmpl;
  auto fail = [&](const std::string& what) {
    const std::string reason = errnoText();
    ::close(fd);
    ::unlink(tmp.c_str());
    throw IoError(what + " '" + tmp + "' for '" + path + "': " + reason);
  };
  size_t written = 0;
  while (written < contents.size()) {
    const ssize_t n = ::write(fd, contents.data() + written, contents.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("cannot write");
    }
    written += static_cast<size_t>(n);
  }
  if (::fchmod(fd, 0644) != 0) fail("cannot set permissions of");
  if (::fsync(fd) != 0) fail("cannot flush");
  if (::close(fd) != 0) {
    const std::string reason = errnoText();
    ::unlink(tmp.c_str());
    throw IoError("cannot close '" + tmp + "': " + reason);
  }
  if (!options.backup_suffix.empty() && fs::exists(target, ec)) {
    fs::copy_file(target, path + options.backup_suffix, fs::copy_options::overwrite_existing, ec);
    if (ec) {
      ::unlink(tmp.c_str());
      throw IoError("cannot keep the previous '" + path + "' as '" + path + options.backup_suffix +
                    "': " + ec.message());
    }
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string reason = errnoText();
    ::unlink(tmp.c_str());
    throw IoError("cannot rename '" + tmp + "' to '" + path + "': " + reason);
  }
  // Make the rename itself durable.
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

void checkWritableFolder(const std::string& dir) {
  // Another stage may check a folder beside this one at the same time, and remove a parent both
  // created between this one's steps (ENOENT): then the check starts again.
  constexpr int kAttempts = 5;
  for (int attempt = 1;; ++attempt) {
    std::error_code ec;
    // The folders this check creates, deepest first: removed again after the probe (the stage
    // creates them when it writes), so that a check leaves the file system as it found it.
    std::vector<fs::path> created;
    for (fs::path p = fs::absolute(dir, ec); !p.empty() && !fs::exists(p, ec);
         p = p.parent_path()) {
      created.push_back(p);
      if (p == p.parent_path()) break;
    }
    const auto removeCreated = [&] {
      std::error_code ignored;  // a folder another process filled meanwhile stays
      for (const fs::path& p : created) fs::remove(p, ignored);
    };
    fs::create_directories(dir, ec);
    if (ec) {
      const std::string reason = ec.message();
      removeCreated();
      if (ec == std::errc::no_such_file_or_directory && attempt < kAttempts) continue;
      throw IoError(dir + ": cannot write here (cannot create the folder: " + reason + ")");
    }
    std::string tmpl = (fs::path(dir) / ".autocal_write_check.XXXXXX").string();
    const int fd = ::mkstemp(tmpl.data());
    if (fd < 0) {
      const int error = errno;
      const std::string reason = errnoText();
      removeCreated();
      if (error == ENOENT && attempt < kAttempts) continue;
      throw IoError(dir + ": cannot write here (" + reason + ")");
    }
    const bool wrote = ::write(fd, "x", 1) == 1;
    const std::string reason = wrote ? "" : errnoText();
    ::close(fd);
    ::unlink(tmpl.c_str());
    removeCreated();
    if (!wrote) throw IoError(dir + ": cannot write here (" + reason + ")");
    return;
  }
}

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError("cannot open '" + path + "': " + errnoText());
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw IoError("cannot read '" + path + "'");
  return ss.str();
}

}  // namespace autocal
