#include "train/redsdf_train.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numeric>
#include <stdexcept>

#include "atacom/rng.hpp"
#include "envs/arm/arm_scene.hpp"
#include "envs/arm/human_model.hpp"
#include "envs/arm/human_motion.hpp"
#include "kernels/redsdf_batch.hpp"
#include "src/core/config_json.hpp"
#include "src/core/fs_util.hpp"
#include "src/core/svg.hpp"
#include "train/adam.hpp"
#include "train/autodiff.hpp"
#include "train/redsdf_loss.hpp"
#include "train/sdf_human_data.hpp"
#include "train/sdf_tiago_data.hpp"

namespace atacom {

using json = nlohmann::json;

namespace {
// The human's centre: the middle of its capsules' bounds in the neutral pose (body frame).
Eigen::Vector3d human_centre(const HumanModel& model) {
  const float q[kHumanDofs] = {};
  double cap[kHumanCapsules * 6];
  human_body_capsules(model, q, cap);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (int c = 0; c < kHumanCapsules; ++c)
    for (int e = 0; e < 2; ++e) {
      const Eigen::Vector3d x(cap + c * 6 + 3 * e);
      const Eigen::Vector3d r = Eigen::Vector3d::Constant(model.fk.cap_radius[c]);
      lo = lo.cwiseMin(x - r);
      hi = hi.cwiseMax(x + r);
    }
  return 0.5 * (lo + hi);
}
}  // namespace

SdfTrainConfig default_sdf_train_config(const std::string& object) {
  SdfTrainConfig c;
  c.object = object;
  c.arch.hidden = {64, 64, 64, 64};
  c.arch.trunk_layers = 2;
  c.arch.side_width = 32;
  c.data = default_sdf_data_config();
  if (object == "human") {
    // Pose-conditioned: 34 joint angles, body frame (train/sdf_human_data.hpp).
    c.arch.pose_dim = kHumanDofs;
    c.arch.hidden = {128, 128, 128, 128};
    c.arch.centre = human_centre(load_human_model());
    // The reference's human list runs from -0.1 to 0.5; the capsules are 4-8 cm
    // thick, so the inner offsets stop at -3 cm (deeper ones cross the axis).
    c.data.epsilons = {-0.03, -0.01, -0.005, 0.0, 0.005, 0.01, 0.02, 0.03, 0.05, 0.08, 0.12, 0.16, 0.2, 0.3, 0.4, 0.5};
    c.data.poses = 3000;
    c.data.surface_points = 20;
    c.data.volume_margin = 0.6;
    c.max_epochs = 60;
    return c;
  }
  if (object == "tiago") {
    // Pose-conditioned on the torso lift only (train/sdf_tiago_data.hpp).
    c.arch.pose_dim = 1;
    c.arch.centre = tiago_body_centre();
    c.data.poses = 600;
    c.data.surface_points = 40;
    c.max_epochs = 300;
    return c;
  }
  sdf_object_geometry(object, &c.arch.centre);  // validates the name
  c.arch.pose_dim = 0;
  return c;
}

void to_json(json& j, const SdfTrainConfig& c) {
  j = {{"object", c.object}, {"arch", c.arch},     {"data", c.data},       {"batch", c.batch},
       {"lr", c.lr},         {"lr_final", c.lr_final}, {"max_epochs", c.max_epochs}, {"patience", c.patience},
       {"gamma", c.gamma},   {"near_weight", c.near_weight}, {"align_weight", c.align_weight},
       {"budget_s", c.budget_s}, {"init_seed", c.init_seed}};
}

void from_json(const json& j, SdfTrainConfig& c) {
  ConfigReader r(j, "sdf_train");
  r.get("object", c.object);
  if (j.contains("arch")) c.arch = r.at("arch").get<RedsdfArch>();
  if (j.contains("data")) c.data = r.at("data").get<SdfDataConfig>();
  r.get("batch", c.batch, range::closed(16, 1 << 16));
  r.get("lr", c.lr, range::open_closed(0.0, 1.0));
  r.get("lr_final", c.lr_final, range::open_closed(0.0, 1.0));
  r.get("max_epochs", c.max_epochs, range::closed(1, 100000));
  r.get("patience", c.patience, range::closed(1, 100000));
  r.get("gamma", c.gamma, range::closed(0.0, 10.0));
  r.get("near_weight", c.near_weight, range::closed(0.0, 1000.0));
  r.get("align_weight", c.align_weight, range::closed(0.0, 1000.0));
  r.get("budget_s", c.budget_s, range::open_closed(0.0, 1e6));
  r.get("init_seed", c.init_seed);
  r.finish();
}

ShapeUnion sdf_object_geometry(const std::string& object, Eigen::Vector3d* centre) {
  if (object != "table" && object != "shelf" && object != "hri_table")
    throw std::invalid_argument("--object " + object + ": static-object geometry exists for table, shelf and hri_table only");
  // hri_table: HRI-Sim's shared table (the reference's HRI cube, 4.4). Its
  // scene places the box by absolute coordinates, so it is built at the
  // default placement and moved back into the object frame (yaw 0 there).
  const bool hri = object == "hri_table";
  ArmSceneConfig sc = default_arm_scene_config(hri ? ArmTask::Hri : parse_arm_task(object));
  const Eigen::Vector3d placed = hri ? sc.position : Eigen::Vector3d::Zero();
  if (!hri) sc.position.setZero();
  sc.yaw_deg = 0;
  ArmScene scene = build_arm_scene(sc, load_tiago_arm_model(0.3));
  for (Shape& sh : scene.obstacle.shapes)
    for (int k = 0; k < 3; ++k) sh.a[k] -= placed(k);
  if (centre) {
    Eigen::Vector3d lo, hi;
    union_box_bounds(scene.obstacle, lo, hi);
    *centre = 0.5 * (lo + hi);
  }
  return scene.obstacle;
}

namespace {

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, size_t(q * double(v.size() - 1) + 0.5))];
}

}  // namespace

