// bench_sdf: points per second of a distance field with its gradient,
// learned (ReDSDF, batched float32, kernels/redsdf_batch.hpp) vs analytic
// (exact primitives, SIMD lanes of 8 doubles, kernels/sdf_impl.hpp), for the
// shelf (8 boxes), the human (16 capsules) and the TIAGo body (cylinder, box,
// sphere; smooth union as in the body rows; the learned field takes the torso
// lift, 0.1 m as on table and shelf), at N envs x PoIs points, 1 and 2 threads. Learned lines carry FLOPs per point and their share of the
// measured float GEMM rate at the network's layer shape (gemm_peak lines).
//
// Weights: the shipped data/sdf/shelf, data/sdf/human and data/sdf/tiago models when present
// (the human's takes the 34 joint angles, in its body frame); the other human
// networks (pose 38) have random weights: dense layers cost the same whatever
// the values, so their rate is that of a trained network of that size.
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <tbb/parallel_for.h>

#include "atacom/parallel.hpp"
#include "atacom/rng.hpp"
#include "bench/bench_common.hpp"
#include "envs/arm/human_model.hpp"
#include "envs/arm/human_motion.hpp"
#include "kernels/human_kernels.hpp"
#include "kernels/redsdf_batch.hpp"
#include "kernels/sdf_impl.hpp"
#include "src/core/data_dir.hpp"
#include "train/redsdf_train.hpp"
#include "train/sdf_tiago_data.hpp"
#include "train/tensor.hpp"

using namespace atacom;

