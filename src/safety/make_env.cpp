// make_env: the registry's env behind a layer of the safety table, with a
// memory check before large batches.
#include "atacom/make_env.hpp"

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "src/core/limits.hpp"

namespace atacom {

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

void require_batch_memory(const EnvEntry& e, const nlohmann::json& cfg, const EnvRequest& request,
                          const nlohmann::json& params) {
  if (request.num_envs <= kProbeAbove) return;
  // Two probes alive together, of P and 2P envs: the difference of their
  // growths is P envs' worth, without what every batch holds once (shared
  // data, tables), and without memory freed earlier and reused.
  const double m0 = bytes_in_use();
  const auto small = wrap_safety(e.make(cfg, kProbeEnvs), request.safety, params);
  const double m1 = bytes_in_use();
  const auto large = wrap_safety(e.make(cfg, 2 * kProbeEnvs), request.safety, params);
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
  const nlohmann::json params = resolve_safety_params(request.safety, request.name, request.safety_params);
  require_batch_memory(e, cfg, request, params);
  return wrap_safety(e.make(cfg, request.num_envs), request.safety, params);
}

}  // namespace atacom
