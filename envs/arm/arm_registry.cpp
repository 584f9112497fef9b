// Registry hooks of the manipulation envs: "table" (TableEnv), "shelf"
// (ShelfEnvSim), "hri" (HRI-Sim, the paper's) and "hri-upright" (HRI-Sim with
// a cup-upright constraint row, ours). The task is fixed by the name; the
// JSON holds everything else.
#include <stdexcept>

#include "envs/arm/arm_env.hpp"
#include "train/sac.hpp"

namespace atacom {

namespace {
std::unique_ptr<BatchEnv> make_arm(ArmTask task, const nlohmann::json& config, int num_envs) {
  ArmEnvConfig c = default_arm_env_config(task);
  from_json(config, c);
  return std::make_unique<ArmEnv>(c, num_envs);
}
}  // namespace

// Reference section 5.4 (the authors' launcher): ATACOM-SAC lr 3e-4 for
// actor and critic, plain SAC and SafeLayer-SAC 1e-5, lr_alpha 1e-6 for all; target entropy
// -10 (their template). default_sac_config() already holds the rest
// (256-256, batch 64, tau 1e-3, gamma 0.995, replay 200k, warm-up 5000).
nlohmann::json arm_sac_defaults(SafetyLayer safety) {
  const double lr = safety == SafetyLayer::Atacom ? 3e-4 : 1e-5;
  return {{"lr_actor", lr}, {"lr_critic", lr}, {"lr_alpha", 1e-6}, {"target_entropy", -10.0}};
}

// HRI: the authors' launcher overrides the networks to 512-512-256
// (reference 5.2 'hri_atacom'); the rest as the arm envs. Top-level keys
// replace, so actor and critic are given whole.
nlohmann::json hri_sac_defaults(SafetyLayer safety) {
  nlohmann::json d = arm_sac_defaults(safety);
  const SacConfig base = default_sac_config();
  MlpConfig actor = base.actor, critic = base.critic;
  actor.hidden = critic.hidden = {512, 512, 256};
  d["actor"] = actor;
  d["critic"] = critic;
  return d;
}

nlohmann::json table_env_default_config() { return default_arm_env_config(ArmTask::Table); }
nlohmann::json shelf_env_default_config() { return default_arm_env_config(ArmTask::Shelf); }
nlohmann::json hri_env_default_config() { return default_arm_env_config(ArmTask::Hri); }
nlohmann::json hri_upright_env_default_config() {
  ArmEnvConfig c = default_arm_env_config(ArmTask::Hri);
  c.hri.upright_row = true;
  return c;
}

nlohmann::json hri_upgrade_pre_issue30_config(const nlohmann::json& overrides) {
  if (!overrides.is_object() || !overrides.contains("hri")) return overrides;
  const nlohmann::json& h = overrides["hri"];
  if (!h.is_object() || !h.contains("targets") || h.contains("upright_row")) return overrides;
  nlohmann::json out = overrides;
  out["hri"]["upright_row"] = true;
  out["hri"]["start_tilt"] = 3.14159265358979323846;
  if (out.contains("sdf") && out["sdf"].is_object() && !out["sdf"].contains("table")) out["sdf"]["table"] = "analytic";
  return out;
}

std::unique_ptr<BatchEnv> make_table_env(const nlohmann::json& config, int num_envs) {
  return make_arm(ArmTask::Table, config, num_envs);
}
std::unique_ptr<BatchEnv> make_shelf_env(const nlohmann::json& config, int num_envs) {
  return make_arm(ArmTask::Shelf, config, num_envs);
}
std::unique_ptr<BatchEnv> make_hri_env(const nlohmann::json& config, int num_envs) {
  return make_arm(ArmTask::Hri, config, num_envs);
}

}  // namespace atacom
