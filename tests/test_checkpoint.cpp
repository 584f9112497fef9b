#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "src/core/binary_io.hpp"
#include "train/checkpoint.hpp"
#include "tests/test_files.hpp"

namespace fs = std::filesystem;

namespace {
std::string tmp_path(const std::string& name) {
  return (fs::temp_directory_path() / ("atacom_ckpt_" + std::to_string(::getpid()) + "_" + name)).string();
}
void dump(const std::string& p, const std::string& bytes) {
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f << bytes;
}
}  // namespace

TEST_CASE("checkpoint: round trip, atomic replace", "[checkpoint]") {
  const std::string p = tmp_path("rt.bin");
  atacom::Checkpoint c;
  c.manifest = {{"env_steps", 1234}, {"name", "x"}};
  c.payload = std::string("\0\1\2binary\xff", 10);
  atacom::write_checkpoint_atomic(p, c);
  for (const auto& e : fs::directory_iterator(fs::path(p).parent_path()))  // no temp file left behind
    REQUIRE(e.path().filename().string().rfind(fs::path(p).filename().string() + ".tmp", 0) != 0);
  const auto back = atacom::read_checkpoint(p);
  REQUIRE(back.manifest == c.manifest);
  REQUIRE(back.payload == c.payload);
  c.payload = "second";
  atacom::write_checkpoint_atomic(p, c);
  REQUIRE(atacom::read_checkpoint(p).payload == "second");
  fs::remove(p);
}

TEST_CASE("checkpoint: truncated, corrupted or foreign files are rejected clearly", "[checkpoint]") {
  const std::string p = tmp_path("bad.bin");
  atacom::Checkpoint c;
  c.manifest = {{"k", 1}};
  c.payload = std::string(1000, 'a');
  atacom::write_checkpoint_atomic(p, c);
  const std::string good = slurp(p);
  dump(p, good.substr(0, good.size() - 100));
  REQUIRE_THROWS_WITH(atacom::read_checkpoint(p), Catch::Contains("truncated"));
  dump(p, good.substr(0, 10));
  REQUIRE_THROWS_WITH(atacom::read_checkpoint(p), Catch::Contains("truncated"));
  std::string flipped = good;
  flipped[flipped.size() / 2] ^= 0x10;
  dump(p, flipped);
  REQUIRE_THROWS_WITH(atacom::read_checkpoint(p), Catch::Contains("checksum"));
  std::string foreign = good;
  foreign[0] = 'X';
  dump(p, foreign);
  REQUIRE_THROWS_WITH(atacom::read_checkpoint(p), Catch::Contains("not an atacom checkpoint"));
  std::string version = good;
  version[8] = 99;
  dump(p, version);
  REQUIRE_THROWS_WITH(atacom::read_checkpoint(p), Catch::Contains("version 99"));
  // A checkpoint of the previous format, intact (checksum recomputed): refused
  // for its version, with what to do about it.
  std::string old = good.substr(0, good.size() - 8);
  old[8] = char(atacom::kCheckpointVersion - 1);
  const uint64_t h = atacom::bin::fnv1a(old.data(), old.size());
  old.append(reinterpret_cast<const char*>(&h), sizeof h);
  dump(p, old);
  REQUIRE_THROWS_WITH(atacom::read_checkpoint(p),
                      Catch::Contains("format version " + std::to_string(atacom::kCheckpointVersion - 1)) &&
                          Catch::Contains("older build") && Catch::Contains("start the run again"));
  dump(p, good + "extra");
  REQUIRE_THROWS_WITH(atacom::read_checkpoint(p), Catch::Contains("longer"));
  fs::remove(p);
  REQUIRE_THROWS_WITH(atacom::read_checkpoint(p), Catch::Contains("cannot open"));
}
