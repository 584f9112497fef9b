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
#include <optional>
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

// Creates `path` holding `data` only if no entry of that name exists: a
// complete temp file is link(2)ed to the name, so of two processes creating
// the same file at once exactly one wins, and the name never shows a partial
// file. Returns false (and leaves the entry alone) when the name exists, a
// symlink included. Throws std::runtime_error naming the path otherwise.
bool create_file_exclusive(const std::string& path, const std::string& data);

// ---- Received directories (a sweep's, a run's): data, never followed.
// A path `rel` below a trusted `base` (the directory the user named) is
// opened one component at a time with O_NOFOLLOW: a symbolic link anywhere
// below `base` is refused, never followed; files are opened O_NONBLOCK and
// must be regular (a FIFO never blocks, /dev/zero is never read).

// The first component of `rel` below `base` that is a symbolic link (or,
// short of the last one, not a directory), as a relative path; "" when
// there is none. Components that do not exist end the walk.
std::string linked_component(const std::string& base, const std::string& rel);

// Throws std::invalid_argument "<what> '<base>': '<component>' is a symbolic
// link (...)" when linked_component() finds one.
void require_no_links(const std::string& base, const std::string& rel, const std::string& what);

// Opens base/rel with `flags` (| O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK) through
// no symlink and checks that it is a regular file. Returns the descriptor,
// or -1 with *why set to what the file is ("does not exist", "is a symbolic
// link", "is not a regular file (a FIFO, device or directory)", "cannot be
// opened: <the system's reason>").
int open_below(const std::string& base, const std::string& rel, int flags, std::string* why, unsigned mode = 0644);

// The bytes of the regular file base/rel, at most max_bytes of them: a larger
// file is refused ("is N bytes, more than the limit of M"), unless
// `tail` (then its last max_bytes are returned). nullopt with *why set when
// it cannot be read (open_below's reasons).
std::optional<std::string> read_below(const std::string& base, const std::string& rel, size_t max_bytes,
                                      std::string* why = nullptr, bool tail = false);

// True when base/rel is a regular file reached through no symlink (lstat).
bool regular_file_below(const std::string& base, const std::string& rel);

// Crash-consistency tests only: after arm_kill_at_write(n) the n-th
// write_file_atomic of this process (counted from the call) kills the
// process with SIGKILL once its temp file is written, before the rename:
// the files on disk are those of a kill at any moment after write n-1, plus
// a leftover temp file. n <= 0 disarms. `atacom train` arms it from the
// environment variable ATACOM_TEST_KILL_AT_WRITE (tests/test_sweep.cpp).
void arm_kill_at_write(long n);

}  // namespace atacom
