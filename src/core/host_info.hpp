// Where and how a run was computed, for config.json and summary.json
// ("host"): CPU model and SIMD flags, logical CPUs, worker threads, host
// name, OS, compiler, build type and flags, -march=native or portable, the
// ISA the binary was compiled for, and the git commit (`git describe` at
// build time, "" outside a git checkout). Bitwise results hold for one
// binary on one instruction set; this is what tells two runs apart.
#pragma once
#include <nlohmann/json.hpp>

namespace atacom {

nlohmann::json host_info();

}  // namespace atacom
