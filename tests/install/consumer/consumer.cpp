// Links atacom::atacom from an install tree: the projector on one problem
// (the README's `atacom filter` example) and an env behind ATACOM.
#include <cmath>
#include <cstdio>
#include <vector>

#include <atacom/data_dir.hpp>
#include <atacom/env_registry.hpp>
#include <atacom/make_env.hpp>
#include <atacom/projector.hpp>

int main() {
  using namespace atacom;
  ProjectorModel model = default_projector_model(/*n=*/2, /*m=*/2, /*k=*/1);
  ProjectorBatch batch(model, 1);
  batch.f = {0.0, 0.0};
  batch.G = {1.0, 0.0, 0.0, 1.0};
  batch.Jq = {1.0, 0.0};
  batch.c = {-0.001};
  batch.alpha = {1.0, 0.5};
  project_batch(model, batch);
  // alpha pushes into the boundary 1 mm away: its first component is cut to ~9e-6, the second kept.
  if (std::abs(batch.a[0] - 9.0e-6) > 1e-7 || std::abs(batch.a[1] - 0.5) > 1e-12) {
    std::printf("projector: unexpected a = [%g, %g]\n", batch.a[0], batch.a[1]);
    return 1;
  }

  set_data_dir(CONSUMER_DATA_DIR);
  auto env = make_env(EnvRequest{"table", 2, SafetyLayer::Atacom, nlohmann::json::object()});
  env->seed(0);
  std::vector<double> actions(2 * env->spec().act_dim, 1.0);
  for (int t = 0; t < 30; ++t) env->step(actions.data());
  double max_c = -INFINITY;
  for (double c : env->buffers().constraints) max_c = std::max(max_c, c);
  std::printf("consumer: a = [%.3g, %.3g], table under ATACOM: %d constraints, max %.4f after 30 steps\n",
              batch.a[0], batch.a[1], env->spec().num_constraints, max_c);
  return max_c <= 1e-3 ? 0 : 1;
}
