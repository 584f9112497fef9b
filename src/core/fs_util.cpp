#include "src/core/fs_util.hpp"

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string_view>
#include <vector>
#include <algorithm>
#include <optional>

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace atacom {

namespace {

// "<anything>.tmp.<pid>" or "<anything>.tmp.<pid>.<suffix without dots>": the pid, else 0.
long temp_file_pid(std::string_view name) {
  const size_t at = name.rfind(".tmp.");
  if (at == std::string_view::npos || at == 0) return 0;
  std::string_view rest = name.substr(at + 5);
  const size_t dot = rest.find('.');
  const std::string_view pid = rest.substr(0, dot);
  if (dot != std::string_view::npos) {
    const std::string_view suffix = rest.substr(dot + 1);
    if (suffix.empty() || suffix.find('.') != std::string_view::npos) return 0;
  }
  if (pid.empty() || pid.size() > 9) return 0;
  long v = 0;
  for (char c : pid) {
    if (c < '0' || c > '9') return 0;
    v = v * 10 + (c - '0');
  }
  return v;
}

// This process counts as dead: the caller starts a run in `dir` and has no
// write in flight there, so a file with its pid is a leftover of an earlier
// process that had the same pid (pids repeat across containers and reboots).
bool process_alive(long pid) {
  if (pid <= 0 || pid == long(::getpid())) return false;
  if (::kill(pid_t(pid), 0) != 0 && errno != EPERM) return false;
  // A killed process nobody has reaped yet (a container's init often does
  // not) still answers kill(0): it is a zombie, state 'Z' in /proc, and dead.
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  if (!std::getline(stat, text)) return true;
  const size_t paren = text.rfind(')');
  return !(paren != std::string::npos && paren + 2 < text.size() && text[paren + 2] == 'Z');
}

std::atomic<long> g_kill_at_write{0}, g_writes{0};

// The directory entry a rename made survives a power loss only once the
// directory itself is synced (a file's fsync covers its data, not its name).
void fsync_parent_dir(const std::string& path) {
  const size_t slash = path.rfind('/');
  const std::string dir = slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0) return;  // the rename is done; durability of the name is best effort here
  const int rc = ::fsync(dfd);
  const int err = errno;
  ::close(dfd);
  if (rc != 0 && err != EINVAL && err != EROFS) {
    errno = err;
    throw std::runtime_error("cannot write '" + path + "': fsync of its directory: " + std::strerror(err));
  }
}

}  // namespace

void arm_kill_at_write(long n) {
  g_writes.store(0);
  g_kill_at_write.store(n > 0 ? n : 0);
}

void write_file_atomic(const std::string& path, const std::string& data) {
  std::string tmp = path + ".tmp." + std::to_string(::getpid()) + ".XXXXXX";
  bool created = false;
  auto fail = [&](const std::string& what) {
    const std::string err = std::strerror(errno);
    if (created) ::unlink(tmp.c_str());
    throw std::runtime_error("cannot write '" + path + "': " + what + ": " + err);
  };
  // mkostemp opens with O_CREAT | O_EXCL (never follows or reuses an entry);
  // O_NOFOLLOW is implied by O_EXCL for the last component.
  const int fd = ::mkostemp(tmp.data(), O_CLOEXEC);
  if (fd < 0) fail("create temp file");
  created = true;
  if (::fchmod(fd, 0644) != 0) {
    ::close(fd);
    fail("chmod temp file");
  }
  size_t off = 0;
  while (off < data.size()) {
    const ssize_t w = ::write(fd, data.data() + off, data.size() - off);
    if (w < 0) {
      if (errno == EINTR) continue;
      ::close(fd);
      fail("write");
    }
    off += static_cast<size_t>(w);
  }
  if (::fsync(fd) != 0) {
    ::close(fd);
    fail("fsync");
  }
  if (::close(fd) != 0) fail("close");
  if (const long k = g_kill_at_write.load(); k > 0 && g_writes.fetch_add(1) + 1 == k) ::raise(SIGKILL);
  if (::rename(tmp.c_str(), path.c_str()) != 0) fail("rename");
  fsync_parent_dir(path);
}

