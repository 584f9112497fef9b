#include "train/sac.hpp"

#include <atomic>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "src/core/binary_io.hpp"
#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"
#include "atacom/parallel.hpp"

#include <tbb/parallel_invoke.h>

namespace atacom {

SacConfig default_sac_config() { return SacConfig{}; }

void to_json(nlohmann::json& j, const SacConfig& c) {
  j = nlohmann::json{
      {"actor", c.actor}, {"critic", c.critic}, {"batch_size", c.batch_size}, {"gamma", c.gamma},
      {"tau", c.tau}, {"lr_actor", c.lr_actor}, {"lr_critic", c.lr_critic}, {"lr_alpha", c.lr_alpha},
      {"init_alpha", c.init_alpha},
      {"target_entropy", c.target_entropy ? nlohmann::json(*c.target_entropy) : nlohmann::json(nullptr)},
      {"log_std_min", c.log_std_min}, {"log_std_max", c.log_std_max}, {"replay_capacity", c.replay_capacity},
      {"initial_replay", c.initial_replay}, {"warmup", c.warmup}, {"updates_per_step", c.updates_per_step},
      {"obs_norm", c.obs_norm}, {"grad_clip", c.grad_clip}, {"adam", c.adam}};
}

void from_json(const nlohmann::json& j, SacConfig& c) {
  ConfigReader r(j, "sac");
  c = default_sac_config();
  if (const auto* s = r.sub("actor")) c.actor = read_mlp_config(*s, r.path("actor"));
  if (const auto* s = r.sub("critic")) c.critic = read_mlp_config(*s, r.path("critic"));
  r.get("batch_size", c.batch_size, range::closed(1, limits::kMaxBatchSize));
  r.get("gamma", c.gamma, range::closed(0.0, 1.0));
  r.get("tau", c.tau, range::open_closed(0.0, 1.0));
  r.get("lr_actor", c.lr_actor, range::non_negative());
  r.get("lr_critic", c.lr_critic, range::non_negative());
  r.get("lr_alpha", c.lr_alpha, range::non_negative());
  r.get("init_alpha", c.init_alpha, range::positive());
  if (const auto* s = r.sub("target_entropy")) {
    if (s->is_null()) c.target_entropy = std::nullopt;
    else if (s->is_number()) c.target_entropy = checked_number(*s, r.name("target_entropy"), range::finite());
    else throw std::invalid_argument("config key 'sac.target_entropy' must be a number or null (-act_dim)");
  }
  r.get("log_std_min", c.log_std_min, range::closed(-100.0, 100.0));
  r.get("log_std_max", c.log_std_max, range::closed(-100.0, 100.0));
  r.get("replay_capacity", c.replay_capacity, range::closed<int64_t>(1, limits::kMaxReplayCapacity));
  r.get("initial_replay", c.initial_replay, range::closed<int64_t>(0, limits::kMaxSteps));
  r.get("warmup", c.warmup, range::closed<int64_t>(0, limits::kMaxSteps));
  r.get("updates_per_step", c.updates_per_step, range::closed(0.0, 1000.0));
  r.get("obs_norm", c.obs_norm);
  r.get("grad_clip", c.grad_clip, range::non_negative());
  if (const auto* s = r.sub("adam")) c.adam = read_adam_config(*s, r.path("adam"));
  r.finish();
  auto bad = [](const std::string& what) { throw std::invalid_argument("config: sac." + what); };
  if (c.batch_size < 1 || c.batch_size > limits::kMaxBatchSize) bad("batch_size must be in [1, 2^16]");
  if (!(c.gamma >= 0 && c.gamma <= 1)) bad("gamma must be in [0, 1]");
  if (!(c.tau > 0 && c.tau <= 1)) bad("tau must be in (0, 1]");
  if (!(c.lr_actor >= 0 && std::isfinite(c.lr_actor))) bad("lr_actor must be >= 0");
  if (!(c.lr_critic >= 0 && std::isfinite(c.lr_critic))) bad("lr_critic must be >= 0");
  if (!(c.lr_alpha >= 0 && std::isfinite(c.lr_alpha))) bad("lr_alpha must be >= 0");
  if (!(c.init_alpha > 0 && std::isfinite(c.init_alpha))) bad("init_alpha must be > 0");
  if (c.target_entropy && !std::isfinite(*c.target_entropy)) bad("target_entropy must be finite");
  if (!(c.log_std_min < c.log_std_max)) bad("log_std_min must be < log_std_max");
  if (c.replay_capacity < c.batch_size) bad("replay_capacity must be >= batch_size");
  if (c.initial_replay < 0 || c.warmup < 0) bad("initial_replay and warmup must be >= 0");
  if (!(c.updates_per_step >= 0 && c.updates_per_step <= 1000)) bad("updates_per_step must be in [0, 1000]");
  if (!(c.grad_clip >= 0)) bad("grad_clip must be >= 0");
}

namespace {
// Each update's backward writes the parameter gradients and Adam leaves
// them in place: no pass clears them, and dW never reads the stale buffer.
constexpr auto kSetGrads = Tape<float>::GradMode::Set;
constexpr auto kKeepGrads = Adam<float>::Grads::Keep;
}  // namespace

Sac::CostCritic::CostCritic(int in, const SacConfig& cfg)
    : critic(in, 1, cfg.critic, 2),
      target(in, 1, cfg.critic, 2),
      opt(critic.params().size(), cfg.adam),
      y(size_t(cfg.batch_size), 0.0f) {}

Sac::Sac(int obs_dim, int act_dim, const SacConfig& cfg, uint64_t seed, bool cost_critic)
    : cfg_(cfg),
      obs_dim_(obs_dim),
      act_dim_(act_dim),
      target_entropy_(cfg.target_entropy ? *cfg.target_entropy : -double(act_dim)),
      actor_(obs_dim, 2 * act_dim, cfg.actor, 1),
      critic_(obs_dim + act_dim, 1, cfg.critic, 2),
      critic_target_(obs_dim + act_dim, 1, cfg.critic, 2),
      actor_opt_(actor_.params().size(), cfg.adam),
      critic_opt_(critic_.params().size(), cfg.adam),
      alpha_opt_(1, cfg.adam),
      log_alpha_(std::log(cfg.init_alpha)),
      rng_(seed, 0x5AC) {
  Rng init(seed, 0x1417);
  actor_.init(init);
  critic_.init(init);
  critic_target_.params() = critic_.params();
  if (cost_critic) {  // drawn after the others: the actor and critics are plain SAC's
    cost_ = std::make_unique<CostCritic>(obs_dim + act_dim, cfg);
    cost_->critic.init(init);
    cost_->target.params() = cost_->critic.params();
  }
  const size_t B = size_t(cfg.batch_size);
  noise_pi_.assign(B * act_dim, 0.0f);
  noise_next_.assign(B * act_dim, 0.0f);
  y_.assign(B, 0.0f);
}

Sac::~Sac() noexcept {
  // A pending step only writes members; wait() rethrows what it threw,
  // which a destructor must not.
  try {
    finish_steps();
  } catch (...) {
  }
}

void Sac::finish_steps() const {
  if (!steps_pending_) return;
  steps_pending_ = false;
  steps_.wait();
}

void Sac::step_actor() {
  if (cfg_.grad_clip > 0) clip_grad_norm(actor_.grads().data(), actor_.grads().size(), cfg_.grad_clip);
  actor_opt_.step_fused(actor_.params().data(), actor_.grads().data(), cfg_.lr_actor, nullptr, 0.0, kKeepGrads);
}

void Sac::step_critic() {
  if (cfg_.grad_clip > 0) clip_grad_norm(critic_.grads().data(), critic_.grads().size(), cfg_.grad_clip);
  critic_opt_.step_fused(critic_.params().data(), critic_.grads().data(), cfg_.lr_critic,
                         critic_target_.params().data(), cfg_.tau, kKeepGrads);
  if (cost_) {
    Mlp<float>& qc = cost_->critic;
    if (cfg_.grad_clip > 0) clip_grad_norm(qc.grads().data(), qc.grads().size(), cfg_.grad_clip);
    cost_->opt.step_fused(qc.params().data(), qc.grads().data(), cfg_.lr_critic, cost_->target.params().data(),
                          cfg_.tau, kKeepGrads);
  }
}

const Mlp<float>& Sac::cost_critic() const {
  if (!cost_) throw std::logic_error("Sac::cost_critic: this agent has no cost critic");
  finish_steps();
  return cost_->critic;
}

double Sac::alpha() const { return std::exp(log_alpha_); }

Sac::PolicyOut Sac::policy(Tape<float>& t, Tape<float>::Id obs, const float* noise, bool param_grads) {
  const int B = t.node(obs).rows, A = act_dim_;
  const auto out = actor_.forward(t, obs, param_grads, kSetGrads);
  const auto mu = t.slice(out, 0, A);
  const auto log_std = t.clamp(t.slice(out, A, 2 * A), float(cfg_.log_std_min), float(cfg_.log_std_max));
  const auto u = t.add(mu, t.mul(t.exp(log_std), t.constant(noise, B, A)));
  return {t.tanh(u), t.tanh_gauss_logp(mu, log_std, u)};
}

void sac_actor_act(Mlp<float>& actor, Tape<float>& tape, double log_std_min, double log_std_max,
                   const float* obs, int N, bool deterministic, Rng* rngs, double* actions) {
  const int A = actor.out() / 2;
  tape.clear();
  // param_grads = false: the weights are only read.
  const auto out = actor.forward(tape, tape.constant(obs, N, actor.in()), false);
  const float* o = tape.value(out).data;
  const float lo = float(log_std_min), hi = float(log_std_max);
  // Per-row noise from the row's own stream: any block partition gives the same actions.
  parallel_blocks(N, kSampleBlock, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const float* r = o + i * 2 * A;
      for (int j = 0; j < A; ++j) {
        float u = r[j];
        if (!deterministic) {
          const float ls = std::min(std::max(r[A + j], lo), hi);
          u += std::exp(ls) * float(rngs[i].normal());
        }
        actions[i * A + j] = double(std::tanh(u));
      }
    }
  });
}

