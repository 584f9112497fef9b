#include "envs/arm/arm_learned_sdf.hpp"

#include <filesystem>
#include <stdexcept>

#include "src/core/data_dir.hpp"

namespace atacom {

std::shared_ptr<LearnedObstacle> load_arm_learned_obstacle(const std::map<std::string, std::string>& sdf,
                                                           const ArmSceneConfig& scene) {
  const std::string object = arm_task_name(scene.task);
  std::shared_ptr<LearnedObstacle> out;
  for (const auto& [key, spec] : sdf) {
    if (key != object)
      throw std::invalid_argument("config key 'env.sdf." + key + "' names no field of this env (its object is " +
                                  object + ")");
    if (spec == "analytic") continue;
    std::string dir;
    if (spec == "learned") {
      dir = data_dir() + "/sdf/" + object;
    } else if (spec.rfind("learned:", 0) == 0 && spec.size() > 8) {
      dir = spec.substr(8);
      // A relative path names a directory from here or, failing that, from the data folder's parent
      // ("learned:data/sdf/table" works from the repository root and from anywhere else).
      if (std::filesystem::path(dir).is_relative() && !std::filesystem::exists(dir)) {
        const auto alt = std::filesystem::path(data_dir()).parent_path() / dir;
        if (std::filesystem::exists(alt)) dir = alt.string();
      }
    } else {
      throw std::invalid_argument("config key 'env.sdf." + key + "' is '" + spec +
                                  "', must be analytic, learned or learned:<dir>");
    }
    auto model = std::make_shared<RedsdfModel>(load_redsdf(dir, object));
    if (model->arch.pose_dim != 0)
      throw std::runtime_error("learned SDF " + dir + ": a static object's field takes no pose (pose_dim " +
                               std::to_string(model->arch.pose_dim) + ")");
    if (!model->manifest.contains("safety_margin") || !model->manifest["safety_margin"].is_number())
      throw std::runtime_error("learned SDF " + dir + ": the manifest has no numeric safety_margin");
    out = std::make_shared<LearnedObstacle>();
    out->model = model;
    out->batch = std::make_shared<RedsdfBatch>(*model);
    out->margin = model->manifest["safety_margin"].get<double>();
    if (!(out->margin >= 0.0 && out->margin < 0.5))
      throw std::runtime_error("learned SDF " + dir + ": safety_margin must be in [0, 0.5) m");
    arm_object_placement(scene, out->R, out->t);
  }
  return out;
}

nlohmann::json sdf_flag_override(const std::string& env, const std::string& mode) {
  if (mode != "analytic" && mode != "learned")
    throw std::invalid_argument("--sdf is '" + mode + "', must be analytic or learned");
  if (env == "table" || env == "shelf") return {{"sdf", {{env, mode}}}};
  if (mode == "analytic") return nlohmann::json::object();
  throw std::invalid_argument("--sdf learned: env '" + env + "' has no field with a shipped learned model (table and shelf have)");
}

}  // namespace atacom
