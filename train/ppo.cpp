#include "train/ppo.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>
#include <tbb/parallel_invoke.h>

#include "atacom/parallel.hpp"
#include "src/core/binary_io.hpp"
#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"

namespace atacom {

namespace {
constexpr double kHalfLog2Pi = 0.91893853320467274178;
constexpr int kMaxRolloutSteps = 100000;
constexpr int kMaxEpochs = 1000;
constexpr int kValueChunk = 4096;  // rows per value pass (fixed: the same bits for any rollout size)

const char* log_std_name(LogStdMode m) {
  return m == LogStdMode::StateDependent ? "state_dependent" : "state_independent";
}
const char* schedule_name(LrSchedule s) { return s == LrSchedule::Linear ? "linear" : "constant"; }
nlohmann::json opt(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); }
}  // namespace

// ---------------------------------------------------------------- config
PpoConfig default_ppo_config() {
  PpoConfig c;
  c.actor.hidden = c.critic.hidden = {64, 64};
  c.actor.activation = c.critic.activation = Activation::Relu;
  c.rollout_steps = 16;
  c.epochs = 10;
  c.minibatch_size = 512;
  c.gamma = 0.99;
  c.gae_lambda = 0.95;
  c.clip_range = 0.2;
  c.value_clip_range = std::nullopt;
  c.entropy_coef = 0.0;
  c.lr_actor = c.lr_critic = 1e-3;
  c.lr_schedule = LrSchedule::Constant;
  c.lr_decay_steps = 10'000'000;
  c.target_kl = std::nullopt;
  c.normalize_advantages = true;
  c.obs_norm = true;
  c.log_std = LogStdMode::StateIndependent;
  c.init_log_std = -0.5;
  c.log_std_min = -5.0;
  c.log_std_max = 2.0;
  c.max_grad_norm = 0.5;
  c.reward_scale = 1.0;
  c.init_output_scale = 0.01;
  c.adam = default_adam_config();
  return c;
}

void to_json(nlohmann::json& j, const PpoConfig& c) {
  j = nlohmann::json{{"actor", c.actor}, {"critic", c.critic}, {"rollout_steps", c.rollout_steps},
                     {"epochs", c.epochs}, {"minibatch_size", c.minibatch_size}, {"gamma", c.gamma},
                     {"gae_lambda", c.gae_lambda}, {"clip_range", c.clip_range},
                     {"value_clip_range", opt(c.value_clip_range)}, {"entropy_coef", c.entropy_coef},
                     {"lr_actor", c.lr_actor}, {"lr_critic", c.lr_critic},
                     {"lr_schedule", schedule_name(c.lr_schedule)},
                     {"lr_decay_steps", c.lr_decay_steps}, {"target_kl", opt(c.target_kl)},
                     {"normalize_advantages", c.normalize_advantages}, {"obs_norm", c.obs_norm},
                     {"log_std", log_std_name(c.log_std)}, {"init_log_std", c.init_log_std},
                     {"log_std_min", c.log_std_min}, {"log_std_max", c.log_std_max},
                     {"max_grad_norm", c.max_grad_norm}, {"reward_scale", c.reward_scale},
                     {"init_output_scale", c.init_output_scale}, {"adam", c.adam}};
}

namespace {
// An optional positive number: null turns it off.
void read_optional(ConfigReader& r, const char* key, std::optional<double>& v, const Range<double>& range) {
  const nlohmann::json* s = r.sub(key);
  if (!s) return;
  if (s->is_null()) v = std::nullopt;
  else v = checked_number(*s, r.name(key), range);
}

template <class E>
E read_choice(ConfigReader& r, const char* key, E current, const char* (*name)(E), std::initializer_list<E> all) {
  std::string s = name(current);
  r.get(key, s);
  std::string known;
  for (E e : all) {
    if (s == name(e)) return e;
    known += (known.empty() ? "" : ", ") + std::string(name(e));
  }
  throw std::invalid_argument("config key '" + r.path(key) + "' is '" + printable_text(s) + "', must be one of " +
                              known);
}
}  // namespace

