#include "atacom/parallel.hpp"

#include <thread>

#include <tbb/global_control.h>
#include <tbb/info.h>

namespace atacom {

namespace {
std::unique_ptr<tbb::global_control> g_control;
int g_threads = 0;
}  // namespace

void set_num_threads(int threads) {
  const int hw = static_cast<int>(tbb::info::default_concurrency());
  g_threads = threads <= 0 ? hw : threads;
  g_control.reset();
  g_control = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<size_t>(g_threads));
}

int num_threads() {
  if (g_threads > 0) return g_threads;
  return static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

}  // namespace atacom
