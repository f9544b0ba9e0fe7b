// Atomic file writes: a calibration file is either the old one or the complete new one, never a
// half-written mix, and the previous version is kept beside it.
#pragma once

#include <string>

namespace autocal {

struct AtomicWriteOptions {
  /// Keep the file being replaced as `<path><backup_suffix>` (empty: keep nothing).
  std::string backup_suffix = ".prev";
  /// Create missing parent directories.
  bool create_directories = true;
};

/// Writes `contents` to `path` through a temporary file in the same directory, flushed to disk
/// and renamed over the target. Throws IoError when any step fails; the target is then untouched.
void writeFileAtomically(const std::string& path, const std::string& contents,
                         const AtomicWriteOptions& options = AtomicWriteOptions());

/// Whether files can be written in `dir`: creates it (and its parents) if missing, writes and
/// removes a probe file in it, then removes the folders it created. A stage checks its output
/// folder so before the robot moves. Throws IoError "<dir>: cannot write here (<reason>)" when it
/// cannot.
void checkWritableFolder(const std::string& dir);

/// Reads a whole file; throws IoError naming the path when it cannot.
std::string readFile(const std::string& path);

}  // namespace autocal