void from_json(const nlohmann::json& j, PpoConfig& c) {
  ConfigReader r(j, "ppo");
  c = default_ppo_config();
  // A network's keys lay over PPO's default network (not the Mlp default).
  for (auto [key, net] : {std::pair{"actor", &c.actor}, std::pair{"critic", &c.critic}}) {
    const nlohmann::json* s = r.sub(key);
    if (!s) continue;
    if (!s->is_object()) throw std::invalid_argument("config section '" + r.path(key) + "' must be a JSON object");
    nlohmann::json merged = *net;
    for (auto it = s->begin(); it != s->end(); ++it) merged[it.key()] = it.value();
    *net = read_mlp_config(merged, r.path(key));
  }
  r.get("rollout_steps", c.rollout_steps, range::closed(1, kMaxRolloutSteps));
  r.get("epochs", c.epochs, range::closed(1, kMaxEpochs));
  r.get("minibatch_size", c.minibatch_size, range::closed(1, limits::kMaxBatchSize));
  r.get("gamma", c.gamma, range::closed(0.0, 1.0));
  r.get("gae_lambda", c.gae_lambda, range::closed(0.0, 1.0));
  r.get("clip_range", c.clip_range, range::open_closed(0.0, 1.0));
  read_optional(r, "value_clip_range", c.value_clip_range, range::positive());
  r.get("entropy_coef", c.entropy_coef, range::closed(0.0, 1e3));
  r.get("lr_actor", c.lr_actor, range::closed(0.0, 1.0));
  r.get("lr_critic", c.lr_critic, range::closed(0.0, 1.0));
  c.lr_schedule =
      read_choice(r, "lr_schedule", c.lr_schedule, schedule_name, {LrSchedule::Constant, LrSchedule::Linear});
  r.get("lr_decay_steps", c.lr_decay_steps, range::closed<int64_t>(1, limits::kMaxSteps));
  read_optional(r, "target_kl", c.target_kl, range::positive());
  r.get("normalize_advantages", c.normalize_advantages);
  r.get("obs_norm", c.obs_norm);
  c.log_std =
      read_choice(r, "log_std", c.log_std, log_std_name, {LogStdMode::StateIndependent, LogStdMode::StateDependent});
  r.get("init_log_std", c.init_log_std, range::closed(-20.0, 20.0));
  r.get("log_std_min", c.log_std_min, range::closed(-20.0, 20.0));
  r.get("log_std_max", c.log_std_max, range::closed(-20.0, 20.0));
  r.get("max_grad_norm", c.max_grad_norm, range::closed(0.0, 1e6));
  r.get("reward_scale", c.reward_scale, range::open_closed(0.0, 1e6));
  r.get("init_output_scale", c.init_output_scale, range::closed(0.0, 10.0));
  if (const auto* s = r.sub("adam")) c.adam = read_adam_config(*s, r.path("adam"));
  r.finish();
  if (!(c.log_std_min < c.log_std_max))
    throw std::invalid_argument("config: ppo.log_std_min (" + readable_number(c.log_std_min) +
                                ") must be below ppo.log_std_max (" + readable_number(c.log_std_max) + ")");
  if (!(c.init_log_std >= c.log_std_min && c.init_log_std <= c.log_std_max))
    throw std::invalid_argument("config: ppo.init_log_std (" + readable_number(c.init_log_std) +
                                ") must be in [ppo.log_std_min, ppo.log_std_max]");
}

double ppo_lr_factor(const PpoConfig& c, int64_t env_steps) {
  if (c.lr_schedule == LrSchedule::Constant) return 1.0;
  return std::max(0.0, 1.0 - double(env_steps) / double(c.lr_decay_steps));
}

