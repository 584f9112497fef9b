#include "train/policy_source.hpp"

#include <stdexcept>

#include "atacom/env_registry.hpp"
#include "src/core/config_json.hpp"

namespace atacom {

PolicySource resolve_policy_source(const PolicyRequest& req) {
  const bool trained = req.policy == "trained";
  if (req.policy != "random" && req.policy != "zero" && req.policy != "la" && !trained)
    throw std::invalid_argument("unknown policy '" + printable_text(req.policy) + "' (random, zero, la, trained)");
  if (!trained && !req.run_dir.empty())
    throw std::invalid_argument("--run applies to --policy trained only (the policy is '" + req.policy + "')");
  PolicySource s;
  s.kind_ = req.policy;
  s.env = req.env;
  s.env_config = req.env_config;
  s.safety = req.safety.value_or(SafetyLayer::Atacom);
  if (trained) {
    if (req.run_dir.empty()) throw std::invalid_argument("--policy trained needs --run DIR (a training run directory)");
    s.trained = TrainedPolicy::load(req.run_dir, req.which);
    const TrainConfig& t = s.trained->config().train;
    if (!s.env.empty() && s.env != t.env)
      throw std::invalid_argument("--env " + s.env + " differs from the env of run '" + req.run_dir + "' (" + t.env + ")");
    if (!s.env_config.is_null() && !(s.env_config.is_object() && s.env_config.empty()))
      throw std::invalid_argument("env config overrides do not apply to --policy trained: the run's env config is used");
    s.env = t.env;
    s.env_config = s.trained->config().env;
    s.safety = req.safety.value_or(s.trained->safety());
    if (s.safety == s.trained->safety()) s.safety_params = s.trained->config().safety;  // the run's layer, as trained
  }
  if (s.env.empty()) throw std::invalid_argument("an env name is needed (--env)");
  return s;
}

Policy& PolicySource::bind(const EnvSpec& spec) {
  Policy* p = trained.get();
  if (!p) {
    if (kind_ == "random") own_ = make_random_policy(spec.obs_dim, spec.act_dim);
    else if (kind_ == "zero") own_ = make_zero_policy(spec.obs_dim, spec.act_dim);
    else own_ = make_attractor_policy(env, resolve_env_config(env, env_config));
    p = own_.get();
  }
  if (p->obs_dim() != spec.obs_dim || p->act_dim() != spec.act_dim)
    throw std::invalid_argument("the policy's obs/act dims do not fit env '" + env + "'");
  return *p;
}

}  // namespace atacom
