// Loading a run directory's learned policy (TrainedPolicy) and writing
// policy files.
#include "train/run_policy.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "atacom/env_registry.hpp"
#include "atacom/make_env.hpp"
#include "atacom/learner.hpp"
#include "atacom/trainer.hpp"
#include "train/algorithms.hpp"
#include "train/checkpoint.hpp"

namespace atacom {

namespace fs = std::filesystem;

const char* run_policy_file(RunPolicy which) { return which == RunPolicy::Best ? "policy_best.bin" : "policy_final.bin"; }

void write_policy_file(const std::string& path, const Policy& policy, nlohmann::json manifest) {
  std::ostringstream p;
  policy.save(p);
  Checkpoint ck;
  ck.payload = p.str();
  manifest["format"] = "atacom-policy";
  manifest["kind"] = policy.kind();
  manifest["obs_dim"] = policy.obs_dim();
  manifest["act_dim"] = policy.act_dim();
  ck.manifest = std::move(manifest);
  write_checkpoint_atomic(path, ck);
}

std::unique_ptr<TrainedPolicy> TrainedPolicy::load(const std::string& run_dir, RunPolicy which) {
  const fs::path dir(run_dir);
  std::ifstream cf(dir / "config.json");
  if (!cf) throw std::runtime_error("no config.json in run directory '" + run_dir + "'");
  nlohmann::json file;
  try {
    file = nlohmann::json::parse(cf);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error("config.json in '" + run_dir + "' is not valid JSON: " + e.what());
  }
  std::unique_ptr<TrainedPolicy> tp(new TrainedPolicy());
  try {
    tp->cfg_ = resolve_run_config(file);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error("config.json in '" + run_dir + "' does not resolve: " + e.what());
  }
  const TrainConfig& t = tp->cfg_.train;
  const Algorithm& algo = find_algorithm(t.algo);
  if (!algo.learns())
    throw std::runtime_error("run '" + run_dir + "' is an evaluation of '" + algo.name +
                             "', which learns nothing: it has no trained policy");
  // The env as training built it (a safety layer may add info columns), for its spec.
  const auto env = make_env(EnvRequest{t.env, 1, algo.safety, tp->cfg_.env, tp->cfg_.safety});
  const LearnerEntry& le = learner_entry(algo.learner);
  tp->inner_ = le.make_policy(env->spec(), tp->cfg_.learner);
  const std::string path = (dir / run_policy_file(which)).string();
  if (!fs::exists(path))
    throw std::runtime_error("run '" + run_dir + "' has no " + run_policy_file(which) +
                             (which == RunPolicy::Final ? " (unfinished, or written before policy files existed)" : ""));
  const Checkpoint ck = read_checkpoint(path, kOldestPolicyVersion);
  const nlohmann::json& m = ck.manifest;
  auto field = [&](const char* k) { return m.contains(k) ? m[k] : nlohmann::json(); };
  if (field("format") != "atacom-policy" || field("kind") != tp->inner_->kind() || field("env") != t.env ||
      field("obs_dim") != tp->inner_->obs_dim() || field("act_dim") != tp->inner_->act_dim())
    throw std::runtime_error("'" + path + "' is not a " + tp->inner_->kind() + " policy for env '" + t.env +
                             "' with this run's dimensions");
  std::istringstream p(ck.payload);
  try {
    tp->inner_->load(p);
  } catch (const std::exception& e) {
    throw std::runtime_error("'" + path + "' does not hold this run's policy: " + e.what());
  }
  if (p.peek() != std::char_traits<char>::eof()) throw std::runtime_error("'" + path + "' is longer than its policy");
  tp->manifest_ = m;
  return tp;
}

}  // namespace atacom