// ---------------------------------------------------------------- acting
void ppo_actor_act(Mlp<float>& actor, const float* log_std, double log_std_min, double log_std_max, Tape<float>& tape,
                   const float* obs, int N, bool deterministic, Rng* rngs, double* actions, const PpoSample* sample) {
  const int A = log_std ? actor.out() : actor.out() / 2;
  const int W = actor.out();
  tape.clear();
  const auto out = actor.forward(tape, tape.constant(obs, N, actor.in()), false);
  const float* o = tape.value(out).data;
  const float lo = float(log_std_min), hi = float(log_std_max);
  // Per-row noise from the row's own stream: any block partition gives the same actions.
  parallel_blocks(N, 512, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const float* mu = o + i * W;
      float lp = 0.0f;
      for (int j = 0; j < A; ++j) {
        float u = mu[j];
        if (!deterministic) {
          const float ls = std::min(std::max(log_std ? log_std[j] : mu[A + j], lo), hi);
          u = mu[j] + std::exp(ls) * float(rngs[i].normal());
          // The density as the update's tape computes it: z = (u - mean) exp(-log_std).
          const float z = (u - mu[j]) * std::exp(-ls);
          lp += -0.5f * (z * z) - float(kHalfLog2Pi) - ls;
          if (sample) sample->u[i * A + j] = u;
        }
        actions[i * A + j] = std::min(std::max(double(u), -1.0), 1.0);  // NaN stays NaN: the env counts it
      }
      if (!deterministic && sample) sample->logp[i] = lp;
    }
  });
}

// ---------------------------------------------------------------- agent
struct Ppo::CostCritic {
  Mlp<float> critic;
  Adam<float> opt;
  Tape<float> tape;
  AlignedVector<float> ret, v;  // (max minibatch) cost returns and old cost values
  CostCritic(int obs_dim, const PpoConfig& c) : critic(obs_dim, 1, c.critic, 1), opt(critic.params().size(), c.adam) {}
};

Ppo::~Ppo() = default;

const Mlp<float>& Ppo::cost_critic() const {
  if (!cost_) throw std::logic_error("Ppo::cost_critic: this agent has no cost critic");
  return cost_->critic;
}

Ppo::Ppo(int obs_dim, int act_dim, const PpoConfig& cfg, uint64_t seed, bool cost_critic)
    : cfg_(cfg),
      obs_dim_(obs_dim),
      act_dim_(act_dim),
      actor_(obs_dim, cfg.log_std == LogStdMode::StateDependent ? 2 * act_dim : act_dim, cfg.actor, 1),
      critic_(obs_dim, 1, cfg.critic, 1),
      log_std_(size_t(act_dim), float(cfg.init_log_std)),
      log_std_grad_(size_t(act_dim), 0.0f),
      actor_opt_(actor_.params().size(), cfg.adam),
      log_std_opt_(size_t(act_dim), cfg.adam),
      critic_opt_(critic_.params().size(), cfg.adam),
      rng_(seed, 0x990) {
  Rng init(seed, 0x9901);
  actor_.init(init);
  critic_.init(init);
  // The output layer (its weights: the rows before its bias, the buffer's
  // last block) starts small so the first actions are near 0 for any input;
  // a state-dependent log-std starts at init_log_std through its bias.
  auto& p = actor_.params();
  const int W = actor_.out(), H = cfg.actor.hidden.back();
  const size_t bias = p.size() - size_t(W), weights = bias - size_t(H) * size_t(W);
  for (size_t k = weights; k < bias; ++k) p[k] *= float(cfg.init_output_scale);
  if (cfg.log_std == LogStdMode::StateDependent)
    for (int j = 0; j < act_dim; ++j) p[bias + size_t(act_dim + j)] = float(cfg.init_log_std);
  if (cost_critic) {  // drawn after the others: the actor and critic are plain PPO's
    cost_ = std::make_unique<CostCritic>(obs_dim, cfg);
    cost_->critic.init(init);
  }
}

void Ppo::values(const float* obs, int64_t rows, float* out) { values_of(critic_, obs, rows, out); }

void Ppo::values_of(Mlp<float>& net, const float* obs, int64_t rows, float* out) {
  for (int64_t r0 = 0; r0 < rows; r0 += kValueChunk) {
    const int n = int(std::min<int64_t>(kValueChunk, rows - r0));
    value_tape_.clear();
    const auto v = net.forward(value_tape_, value_tape_.constant(obs + r0 * obs_dim_, n, obs_dim_), false);
    std::copy_n(value_tape_.value(v).data, n, out + r0);
  }
}

