// Registry hooks of the manipulation envs: "table" (TableEnv), "shelf"
// (ShelfEnvSim) and "hri" (HRI-Sim). The task is fixed by the name; the JSON
// holds everything else.
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