bool create_file_exclusive(const std::string& path, const std::string& data) {
  std::string tmp = path + ".tmp." + std::to_string(::getpid()) + ".XXXXXX";
  const int fd = ::mkostemp(tmp.data(), O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("cannot write '" + path + "': create temp file: " + std::strerror(errno));
  auto fail = [&](const std::string& what) {
    const std::string err = std::strerror(errno);
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot write '" + path + "': " + what + ": " + err);
  };
  bool ok = ::fchmod(fd, 0644) == 0;
  for (size_t off = 0; ok && off < data.size();) {
    const ssize_t w = ::write(fd, data.data() + off, data.size() - off);
    if (w < 0 && errno == EINTR) continue;
    ok = w >= 0;
    if (ok) off += size_t(w);
  }
  ok = ok && ::fsync(fd) == 0;
  if (::close(fd) != 0) ok = false;
  if (!ok) fail("write");
  // link(2) never replaces an entry: the first of two racing creators wins, whole.
  if (::link(tmp.c_str(), path.c_str()) != 0) {
    if (errno == EEXIST) {
      ::unlink(tmp.c_str());
      return false;
    }
    fail("link");
  }
  ::unlink(tmp.c_str());
  fsync_parent_dir(path);
  return true;
}

namespace {

// The components of a relative path; nullopt when one is ".." or the path is absolute.
std::optional<std::vector<std::string>> components(const std::string& rel) {
  std::vector<std::string> out;
  if (!rel.empty() && rel.front() == '/') return std::nullopt;
  size_t i = 0;
  while (i <= rel.size()) {
    const size_t j = std::min(rel.find('/', i), rel.size());
    const std::string part = rel.substr(i, j - i);
    if (part == "..") return std::nullopt;
    if (!part.empty() && part != ".") out.push_back(part);
    i = j + 1;
  }
  return out;
}

}  // namespace

std::string linked_component(const std::string& base, const std::string& rel) {
  const auto parts = components(rel);
  if (!parts) return rel;
  std::string at = base.empty() ? "." : base, shown;
  for (size_t i = 0; i < parts->size(); ++i) {
    at += "/" + (*parts)[i];
    shown += (shown.empty() ? "" : "/") + (*parts)[i];
    struct stat st;
    if (::lstat(at.c_str(), &st) != 0) return "";  // missing: nothing below it either
    if (S_ISLNK(st.st_mode)) return shown;
    if (i + 1 < parts->size() && !S_ISDIR(st.st_mode)) return shown;
  }
  return "";
}

void require_no_links(const std::string& base, const std::string& rel, const std::string& what) {
  const std::string bad = linked_component(base, rel);
  if (bad.empty()) return;
  throw std::invalid_argument(what + " '" + base + "': '" + bad +
                              "' is a symbolic link (or not a directory); a received directory is data and its links "
                              "are never followed: remove it (docs/security.md)");
}

int open_below(const std::string& base, const std::string& rel, int flags, std::string* why, unsigned mode) {
  auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return -1;
  };
  const auto parts = components(rel);
  if (!parts || parts->empty()) return fail("is not a path below the directory");
  int dfd = ::open(base.empty() ? "." : base.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0) return fail(errno == ENOENT ? "does not exist" : std::string("cannot be opened: ") + std::strerror(errno));
  for (size_t i = 0; i + 1 < parts->size(); ++i) {
    const int next = ::openat(dfd, (*parts)[i].c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    const int err = errno;
    struct stat st;
    const bool link = next < 0 && ::fstatat(dfd, (*parts)[i].c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(st.st_mode);
    ::close(dfd);
    if (next < 0)
      return fail(link ? "is below a symbolic link ('" + (*parts)[i] + "')"
                       : err == ENOENT  ? "does not exist"
                       : err == ENOTDIR ? "is below a file that is not a directory"
                                        : std::string("cannot be opened: ") + std::strerror(err));
    dfd = next;
  }
  const std::string& last = parts->back();
  const int fd = ::openat(dfd, last.c_str(), flags | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK, mode);
  const int err = errno;
  struct stat st;
  const bool link = fd < 0 && ::fstatat(dfd, last.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(st.st_mode);
  ::close(dfd);
  if (fd < 0)
    return fail(link || err == ELOOP ? "is a symbolic link"
                : err == ENOENT      ? "does not exist"
                                     : std::string("cannot be opened: ") + std::strerror(err));
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    return fail("is not a regular file (a FIFO, device or directory)");
  }
  // Back to blocking reads and writes on the regular file (O_NONBLOCK only kept open() from waiting).
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  return fd;
}

std::optional<std::string> read_below(const std::string& base, const std::string& rel, size_t max_bytes,
                                      std::string* why, bool tail) {
  const int fd = open_below(base, rel, O_RDONLY, why);
  if (fd < 0) return std::nullopt;
  struct stat st;
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    if (why) *why = std::string("cannot be read: ") + std::strerror(errno);
    return std::nullopt;
  }
  off_t start = 0;
  if (size_t(st.st_size) > max_bytes) {
    if (!tail) {
      ::close(fd);
      if (why)
        *why = "is " + std::to_string(st.st_size) + " bytes, more than the limit of " + std::to_string(max_bytes);
      return std::nullopt;
    }
    start = st.st_size - off_t(max_bytes);
  }
  std::string text;
  char buf[1 << 16];
  while (text.size() < max_bytes) {  // a file that grows while read stops at the cap
    const ssize_t n = ::pread(fd, buf, std::min(sizeof(buf), max_bytes - text.size()), start + off_t(text.size()));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      if (why) *why = std::string("cannot be read: ") + std::strerror(errno);
      ::close(fd);
      return std::nullopt;
    }
    if (n == 0) break;
    text.append(buf, size_t(n));
  }
  ::close(fd);
  return text;
}

bool regular_file_below(const std::string& base, const std::string& rel) {
  if (!linked_component(base, rel).empty()) return false;
  struct stat st;
  return ::lstat((base + "/" + rel).c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

int remove_stale_temp_files(const std::string& dir) {
  const int dfd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd < 0) return 0;
  DIR* d = ::fdopendir(dfd);
  if (!d) {
    ::close(dfd);
    return 0;
  }
  int removed = 0;
  while (const dirent* e = ::readdir(d)) {
    const long pid = temp_file_pid(e->d_name);
    if (pid == 0 || process_alive(pid)) continue;
    struct stat st;
    if (::fstatat(dfd, e->d_name, &st, AT_SYMLINK_NOFOLLOW) != 0) continue;
    if (!S_ISREG(st.st_mode) && !S_ISLNK(st.st_mode)) continue;
    if (::unlinkat(dfd, e->d_name, 0) == 0) ++removed;
  }
  ::closedir(d);
  return removed;
}

}  // namespace atacom
