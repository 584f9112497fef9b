// A run config (what `atacom train --config FILE` reads): any bytes are
// either a RunConfig or a std::invalid_argument whose message is printable.
#include <stdexcept>
#include <string>

#include "atacom/trainer.hpp"
#include "src/core/config_json.hpp"
#include "tests/fuzz/fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const atacom::RunConfig c = atacom::resolve_run_config(atacom::parse_json_strict(text, "config"));
    (void)atacom::run_config_json(c).dump();  // what config.json would hold
  } catch (const std::invalid_argument& e) {
    for (const char* p = e.what(); *p; ++p)
      if (static_cast<unsigned char>(*p) < 0x20 || static_cast<unsigned char>(*p) >= 0x7f)
        fuzz_fail("raw byte in an error message:", e.what());
  }
  return 0;
}
