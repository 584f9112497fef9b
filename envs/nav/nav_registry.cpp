// Registry glue for NavEnv: the factory (plain or wrapped in SafeEnv).
#include <nlohmann/json.hpp>

#include "envs/nav/nav_env.hpp"

namespace atacom {

std::unique_ptr<BatchEnv> make_nav_env(const nlohmann::json& config, int num_envs, bool atacom) {
  NavConfig c;
  from_json(config, c);
  auto env = std::make_unique<NavEnv>(c, num_envs);
  if (!atacom) return env;
  const ProjectorModel model = env->projector_model();
  return std::make_unique<SafeEnv>(std::move(env), model);
}

}  // namespace atacom
