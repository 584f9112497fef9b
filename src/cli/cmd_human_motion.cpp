// atacom human-motion: regenerate the human's motion library, or print the
// shipped library's speed statistics (--stats; docs/human.md).
#include <iostream>

#include "cli/command.hpp"
#include "cli/flag_checks.hpp"
#include "src/core/limits.hpp"
#include "envs/arm/human_model.hpp"
#include "envs/arm/human_motion.hpp"
#include "envs/arm/human_motion_stats.hpp"

namespace atacom::cli {
namespace {

std::string manifest_path(const std::string& bin) {
  const size_t dot = bin.rfind('.');
  const size_t slash = bin.rfind('/');
  const bool has_ext = dot != std::string::npos && (slash == std::string::npos || dot > slash);
  return (has_ext ? bin.substr(0, dot) : bin) + ".json";
}

const RegisterCommand register_human_motion{{"human-motion",
                           "generate the human motion library (frames FILE, manifest FILE with .json), or --stats",
                           [](CLI::App& app) {
                             auto seed = std::make_shared<uint64_t>(default_human_motion_config().seed);
                             auto frames = std::make_shared<int>(default_human_motion_config().frames);
                             auto out = std::make_shared<std::string>();
                             auto stats = std::make_shared<bool>(false);
                             add_integer_flag(app, "--seed", *seed, seed_range<uint64_t>(),
                                              "generator seed (the project's library: 2023)");
                             add_integer_flag(app, "--frames", *frames, range::closed(100, 1000000),
                                              "at least this many frames at 30 Hz");
                             auto* o_out = app.add_option("--out", *out, "frames file, e.g. data/human_motion.bin");
                             app.add_flag("--stats", *stats,
                                          "print the shipped library's speed percentiles (pelvis, wrist, hand; JSON) "
                                          "instead of generating")
                                 ->excludes(o_out);
                             return [=]() {
                               if (*stats) {
                                 std::cout << human_motion_speed_stats(load_default_human_motion(), load_human_model())
                                                  .dump(2)
                                           << "\n";
                                 return 0;
                               }
                               if (out->empty()) throw std::invalid_argument("human-motion: --out FILE is required (or --stats)");
                               HumanMotionConfig c = default_human_motion_config();
                               c.seed = *seed;
                               c.frames = *frames;
                               const HumanModel model = load_human_model();
                               const HumanMotionLibrary lib = generate_human_motion(model, c);
                               const std::string manifest = manifest_path(*out);
                               save_human_motion(lib, model, *out, manifest);
                               std::cout << nlohmann::json{{"frames", lib.num_frames},
                                                           {"segments", lib.segments.size()},
                                                           {"test_begin", lib.test_begin},
                                                           {"seed", c.seed},
                                                           {"version", lib.version},
                                                           {"out", *out},
                                                           {"manifest", manifest}}
                                                .dump()
                                         << "\n";
                               return 0;
                             };
                           }}};

}  // namespace
}  // namespace atacom::cli
