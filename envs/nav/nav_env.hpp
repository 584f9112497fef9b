// NavEnv: a differential-drive TIAGo base reaches a random goal in a 7 m x
// 5 m room while a Fetch robot drives to its own random goals, ignoring TIAGo
// (paper: "Navigation: Differential-Drive Robot"; reference digest 4.3).
//
// Simulation: one single-threaded Box2D 2.4 world per env (zero gravity, top
// down); the four walls are static boxes, TIAGo and Fetch are dynamic discs
// whose velocities are set every step so that Box2D's position update lands
// exactly on the unicycle's closed-form step (docs/envs_nav.md). TBB runs
// fixed blocks of worlds in parallel. A TIAGo contact (wall or Fetch), read
// from Box2D's contact pairs at the state the step reached, ends the episode
// with the collision reward.
//
// Observation (18): goal x, y | TIAGo x, y, cos, sin | TIAGo vx, vy, omega |
// Fetch x, y, cos, sin | Fetch vx, vy, omega | previous action (2).
// Action (2): [v / v_max, omega / w_max] in [-1, 1].
//
// The parts, as for the arm envs: NavConfig (nav_config.hpp), the static
// NavModel (nav_model.hpp), the per-env arrays NavBatch (nav_batch.hpp), the
// Box2D worlds NavWorlds (nav_world.hpp) and the range kernels with their
// scalar reference (nav_kernels.hpp). NavEnv owns one of each and runs the
// kernels over fixed blocks. After each step the body poses are mirrored into
// NavBatch, which the constraint kernel (nav_constraints.hpp) and the
// observation read; Box2D holds no state that the next step depends on
// besides the body poses, so snapshots store the SoA and rebuild the worlds.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "atacom/control_affine_env.hpp"
#include "envs/nav/nav_batch.hpp"
#include "envs/nav/nav_config.hpp"
#include "envs/nav/nav_kernels.hpp"
#include "envs/nav/nav_model.hpp"
#include "envs/nav/nav_world.hpp"

namespace atacom {

class NavEnv final : public ControlAffineEnv {
 public:
  NavEnv(const NavConfig& config, int num_envs);
  ~NavEnv() override;
  NavEnv(const NavEnv&) = delete;
  NavEnv& operator=(const NavEnv&) = delete;

  const EnvSpec& spec() const override { return model_.spec; }
  void seed(uint64_t seed) override;
  void reset(const uint8_t* mask = nullptr) override;
  void step(const double* actions) override;
  void save_state(std::ostream& out) const override;
  void load_state(std::istream& in) override;

  // Sections: "box2d" (world steps and contact queries), "env" (the rest of
  // step: actions, Fetch controller, reward, observation, resets). Seconds
  // are summed over blocks, i.e. thread-seconds.
  std::vector<std::string> profile_sections() const override;
  void set_profiling(bool on) override;
  std::vector<double> profile_seconds() const override;

  // ATACOM: n = 3, m = 2, k = 5, p = 3 (Fetch's pose), dense G, no drift, K_c = 1/dt.
  ProjectorModel projector_model() const override;
  void constraint_model(ProjectorBatch& pb, int begin, int end) const override;

  const NavConfig& config() const { return model_.config; }
  const NavModel& model() const { return model_; }
  const NavBatch& state() const { return st_; }

  // Scripted start for env i (tests, demos): poses [x, y, theta] and goals
  // [x, y]; the episode restarts there (t = 0, zero velocities). Poses are
  // rounded to Box2D's float. No check that the start is collision free.
  void place(int i, const double* tiago_pose, const double* fetch_pose, const double* goal,
             const double* fetch_goal);

 private:
  NavModel model_;
  NavBatch st_;
  NavWorlds worlds_;
  bool profiling_ = false;
  std::vector<NavProfile> profile_;  // (blocks) seconds per parallel block
};

// Registry factory: resolved JSON config -> NavEnv.
nlohmann::json nav_default_config_json();
std::unique_ptr<BatchEnv> make_nav_env(const nlohmann::json& config, int num_envs);

}  // namespace atacom
