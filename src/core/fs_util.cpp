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