json sdf_accuracy(const RedsdfModel& m, const SdfSamples& s, const std::vector<int>& idx) {
  RedsdfBatch batch(m);
  const int64_t n = int64_t(idx.size());
  std::vector<float> p(static_cast<size_t>(3 * n)), d(static_cast<size_t>(n)), g(static_cast<size_t>(3 * n));
  const int P = s.pose_dim;
  std::vector<float> pose(size_t(n) * size_t(P));
  for (int64_t i = 0; i < n; ++i) {
    const int j = idx[size_t(i)];
    for (int k = 0; k < 3; ++k) p[size_t(3 * i + k)] = s.p[size_t(3 * j + k)];
    for (int k = 0; k < P; ++k) pose[size_t(i * P + k)] = s.poses[size_t(s.pose_id[size_t(j)]) * P + size_t(k)];
  }
  batch.evaluate(p.data(), P ? pose.data() : nullptr, false, n, d.data(), g.data());
  struct Acc { double sum = 0, max = 0; int64_t cnt = 0; std::vector<double> ang; };
  Acc near, far, all;
  const std::vector<double> margins{0.0, 0.005, 0.01, 0.02, 0.03, 0.05, 0.1};
  std::vector<int64_t> unsafe(margins.size(), 0);
  int64_t inside = 0;
  double over_band = -1e300, inside_max = -1e300;
  for (int64_t i = 0; i < n; ++i) {
    const int j = idx[size_t(i)];
    const double y = s.y[size_t(j)], e = std::abs(double(d[size_t(i)]) - y);
    Eigen::Vector3d gl(g[size_t(3 * i)], g[size_t(3 * i + 1)], g[size_t(3 * i + 2)]);
    const Eigen::Vector3d ge(s.grad[size_t(3 * j)], s.grad[size_t(3 * j + 1)], s.grad[size_t(3 * j + 2)]);
    const double c = gl.norm() > 0 ? std::clamp(gl.normalized().dot(ge), -1.0, 1.0) : -1.0;
    const double ang = std::acos(c) * 180.0 / M_PI;
    for (Acc* a : {&all, std::abs(y) < 0.1 ? &near : nullptr, y > 0.3 ? &far : nullptr}) {
      if (!a) continue;
      a->sum += e, a->max = std::max(a->max, e), ++a->cnt;
      a->ang.push_back(ang);
    }
    if (y >= -0.15 && y <= 0.3) over_band = std::max(over_band, double(d[size_t(i)]) - y);
    if (y < 0) {
      ++inside;
      inside_max = std::max(inside_max, double(d[size_t(i)]));
      for (size_t k = 0; k < margins.size(); ++k) unsafe[k] += d[size_t(i)] > margins[k];
    }
  }
  auto acc_json = [](const Acc& a) {
    double mean_ang = 0;
    for (double x : a.ang) mean_ang += x;
    return json{{"points", a.cnt},
                {"mean_abs_err", a.cnt ? a.sum / double(a.cnt) : 0.0},
                {"max_abs_err", a.max},
                {"grad_angle_mean_deg", a.ang.empty() ? 0.0 : mean_ang / double(a.ang.size())},
                {"grad_angle_p95_deg", percentile(a.ang, 0.95)},
                {"grad_angle_max_deg", percentile(a.ang, 1.0)}};
  };
  json um = json::array();
  for (size_t k = 0; k < margins.size(); ++k)
    um.push_back({{"margin", margins[k]},
                  {"fraction_of_points", n ? double(unsafe[k]) / double(n) : 0.0},
                  {"fraction_of_inside", inside ? double(unsafe[k]) / double(inside) : 0.0}});
  return {{"points", n},
          {"near", acc_json(near)},
          {"far", acc_json(far)},
          {"all", acc_json(all)},
          {"inside_points", inside},
          {"max_learned_where_inside", inside ? inside_max : 0.0},
          {"max_overestimate_band", over_band},
          {"farther_than_margin_while_inside", um}};
}

