// progress.svg: what a run's progress.csv says, as panels against env steps,
// redrawn after every evaluation: the evaluation return (mean +- std), the
// final distance to the goal (envs with one), and, for envs with constraints,
// the safety record: training collisions and violations (running totals over
// all training steps) and the evaluation's collisions and violations per
// episode.
#pragma once
#include <string>

#include "train/run_files.hpp"

namespace atacom {

// Panels for the columns `progress` holds (absent columns: no panel), drawn
// from the values as progress.csv writes them, so a resumed run draws the
// same bytes; constrained: the env has constraints (the safety panels).
std::string progress_svg(const std::string& title, const ProgressFile& progress, bool constrained);

}  // namespace atacom
