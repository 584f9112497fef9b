// Registry glue for NavEnv: the factory of the plain env (make_env adds the safety layer).
#include <nlohmann/json.hpp>

#include "envs/nav/nav_env.hpp"

namespace atacom {

std::unique_ptr<BatchEnv> make_nav_env(const nlohmann::json& config, int num_envs) {
  NavConfig c;
  from_json(config, c);
  return std::make_unique<NavEnv>(c, num_envs);
}

}  // namespace atacom
