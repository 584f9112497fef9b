// A checkpoint from anyone is data, not code: any checkpoint.bin in a run
// directory is either resumed or refused with std::runtime_error /
// std::invalid_argument, never a crash, a hang, a bare std::bad_alloc or a
// std::logic_error. The target repairs the trailing FNV-1a checksum of the
// input, so the fuzzer reaches the envelope, the manifest and the payload
// behind it (counters, learner, RNG streams, env batch) instead of stopping
// at "checksum mismatch".
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <new>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "atacom/trainer.hpp"
#include "src/core/binary_io.hpp"
#include "src/core/fs_util.hpp"
#include "tests/fuzz/fuzz_target.hpp"

namespace fs = std::filesystem;

namespace {

// The run every input is resumed into: the corpus's checkpoints were cut from it
// (`fuzz_checkpoint --write-seed FILE` writes one; docs/security.md, "Fuzzing", says how the targets run).
nlohmann::json template_config() {
  return {{"sac", {{"actor", {{"hidden", {8}}}}, {"critic", {{"hidden", {8}}}}, {"batch_size", 8},
                   {"initial_replay", 50}, {"warmup", 50}, {"replay_capacity", 300}}},
          {"train", {{"env", "pendulum"}, {"steps", 300}, {"eval_every", 100}, {"eval_episodes", 1}, {"seed", 7}}}};
}

// A temp directory that goes away with the process (libFuzzer and the replay both exit normally).
struct BaseDir {
  fs::path dir = fs::temp_directory_path() / ("atacom_fuzz_checkpoint_" + std::to_string(::getpid()));
  BaseDir() {
    fs::remove_all(dir);
    atacom::TrainOptions o;
    o.out_dir = (dir / "template").string();
    o.stop_after = 100;
    atacom::run_training(atacom::resolve_run_config(template_config()), o);
  }
  ~BaseDir() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

const fs::path& base_dir() {
  static const BaseDir d;
  return d.dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const fs::path work = base_dir() / "work";
  fs::remove_all(work);
  fs::copy(base_dir() / "template", work);
  std::string bytes(reinterpret_cast<const char*>(data), size);
  if (bytes.size() >= 16) {
    const uint64_t h = atacom::bin::fnv1a(bytes.data(), bytes.size() - 8);
    std::memcpy(bytes.data() + bytes.size() - 8, &h, 8);
  }
  atacom::write_file_atomic((work / "checkpoint.bin").string(), bytes);
  atacom::TrainOptions o;
  o.out_dir = work.string();
  o.resume = true;
  try {
    atacom::run_training(atacom::resolve_run_config(template_config()), o);
  } catch (const std::runtime_error&) {
  } catch (const std::invalid_argument&) {
  } catch (const std::bad_alloc&) {
    fuzz_fail("std::bad_alloc: a size in the checkpoint was not checked before allocating");
  } catch (const std::exception& e) {
    fuzz_fail("unexpected exception:", e.what());
  }
  return 0;
}

// `fuzz_checkpoint --write-seed FILE`: the template run's checkpoint.bin, for the corpus.
extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  for (int i = 1; i + 1 < *argc; ++i)
    if (std::strcmp((*argv)[i], "--write-seed") == 0) {
      fs::copy_file(base_dir() / "template" / "checkpoint.bin", (*argv)[i + 1], fs::copy_options::overwrite_existing);
      std::exit(0);
    }
  return 0;
}
