// atacom sdf-train: train a learned distance field (ReDSDF) of an object from
// its exact geometry and write the weights with a manifest.
#include <cstdio>
#include <iostream>

#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "cli/json_file.hpp"
#include "src/core/limits.hpp"
#include "train/redsdf_train.hpp"

namespace {

struct SdfTrainArgs {
  std::string object, out, config_file, hidden;
  int epochs = 0, patience = 0, surface_points = 0, batch = 0;
  double budget_s = 0, lr = 0, align_weight = 0;
  int64_t seed = 0, data_seed = 0;
  // Which flags were given (a flag overrides the config; unset ones leave it).
  bool set_epochs = false, set_patience = false, set_points = false, set_batch = false, set_budget = false,
       set_lr = false, set_align = false, set_seed = false, set_data_seed = false;
  bool quiet = false;
  std::string argv_line;
};

// "64,64,64": each width a whole decimal integer in [1, 8192] (the MLP's limit).
std::vector<int> parse_widths(const std::string& s) {
  std::vector<int> w;
  size_t i = 0;
  while (i <= s.size()) {
    size_t j = s.find(',', i);
    if (j == std::string::npos) j = s.size();
    w.push_back(atacom::parse_flag_value<int>("--hidden", std::string_view(s).substr(i, j - i),
                                              atacom::range::closed(1, atacom::limits::kMaxMlpWidth)));
    if (w.size() > size_t(atacom::limits::kMaxMlpLayers))
      throw std::invalid_argument("--hidden: more than " + std::to_string(atacom::limits::kMaxMlpLayers) + " widths");
    i = j + 1;
  }
  return w;
}

// --help's defaults: each object's training config (default_sdf_train_config), the values the flags override.
std::string defaults_footer() {
  std::string f = "\nDefaults per --object (a flag or --config overrides them):\n";
  for (const char* obj : {"table", "shelf", "human", "tiago"}) {
    const atacom::SdfTrainConfig c = atacom::default_sdf_train_config(obj);
    std::string hidden;
    for (int w : c.arch.hidden) hidden += (hidden.empty() ? "" : ",") + std::to_string(w);
    char b[320];
    std::snprintf(b, sizeof b,
                  "  %-6s --hidden %s --epochs %d --patience %d --surface-points %d --batch %d --lr %g "
                  "--align-weight %g --budget-s %g --seed %llu --data-seed %llu\n",
                  obj, hidden.c_str(), c.max_epochs, c.patience, c.data.surface_points, c.batch, c.lr,
                  c.align_weight, c.budget_s, static_cast<unsigned long long>(c.init_seed),
                  static_cast<unsigned long long>(c.data.seed));
    f += b;
  }
  return f;
}

int run(SdfTrainArgs& a) {
  atacom::SdfTrainConfig c = atacom::default_sdf_train_config(a.object);
  if (!a.config_file.empty()) {
    nlohmann::json j = c;
    j.merge_patch(atacom::cli::read_json_file(a.config_file));
    c = j.get<atacom::SdfTrainConfig>();
    if (c.object != a.object)
      throw std::invalid_argument("--config sets object '" + c.object + "', but --object is " + a.object);
  }
  if (!a.hidden.empty()) {
    c.arch.hidden = parse_widths(a.hidden);
    c.arch.validate();
  }
  if (a.set_epochs) c.max_epochs = a.epochs;
  if (a.set_patience) c.patience = a.patience;
  if (a.set_points) c.data.surface_points = a.surface_points;
  if (a.set_batch) c.batch = a.batch;
  if (a.set_budget) c.budget_s = a.budget_s;
  if (a.set_lr) c.lr = a.lr;
  if (a.set_align) c.align_weight = a.align_weight;
  if (a.set_seed) c.init_seed = uint64_t(a.seed);
  if (a.set_data_seed) c.data.seed = uint64_t(a.data_seed);
  const nlohmann::json man = atacom::train_sdf(c, a.out, a.argv_line, !a.quiet);
  std::cout << nlohmann::json{{"object", c.object}, {"out", a.out}, {"stop", man.at("stop")},
                              {"epochs", man.at("epochs")}, {"seconds", man.at("seconds")},
                              {"test", man.at("metrics").at("test")}}
                   .dump()
            << std::endl;
  return 0;
}

atacom::cli::RegisterCommand register_sdf_train(
    {"sdf-train", "train a learned signed distance field (ReDSDF) of an object from its exact geometry",
     [](CLI::App& app) -> std::function<int()> {
       auto a = std::make_shared<SdfTrainArgs>();
       app.add_option("--object", a->object, "table | shelf | hri_table (HRI-Sim's table) | human | tiago")
           ->required()
           ->check(CLI::IsMember({"table", "shelf", "hri_table", "human", "tiago"}));
       app.add_option("--out", a->out, "output directory (weights, manifest, progress.csv, learning curve)")->required();
       app.add_option("--config", a->config_file, "JSON overrides of the training config (see docs/sdf.md)");
       app.add_option("--hidden", a->hidden, "hidden widths, trunk first, e.g. 64,64,64,64");
       using atacom::cli::add_number_flag;
       namespace range = atacom::range;
       add_number_flag(app, "--epochs", a->epochs, range::closed(1, 100000), "most epochs (default: the config's)",
                       &a->set_epochs);
       add_number_flag(app, "--patience", a->patience, range::closed(1, 100000), "early-stopping patience, epochs",
                       &a->set_patience);
       add_number_flag(app, "--surface-points", a->surface_points, range::closed(1, 1 << 22),
                       "surface samples (each shifted by every epsilon)", &a->set_points);
       add_number_flag(app, "--batch", a->batch, range::closed(16, 1 << 16), "batch size", &a->set_batch);
       add_number_flag(app, "--lr", a->lr, range::open_closed(0.0, 1.0), "initial Adam learning rate", &a->set_lr);
       add_number_flag(app, "--align-weight", a->align_weight, range::closed(0.0, 1000.0),
                       "weight of the gradient-alignment loss term (mean sin^2 of the angle between grad d and the "
                       "normal; 0 = off)",
                       &a->set_align);
       add_number_flag(app, "--budget-s", a->budget_s, range::open_closed(0.0, 1e6),
                       "wall-clock limit of the epoch loop, s", &a->set_budget);
       add_number_flag(app, "--seed", a->seed, atacom::cli::seed_range<int64_t>(), "weight init and batch order seed",
                       &a->set_seed);
       add_number_flag(app, "--data-seed", a->data_seed, atacom::cli::seed_range<int64_t>(), "data sampling seed",
                       &a->set_data_seed);
       app.add_flag("--quiet", a->quiet, "no progress lines");
       // The numeric flags default to the object's config (below), not to the placeholders they hold.
       for (CLI::Option* o : app.get_options())
         if (o->get_name() != "--help" && o->get_expected_min() > 0) o->default_str("");
       app.footer(std::function<std::string()>(defaults_footer));  // built when --help asks (it loads the human model)
       return [a, &app] {
         // The command as given (recorded in the manifest).
         std::string line = "atacom sdf-train";
         for (const CLI::Option* o : app.get_options())
           if (o->count() && o->get_name() != "--help")
             for (const std::string& v : o->as<std::vector<std::string>>())
               line += " " + o->get_name() + (o->get_expected_min() == 0 ? "" : " " + v);
         a->argv_line = line;
         return run(*a);
       };
     }});

}  // namespace
