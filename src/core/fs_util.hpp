// Files a run leaves behind are written atomically: temp file, fsync, rename,
// fsync of the directory (so the new name survives a power loss too).
// A crash mid-write never leaves a half-written result or checkpoint.
//
// Hostile directories: the temp file `<file>.tmp.<pid>.<6 random chars>` is
// created in the target's directory with O_CREAT | O_EXCL | O_NOFOLLOW
// (mkostemp), so a file or symlink planted under any temp name is never
// opened, followed or truncated; rename() then replaces the target entry
// itself, so a symlink planted at the target is replaced, not written
// through. Temp files a killed process left behind are removed by
// remove_stale_temp_files() when the same run starts again.
#pragma once
#include <string>

namespace atacom {

// Writes `data` to `path` atomically. Throws std::runtime_error naming the path.
void write_file_atomic(const std::string& path, const std::string& data);

// Removes temp files of write_file_atomic left in directory `dir` by
// processes that no longer run (names `<file>.tmp.<pid>` or
// `<file>.tmp.<pid>.<suffix>`, regular files or symlinks; symlinks are
// unlinked, never followed). Call it when a run starts, before this process
// writes in `dir`: files with this process's own pid count as leftovers (of
// an earlier process with the same pid); those of another live process and
// everything else are left alone. A missing directory is not an error.
// Returns how many files it removed.
int remove_stale_temp_files(const std::string& dir);

// Crash-consistency tests only: after arm_kill_at_write(n) the n-th
// write_file_atomic of this process (counted from the call) kills the
// process with SIGKILL once its temp file is written, before the rename:
// the files on disk are those of a kill at any moment after write n-1, plus
// a leftover temp file. n <= 0 disarms. `atacom train` arms it from the
// environment variable ATACOM_TEST_KILL_AT_WRITE (tests/test_sweep.cpp).
void arm_kill_at_write(long n);

}  // namespace atacom
