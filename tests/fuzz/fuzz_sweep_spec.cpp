// A sweep spec (what `atacom sweep SPEC` and `atacom sweep status DIR` read):
// any bytes are either a spec or a std::invalid_argument whose message is
// printable. A spec re-reads to itself from the spec.json a sweep saves, and
// every cell's run directory stays inside the sweep directory.
#include <filesystem>
#include <stdexcept>
#include <string>

#include "src/core/config_json.hpp"
#include "src/experiments/sweep_spec.hpp"
#include "tests/fuzz/fuzz_target.hpp"

namespace {

void check_printable(const char* msg) {
  for (const char* p = msg; *p; ++p)
    if (static_cast<unsigned char>(*p) < 0x20 || static_cast<unsigned char>(*p) >= 0x7f)
      fuzz_fail("raw byte in an error message:", msg);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  atacom::SweepSpec spec;
  try {
    spec = atacom::parse_sweep_spec(atacom::parse_json_strict(text, "sweep spec"));
  } catch (const std::invalid_argument& e) {
    check_printable(e.what());
    return 0;
  }
  const std::string saved = atacom::sweep_spec_json(spec).dump();  // DIR/spec.json
  try {
    const atacom::SweepSpec again = atacom::parse_sweep_spec(atacom::parse_json_strict(saved, "sweep spec"));
    if (atacom::sweep_spec_json(again).dump() != saved) fuzz_fail("spec.json does not re-read to itself:", saved.c_str());
  } catch (const std::invalid_argument& e) {
    fuzz_fail("the saved spec.json is refused:", e.what());
  }
  for (const atacom::SweepCell& c : atacom::sweep_cells(spec)) {
    const std::filesystem::path run = c.run_dir();
    bool inside = run.is_relative() && !run.empty();
    for (const auto& part : run) inside = inside && part != ".." && part != ".";
    if (!inside) fuzz_fail("a cell's run directory leaves the sweep directory:", c.run_dir().c_str());
    for (char ch : c.name())
      if (ch == '/' || ch == '\0') fuzz_fail("a cell name (log and state file name) holds a path separator:", c.name().c_str());
  }
  return 0;
}