json train_sdf(const SdfTrainConfig& cfg, const std::string& dir, const std::string& command, bool progress) {
  using clock = std::chrono::steady_clock;
  const auto t_start = clock::now();
  auto secs = [&] { return std::chrono::duration<double>(clock::now() - t_start).count(); };
  std::filesystem::create_directories(dir);
  remove_stale_temp_files(dir);
  write_file_atomic(dir + "/config.json", json(cfg).dump(2) + "\n");

  Eigen::Vector3d centre;
  SdfSamples s;
  if (cfg.object == "human") {
    const HumanModel hm = load_human_model();
    centre = human_centre(hm);
    s = make_human_sdf_samples(hm, load_default_human_motion(), cfg.data);
  } else if (cfg.object == "tiago") {
    centre = tiago_body_centre();
    s = make_tiago_sdf_samples(cfg.data);
  } else {
    s = make_static_sdf_samples(sdf_object_geometry(cfg.object, &centre), cfg.data);
  }
  if (s.pose_dim != cfg.arch.pose_dim)
    throw std::invalid_argument("sdf-train: config key 'arch.pose_dim' is " + std::to_string(cfg.arch.pose_dim) +
                                ", object " + cfg.object + " has " + std::to_string(s.pose_dim) + " pose inputs");
  const int P = s.pose_dim, IN = 3 + P;
  auto pose_of = [&](int j) { return &s.poses[size_t(s.pose_id[size_t(j)]) * size_t(P)]; };
  const double t_data = secs();
  // Split 0.8 / 0.1 / 0.1 after a seeded shuffle.
  std::vector<int> perm(size_t(s.n));
  std::iota(perm.begin(), perm.end(), 0);
  Rng rng(cfg.init_seed, 0x5117);
  for (int i = s.n - 1; i > 0; --i) std::swap(perm[size_t(i)], perm[size_t(rng.below(uint64_t(i + 1)))]);
  const int n_tr = int(0.8 * s.n), n_va = int(0.1 * s.n);
  std::vector<int> tr(perm.begin(), perm.begin() + n_tr), va(perm.begin() + n_tr, perm.begin() + n_tr + n_va),
      te(perm.begin() + n_tr + n_va, perm.end());
  if (n_tr < cfg.batch)
    throw std::invalid_argument("sdf-train: " + std::to_string(n_tr) + " training points, fewer than one batch (" +
                                std::to_string(cfg.batch) + ")");

  RedsdfArch arch = cfg.arch;
  arch.centre = centre;
  RedsdfModel m(arch);
  init_redsdf(m, cfg.init_seed);
  AlignedVector<float> grads(m.params.size(), 0.0f), best = m.params;
  Adam<float> adam(m.params.size(), default_adam_config());
  Tape<float> tape;
  const int B = cfg.batch;
  AlignedVector<float> bx(static_cast<size_t>(B) * IN), bn(static_cast<size_t>(B)), by(bn), bw(bn), bhas(bn),
      bnrm(static_cast<size_t>(B) * 3);
  RedsdfLoss<float> loss(m.arch, B);
  const bool align = cfg.align_weight > 0.0;
  RedsdfBatch batch(m);
  std::vector<float> vp(static_cast<size_t>(3 * n_va)), vd(static_cast<size_t>(n_va)), vpose(size_t(n_va) * size_t(P));
  for (int i = 0; i < n_va; ++i) {
    for (int k = 0; k < 3; ++k) vp[size_t(3 * i + k)] = s.p[size_t(3 * va[size_t(i)] + k)];
    for (int k = 0; k < P; ++k) vpose[size_t(i * P + k)] = pose_of(va[size_t(i)])[k];
  }
  auto weight = [&](float y) { return std::abs(y) < 0.1f ? float(cfg.near_weight) : 1.0f; };
  auto val_wmse = [&] {
    batch.evaluate(vp.data(), P ? vpose.data() : nullptr, false, n_va, vd.data(), nullptr);
    double acc = 0, ws = 0;
    for (int i = 0; i < n_va; ++i) {
      const float y = s.y[size_t(va[size_t(i)])];
      const double e = double(vd[size_t(i)]) - y;
      acc += weight(y) * e * e, ws += 1;
    }
    return acc / std::max(ws, 1.0);
  };

  std::string csv = "epoch,train_loss,val_wmse,lr,seconds\n";
  std::vector<std::pair<double, double>> curve_tr, curve_va;
  double best_val = 1e300;
  int best_epoch = 0, epoch = 0;
  std::string stop = "max_epochs";
  const int steps_per_epoch = n_tr / B;
  for (epoch = 1; epoch <= cfg.max_epochs; ++epoch) {
    const double frac = cfg.max_epochs > 1 ? double(epoch - 1) / double(cfg.max_epochs - 1) : 0.0;
    const double lr = cfg.lr + (cfg.lr_final - cfg.lr) * frac;
    for (int i = n_tr - 1; i > 0; --i) std::swap(tr[size_t(i)], tr[size_t(rng.below(uint64_t(i + 1)))]);
    double loss_sum = 0;
    for (int st = 0; st < steps_per_epoch; ++st) {
      for (int r = 0; r < B; ++r) {
        const int j = tr[size_t(st * B + r)];
        const float* pj = &s.p[size_t(3 * j)];
        float nn = 0;
        for (int k = 0; k < 3; ++k) {
          bx[size_t(IN * r + k)] = pj[k];
          const float dk = pj[k] - float(centre(k));
          nn += dk * dk;
        }
        for (int k = 0; k < P; ++k) bx[size_t(IN * r + 3 + k)] = pose_of(j)[k];
        bn[size_t(r)] = std::sqrt(nn);
        by[size_t(r)] = s.y[size_t(j)];
        bw[size_t(r)] = weight(s.y[size_t(j)]);
        if (align) {
          for (int k = 0; k < 3; ++k) bnrm[size_t(3 * r + k)] = s.grad[size_t(3 * j + k)];
          bhas[size_t(r)] = s.shifted[size_t(j)] ? 1.0f : 0.0f;
        }
      }
      tape.clear();
      const auto L = loss.record(tape, m.params.data(), grads.data(),
                                 {B, bx.data(), bn.data(), by.data(), bw.data(), bnrm.data(), bhas.data()},
                                 float(cfg.gamma), float(cfg.align_weight));
      tape.backward(L.loss);
      loss_sum += tape.scalar(L.loss);
      adam.step_fused(m.params.data(), grads.data(), lr);
    }
    const double tl = loss_sum / steps_per_epoch, vl = val_wmse();
    if (!std::isfinite(tl) || !std::isfinite(vl)) {
      stop = "non-finite loss";
      break;
    }
    if (vl < best_val) best_val = vl, best_epoch = epoch, best = m.params;
    char line[256];
    std::snprintf(line, sizeof(line), "%d,%.6g,%.6g,%.3g,%.1f\n", epoch, tl, vl, lr, secs());
    csv += line;
    write_file_atomic(dir + "/progress.csv", csv);
    curve_tr.emplace_back(epoch, std::log10(tl)), curve_va.emplace_back(epoch, std::log10(vl));
    if (progress)
      std::printf("sdf-train %s epoch %d/%d  train %.3e  val %.3e  best %.3e (epoch %d)  lr %.2g  %.0f s\n",
                  cfg.object.c_str(), epoch, cfg.max_epochs, tl, vl, best_val, best_epoch, lr, secs()),
          std::fflush(stdout);
    if (epoch - best_epoch >= cfg.patience) { stop = "early stopping"; break; }
    if (secs() - t_data > cfg.budget_s) { stop = "time budget"; break; }
  }
  const int epochs_run = std::min(epoch, cfg.max_epochs);
  m.params = best;
  // Learning curve.
  double ylo = 1e300, yhi = -1e300;
  for (const auto* c : {&curve_tr, &curve_va})
    for (const auto& [x, y] : *c) ylo = std::min(ylo, y), yhi = std::max(yhi, y);
  if (!curve_tr.empty()) {
    SvgCanvas svg(640, 400, 1, std::max(2.0, double(curve_tr.size())), std::floor(ylo), std::ceil(yhi + 1e-9));
    svg.axes("epoch", "log10 loss");
    svg.polyline(curve_tr, "#1f77b4");
    svg.polyline(curve_va, "#d62728");
    svg.label(60, 20, "ReDSDF " + cfg.object + ": train loss (blue), validation WMSE (red)", 13);
    svg.save(dir + "/learning_curve.svg");
  }
  m.manifest = {{"object", cfg.object},
                {"data_seed", cfg.data.seed},
                {"init_seed", cfg.init_seed},
                {"command", command},
                {"train_config", cfg},
                {"samples", {{"train", n_tr}, {"validation", n_va}, {"test", int(te.size())}}},
                {"epochs", epochs_run},
                {"best_epoch", best_epoch},
                {"stop", stop},
                {"best_val_wmse", best_val},
                {"seconds", {{"data", t_data}, {"total", secs()}}},
                {"frame", cfg.object == "human"
                              ? "body frame: p_body = Rz(yaw)^T (p - (x, y, z)) of the human's root; pose input = the 34 "
                                "joint angles (pose entries 4..37)"
                          : cfg.object == "tiago"
                              ? "base_footprint; pose input = the torso lift, m (trained on [0, 0.35])"
                              : "object frame: the arm scene's object at position 0, yaw 0 (base_footprint axes)"}};
  m.manifest["metrics"] = {{"test", sdf_accuracy(m, s, te)}};
  // The margin a learned row adds to its threshold: the largest over-estimate
  // near the surface on the test split, plus 5 mm, rounded up to a millimetre.
  const double over = std::max(0.0, m.manifest["metrics"]["test"]["max_overestimate_band"].get<double>());
  m.manifest["safety_margin"] = std::ceil((over + 0.005) * 1000.0) / 1000.0;
  save_redsdf(m, dir);
  return m.manifest;
}

}  // namespace atacom
