// One training run into `dir` from a config, as `atacom train` runs it: the
// helper every trainer-level test shares.
#pragma once
#include <cstdint>
#include <ostream>
#include <string>

#include <nlohmann/json.hpp>

#include "atacom/trainer.hpp"

inline atacom::TrainSummary train(const nlohmann::json& cfg, const std::string& dir, bool resume = false,
                                  int64_t stop_after = 0, std::ostream* log = nullptr) {
  atacom::TrainOptions o;
  o.out_dir = dir;
  o.resume = resume;
  o.stop_after = stop_after;
  o.log = log;
  return atacom::run_training(atacom::resolve_run_config(cfg), o);
}