void Sac::act(const float* obs, int N, bool deterministic, Rng* rngs, double* actions) {
  sac_actor_act(actor_, act_tape_, cfg_.log_std_min, cfg_.log_std_max, obs, N, deterministic, rngs, actions);
}

SacStats Sac::update(const ReplayBatch& batch, bool update_actor, double cost_weight) {
  const int B = cfg_.batch_size, A = act_dim_, D = obs_dim_;
  if (batch.B != B) throw std::invalid_argument("Sac::update: batch has " + std::to_string(batch.B) +
                                                " rows, config batch_size is " + std::to_string(B));
  SacStats st;
  // All noise is drawn up front, in a fixed order, so the two phases below
  // can run in any order or concurrently. The last update's critic step
  // may still run meanwhile: it does not touch the RNG or the noise.
  if (update_actor)
    for (auto& z : noise_pi_) z = float(rng_.normal());
  for (auto& z : noise_next_) z = float(rng_.normal());
  finish_steps();
  const float alpha = float(std::exp(log_alpha_));
  const float lambda = float(cost_weight);
  if (cost_ && !(std::isfinite(cost_weight) && cost_weight >= 0))
    throw std::invalid_argument("Sac::update: the cost weight must be a finite number >= 0");
  double mean_logp = 0;

  // Set by the critic phase once it has read the actor (its next-state policy).
  std::atomic<bool> actor_read{false};
  bool actor_stepped = false;  // the actor branch has stepped the actor already

  // Actor phase: gradient of L_pi at the current actor, critics and alpha.
  // Reads critic parameters, writes only actor gradients.
  auto actor_phase = [&]() {
    Tape<float>& t = actor_tape_;
    t.clear();
    const auto obs = t.constant(batch.obs.data(), B, D);
    const PolicyOut pi = policy(t, obs, noise_pi_.data(), true);
    const auto sa = t.concat(obs, pi.action);
    const auto q = critic_.forward(t, sa, false);
    const auto qmin = t.minimum(t.slice(q, 0, 1), t.slice(q, 1, 2));
    auto per_row = t.sub(t.affine(pi.logp, alpha, 0.0f), qmin);
    if (cost_) {  // + lambda max_i Q_c,i, all over (1 + lambda); max(x, y) = -min(-x, -y)
      const auto qc = cost_->critic.forward(t, sa, false);
      const auto qc_max = t.affine(t.minimum(t.affine(t.slice(qc, 0, 1), -1.0f, 0.0f),
                                             t.affine(t.slice(qc, 1, 2), -1.0f, 0.0f)),
                                   -1.0f, 0.0f);
      per_row = t.affine(t.add(per_row, t.affine(qc_max, lambda, 0.0f)), 1.0f / (1.0f + lambda), 0.0f);
    }
    const auto loss = t.mean(per_row);
    t.backward(loss);  // writes the actor grads (GradMode::Set): nothing clears them
    const float* lp = t.value(pi.logp).data;
    for (int i = 0; i < B; ++i) mean_logp += lp[i];
    mean_logp /= B;
    st.actor_loss = t.scalar(loss);
  };

  // Critic phase: gradient of L_Q at the current critics, targets, actor and
  // alpha. Reads actor parameters, writes only critic gradients.
  auto critic_phase = [&]() {
    Tape<float>& t = tape_;
    t.clear();
    const auto next = t.constant(batch.next_obs.data(), B, D);
    const PolicyOut pn = policy(t, next, noise_next_.data(), false);
    actor_read.store(true, std::memory_order_release);  // no actor parameter is read after this
    const auto sn = t.concat(next, pn.action);
    const auto qt = critic_target_.forward(t, sn, false);
    const float* qtv = t.value(qt).data;
    const float* lpn = t.value(pn.logp).data;
    const float gamma = float(cfg_.gamma);
    for (int i = 0; i < B; ++i) {
      const float v = std::min(qtv[2 * i], qtv[2 * i + 1]) - alpha * lpn[i];
      // Termination cuts the bootstrap; truncation does not.
      y_[size_t(i)] = batch.reward[size_t(i)] + gamma * (1.0f - batch.terminated[size_t(i)]) * v;
    }
    if (cost_) {  // the cost target at the same a': the largest twin, no entropy term
      const float* qct = t.value(cost_->target.forward(t, sn, false)).data;
      for (int i = 0; i < B; ++i)
        cost_->y[size_t(i)] = batch.cost[size_t(i)] +
                              gamma * (1.0f - batch.terminated[size_t(i)]) * std::max(qct[2 * i], qct[2 * i + 1]);
    }
    const auto obs = t.constant(batch.obs.data(), B, D);
    const auto sa = t.concat(obs, t.constant(batch.action.data(), B, A));
    const auto q = critic_.forward(t, sa, true, kSetGrads);
    const auto err = t.sub(q, t.constant(y_.data(), B, 1));
    const auto loss = t.sum(t.mean(t.square(err), 0));
    if (cost_) {
      // One backward over both losses: each critic's grads come from its own (the parameters are disjoint).
      const auto qc = cost_->critic.forward(t, sa, true, kSetGrads);
      const auto loss_c = t.sum(t.mean(t.square(t.sub(qc, t.constant(cost_->y.data(), B, 1))), 0));
      t.backward(t.add(loss, loss_c));
      st.cost_critic_loss = 0.5 * t.scalar(loss_c);
      double qcm = 0;
      const float* qcv = t.value(qc).data;
      for (int i = 0; i < 2 * B; ++i) qcm += qcv[i];
      st.cost_q_mean = qcm / (2 * B);
    } else {
      t.backward(loss);  // writes the critic grads (GradMode::Set)
    }
    st.critic_loss = 0.5 * t.scalar(loss);  // mean over the two critics
    double qm = 0;
    const float* qv = t.value(q).data;
    for (int i = 0; i < 2 * B; ++i) qm += qv[i];
    st.q_mean = qm / (2 * B);
  };

  // The phases share no written state, so running them concurrently gives
  // the same bits as running them one after the other. The critic phase is
  // the longer one; when the actor phase ends after the critic phase has
  // read the actor, the actor step runs at once, in the time the actor's
  // thread would wait at the join (bench/README.md, "One update's critical
  // path"). Otherwise (the critic phase started late) it runs after the
  // join. Either way it follows every read of the actor parameters, so the
  // bits are the same.
  auto actor_branch = [&]() {
    actor_phase();
    if (actor_read.load(std::memory_order_acquire) && std::isfinite(st.actor_loss) && std::isfinite(mean_logp)) {
      step_actor();
      actor_stepped = true;
    }
  };
  if (update_actor) tbb::parallel_invoke(actor_branch, critic_phase);
  else critic_phase();

  // A non-finite loss throws: the run stops with its last checkpoint on
  // disk. The actor may have been stepped by then; the critic and alpha not.
  if (!std::isfinite(st.critic_loss) || !std::isfinite(st.cost_critic_loss))
    throw std::runtime_error("SAC critic update produced a non-finite loss (lower lr_critic or check the rewards)");
  if (update_actor) {
    if (!std::isfinite(st.actor_loss) || !std::isfinite(mean_logp))
      throw std::runtime_error("SAC actor update produced a non-finite loss "
                               "(lower lr_actor/lr_alpha or check the rewards)");
    const double g_alpha = -(mean_logp + target_entropy_);
    st.alpha_loss = -log_alpha_ * (mean_logp + target_entropy_);
    alpha_opt_.step(&log_alpha_, &g_alpha, cfg_.lr_alpha);
    st.entropy = -mean_logp;
    st.actor_updated = true;
  }
  // The actor steps now (act() reads it next). The critics step on a
  // worker while the caller steps its envs, samples the next batch and
  // draws the next noise; whatever reads them next waits (finish_steps).
  // With one thread the step runs at that wait: the same bits either way.
  if (update_actor && !actor_stepped) step_actor();
  steps_pending_ = true;
  steps_.run([this] { step_critic(); });
  return st;
}