void Ppo::gather(const PpoRollout& r, const int32_t* idx, int B) {
  const int D = obs_dim_, A = act_dim_;
  parallel_blocks(B, 1024, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const size_t k = size_t(idx[i]);
      std::copy_n(r.obs.data() + k * D, D, mb_obs_.data() + i * D);
      std::copy_n(r.sample.data() + k * A, A, mb_u_.data() + i * A);
      mb_logp_[size_t(i)] = r.logp[k];
      mb_adv_[size_t(i)] = r.advantage[k];
      mb_ret_[size_t(i)] = r.ret[k];
      mb_v_[size_t(i)] = r.value[k];
      if (cost_) cost_->ret[size_t(i)] = r.cost_ret[k], cost_->v[size_t(i)] = r.cost_value[k];
    }
  });
}

double Ppo::cost_loss(int B) {
  Tape<float>& t = cost_->tape;
  t.clear();
  const auto loss = record_ppo_value_loss<float>(t, cost_->critic, cfg_, mb_obs_.data(), cost_->ret.data(),
                                                 cost_->v.data(), B);
  t.backward(loss);
  return t.scalar(loss);
}

template <class T>
PpoActorLoss<T> record_ppo_actor_loss(Tape<T>& t, Mlp<T>& actor, T* log_std, T* log_std_grad, int A,
                                      const PpoConfig& c, const T* obs, const T* u, const T* logp_old, const T* adv_in,
                                      int B) {
  constexpr auto set = Tape<T>::GradMode::Set;
  const auto out = actor.forward(t, t.constant(obs, B, actor.in()), true, set);
  const auto mu = log_std ? out : t.slice(out, 0, A);
  const auto ls_raw = log_std ? t.leaf(log_std, log_std_grad, 1, A, set) : t.slice(out, A, 2 * A);
  const auto ls = t.clamp(ls_raw, T(c.log_std_min), T(c.log_std_max));
  const auto z = t.mul(t.sub(t.constant(u, B, A), mu), t.exp(t.affine(ls, T(-1), T(0))));
  const auto logp = t.sum(t.sub(t.affine(t.square(z), T(-0.5), T(-kHalfLog2Pi)), ls), 1);  // (B x 1)
  const auto ratio = t.exp(t.sub(logp, t.constant(logp_old, B, 1)));
  const auto adv = t.constant(adv_in, B, 1);
  const T e = T(c.clip_range);
  const auto surr = t.minimum(t.mul(ratio, adv), t.mul(t.clamp(ratio, T(1) - e, T(1) + e), adv));
  const auto pg = t.affine(t.mean(surr), T(-1), T(0));
  const auto ls_sum = t.mean(t.sum(ls, 1));  // the entropy is this + A (0.5 + 0.5 log 2 pi)
  const auto loss = c.entropy_coef > 0 ? t.sub(pg, t.affine(ls_sum, T(c.entropy_coef), T(0))) : pg;
  return {loss, pg, ls_sum, logp};
}

template <class T>
typename Tape<T>::Id record_ppo_value_loss(Tape<T>& t, Mlp<T>& critic, const PpoConfig& c, const T* obs,
                                           const T* ret_in, const T* v_old, int B) {
  const auto v = critic.forward(t, t.constant(obs, B, critic.in()), true, Tape<T>::GradMode::Set);
  const auto ret = t.constant(ret_in, B, 1);
  auto l = t.square(t.sub(v, ret));
  if (c.value_clip_range) {
    const T r = T(*c.value_clip_range);
    const auto vo = t.constant(v_old, B, 1);
    const auto l2 = t.square(t.sub(t.add(vo, t.clamp(t.sub(v, vo), -r, r)), ret));
    l = t.affine(t.minimum(t.affine(l, T(-1), T(0)), t.affine(l2, T(-1), T(0))), T(-1), T(0));  // max(l, l2)
  }
  return t.affine(t.mean(l), T(0.5), T(0));
}

template PpoActorLoss<float> record_ppo_actor_loss<float>(Tape<float>&, Mlp<float>&, float*, float*, int,
                                                          const PpoConfig&, const float*, const float*, const float*,
                                                          const float*, int);
template PpoActorLoss<double> record_ppo_actor_loss<double>(Tape<double>&, Mlp<double>&, double*, double*, int,
                                                            const PpoConfig&, const double*, const double*,
                                                            const double*, const double*, int);
