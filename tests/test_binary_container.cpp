// The one binary container (src/core/binary_container.hpp): its layout, its
// messages for bad input, and that the three formats built on it write the
// bytes their committed files hold (the learned fields under data/sdf/, the
// checkpoint of the fuzz corpus): each is read and written again, bit for bit.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "atacom/data_dir.hpp"
#include "src/core/binary_container.hpp"
#include "src/core/binary_io.hpp"
#include "src/core/redsdf_model.hpp"
#include "train/checkpoint.hpp"
#include "tests/test_files.hpp"

namespace fs = std::filesystem;
using namespace atacom;

namespace {

std::string sample() {
  ContainerWriter w("TESTMAGC", 3u);
  w.section("hello");
  const float x[2] = {1.0f, 2.0f};
  w.section(std::string_view(reinterpret_cast<const char*>(x), sizeof x), sizeof(float));
  return w.finish();
}

void read_sample(const std::string& bytes) {
  std::istringstream in(bytes);
  ContainerReader r(in, "test: ", true);
  REQUIRE(r.magic() == "TESTMAGC");
  REQUIRE(r.version() == 3);
  r.read({{"text"}, {"floats", sizeof(float)}});
  r.expect_end();
  REQUIRE(r.section(0) == "hello");
  REQUIRE(r.section(1).size() == 2 * sizeof(float));
}

fs::path temp_dir(const char* what) {
  return fs::temp_directory_path() / (std::string("atacom_container_") + what + "_" + std::to_string(::getpid()));
}

}  // namespace

TEST_CASE("binary container: layout, and bad input refused with a clear message", "[container][checkpoint]") {
  const std::string good = sample();
  // magic 8 | version 4 | (8 + 5) | (8 + 2 x 4) | checksum 8
  REQUIRE(good.size() == 8 + 4 + 13 + 16 + 8);
  uint64_t count = 0;
  std::memcpy(&count, good.data() + 25, 8);
  REQUIRE(count == 2);  // a float section counts elements
  uint64_t sum = 0;
  std::memcpy(&sum, good.data() + good.size() - 8, 8);
  REQUIRE(sum == bin::fnv1a(good.data(), good.size() - 8));
  read_sample(good);

  for (size_t cut = 0; cut < good.size(); ++cut) {
    INFO("cut at " << cut);
    REQUIRE_THROWS_WITH(read_sample(good.substr(0, cut)), Catch::StartsWith("test: truncated"));
  }
  for (size_t at = 12; at < good.size(); ++at) {  // past the magic and version: any flipped byte
    INFO("flipped byte " << at);
    std::string flipped = good;
    flipped[at] ^= 0x01;
    REQUIRE_THROWS_WITH(read_sample(flipped), Catch::Contains("test: truncated") || Catch::Contains("checksum mismatch") ||
                                                  Catch::Contains("longer than its header says"));
  }
  REQUIRE_THROWS_WITH(read_sample(good + "x"), Catch::Contains("longer than its header says"));
  // A count the input does not back: "truncated" after bounded reads, no huge allocation.
  std::string huge = good;
  const uint64_t n = uint64_t{1} << 39;
  std::memcpy(&huge[12], &n, 8);
  REQUIRE_THROWS_WITH(read_sample(huge), Catch::Contains("truncated (section text"));
  const uint64_t absurd = ~uint64_t{0};
  std::memcpy(&huge[12], &absurd, 8);
  REQUIRE_THROWS_WITH(read_sample(huge), Catch::Contains("claims"));
}

TEST_CASE("binary container: the committed learned fields load and save to the same bytes", "[container][redsdf]") {
  int files = 0;
  for (const char* object : {"table", "shelf", "hri_table", "tiago", "human"}) {
    const fs::path dir = fs::path(data_dir()) / "sdf" / object;
    if (!fs::exists(dir / "redsdf.bin")) continue;
    INFO(dir.string());
    const RedsdfModel m = load_redsdf(dir.string());
    const fs::path out = temp_dir(object);
    fs::remove_all(out);
    save_redsdf(m, out.string());
    CHECK(slurp(out / "redsdf.bin") == slurp(dir / "redsdf.bin"));
    fs::remove_all(out);
    ++files;
  }
  REQUIRE(files >= 1);
}

TEST_CASE("binary container: checkpoints keep their layout, and the committed one reads and writes its sections back",
          "[container][checkpoint]") {
  // The layout of train/checkpoint.hpp, by hand.
  Checkpoint ck;
  ck.manifest = {{"k", 1}, {"name", "x"}};
  ck.payload = std::string("\0\1payload", 9);
  const std::string m = ck.manifest.dump(1);
  std::string expect("ATACKPT\0", 8);
  expect.append(reinterpret_cast<const char*>(&kCheckpointVersion), 4);
  const uint64_t ml = m.size(), pl = ck.payload.size();
  expect.append(reinterpret_cast<const char*>(&ml), 8);
  expect += m;
  expect.append(reinterpret_cast<const char*>(&pl), 8);
  expect += ck.payload;
  const uint64_t h = bin::fnv1a(expect.data(), expect.size());
  expect.append(reinterpret_cast<const char*>(&h), 8);
  const fs::path out = temp_dir("checkpoint");
  fs::create_directories(out);
  write_checkpoint_atomic((out / "a.bin").string(), ck);
  CHECK(slurp(out / "a.bin") == expect);

  // The fuzz corpus's checkpoint (format version 3, which runs no longer
  // resume from): the container still parses it, and today's writer puts
  // the same sections back under today's version.
  const fs::path file = fs::path(ATACOM_TEST_DATA_DIR) / ".." / "fuzz" / "corpus" / "checkpoint" / "template_step100.bin";
  const std::string committed = slurp(file);
  uint32_t version = 0;
  std::memcpy(&version, committed.data() + 8, 4);
  REQUIRE_THROWS_WITH(read_checkpoint(file.string()), Catch::Contains("format version " + std::to_string(version)));
  const Checkpoint old = read_checkpoint(file.string(), version);
  write_checkpoint_atomic((out / "b.bin").string(), old);
  const std::string written = slurp(out / "b.bin");
  REQUIRE(written.size() == committed.size());
  CHECK(written.compare(12, written.size() - 20, committed, 12, committed.size() - 20) == 0);
  fs::remove_all(out);
}
