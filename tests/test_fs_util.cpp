// write_file_atomic never follows or reuses a planted file, replaces a
// planted symlink instead of writing through it, and stale temp files of a
// killed run are removed on the next start (issue 10 item 5).
#include <catch2/catch.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "src/core/fs_util.hpp"
#include "tests/test_files.hpp"

namespace fs = std::filesystem;

namespace {
struct TempDir {
  fs::path p;
  explicit TempDir(const std::string& name)
      : p(fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(p);
    fs::create_directories(p);
  }
  ~TempDir() { fs::remove_all(p); }
};
}  // namespace

TEST_CASE("fs: a symlink planted at the old temp name is never followed", "[fs]") {
  TempDir d("atacom_fs_tmp");
  const fs::path victim = d.p / "victim.txt", target = d.p / "checkpoint.bin";
  std::ofstream(victim) << "precious";
  // Today's code opened "<file>.tmp.<pid>" with O_CREAT|O_TRUNC: through this link.
  fs::create_symlink(victim, d.p / ("checkpoint.bin.tmp." + std::to_string(::getpid())));
  atacom::write_file_atomic(target.string(), "new data");
  CHECK(slurp(victim) == "precious");
  CHECK(slurp(target) == "new data");
  CHECK(fs::is_regular_file(fs::symlink_status(target)));
}

TEST_CASE("fs: a symlink planted at the target is replaced, not written through", "[fs]") {
  TempDir d("atacom_fs_link");
  const fs::path outside = d.p / "outside.txt", target = d.p / "config.json";
  std::ofstream(outside) << "outside";
  fs::create_symlink(outside, target);
  atacom::write_file_atomic(target.string(), "{}\n");
  CHECK(slurp(outside) == "outside");
  CHECK(fs::is_regular_file(fs::symlink_status(target)));
  CHECK(slurp(target) == "{}\n");
  // No temp file stays behind.
  int entries = 0;
  for (const auto& e : fs::directory_iterator(d.p)) entries += e.path().filename().string().find(".tmp.") != std::string::npos;
  CHECK(entries == 0);
}

TEST_CASE("fs: a failed write names the path and leaves no temp file", "[fs]") {
  TempDir d("atacom_fs_fail");
  CHECK_THROWS_WITH(atacom::write_file_atomic((d.p / "missing_dir" / "x").string(), "x"),
                    Catch::Contains("missing_dir/x"));
  // /dev/full: every write fails with ENOSPC (writing into /dev itself is refused first, also an error).
  fs::create_directories(d.p / "sub");
  CHECK_THROWS(atacom::write_file_atomic("/proc/atacom_cannot_write_here", "x"));
}

TEST_CASE("fs: stale temp files of dead processes are removed, nothing else", "[fs]") {
  TempDir d("atacom_fs_stale");
  // A pid that cannot be running (above pid_max), this process's own pid
  // (an earlier process with the same pid), another live process (pid 1).
  const std::string dead = "999999999";
  const std::string mine = std::to_string(::getpid());
  for (const std::string& name : std::vector<std::string>{"checkpoint.bin.tmp." + dead, "progress.csv.tmp." + dead + ".Ab12Cd",
                                  "summary.json.tmp." + mine, "checkpoint.bin.tmp.1", "checkpoint.bin",
                                  "notes.tmp.txt", "x.tmp.12ab"})
    std::ofstream(d.p / name) << "x";
  const fs::path outside = d.p / "outside";
  std::ofstream(outside) << "keep";
  fs::create_symlink(outside, d.p / ("config.json.tmp." + dead));  // a link is removed, its target is not
  fs::create_directories(d.p / ("dir.tmp." + dead));                // directories are left alone
  CHECK(atacom::remove_stale_temp_files(d.p.string()) == 4);
  CHECK_FALSE(fs::exists(d.p / ("checkpoint.bin.tmp." + dead)));
  CHECK_FALSE(fs::exists(d.p / ("progress.csv.tmp." + dead + ".Ab12Cd")));
  CHECK_FALSE(fs::exists(d.p / ("summary.json.tmp." + mine)));
  CHECK_FALSE(fs::exists(fs::symlink_status(d.p / ("config.json.tmp." + dead))));
  CHECK(fs::exists(d.p / "checkpoint.bin.tmp.1"));
  CHECK(fs::exists(d.p / "checkpoint.bin"));
  CHECK(fs::exists(d.p / "notes.tmp.txt"));
  CHECK(fs::exists(d.p / "x.tmp.12ab"));
  CHECK(slurp(outside) == "keep");
  CHECK(fs::is_directory(d.p / ("dir.tmp." + dead)));
  CHECK(atacom::remove_stale_temp_files((d.p / "does_not_exist").string()) == 0);
}
