// atacom render: one episode as a self-contained HTML page (docs/render.md).
#include <iostream>

#include "atacom/env_registry.hpp"
#include "atacom/safety_layer.hpp"
#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "cli/json_file.hpp"
#include "src/core/limits.hpp"
#include "src/core/fs_util.hpp"
#include "src/experiments/render.hpp"

namespace atacom::cli {
namespace {

struct RenderArgs {
  RenderConfig cfg;
  std::string safety, out, config_file, which = "final";
};

const RegisterCommand register_render{
    {"render", "draw one episode as a self-contained HTML page (animated SVG, slider, constraint and reward plots)",
     [](CLI::App& app) -> std::function<int()> {
       auto a = std::make_shared<RenderArgs>();
       app.add_option("--env", a->cfg.env, "table | shelf | nav | hri (required unless --policy trained)")
           ->check(CLI::IsMember(env_names()));
       app.add_option("--policy", a->cfg.policy, "random | zero | la (the env's linear attractor) | trained (with --run)")
           ->check(CLI::IsMember({"random", "zero", "la", "trained"}));
       app.add_option("--run", a->cfg.run_dir, "training run directory (--policy trained)");
       app.add_option("--which", a->which, "final | best: the run's policy file (--policy trained)")
           ->check(CLI::IsMember({"final", "best"}));
       app.add_option("--safety", a->safety,
                      safety_choices() + ": the layer between policy and env (default atacom; with --policy "
                      "trained the run's)")
           ->check(CLI::IsMember(safety_layer_names()));
       add_integer_flag(app, "--seed", a->cfg.seed, seed_range<decltype(a->cfg.seed)>(), "seed of the env and the policy");
       app.add_option("--config", a->config_file, "JSON file with env config overrides");
       app.add_option("--out", a->out, "the HTML file to write")->required();
       return [a] {
         if (!a->safety.empty()) a->cfg.safety = parse_safety_layer(a->safety);
         if (a->which != "final" && a->cfg.policy != "trained")
           throw std::invalid_argument("--which applies to --policy trained only");
         a->cfg.which = a->which == "best" ? RunPolicy::Best : RunPolicy::Final;
         if (a->cfg.env.empty() && a->cfg.policy != "trained")
           throw std::invalid_argument("--env is required (unless --policy trained)");
         // The one strict reader: duplicate keys, a directory, a file above 64 MiB or nesting deeper than 64 are errors.
         if (!a->config_file.empty()) a->cfg.env_config = read_json_file(a->config_file);
         const RenderResult r = render_episode(a->cfg);
         write_file_atomic(a->out, r.html);
         std::cout << nlohmann::json{{"out", a->out},
                                     {"steps", r.steps},
                                     {"return", r.episode_return},
                                     {"collisions", r.collisions},
                                     {"max_constraint", r.max_constraint},
                                     {"terminated", r.terminated},
                                     {"bytes", r.html.size()}}
                          .dump()
                   << "\n";
         return 0;
       };
     }}};

}  // namespace
}  // namespace atacom::cli
