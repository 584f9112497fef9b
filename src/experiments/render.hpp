// `atacom render`: one episode of an env as a self-contained HTML page (no
// server, no network): animated SVG views of the scene (top and side for the
// arm envs, top for nav), a time slider with play/pause, and plots of the
// constraint values and the reward over the episode with the collisions
// marked. Users watch what the robot does before they trust a number.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <optional>

#include "atacom/safety_layer.hpp"
#include "atacom/trainer.hpp"

namespace atacom {

struct RenderConfig {
  std::string env;                // table | shelf | nav | hri (any env with a recorder); optional with "trained"
  std::string policy = "random";  // random | zero | la (the env's linear attractor) | trained (run_dir's, deterministic)
  std::string run_dir;            // "trained" only
  RunPolicy which = RunPolicy::Final;
  std::optional<SafetyLayer> safety;  // between the policy and the env; unset: ATACOM, or the run's layer
  uint64_t seed = 0;                  // env streams and the policy's noise
  nlohmann::json env_config = nlohmann::json::object();  // overrides of the env's defaults (not with "trained")
};

struct RenderResult {
  std::string html;
  int steps = 0;            // steps of the episode (= frames in the page)
  double episode_return = 0.0;
  int collisions = 0;       // steps whose info "collision" was set
  double max_constraint = 0.0;
  bool terminated = false;  // ended in a terminal state (else truncated at the horizon)
};

// Runs one episode of env 0 (N = 1) and draws it. Throws std::invalid_argument
// for an unknown env or policy, a setting that does not apply, or an env
// without a picture; std::runtime_error for an unreadable run.
RenderResult render_episode(const RenderConfig& config);

// The constraint plot's y range [lo, hi]: from the lowest value of any row
// to the highest, always including the boundary c = 0, padded by 5 % of the
// span and rounded out to tick steps (non-finite values ignored).
std::pair<double, double> constraint_plot_range(const std::vector<std::vector<double>>& rows);

// The page around the episode's data (render_page.cpp): title, the data JSON
// (one object, see render.cpp), the two plot SVGs.
std::string render_page_html(const std::string& title, const std::string& data_json, const std::string& constraint_svg,
                             const std::string& reward_svg);

}  // namespace atacom