namespace {
constexpr uint32_t kTagSac = 0x53414331;  // "SAC1"
}

void Sac::save(std::ostream& out) const {
  finish_steps();
  bin::write_tag(out, kTagSac);
  bin::write_pod<int32_t>(out, obs_dim_);
  bin::write_pod<int32_t>(out, act_dim_);
  bin::write_vec(out, actor_.params());
  bin::write_vec(out, critic_.params());
  bin::write_vec(out, critic_target_.params());
  actor_opt_.save(out);
  critic_opt_.save(out);
  alpha_opt_.save(out);
  bin::write_pod<double>(out, log_alpha_);
  bin::write_rng(out, rng_);
  if (cost_) {  // plain SAC's bytes end above
    bin::write_vec(out, cost_->critic.params());
    bin::write_vec(out, cost_->target.params());
    cost_->opt.save(out);
  }
}

void Sac::load(std::istream& in) {
  finish_steps();
  bin::expect_tag(in, kTagSac, "sac");
  const auto od = bin::read_pod<int32_t>(in, "sac.obs_dim");
  const auto ad = bin::read_pod<int32_t>(in, "sac.act_dim");
  if (od != obs_dim_ || ad != act_dim_)
    throw std::runtime_error("agent snapshot is for obs/act dims " + std::to_string(od) + "/" + std::to_string(ad) +
                             ", expected " + std::to_string(obs_dim_) + "/" + std::to_string(act_dim_));
  bin::read_vec(in, actor_.params(), "sac.actor", int64_t(actor_.params().size()));
  bin::read_vec(in, critic_.params(), "sac.critic", int64_t(critic_.params().size()));
  bin::read_vec(in, critic_target_.params(), "sac.critic_target", int64_t(critic_target_.params().size()));
  actor_opt_.load(in);
  critic_opt_.load(in);
  alpha_opt_.load(in);
  log_alpha_ = bin::read_pod<double>(in, "sac.log_alpha");
  bin::read_rng(in, rng_, "sac.rng");
  if (cost_) {
    bin::read_vec(in, cost_->critic.params(), "sac.cost_critic", int64_t(cost_->critic.params().size()));
    bin::read_vec(in, cost_->target.params(), "sac.cost_critic_target", int64_t(cost_->target.params().size()));
    cost_->opt.load(in);
  }
}

uint64_t Sac::state_hash() const {
  std::ostringstream s;
  save(s);
  const std::string b = s.str();
  return bin::fnv1a(b.data(), b.size());
}

}  // namespace atacom
