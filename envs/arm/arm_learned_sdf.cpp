#include "envs/arm/arm_learned_sdf.hpp"

#include <filesystem>
#include <stdexcept>

#include "src/core/data_dir.hpp"

namespace atacom {

namespace {

// The weight directory of `spec` for `key` ("" for analytic); `shipped`
// names the field under data/sdf (the key's own by default).
std::string learned_dir(const std::string& key, const std::string& spec, const std::string& shipped = "") {
  if (spec == "analytic") return "";
  if (spec == "learned") return data_dir() + "/sdf/" + (shipped.empty() ? key : shipped);
  if (spec.rfind("learned:", 0) == 0 && spec.size() > 8) {
    std::string dir = spec.substr(8);
    // A relative path names a directory from here or, failing that, from the data folder's parent
    // ("learned:data/sdf/table" works from the repository root and from anywhere else).
    if (std::filesystem::path(dir).is_relative() && !std::filesystem::exists(dir)) {
      const auto alt = std::filesystem::path(data_dir()).parent_path() / dir;
      if (std::filesystem::exists(alt)) dir = alt.string();
    }
    return dir;
  }
  throw std::invalid_argument("config key 'env.sdf." + key + "' is '" + spec +
                              "', must be analytic, learned or learned:<dir>");
}

double checked_margin(const RedsdfModel& m, const std::string& dir) {
  if (!m.manifest.contains("safety_margin") || !m.manifest["safety_margin"].is_number())
    throw std::runtime_error("learned SDF " + dir + ": the manifest has no numeric safety_margin");
  const double margin = m.manifest["safety_margin"].get<double>();
  if (!(margin >= 0.0 && margin < 0.5)) throw std::runtime_error("learned SDF " + dir + ": safety_margin must be in [0, 0.5) m");
  return margin;
}

}  // namespace

std::shared_ptr<LearnedHuman> load_arm_learned_human(const std::map<std::string, std::string>& sdf) {
  const auto it = sdf.find("human");
  if (it == sdf.end()) return nullptr;
  const std::string dir = learned_dir(it->first, it->second);
  if (dir.empty()) return nullptr;
  auto model = std::make_shared<RedsdfModel>(load_redsdf(dir, "human"));
  if (model->arch.pose_dim != kHumanDofs)
    throw std::runtime_error("learned SDF " + dir + ": the human's field takes the " + std::to_string(kHumanDofs) +
                             " joint angles (pose_dim " + std::to_string(model->arch.pose_dim) + ")");
  auto out = std::make_shared<LearnedHuman>();
  out->model = model;
  out->batch = std::make_shared<RedsdfBatch>(*model);
  out->margin = checked_margin(*model, dir);
  return out;
}

std::shared_ptr<LearnedObstacle> load_arm_learned_body(const std::map<std::string, std::string>& sdf, double torso_lift) {
  const auto it = sdf.find("tiago");
  if (it == sdf.end()) return nullptr;
  const std::string dir = learned_dir(it->first, it->second);
  if (dir.empty()) return nullptr;
  auto model = std::make_shared<RedsdfModel>(load_redsdf(dir, "tiago"));
  if (model->arch.pose_dim != 1)
    throw std::runtime_error("learned SDF " + dir + ": the robot body's field takes the torso lift as its one pose input (pose_dim " +
                             std::to_string(model->arch.pose_dim) + ")");
  auto out = std::make_shared<LearnedObstacle>();
  out->model = model;
  out->batch = std::make_shared<RedsdfBatch>(*model);
  out->margin = checked_margin(*model, dir);
  out->pose = {float(torso_lift)};  // base_footprint: R, t stay the identity
  return out;
}

std::shared_ptr<LearnedObstacle> load_arm_learned_obstacle(const std::map<std::string, std::string>& sdf,
                                                           const ArmSceneConfig& scene) {
  // The env's key and the field's object: HRI's shared table is "table" in the
  // env config and the field "hri_table" (a box of its own, data/sdf/hri_table).
  const bool hri = scene.task == ArmTask::Hri;
  const std::string key_name = hri ? "table" : arm_task_name(scene.task);
  const std::string object = hri ? "hri_table" : key_name;
  std::shared_ptr<LearnedObstacle> out;
  for (const auto& [key, spec] : sdf) {
    if (key == "human" && hri) continue;  // load_arm_learned_human
    if (key == "tiago") continue;         // load_arm_learned_body
    if (key != key_name)
      throw std::invalid_argument("config key 'env.sdf." + key + "' names no field of this env (" +
                                  (hri ? std::string("its fields are human, table and tiago")
                                       : "its object is " + key_name) + ")");
    const std::string dir = learned_dir(key, spec, object);
    if (dir.empty()) continue;
    auto model = std::make_shared<RedsdfModel>(load_redsdf(dir, object));
    if (model->arch.pose_dim != 0)
      throw std::runtime_error("learned SDF " + dir + ": a static object's field takes no pose (pose_dim " +
                               std::to_string(model->arch.pose_dim) + ")");
    out = std::make_shared<LearnedObstacle>();
    out->model = model;
    out->batch = std::make_shared<RedsdfBatch>(*model);
    out->margin = checked_margin(*model, dir);
    arm_object_placement(scene, out->R, out->t);
  }
  return out;
}

nlohmann::json sdf_flag_override(const std::string& env, const std::string& mode) {
  if (mode != "analytic" && mode != "learned")
    throw std::invalid_argument("--sdf is '" + mode + "', must be analytic or learned");
  if (env == "table" || env == "shelf") return {{"sdf", {{env, mode}, {"tiago", mode}}}};
  if (env == "hri" || env == "hri-upright") return {{"sdf", {{"human", mode}, {"table", mode}, {"tiago", mode}}}};
  if (mode == "analytic") return nlohmann::json::object();
  throw std::invalid_argument("--sdf learned: env '" + env +
                              "' has no field with a shipped learned model (table, shelf, hri's human and table and the "
                              "arm envs' robot body have)");
}

}  // namespace atacom
