#include "atacom/env_registry.hpp"

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "envs/arm/arm_attractor.hpp"
#include "envs/arm/arm_env.hpp"
#include "envs/nav/nav_attractor.hpp"
#include "envs/nav/nav_env.hpp"
#include "envs/pendulum/pendulum.hpp"
#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"

namespace atacom {

// Each env adds one line here (a function declared next to its class).
const std::vector<EnvEntry>& env_entries() {
  static const std::vector<EnvEntry> entries = {
      {"table", "TableEnv: TIAGo++ arm reaching above a table (34 constraints)", true, table_env_default_config,
       make_table_env, arm_sac_defaults, make_table_attractor},
      {"shelf", "ShelfEnvSim: TIAGo++ arm reaching into a shelf (34 constraints)", true, shelf_env_default_config,
       make_shelf_env, arm_sac_defaults, make_shelf_attractor},
      {"nav", "differential-drive TIAGo to a goal among walls and a moving Fetch (Box2D)", true,
       &nav_default_config_json, &make_nav_env, nullptr, make_nav_attractor},
      {"hri", "HRI-Sim: TIAGo++ arm carrying a cup past a moving human, spills counted (43 constraints)", true,
       hri_env_default_config, make_hri_env, hri_sac_defaults, make_hri_attractor},
      {"hri-upright", "HRI-Sim plus a cup-upright constraint row (ours; 44 constraints)", true,
       hri_upright_env_default_config, make_hri_env, hri_sac_defaults, make_hri_attractor},
      pendulum_env_entry(),
  };
  return entries;
}

std::vector<std::string> env_names() {
  std::vector<std::string> names;
  for (const auto& e : env_entries()) names.push_back(e.name);
  return names;
}

const EnvEntry& env_entry(const std::string& name) {
  for (const auto& e : env_entries())
    if (e.name == name) return e;
  std::string known;
  for (const auto& e : env_entries()) known += (known.empty() ? "" : ", ") + e.name;
  throw std::invalid_argument("unknown env '" + printable_text(name) + "' (known: " + known + ")");
}

nlohmann::json merge_config_strict(const nlohmann::json& base, const nlohmann::json& overrides,
                                   const std::string& path) {
  if (!overrides.is_object())
    throw std::invalid_argument("config" + (path.empty() ? std::string() : " key '" + path + "'") +
                                " must be a JSON object");
  nlohmann::json out = base;
  for (auto it = overrides.begin(); it != overrides.end(); ++it) {
    const std::string key = path.empty() ? it.key() : path + "." + it.key();
    if (!base.contains(it.key())) throw std::invalid_argument("unknown config key '" + printable_text(key) + "'");
    const auto& b = base[it.key()];
    const auto& v = it.value();
    if (b.is_object()) {
      out[it.key()] = merge_config_strict(b, v, key);
    } else {
      const bool both_numbers = b.is_number() && v.is_number();
      const bool same = b.type() == v.type() || both_numbers || b.is_null();
      if (!same)
        throw std::invalid_argument("config key '" + key + "' has type " + v.type_name() + ", expected " +
                                    b.type_name());
      if (b.is_number_integer() && v.is_number_float())
        throw std::invalid_argument("config key '" + key + "' must be an integer");
      out[it.key()] = v;
    }
  }
  return out;
}

nlohmann::json resolve_env_config(const std::string& name, const nlohmann::json& overrides) {
  // Runs recorded before issue 30 named today's hri-upright "hri" (envs/arm/arm_registry.cpp).
  const nlohmann::json& o = name == "hri" ? hri_upgrade_pre_issue30_config(overrides) : overrides;
  return merge_config_strict(env_entry(name).default_config(), o, "env");
}

std::unique_ptr<Policy> make_attractor_policy(const std::string& env, const nlohmann::json& resolved_env_config) {
  const EnvEntry& e = env_entry(env);
  if (e.make_attractor == nullptr) {
    std::string with;
    for (const auto& x : env_entries())
      if (x.make_attractor) with += (with.empty() ? "" : ", ") + x.name;
    throw std::invalid_argument("env '" + env + "' has no linear attractor (envs with one: " + with + ")");
  }
  return e.make_attractor(resolved_env_config);
}

namespace {

// Bytes this process holds: the allocator's in-use bytes, or resident memory
// where the allocator does not say (sanitizer runtimes); the larger of the two.
double bytes_in_use() {
  const struct mallinfo2 mi = ::mallinfo2();
  double heap = double(mi.uordblks) + double(mi.hblkhd);
  std::ifstream statm("/proc/self/statm");
  double pages_total = 0, pages_resident = 0;
  if (statm >> pages_total >> pages_resident) heap = std::max(heap, pages_resident * double(::sysconf(_SC_PAGE_SIZE)));
  return heap;
}

// A batch's memory grows with N by an amount only the env knows (a nav env
// keeps a physics world, about 190 KB; an arm env a few KB): before a large
// batch is built, a probe batch of the same env and safety layer is built and
// measured, and the batch is refused when N times that exceeds this machine's
// memory, instead of ending in std::bad_alloc or the OOM killer.
constexpr int kProbeAbove = 4096;  // smaller batches are built without a probe
constexpr int kProbeEnvs = 128;

void require_batch_memory(const EnvEntry& e, const nlohmann::json& cfg, const EnvRequest& request) {
  if (request.num_envs <= kProbeAbove) return;
  // Two probes alive together, of P and 2P envs: the difference of their
  // growths is P envs' worth, without what every batch holds once (shared
  // data, tables), and without memory freed earlier and reused.
  const double m0 = bytes_in_use();
  const auto small = wrap_safety(e.make(cfg, kProbeEnvs), request.safety);
  const double m1 = bytes_in_use();
  const auto large = wrap_safety(e.make(cfg, 2 * kProbeEnvs), request.safety);
  const double m2 = bytes_in_use();
  const EnvSpec& sp = small->spec();
  // At least the batch's own buffers (EnvBuffers).
  const double buffers = 2.0 * 4 * sp.obs_dim + 8.0 * sp.num_constraints + 4.0 * double(sp.info_names.size()) + 22;
  const double per_env = std::max(((m2 - m1) - (m1 - m0)) / kProbeEnvs, buffers);
  char b[200];
  std::snprintf(b, sizeof(b), "%d envs of '%s' (about %.0f KB each, measured on batches of %d and %d; lower --envs, "
                "train.num_envs or train.eval_episodes)", request.num_envs, request.name.c_str(), per_env / 1e3,
                kProbeEnvs, 2 * kProbeEnvs);
  limits::require_memory(per_env * double(request.num_envs), b);
}

}  // namespace

std::unique_ptr<BatchEnv> make_env(const EnvRequest& request) {
  const EnvEntry& e = env_entry(request.name);
  if (request.num_envs < 1) throw std::invalid_argument("number of envs must be >= 1");
  if (request.safety != SafetyLayer::None && !e.has_constraints)
    throw std::invalid_argument("env '" + request.name + "' has no constraint model, so the " +
                                safety_layer_title(request.safety) + " safety layer cannot wrap it");
  const nlohmann::json cfg = resolve_env_config(request.name, request.config);
  require_batch_memory(e, cfg, request);
  return wrap_safety(e.make(cfg, request.num_envs), request.safety);
}

}  // namespace atacom
