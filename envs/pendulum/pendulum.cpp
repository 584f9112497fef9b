#include "envs/pendulum/pendulum.hpp"

#include <cmath>
#include <numbers>
#include <istream>
#include <ostream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "src/core/binary_io.hpp"
#include "src/core/record_fields.hpp"
#include "src/core/snapshot.hpp"
#include "src/core/config_fields.hpp"
#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"
#include "atacom/parallel.hpp"

namespace atacom {

namespace {
constexpr uint32_t kTagPendulum = snapshot_tag("PEND");
constexpr uint32_t kTagPendulumState = snapshot_tag("PSTA");
constexpr int kInfoAbsTheta = 0, kInfoNonfinite = 1;

// PendulumBatch's one field list, in the order of the PSTA section.
struct PendulumStateFields {
  using Record = PendulumBatch;
  template <class V>
  static constexpr void each(V&& v) {
    v("theta", &PendulumBatch::theta);
    v("theta_dot", &PendulumBatch::theta_dot);
    v("t", &PendulumBatch::t);
    v("return", &PendulumBatch::ret);
    v("rng", &PendulumBatch::rng);
  }
};
static_assert(sizeof(PendulumBatch) == field_bytes<PendulumStateFields>(),
              "PendulumBatch has a member PendulumStateFields does not list");
}  // namespace

PendulumModel default_pendulum_model() { return PendulumModel{}; }

namespace {
// PendulumModel's one key list (src/core/config_fields.hpp); every key is
// optional when read (Gymnasium's constants fill the rest).
template <class P, class V>
void pendulum_model_fields(P& p, V& v) {
  v.number("g", p.g, range::finite());
  v.number("m", p.m, range::positive());
  v.number("l", p.l, range::positive());
  v.number("dt", p.dt, range::open_closed(0.0, 1.0));
  v.number("max_speed", p.max_speed, range::positive());
  v.number("max_torque", p.max_torque, range::positive());
  v.integer("horizon", p.horizon, range::closed(1, limits::kMaxHorizon));
}
}  // namespace

void to_json(nlohmann::json& j, const PendulumModel& p) {
  ConfigJsonWriter w;
  pendulum_model_fields(p, w);
  j = std::move(w.json());
}

void from_json(const nlohmann::json& j, PendulumModel& p) {
  ConfigReader r(j, "env");
  p = default_pendulum_model();
  ConfigFieldReader v(r, ConfigFieldReader::Keys::Optional);
  pendulum_model_fields(p, v);
  r.finish();
  auto pos = [](double v) { return v > 0 && std::isfinite(v); };
  if (!std::isfinite(p.g)) throw std::invalid_argument("config: env.g must be finite");
  if (!pos(p.m) || !pos(p.l) || !pos(p.dt) || !pos(p.max_speed) || !pos(p.max_torque))
    throw std::invalid_argument("config: env.m, l, dt, max_speed and max_torque must be positive");
  if (p.horizon < 1) throw std::invalid_argument("config: env.horizon must be >= 1");
}

double angle_normalize(double x) {
  double r = std::fmod(x + std::numbers::pi, 2.0 * std::numbers::pi);
  if (r < 0) r += 2.0 * std::numbers::pi;
  return r - std::numbers::pi;
}

PendulumEnv::PendulumEnv(const PendulumModel& model, int num_envs) : model_(model) {
  if (num_envs < 1) throw std::invalid_argument("pendulum: number of envs must be >= 1");
  spec_.name = "pendulum";
  spec_.obs_dim = 3;
  spec_.act_dim = 1;
  spec_.obs_low = {-1.0f, -1.0f, -float(model.max_speed)};
  spec_.obs_high = {1.0f, 1.0f, float(model.max_speed)};
  spec_.dt = model.dt;
  spec_.horizon = model.horizon;
  spec_.gamma = 0.99;  // as configs/pendulum_sac.json
  spec_.info_names = {"abs_theta", "nonfinite_action"};
  spec_.info_reduce = {InfoReduce::Last, InfoReduce::Sum};
  buffers_.resize(spec_, num_envs);
  const size_t n = size_t(num_envs);
  st_.theta.assign(n, 0.0);
  st_.theta_dot.assign(n, 0.0);
  st_.t.assign(n, 0);
  st_.ret.assign(n, 0.0);
  st_.rng.assign(n, Rng());
  seed(0);
}

void PendulumEnv::write_obs(int i, float* obs) const {
  float* o = obs + size_t(i) * 3;
  o[0] = float(std::cos(st_.theta[size_t(i)]));
  o[1] = float(std::sin(st_.theta[size_t(i)]));
  o[2] = float(st_.theta_dot[size_t(i)]);
}

void PendulumEnv::reset_one(int i) {
  Rng& r = st_.rng[size_t(i)];
  st_.theta[size_t(i)] = r.uniform(-std::numbers::pi, std::numbers::pi);
  st_.theta_dot[size_t(i)] = r.uniform(-1.0, 1.0);
  st_.t[size_t(i)] = 0;
  st_.ret[size_t(i)] = 0.0;
}

void PendulumEnv::seed(uint64_t s) {
  for (int i = 0; i < num_envs(); ++i) st_.rng[size_t(i)].reseed(s, uint64_t(i));
  reset(nullptr);
}

void PendulumEnv::reset(const uint8_t* mask) {
  EnvBuffers& b = buffers_;
  for (int i = 0; i < num_envs(); ++i) {
    if (mask && !mask[i]) continue;
    reset_one(i);
    write_obs(i, b.obs.data());
    write_obs(i, b.final_obs.data());
    b.terminated[size_t(i)] = 0;
    b.truncated[size_t(i)] = 0;
  }
}

void PendulumEnv::step(const double* actions) {
  EnvBuffers& b = buffers_;
  const PendulumModel& p = model_;
  const int ninfo = static_cast<int>(spec_.info_names.size());
  parallel_blocks(num_envs(), kCheapEnvBlock, [&](int64_t lo, int64_t hi) {
    for (int64_t k = lo; k < hi; ++k) {
      const int i = static_cast<int>(k);
      const size_t s = size_t(i);
      double a = actions[s];
      const bool bad = !std::isfinite(a);
      if (bad) a = 0.0;
      a = std::min(std::max(a, -1.0), 1.0);
      const double u = p.max_torque * a;
      const double th = st_.theta[s], thdot = st_.theta_dot[s];
      const double thn = angle_normalize(th);
      const double costs = thn * thn + 0.1 * thdot * thdot + 0.001 * u * u;
      double newthdot = thdot + (3.0 * p.g / (2.0 * p.l) * std::sin(th) + 3.0 / (p.m * p.l * p.l) * u) * p.dt;
      newthdot = std::min(std::max(newthdot, -p.max_speed), p.max_speed);
      st_.theta[s] = th + newthdot * p.dt;
      st_.theta_dot[s] = newthdot;
      const double reward = -costs;
      st_.ret[s] += reward;
      st_.t[s] += 1;
      b.reward[s] = float(reward);
      b.cost[s] = b.cost_continuous[s] = 0.0f;
      b.terminated[s] = 0;
      b.truncated[s] = st_.t[s] >= p.horizon ? 1 : 0;
      b.info[s * ninfo + kInfoAbsTheta] = float(std::abs(angle_normalize(st_.theta[s])));
      b.info[s * ninfo + kInfoNonfinite] = bad ? 1.0f : 0.0f;
      write_obs(i, b.final_obs.data());
      if (b.truncated[s]) {
        b.episode_return[s] = st_.ret[s];
        b.episode_length[s] = st_.t[s];
        reset_one(i);  // same-step autoreset: obs starts the next episode
        write_obs(i, b.obs.data());
      } else {
        for (int j = 0; j < 3; ++j) b.obs[s * 3 + j] = b.final_obs[s * 3 + j];
      }
    }
  });
}

// Snapshot (src/core/snapshot.hpp): HEAD, PEND (state and streams), BUFS;
// read into copies, swapped in at the end.
void PendulumEnv::save_state(std::ostream& out) const {
  nlohmann::json j;
  to_json(j, model_);
  SnapshotWriter w(kTagPendulum, "pendulum");
  write_head_section(w, num_envs(), snapshot_fingerprint(j.dump()));
  write_fields<PendulumStateFields>(w.section(kTagPendulumState), st_);
  write_buffers_section(w, buffers_);
  w.finish(out);
}

void PendulumEnv::load_state(std::istream& in) {
  nlohmann::json j;
  to_json(j, model_);
  SnapshotReader r(in, kTagPendulum, "pendulum");
  read_head_section(r, num_envs(), snapshot_fingerprint(j.dump()));
  PendulumBatch s = st_;  // same sizes; every array is checked against them
  read_fields<PendulumStateFields>(r.section(kTagPendulumState, "state"), s, "pendulum.");
  EnvBuffers b = buffers_;
  read_buffers_section(r, b);
  r.finish();
  st_ = std::move(s);
  buffers_.copy_values_from(b);
}

EnvEntry pendulum_env_entry() {
  EnvEntry e;
  e.name = "pendulum";
  e.help = "Gymnasium Pendulum-v1 swing-up (no constraints)";
  e.has_constraints = false;
  e.default_config = []() { return nlohmann::json(default_pendulum_model()); };
  e.make = [](const nlohmann::json& cfg, int num_envs) -> std::unique_ptr<BatchEnv> {
    return std::make_unique<PendulumEnv>(cfg.get<PendulumModel>(), num_envs);
  };
  return e;
}

}  // namespace atacom
