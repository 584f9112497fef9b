// Learner presets: per env x algorithm run-config fragments, one JSON file
// each (configs/presets/<name>.json, compiled in). A preset file is
//   {"description": "...", "entries": {"<env>/<algo>": fragment, ...}}
// where either part of a key may be `*` and a fragment holds run-config
// sections ("env", "train", a learner's, a safety layer's) plus a "note"
// that says where its values come from (the measurement behind them).
// "paper" (the default) is the paper's protocol; "fast" the measured best
// time-to-target settings (docs/training.md).
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace atacom {

struct Preset {
  std::string name;         // the file's stem: "paper", "fast"
  std::string description;
  nlohmann::json entries;   // "<env>/<algo>" -> fragment
};

// Every shipped preset, validated (throws std::logic_error on a malformed file).
const std::vector<Preset>& presets();
std::vector<std::string> preset_names();
// Throws std::invalid_argument for an unknown name, listing the known ones.
const Preset& find_preset(const std::string& name);
inline constexpr const char* kDefaultPreset = "paper";

// The fragment of `entries` for one cell: "*/*", "<env>/*", "*/<algo>",
// "<env>/<algo>", merged least specific first (objects recursively, the
// later key wins). A wildcard entry's learner and safety-layer sections reach
// only the cells that use that learner or layer; an exact entry's must fit
// its cell (resolve_run_config says so otherwise). "note" keys are dropped.
// Sweep spec overrides use the same rule.
nlohmann::json config_fragment(const nlohmann::json& entries, const std::string& env, const std::string& algo);

// a's objects merged with b's keys (b wins; objects merge recursively).
void merge_into(nlohmann::json& a, const nlohmann::json& b);

}  // namespace atacom