namespace {
int repeats = 5;
double window_s = 0.2;

double best_rate(const std::function<void()>& fn) { return 1.0 / bench::best_seconds_per_call(fn, repeats, window_s); }

// Points around the object: uniform in its bounds grown by 0.5 m (the PoIs'
// range in the arm envs).
std::vector<double> sample_points(int64_t n, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  Rng rng(3, 0);
  std::vector<double> p(static_cast<size_t>(3 * n));
  for (int64_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) p[size_t(3 * i + k)] = rng.uniform(lo(k) - 0.5, hi(k) + 0.5);
  return p;
}

// Analytic: lanes of 8 points, structure-of-arrays per lane group.
void bench_analytic(const std::string& object, const std::vector<Shape>& shapes, const std::vector<double>& p, int N,
                    int poi, int threads, double blend = 0.0) {
  set_num_threads(threads);
  const int64_t n = int64_t(N) * poi, groups = n / lanes::kLanes;
  std::vector<double> soa(size_t(groups) * 3 * lanes::kLanes), d(static_cast<size_t>(n)), g(static_cast<size_t>(3 * n));
  for (int64_t q = 0; q < groups; ++q)
    for (int l = 0; l < lanes::kLanes; ++l)
      for (int k = 0; k < 3; ++k) soa[size_t((q * 3 + k) * lanes::kLanes + l)] = p[size_t(3 * (q * lanes::kLanes + l) + k)];
  auto run = [&] {
    parallel_blocks(groups, 64, [&](int64_t lo, int64_t hi) {
      for (int64_t q = lo; q < hi; ++q) {
        lanes::vd P[3], G[3];
        for (int k = 0; k < 3; ++k) P[k] = lanes::load(&soa[size_t((q * 3 + k) * lanes::kLanes)]);
        const lanes::vd dd = sdf_impl::union_of<lanes::vd>(shapes.data(), int(shapes.size()), blend, P, G);
        lanes::store(&d[size_t(q * lanes::kLanes)], dd);
        for (int k = 0; k < 3; ++k) lanes::store(&g[size_t((q * 3 + k) * lanes::kLanes)], G[k]);
      }
    });
  };
  const double per_s = best_rate(run) * double(groups * lanes::kLanes);
  bench::emit({{"bench", "sdf"}, {"object", object}, {"kind", "analytic"}, {"N", N}, {"poi", poi},
               {"threads", threads}, {"per_s", per_s}, {"primitives", shapes.size()}, {"blend", blend},
               {"precision", "float64"}});
}

// Eigen float GEMM (rows x k) (k x m), one independent product per thread: GFLOP/s per thread.
double gemm_gflops(int rows, int k, int m, int threads) {
  set_num_threads(threads);
  using M = RowMat<float>;
  std::vector<M> As, Bs, Cs;
  for (int t = 0; t < threads; ++t) As.push_back(M::Random(rows, k)), Bs.push_back(M::Random(k, m)), Cs.push_back(M::Zero(rows, m));
  const int inner = std::max(1, int(2e7 / (2.0 * rows * k * m)));
  const double calls = best_rate([&] {
    tbb::parallel_for(0, threads, [&](int t) {
      for (int i = 0; i < inner; ++i) Cs[size_t(t)].noalias() = As[size_t(t)] * Bs[size_t(t)];
    });
  });
  const double gf = calls * inner * 2.0 * rows * k * m * 1e-9;
  bench::emit({{"bench", "gemm_peak"}, {"m", rows}, {"k", k}, {"n", m}, {"threads", threads},
               {"per_s", calls * inner * threads}, {"gflops", gf}});
  return gf;
}

void bench_learned(const std::string& object, const std::string& weights, const RedsdfModel& model,
                   const std::vector<double>& p, const std::vector<float>& pose, int N, int poi, int threads) {
  const int64_t n = int64_t(N) * poi;
  RedsdfBatch batch(model);
  std::vector<float> pf(p.begin(), p.begin() + 3 * n), d(static_cast<size_t>(n)), g(static_cast<size_t>(3 * n));
  const int w = model.arch.hidden[0];
  const double gemm = gemm_gflops(kRedsdfBlock, w, w, threads);
  set_num_threads(threads);
  const float* ps = model.arch.pose_dim ? pose.data() : nullptr;
  const double per_s =
      best_rate([&] { batch.evaluate(pf.data(), ps, false, n, d.data(), g.data()); }) * double(n);
  const double fpp = batch.flops_per_point();
  bench::emit({{"bench", "sdf"}, {"object", object}, {"kind", "learned"}, {"N", N}, {"poi", poi},
               {"threads", threads}, {"per_s", per_s}, {"hidden", model.arch.hidden}, {"pose_dim", model.arch.pose_dim},
               {"weights", weights}, {"flops_per_point", fpp}, {"gflops_per_thread", per_s * fpp * 1e-9 / threads},
               {"gemm_gflops_per_thread", gemm}, {"gemm_share", per_s * fpp * 1e-9 / threads / gemm},
               {"precision", "float32"}});
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"bench_sdf: analytic and learned distance fields, points per second"};
  bool quick = false;
  app.add_flag("--quick", quick, "2 repeats of 0.1 s windows");
  if (int code = 0; !bench::parse_args(app, argc, argv, code)) return code;
  if (quick) {
    repeats = 2;
    window_s = 0.1;
  }
  const int N = 4096, poi = 9;
  const int64_t n = int64_t(N) * poi;
  bench::emit({{"bench", "sdf_host"}, {"cpu", bench::cpu_name()}, {"per_s", 0}});
  // Shelf.
  Eigen::Vector3d centre, lo, hi;
  const ShapeUnion shelf = sdf_object_geometry("shelf", &centre);
  union_box_bounds(shelf, lo, hi);
  const std::vector<double> ps = sample_points(n, lo, hi);
  const std::string shipped = data_dir() + "/sdf/shelf";
  RedsdfModel shelf_model;
  std::string shelf_weights = "shipped " + shipped;
  if (std::filesystem::exists(shipped + "/redsdf.bin")) {
    shelf_model = load_redsdf(shipped, "shelf");
  } else {
    shelf_model = RedsdfModel(default_sdf_train_config("shelf").arch);
    init_redsdf(shelf_model, 1);
    shelf_weights = "random (throughput only)";
  }
  // Human: 16 capsules of one motion-library pose (every env's pose costs the same).
  const HumanModel hm = load_human_model();
  const HumanMotionLibrary lib = load_default_human_motion();
  HumanBatch hb(1);
  const double t0 = 100.0;
  human_motion_range(lib, HumanReplayConfig{}, 1.0 / 30.0, &t0, hb, 0, 1);
  human_capsules_range(hm.fk, hb, 0, 1, false);
  std::vector<Shape> caps;
  Eigen::Vector3d hlo = Eigen::Vector3d::Constant(1e9), hhi = -hlo;
  for (size_t c = 0; c < hm.capsules.size(); ++c) {
    const double* e = &hb.cap[c * 6];
    const Eigen::Vector3d a(e[0], e[1], e[2]), b(e[3], e[4], e[5]);
    caps.push_back(Shape::capsule(a, b, hm.capsules[c].radius));
    hlo = hlo.cwiseMin(a.cwiseMin(b)), hhi = hhi.cwiseMax(a.cwiseMax(b));
  }
  const std::vector<double> ph = sample_points(n, hlo, hhi);
  const int pose_dim = int(hb.pose.size());
  std::vector<float> pose(size_t(n) * pose_dim);
  for (int64_t i = 0; i < n; ++i)
    for (int k = 0; k < pose_dim; ++k) pose[size_t(i * pose_dim + k)] = float(hb.pose[size_t(k)]);
  auto human_net = [&](std::vector<int> hidden) {
    RedsdfArch a;
    a.pose_dim = pose_dim;
    a.hidden = std::move(hidden);
    RedsdfModel m(a);
    init_redsdf(m, 2);
    return m;
  };
  const RedsdfModel human_small = human_net({128, 128, 128, 128, 128});
  const std::string shipped_human = data_dir() + "/sdf/human";
  const bool have_human = std::filesystem::exists(shipped_human + "/redsdf.bin");
  const RedsdfModel human_shipped = have_human ? load_redsdf(shipped_human, "human") : RedsdfModel();
  std::vector<float> joints(size_t(n) * kHumanDofs);
  for (int64_t i = 0; i < n; ++i)
    for (int k = 0; k < kHumanDofs; ++k) joints[size_t(i * kHumanDofs + k)] = float(hb.pose[size_t(kHumanRootDofs + k)]);
  const RedsdfModel human_ref = human_net({512, 512, 512, 512, 512});
  // TIAGo body at the table/shelf torso lift.
  const float lift = 0.1f;
  const ShapeUnion body = tiago_body_geometry(lift);
  Eigen::Vector3d blo = Eigen::Vector3d::Constant(1e9), bhi = -blo;
  for (const Shape& sh : body.shapes) {
    const Eigen::Vector3d c(sh.a[0], sh.a[1], sh.a[2]);
    const Eigen::Vector3d h = sh.type == ShapeType::Box ? Eigen::Vector3d(sh.half[0], sh.half[1], sh.half[2])
                              : sh.type == ShapeType::CylinderZ ? Eigen::Vector3d(sh.radius, sh.radius, sh.half[2])
                                                                : Eigen::Vector3d::Constant(sh.radius);
    blo = blo.cwiseMin(c - h), bhi = bhi.cwiseMax(c + h);
  }
  const std::vector<double> pb = sample_points(n, blo, bhi);
  const std::vector<float> lifts(static_cast<size_t>(n), lift);
  const std::string shipped_tiago = data_dir() + "/sdf/tiago";
  RedsdfModel tiago_model;
  std::string tiago_weights = "shipped " + shipped_tiago;
  if (std::filesystem::exists(shipped_tiago + "/redsdf.bin")) {
    tiago_model = load_redsdf(shipped_tiago, "tiago");
  } else {
    tiago_model = RedsdfModel(default_sdf_train_config("tiago").arch);
    init_redsdf(tiago_model, 1);
    tiago_weights = "random (throughput only)";
  }
  for (int threads : {1, 2}) {
    bench_analytic("shelf", shelf.shapes, ps, N, poi, threads);
    bench_learned("shelf", shelf_weights, shelf_model, ps, pose, N, poi, threads);
    bench_analytic("human", caps, ph, N, poi, threads);
    if (have_human) bench_learned("human", "shipped " + shipped_human, human_shipped, ph, joints, N, poi, threads);
    bench_learned("human", "random (throughput only)", human_small, ph, pose, N, poi, threads);
    bench_learned("human", "random (throughput only), the reference's 5 x 512", human_ref, ph, pose, N, poi, threads);
    bench_analytic("tiago", body.shapes, pb, N, poi, threads, body.blend);
    bench_learned("tiago", tiago_weights, tiago_model, pb, lifts, N, poi, threads);
  }
  return 0;
}
