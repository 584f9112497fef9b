// `atacom filter`'s stream: any bytes in, exactly one answer line per input
// line out, each a JSON object with "a" (a result) or "error" (with its line
// number), and the failure count equal to the error answers.
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "src/safety/filter.hpp"
#include "tests/fuzz/fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  long lines = 0;
  for (char c : text) lines += c == '\n';
  if (!text.empty() && text.back() != '\n') ++lines;
  std::istringstream in(text);
  std::ostringstream out;
  // A small line limit, so the over-long path is reached too.
  const long failed = atacom::run_filter(in, out, 4096);
  std::istringstream answers(out.str());
  std::string a;
  long n = 0, errors = 0;
  while (std::getline(answers, a)) {
    ++n;
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(a);
    } catch (const std::exception&) {
      fuzz_fail("answer is not JSON:", a.substr(0, 200).c_str());
    }
    if (!j.is_object() || (j.contains("a") == j.contains("error"))) fuzz_fail("answer has neither a nor error");
    if (j.contains("error")) {
      ++errors;
      if (j["line"] != n) fuzz_fail("error answer names the wrong line");
    }
  }
  if (n != lines) fuzz_fail("lost or extra answer");
  if (errors != failed) fuzz_fail("failure count differs from the error answers");
  return 0;
}
