#include "src/core/host_info.hpp"

#include <sys/utsname.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "atacom/parallel.hpp"
#include "atacom_build_flags.hpp"
#include "atacom_git.hpp"

namespace atacom {

namespace {

// The instruction-set extensions that change what the kernels compile to.
const char* const kIsaFlags[] = {"sse2",     "sse3",     "ssse3",    "sse4_1",   "sse4_2",      "popcnt",
                                 "avx",      "avx2",     "fma",      "f16c",     "bmi1",        "bmi2",
                                 "avx512f",  "avx512dq", "avx512cd", "avx512bw", "avx512vl",    "avx512_vnni",
                                 "avx512_bf16", "amx_tile", "asimd",  "sve"};

std::vector<std::string> compiled_isa() {
  std::vector<std::string> v;
#ifdef __SSE4_2__
  v.push_back("sse4_2");
#endif
#ifdef __AVX__
  v.push_back("avx");
#endif
#ifdef __AVX2__
  v.push_back("avx2");
#endif
#ifdef __FMA__
  v.push_back("fma");
#endif
#ifdef __AVX512F__
  v.push_back("avx512f");
#endif
#ifdef __AVX512DQ__
  v.push_back("avx512dq");
#endif
#ifdef __AVX512BW__
  v.push_back("avx512bw");
#endif
#ifdef __AVX512VL__
  v.push_back("avx512vl");
#endif
#ifdef __ARM_NEON
  v.push_back("neon");
#endif
  return v;
}

}  // namespace

nlohmann::json host_info() {
  std::string model, flags;
  std::ifstream cpu("/proc/cpuinfo");
  for (std::string line; std::getline(cpu, line);) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string key = line.substr(0, colon);
    while (!key.empty() && (key.back() == ' ' || key.back() == '\t')) key.pop_back();
    const std::string value = colon + 2 <= line.size() ? line.substr(colon + 2) : "";
    if (model.empty() && (key == "model name" || key == "Model")) model = value;
    if (flags.empty() && (key == "flags" || key == "Features")) flags = value;
    if (!model.empty() && !flags.empty()) break;
  }
  std::vector<std::string> isa;
  std::istringstream fs(" " + flags + " ");
  std::vector<std::string> have;
  for (std::string f; fs >> f;) have.push_back(f);
  for (const char* f : kIsaFlags)
    for (const std::string& h : have)
      if (h == f) { isa.push_back(f); break; }
  char host[256] = {0};
  if (::gethostname(host, sizeof(host) - 1) != 0) host[0] = 0;
  struct utsname u {};
  std::string os;
  if (::uname(&u) == 0) os = std::string(u.sysname) + " " + u.release + " " + u.machine;
  const std::string git = ATACOM_GIT_DESCRIBE;
  return {{"cpu_model", model},
          {"cpu_isa_flags", isa},
          {"logical_cpus", std::thread::hardware_concurrency()},
          {"threads", num_threads()},
          {"hostname", host},
          {"os", os},
#if defined(__clang__)
          {"compiler", "clang " __clang_version__},
#elif defined(__GNUC__)
          {"compiler", "gcc " __VERSION__},
#else
          {"compiler", __VERSION__},
#endif
          {"build_type", ATACOM_BUILD_TYPE},
          {"build_flags", ATACOM_BUILD_FLAGS},
          {"build_native", ATACOM_BUILD_NATIVE != 0},
          {"build_sanitize", ATACOM_BUILD_SANITIZE != 0},
          {"build_isa", compiled_isa()},
          {"git_describe", git.empty() ? nlohmann::json(nullptr) : nlohmann::json(git)}};
}

}  // namespace atacom
