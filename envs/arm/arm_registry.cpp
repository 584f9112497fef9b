// Registry hooks of the manipulation envs: "table" (TableEnv) and "shelf"
// (ShelfEnvSim). The task is fixed by the name; the JSON holds everything else.
#include <stdexcept>

#include "envs/arm/arm_env.hpp"

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

// Reference section 5.4 (the authors' launcher): ATACOM-SAC lr 3e-4 for
// actor and critic, plain SAC 1e-5, lr_alpha 1e-6 for both; target entropy
// -10 (their template). default_sac_config() already holds the rest
// (256-256, batch 64, tau 1e-3, gamma 0.995, replay 200k, warm-up 5000).
nlohmann::json arm_sac_defaults(const std::string& algo) {
  const double lr = algo == "atacom-sac" ? 3e-4 : 1e-5;
  return {{"lr_actor", lr}, {"lr_critic", lr}, {"lr_alpha", 1e-6}, {"target_entropy", -10.0}};
}

nlohmann::json table_env_default_config() { return default_arm_env_config(ArmTask::Table); }
nlohmann::json shelf_env_default_config() { return default_arm_env_config(ArmTask::Shelf); }

std::unique_ptr<BatchEnv> make_table_env(const nlohmann::json& config, int num_envs, bool atacom) {
  return make_arm(ArmTask::Table, config, num_envs, atacom);
}
std::unique_ptr<BatchEnv> make_shelf_env(const nlohmann::json& config, int num_envs, bool atacom) {
  return make_arm(ArmTask::Shelf, config, num_envs, atacom);
}

}  // namespace atacom
