// atacom sdf-paths: accuracy of an env's learned distance field along the
// arm's points of interest during random-alpha rollouts, for the env's object
// or the robot body (docs/sdf.md).
#include <iostream>

#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "train/sdf_path_accuracy.hpp"

namespace {

atacom::cli::RegisterCommand register_sdf_paths(
    {"sdf-paths", "learned vs analytic distance and gradient along the arm's PoIs in ATACOM rollouts (one JSON line)",
     [](CLI::App& app) -> std::function<int()> {
       auto c = std::make_shared<atacom::SdfPathConfig>();
       app.add_option("--env", c->env, "table | shelf | hri")
           ->required()
           ->check(CLI::IsMember({"table", "shelf", "hri"}));
       app.add_option("--field", c->field, "obstacle (the env's object: table, shelf, hri's human) | body (the TIAGo body)")
           ->check(CLI::IsMember({"obstacle", "body"}));
       atacom::cli::add_number_flag(app, "--steps", c->steps, atacom::range::closed(1L, 100000000L),
                                    "env steps over all envs");
       atacom::cli::add_number_flag(app, "--envs", c->envs, atacom::range::closed(1, 65536), "parallel envs");
       atacom::cli::add_number_flag(app, "--seed", c->seed, atacom::cli::seed_range<uint64_t>(),
                                    "seed of the envs and the random alpha");
       app.add_option("--safety", c->safety, "atacom | none (raw random actions)")->check(CLI::IsMember({"atacom", "none"}));
       app.add_option("--split", c->split, "hri: motion split (train | test)")->check(CLI::IsMember({"train", "test"}));
       return [c] {
         std::cout << atacom::sdf_path_accuracy(*c).dump() << std::endl;
         return 0;
       };
     }});

}  // namespace
