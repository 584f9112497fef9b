// A learned-SDF weight file (`--sdf object=learned:<dir>` reads any
// redsdf.bin): any bytes either load into a model the reference can
// evaluate, or are refused with std::runtime_error; never a crash, a
// bare std::bad_alloc or another exception. The target repairs the trailing
// FNV-1a checksum, so the fuzzer reaches the container's sections, the
// manifest and the parameters behind it.
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

#include "src/core/binary_io.hpp"
#include "src/core/fs_util.hpp"
#include "src/core/redsdf_model.hpp"
#include "tests/fuzz/fuzz_target.hpp"

namespace fs = std::filesystem;

namespace {

struct TempFile {
  fs::path path = fs::temp_directory_path() / ("atacom_fuzz_redsdf_" + std::to_string(::getpid()) + ".bin");
  ~TempFile() {
    std::error_code ec;
    fs::remove(path, ec);
  }
};

const fs::path& temp_file() {
  static const TempFile f;
  return f.path;
}

// A small model: the corpus seed (`fuzz_redsdf --write-seed DIR` writes DIR/redsdf.bin).
atacom::RedsdfModel seed_model() {
  atacom::RedsdfArch a;
  a.pose_dim = 2;
  a.hidden = {6, 5};
  a.trunk_layers = 1;
  a.side_width = 3;
  atacom::RedsdfModel m(a);
  atacom::init_redsdf(m, 1);
  m.manifest["object"] = "fuzz";
  return m;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string bytes(reinterpret_cast<const char*>(data), size);
  if (bytes.size() >= 16) {
    const uint64_t h = atacom::bin::fnv1a(bytes.data(), bytes.size() - 8);
    std::memcpy(bytes.data() + bytes.size() - 8, &h, 8);
  }
  atacom::write_file_atomic(temp_file().string(), bytes);
  try {
    const atacom::RedsdfModel m = atacom::load_redsdf(temp_file().string());
    const std::vector<double> pose(size_t(m.arch.pose_dim), 0.1);
    Eigen::Vector3d g;
    (void)atacom::redsdf_reference(m, Eigen::Vector3d(0.2, -0.1, 0.3), pose.data(), &g);  // the layout fits the parameters
  } catch (const std::runtime_error&) {
  } catch (const std::bad_alloc&) {
    fuzz_fail("std::bad_alloc: a size in the file was not checked before allocating");
  } catch (const std::exception& e) {
    fuzz_fail("unexpected exception:", e.what());
  }
  return 0;
}

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  for (int i = 1; i + 1 < *argc; ++i)
    if (std::strcmp((*argv)[i], "--write-seed") == 0) {
      atacom::save_redsdf(seed_model(), (*argv)[i + 1]);
      std::exit(0);
    }
  return 0;
}