template Tape<float>::Id record_ppo_value_loss<float>(Tape<float>&, Mlp<float>&, const PpoConfig&, const float*,
                                                      const float*, const float*, int);
template Tape<double>::Id record_ppo_value_loss<double>(Tape<double>&, Mlp<double>&, const PpoConfig&, const double*,
                                                        const double*, const double*, int);

PpoStats Ppo::losses(const float* obs, const float* u, const float* logp_old, const float* adv, const float* ret,
                     const float* v_old, int B) {
  const int A = act_dim_;
  PpoStats st;
  double kl = 0, clipped = 0;
  auto actor_phase = [&]() {
    Tape<float>& t = actor_tape_;
    t.clear();
    const bool indep = cfg_.log_std == LogStdMode::StateIndependent;
    const PpoActorLoss<float> l = record_ppo_actor_loss<float>(t, actor_, indep ? log_std_.data() : nullptr,
                                                               log_std_grad_.data(), A, cfg_, obs, u, logp_old, adv, B);
    t.backward(l.loss);
    st.policy_loss = t.scalar(l.policy_loss);
    st.entropy = double(t.scalar(l.log_std_sum)) + A * (0.5 + double(kHalfLog2Pi));
    const float* lp = t.value(l.logp).data;
    for (int i = 0; i < B; ++i) {
      const double lr = double(lp[i]) - double(logp_old[i]), r = std::exp(lr);
      kl += (r - 1.0) - lr;
      clipped += std::abs(r - 1.0) > cfg_.clip_range;
    }
  };
  auto critic_phase = [&]() {
    Tape<float>& t = critic_tape_;
    t.clear();
    const auto loss = record_ppo_value_loss<float>(t, critic_, cfg_, obs, ret, v_old, B);
    t.backward(loss);
    st.value_loss = t.scalar(loss);
  };
  // The phases share no written state: concurrent or not, the same bits.
  tbb::parallel_invoke(actor_phase, critic_phase);
  st.approx_kl = kl / B;
  st.clip_fraction = clipped / B;
  return st;
}

void Ppo::step(double lr_actor, double lr_critic) {
  const bool indep = cfg_.log_std == LogStdMode::StateIndependent;
  if (cfg_.max_grad_norm > 0) {
    // The actor's norm covers its log-std parameter too.
    auto& ga = actor_.grads();
    const double na = clip_grad_norm(ga.data(), ga.size(), 0.0);
    const double nl = indep ? clip_grad_norm(log_std_grad_.data(), log_std_grad_.size(), 0.0) : 0.0;
    const double norm = std::sqrt(na * na + nl * nl);
    if (norm > cfg_.max_grad_norm) {
      const float s = float(cfg_.max_grad_norm / (norm + 1e-6));
      for (float& g : ga) g *= s;
      for (float& g : log_std_grad_) g *= s;
    }
    clip_grad_norm(critic_.grads().data(), critic_.grads().size(), cfg_.max_grad_norm);
  }
  constexpr auto keep = Adam<float>::Grads::Keep;
  actor_opt_.step_fused(actor_.params().data(), actor_.grads().data(), lr_actor, nullptr, 0.0, keep);
  if (indep) log_std_opt_.step(log_std_.data(), log_std_grad_.data(), lr_actor);
  critic_opt_.step_fused(critic_.params().data(), critic_.grads().data(), lr_critic, nullptr, 0.0, keep);
  if (cost_) {
    auto& g = cost_->critic.grads();
    if (cfg_.max_grad_norm > 0) clip_grad_norm(g.data(), g.size(), cfg_.max_grad_norm);
    cost_->opt.step_fused(cost_->critic.params().data(), g.data(), lr_critic, nullptr, 0.0, keep);
  }
}

