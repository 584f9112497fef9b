// Registry hooks of the manipulation envs: "table" (TableEnv), "shelf"
// (ShelfEnvSim), "hri" (HRI-Sim, the paper's) and "hri-upright" (HRI-Sim with
// a cup-upright constraint row, ours). The task is fixed by the name; the
// JSON holds everything else.
#include <stdexcept>

#include "envs/arm/arm_env.hpp"

namespace atacom {

namespace {
std::unique_ptr<BatchEnv> make_arm(ArmTask task, const nlohmann::json& config, int num_envs) {
  ArmEnvConfig c = default_arm_env_config(task);
  from_json(config, c);
  return std::make_unique<ArmEnv>(c, num_envs);
}
}  // namespace

nlohmann::json table_env_default_config() { return default_arm_env_config(ArmTask::Table); }
nlohmann::json shelf_env_default_config() { return default_arm_env_config(ArmTask::Shelf); }
nlohmann::json hri_env_default_config() { return default_arm_env_config(ArmTask::Hri); }
nlohmann::json hri_upright_env_default_config() {
  ArmEnvConfig c = default_arm_env_config(ArmTask::Hri);
  c.hri.upright_row = true;
  // The row holds the tilt 5 deg inside theta_max (the 25 deg spill angle):
  // its tolerance (0.02 in cosine, 3.3 deg at 20 deg) then ends at 23.3 deg,
  // so a row within tolerance never spills (docs/envs_arm.md).
  c.hri.upright.margin[0] = 0.0873;
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
