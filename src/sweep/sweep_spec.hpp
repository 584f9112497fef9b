// A sweep: every (env, algo, seed) cell of a spec is one `atacom train` run.
//
// Spec (JSON, strict: unknown keys, duplicate keys and bad values are errors
// naming the key):
//   {"envs": ["table", ...], "algos": ["sac", "atacom-sac", ...],
//    "seeds": [0, 1, ...], "steps": 2000000,
//    "num_envs": 4,                              optional (train.num_envs)
//    "overrides": {"table/sac": {"sac": {"lr_actor": 1e-5}},
//                  "*/*": {"train": {"eval_every": 10000}}},   optional
//    "description": "..."}                       optional
// An override key is "<env>/<algo>", either part "*"; its value is a run
// config fragment (sections env, train, sac, ...) merged into the cell's
// config, least specific first: "*/*", "<env>/*", "*/<algo>", "<env>/<algo>".
// A wildcard key's learner sections ("sac", ...) reach only the cells whose
// algorithm trains that learner; an exact key's must fit its cell.
// train.env/algo/seed/steps/num_envs/preset come from the spec only; every section
// of an override is an object. Every (env, algo) pair is resolved when the
// spec is read (its seeds differ in train.seed only), so a bad override fails
// before any run. At most kMaxSweepCells cells.
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace atacom {

// Most cells of one spec (envs x algos x seeds): the bookkeeping of a sweep
// of this many costs about a kilobyte of memory and of sweep.json per cell
// (docs/sweeps.md, "How many cells").
constexpr int64_t kMaxSweepCells = 100'000;

struct SweepCell {
  std::string env, algo;
  int64_t seed = 0;
  int64_t steps = 0;
  bool learns = true;     // false: la/random/zero runs (one evaluation, no checkpoint)
  // The merged overrides of (env, algo), shared by the cell's seeds (one copy per pair, not per cell).
  std::shared_ptr<const nlohmann::json> base;
  int num_envs = 0;
  std::string preset;             // "": train.preset unset (the default)
  nlohmann::json config() const;  // the `atacom train --config` file of this cell
  std::string name() const;       // "table-atacom-sac-seed3" (logs, state files)
  std::string run_dir() const;    // "runs/table/atacom-sac/seed-3" (relative to the sweep directory)
};

struct SweepSpec {
  std::vector<std::string> envs, algos;
  std::vector<int64_t> seeds;
  int64_t steps = 0;
  int num_envs = 0;           // 0: the train default (or the preset's)
  std::string preset;         // "": the train default ("paper"); else train.preset of every cell
  nlohmann::json overrides = nlohmann::json::object();
  std::string description;
};

// Throws std::invalid_argument naming the key (and the cell, for overrides).
SweepSpec parse_sweep_spec(const nlohmann::json& j);
nlohmann::json sweep_spec_json(const SweepSpec& s);
// Cells in a fixed order (env, then algo, then seed, as listed in the spec).
std::vector<SweepCell> sweep_cells(const SweepSpec& s);

// "--shard i/n": 0 <= i < n. Cell k belongs to shard k mod n.
struct Shard {
  int index = 0, count = 1;
  bool holds(size_t cell) const { return int(cell % size_t(count)) == index; }
};
Shard parse_shard(const std::string& text);

}  // namespace atacom