PpoStats Ppo::update(PpoRollout& r, double lr_actor, double lr_critic, double cost_weight) {
  if (r.steps != r.T) throw std::logic_error("Ppo::update on an unfinished rollout");
  if (cost_ && !r.with_cost) throw std::logic_error("Ppo::update: a cost critic needs a rollout with costs");
  if (cost_ && !(std::isfinite(cost_weight) && cost_weight >= 0))
    throw std::invalid_argument("Ppo::update: the cost weight must be a finite number >= 0");
  const int N = r.N, T = r.T;
  const int64_t S = int64_t(T) * N;
  values(r.obs.data(), S, r.value.data());
  values(r.final_obs.data(), r.finals, r.final_value.data());
  values(r.last_obs.data(), N, r.last_value.data());
  compute_gae(T, N, r.reward.data(), r.value.data(), r.last_value.data(), r.terminated.data(), r.truncated.data(),
              r.final_row.data(), r.final_value.data(), cfg_.gamma, cfg_.gae_lambda, r.advantage.data(), r.ret.data());
  PpoStats total;
  {  // explained variance of the value targets by the old values
    double mr = 0, me = 0;
    for (int64_t k = 0; k < S; ++k) mr += r.ret[size_t(k)], me += r.ret[size_t(k)] - r.value[size_t(k)];
    mr /= double(S), me /= double(S);
    double vr = 0, ve = 0;
    for (int64_t k = 0; k < S; ++k) {
      const double a = r.ret[size_t(k)] - mr, b = (r.ret[size_t(k)] - r.value[size_t(k)]) - me;
      vr += a * a, ve += b * b;
    }
    total.explained_variance = vr > 0 ? 1.0 - ve / vr : std::numeric_limits<double>::quiet_NaN();
  }
  if (cost_) {  // cost GAE, then the actor's advantage (A_r - w A_c) / (1 + w)
    values_of(cost_->critic, r.obs.data(), S, r.cost_value.data());
    values_of(cost_->critic, r.final_obs.data(), r.finals, r.cost_final_value.data());
    values_of(cost_->critic, r.last_obs.data(), N, r.cost_last_value.data());
    compute_gae(T, N, r.cost.data(), r.cost_value.data(), r.cost_last_value.data(), r.terminated.data(),
                r.truncated.data(), r.final_row.data(), r.cost_final_value.data(), cfg_.gamma, cfg_.gae_lambda,
                r.cost_advantage.data(), r.cost_ret.data());
    const double w = cost_weight, inv = 1.0 / (1.0 + w);
    for (int64_t k = 0; k < S; ++k)
      r.advantage[size_t(k)] = float((double(r.advantage[size_t(k)]) - w * double(r.cost_advantage[size_t(k)])) * inv);
  }
  const int K = int(ppo_minibatches(S, cfg_.minibatch_size));
  const int max_b = int((S + K - 1) / K);
  if (mb_obs_.size() < size_t(max_b) * obs_dim_) {  // first update: sized once
    mb_obs_.assign(size_t(max_b) * obs_dim_, 0.0f);
    mb_u_.assign(size_t(max_b) * act_dim_, 0.0f);
    for (auto* v : {&mb_logp_, &mb_adv_, &mb_ret_, &mb_v_}) v->assign(size_t(max_b), 0.0f);
  }
  if (cost_ && cost_->ret.size() < size_t(max_b)) {
    cost_->ret.assign(size_t(max_b), 0.0f);
    cost_->v.assign(size_t(max_b), 0.0f);
  }
  if (perm_.size() != size_t(S)) perm_.resize(size_t(S));
  std::iota(perm_.begin(), perm_.end(), 0);
  total.minibatches = K;
  bool stop = false;
  for (int epoch = 0; epoch < cfg_.epochs && !stop; ++epoch) {
    for (int64_t i = S - 1; i > 0; --i) std::swap(perm_[size_t(i)], perm_[size_t(rng_.below(uint64_t(i + 1)))]);
    for (int k = 0; k < K; ++k) {
      const int64_t b0 = S * k / K, b1 = S * (k + 1) / K;
      const int B = int(b1 - b0);
      gather(r, perm_.data() + b0, B);
      if (cfg_.normalize_advantages) {
        double m = 0, s2 = 0;
        for (int i = 0; i < B; ++i) m += mb_adv_[size_t(i)];
        m /= B;
        for (int i = 0; i < B; ++i) s2 += (mb_adv_[size_t(i)] - m) * (mb_adv_[size_t(i)] - m);
        const double inv = 1.0 / (std::sqrt(B > 1 ? s2 / (B - 1) : 0.0) + 1e-8);
        for (int i = 0; i < B; ++i) mb_adv_[size_t(i)] = float((mb_adv_[size_t(i)] - m) * inv);
      }
      const PpoStats st = losses(mb_obs_.data(), mb_u_.data(), mb_logp_.data(), mb_adv_.data(), mb_ret_.data(),
                                 mb_v_.data(), B);
      const double lc = cost_ ? cost_loss(B) : 0.0;
      if (!std::isfinite(st.policy_loss) || !std::isfinite(st.value_loss) || !std::isfinite(st.approx_kl) ||
          !std::isfinite(lc))
        throw std::runtime_error("PPO update produced a non-finite loss (lower ppo.lr_actor/lr_critic, "
                                 "or scale the rewards with ppo.reward_scale)");
      if (cfg_.target_kl && st.approx_kl > *cfg_.target_kl) {
        stop = true;
        if (total.minibatch_steps == 0) total.approx_kl = st.approx_kl;  // what stopped it
        break;
      }
      step(lr_actor, lr_critic);
      ++total.minibatch_steps;
      total.policy_loss += st.policy_loss;
      total.value_loss += st.value_loss;
      total.cost_value_loss += lc;
      total.entropy += st.entropy;
      total.approx_kl += st.approx_kl;
      total.clip_fraction += st.clip_fraction;
    }
  }
  if (const int n = total.minibatch_steps) {
    total.policy_loss /= n, total.value_loss /= n, total.entropy /= n, total.approx_kl /= n, total.clip_fraction /= n;
    total.cost_value_loss /= n;
  } else {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    total.policy_loss = total.value_loss = total.entropy = total.clip_fraction = total.cost_value_loss = nan;
  }
  return total;
}

