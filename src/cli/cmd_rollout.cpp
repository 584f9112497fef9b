// atacom rollout: check a safety setup before training.
#include <fstream>
#include <iostream>

#include "train/rollout.hpp"
#include "cli/command.hpp"

namespace {

struct RolloutArgs {
  atacom::RolloutConfig cfg;
  std::string atacom = "on";
  std::string config_file;
};

atacom::cli::RegisterCommand reg(
    {"rollout", "run an env with a random or zero policy, with or without ATACOM, and count collisions and violations",
     [](CLI::App& app) -> std::function<int()> {
       auto a = std::make_shared<RolloutArgs>();
       app.add_option("--env", a->cfg.env, "environment name")->required();
       app.add_option("--policy", a->cfg.policy, "random | zero")->check(CLI::IsMember({"random", "zero"}));
       app.add_option("--atacom", a->atacom, "on | off")->check(CLI::IsMember({"on", "off"}));
       app.add_option("--steps", a->cfg.steps, "env steps in total")->check(CLI::PositiveNumber);
       app.add_option("--envs", a->cfg.envs, "parallel envs")->check(CLI::PositiveNumber);
       app.add_option("--seed", a->cfg.seed, "random seed");
       app.add_option("--config", a->config_file, "JSON file with env config overrides");
       return [a] {
         a->cfg.atacom = a->atacom == "on";
         if (!a->config_file.empty()) {
           std::ifstream in(a->config_file);
           if (!in) throw std::runtime_error("cannot read config file '" + a->config_file + "'");
           try {
             a->cfg.env_config = nlohmann::json::parse(in);
           } catch (const nlohmann::json::exception& e) {
             throw std::runtime_error("config file '" + a->config_file + "' is not valid JSON: " + e.what());
           }
         }
         std::cout << atacom::run_rollout(a->cfg).dump() << std::endl;
         return 0;
       };
     }});

}  // namespace
