// Registry hooks of the manipulation envs: "table" (TableEnv) and "shelf"
// (ShelfEnvSim). The task is fixed by the name; the JSON holds everything else.
#include <stdexcept>

#include "atacom/arm_env.hpp"

namespace atacom {

namespace {
std::unique_ptr<BatchEnv> make_arm(ArmTask task, const nlohmann::json& config, int num_envs, bool atacom) {
  ArmEnvConfig c = default_arm_env_config(task);
  from_json(config, c);
  auto env = std::make_unique<ArmEnv>(c, num_envs);
  if (!atacom) return env;
  const ProjectorModel pm = env->projector_model();
  return std::make_unique<SafeEnv>(std::move(env), pm);
}
}  // namespace

nlohmann::json table_env_default_config() { return default_arm_env_config(ArmTask::Table); }
nlohmann::json shelf_env_default_config() { return default_arm_env_config(ArmTask::Shelf); }

std::unique_ptr<BatchEnv> make_table_env(const nlohmann::json& config, int num_envs, bool atacom) {
  return make_arm(ArmTask::Table, config, num_envs, atacom);
}
std::unique_ptr<BatchEnv> make_shelf_env(const nlohmann::json& config, int num_envs, bool atacom) {
  return make_arm(ArmTask::Shelf, config, num_envs, atacom);
}

}  // namespace atacom