// ---------------------------------------------------------------- snapshots
namespace {
constexpr uint32_t kTagPpo = 0x50504f31;  // "PPO1"
}

void Ppo::save(std::ostream& out) const {
  bin::write_tag(out, kTagPpo);
  bin::write_pod<int32_t>(out, obs_dim_);
  bin::write_pod<int32_t>(out, act_dim_);
  bin::write_vec(out, actor_.params());
  bin::write_vec(out, log_std_);
  bin::write_vec(out, critic_.params());
  actor_opt_.save(out);
  log_std_opt_.save(out);
  critic_opt_.save(out);
  bin::write_rng(out, rng_);
  if (cost_) {  // plain PPO's bytes end above
    bin::write_vec(out, cost_->critic.params());
    cost_->opt.save(out);
  }
}

void Ppo::load(std::istream& in) {
  bin::expect_tag(in, kTagPpo, "ppo");
  const auto od = bin::read_pod<int32_t>(in, "ppo.obs_dim");
  const auto ad = bin::read_pod<int32_t>(in, "ppo.act_dim");
  if (od != obs_dim_ || ad != act_dim_)
    throw std::runtime_error("PPO snapshot is for obs/act dims " + std::to_string(od) + "/" + std::to_string(ad) +
                             ", expected " + std::to_string(obs_dim_) + "/" + std::to_string(act_dim_));
  bin::read_vec(in, actor_.params(), "ppo.actor", int64_t(actor_.params().size()));
  bin::read_vec(in, log_std_, "ppo.log_std", act_dim_);
  bin::read_vec(in, critic_.params(), "ppo.critic", int64_t(critic_.params().size()));
  actor_opt_.load(in);
  log_std_opt_.load(in);
  critic_opt_.load(in);
  bin::read_rng(in, rng_, "ppo.rng");
  if (cost_) {
    bin::read_vec(in, cost_->critic.params(), "ppo.cost_critic", int64_t(cost_->critic.params().size()));
    cost_->opt.load(in);
    for (float x : cost_->critic.params())
      if (!std::isfinite(x)) throw std::runtime_error("PPO snapshot holds a non-finite cost critic parameter");
  }
  for (const auto* v : {&actor_.params(), &log_std_, &critic_.params()})
    for (float x : *v)
      if (!std::isfinite(x)) throw std::runtime_error("PPO snapshot holds a non-finite parameter");
}

uint64_t Ppo::state_hash() const {
  std::ostringstream s;
  save(s);
  const std::string b = s.str();
  return bin::fnv1a(b.data(), b.size());
}

}  // namespace atacom
