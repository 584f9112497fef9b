// The ReDSDF loss's gradient-alignment term (train/redsdf_loss.*): its value
// against a direct computation from the double twin's gradient, its weight
// gradient against central finite differences, and align = 0 recording the
// loss graph of before the term, bit for bit.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <vector>
#include <unistd.h>

#include "atacom/rng.hpp"
#include "train/redsdf_loss.hpp"
#include "train/redsdf_train.hpp"

using namespace atacom;

namespace {

struct Fixture {
  RedsdfModel m;
  int B = 16;
  std::vector<double> x, radius, y, w, normal, has;
  Fixture() {
    RedsdfArch a;
    a.pose_dim = 1;
    a.hidden = {8, 6, 5};
    a.trunk_layers = 2;
    a.side_width = 4;
    a.centre = {0.1, -0.2, 0.3};
    m = RedsdfModel(a);
    init_redsdf(m, 7);
    // Nonzero biases, so masks and the blend vary across the batch.
    Rng rng(3, 1);
    for (const auto* v : {&m.layout.trunk, &m.layout.head, &m.layout.side})
      for (const RedsdfLayer& l : *v)
        for (int o = 0; o < l.out; ++o) m.params[l.b + size_t(o)] = float(rng.uniform(-0.4, 0.4));
    const int IN = a.input_dim();
    for (int i = 0; i < B; ++i) {
      Eigen::Vector3d p(rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8), rng.uniform(-0.5, 1.0));
      for (int k = 0; k < 3; ++k) x.push_back(p(k));
      x.push_back(rng.uniform(0.0, 0.35));
      radius.push_back((p - a.centre).norm());
      y.push_back(rng.uniform(-0.1, 0.5));
      w.push_back(i % 2 ? 4.0 : 1.0);
      Eigen::Vector3d n(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
      n *= (i % 4 == 1 ? 2.5 : 1.0) / n.norm();  // one in four not unit: the term normalises
      for (int k = 0; k < 3; ++k) normal.push_back(n(k));
      has.push_back(i % 3 ? 1.0 : 0.0);
    }
    REQUIRE(int(x.size()) == B * IN);
  }
  RedsdfLossBatch<double> batch() const {
    return {B, x.data(), radius.data(), y.data(), w.data(), normal.data(), has.data()};
  }
  std::vector<double> params() const { return std::vector<double>(m.params.begin(), m.params.end()); }
};

// The loss of before the alignment term, as it was recorded in train/redsdf_train.cpp.
Tape<float>::Id old_loss_graph(Tape<float>& tp, RedsdfModel& m, AlignedVector<float>& grads, const float* x,
                               const float* n, const float* y, const float* w, int B, float gamma) {
  using Id = Tape<float>::Id;
  float* P = m.params.data();
  float* G = grads.data();
  auto lin = [&](const RedsdfLayer& l, Id in) {
    const Id W = tp.leaf(P + l.w, G + l.w, l.in, l.out);
    const Id b = tp.leaf(P + l.b, G + l.b, 1, l.out);
    const Id o = tp.linear(in, W, b);
    return l.relu ? tp.relu(o) : o;
  };
  Id h = tp.constant(x, B, m.arch.input_dim());
  for (const auto& l : m.layout.trunk) h = lin(l, h);
  const Id t = h;
  for (const auto& l : m.layout.head) h = lin(l, h);
  const Id f = h;
  const Id bb = lin(m.layout.side[1], lin(m.layout.side[0], t));
  const Id alpha = tp.affine(tp.softplus(tp.slice(bb, 0, 1)), 1.0f, 1.0f);
  const Id rho = tp.affine(tp.sigmoid(tp.slice(bb, 1, 2)), 1.0f, 0.5f);
  const Id nn = tp.constant(n, B, 1);
  const Id sigma = tp.sigmoid(tp.mul(alpha, tp.sub(nn, rho)));
  const Id d = tp.add(f, tp.mul(sigma, tp.sub(nn, f)));
  const Id err = tp.sub(d, tp.constant(y, B, 1));
  const Id wmse = tp.mean(tp.mul(tp.constant(w, B, 1), tp.square(err)));
  return tp.add(wmse, tp.affine(tp.mean(rho), gamma, 0.0f));
}

}  // namespace

TEST_CASE("redsdf alignment term: the mean sin^2 between grad_p d and the normal, as computed directly", "[redsdf]") {
  Fixture fx;
  std::vector<double> P = fx.params(), G(P.size(), 0.0);
  RedsdfLoss<double> loss(fx.m.arch, fx.B);
  Tape<double> tp;
  const double gamma = 0.02, align = 0.7;
  const auto t = loss.record(tp, P.data(), G.data(), fx.batch(), gamma, align);
  double sum = 0;
  int cnt = 0;
  for (int i = 0; i < fx.B; ++i) {
    if (fx.has[size_t(i)] == 0.0) continue;
    Eigen::Vector3d g;
    const double* xi = &fx.x[size_t(4 * i)];
    redsdf_reference(fx.m, Eigen::Vector3d(xi[0], xi[1], xi[2]), xi + 3, &g);
    const Eigen::Vector3d n(&fx.normal[size_t(3 * i)]);
    const double c = n.dot(g) / (n.norm() * g.norm());
    sum += 1.0 - c * c, ++cnt;
  }
  REQUIRE(t.normals == cnt);
  const double direct = sum / cnt;
  CHECK(direct > 0.05);  // random normals: far from aligned
  CHECK(tp.scalar(t.align) == Approx(direct).epsilon(1e-10));
  CHECK(tp.scalar(t.loss) ==
        Approx(tp.scalar(t.wmse) + gamma * tp.scalar(t.rho_mean) + align * direct).epsilon(1e-10));
  // Normals along the twin's gradient give 0; the term only sees directions.
  Fixture al;
  for (int i = 0; i < al.B; ++i) {
    Eigen::Vector3d g;
    const double* xi = &al.x[size_t(4 * i)];
    redsdf_reference(al.m, Eigen::Vector3d(xi[0], xi[1], xi[2]), xi + 3, &g);
    for (int k = 0; k < 3; ++k) al.normal[size_t(3 * i + k)] = (i % 2 ? -3.0 : 0.5) * g(k);
  }
  tp.clear();
  const auto t2 = loss.record(tp, P.data(), G.data(), al.batch(), gamma, align);
  CHECK(std::abs(tp.scalar(t2.align)) < 1e-9);  // the 1e-12 guard under |g|^2 leaves ~1e-11
  // A batch without normals leaves the term out; align = 0 never records it.
  std::vector<double> none(size_t(fx.B), 0.0);
  RedsdfLossBatch<double> nb = fx.batch();
  nb.has_normal = none.data();
  tp.clear();
  CHECK(loss.record(tp, P.data(), G.data(), nb, gamma, align).align == -1);
  tp.clear();
  CHECK(loss.record(tp, P.data(), G.data(), fx.batch(), gamma, 0.0).align == -1);
  // The float instantiation agrees, and re-recording allocates nothing.
  Tape<float> tf;
  RedsdfLoss<float> lf(fx.m.arch, fx.B);
  std::vector<float> xf(fx.x.begin(), fx.x.end()), rf(fx.radius.begin(), fx.radius.end()),
      yf(fx.y.begin(), fx.y.end()), wf(fx.w.begin(), fx.w.end()), nf(fx.normal.begin(), fx.normal.end()),
      hf(fx.has.begin(), fx.has.end());
  AlignedVector<float> gf(fx.m.params.size(), 0.0f);
  const RedsdfLossBatch<float> bf{fx.B, xf.data(), rf.data(), yf.data(), wf.data(), nf.data(), hf.data()};
  const auto tf1 = lf.record(tf, fx.m.params.data(), gf.data(), bf, float(gamma), float(align));
  tf.backward(tf1.loss);
  CHECK(tf.scalar(tf1.align) == Approx(direct).epsilon(1e-4));
  const size_t allocs = tf.allocations();
  tf.clear();
  tf.backward(lf.record(tf, fx.m.params.data(), gf.data(), bf, float(gamma), float(align)).loss);
  CHECK(tf.allocations() == allocs);
  CHECK_THROWS_WITH(lf.record(tf, fx.m.params.data(), gf.data(), {fx.B + 1, xf.data()}, 0.0f, 0.0f),
                    Catch::Contains("scratch holds 1 to 16"));
}

TEST_CASE("redsdf alignment term: weight gradient against central finite differences", "[redsdf]") {
  Fixture fx;
  std::vector<double> P = fx.params();
  RedsdfLoss<double> loss(fx.m.arch, fx.B);
  Tape<double> tp;
  // w = 0 and gamma = 0: the loss is the alignment term alone. Then the full loss.
  for (const bool alone : {true, false}) {
    Fixture f2;
    if (alone) std::fill(f2.w.begin(), f2.w.end(), 0.0);
    const double gamma = alone ? 0.0 : 0.02, align = alone ? 1.0 : 0.3;
    auto value = [&](std::vector<double>& p) {
      std::vector<double> g(p.size(), 0.0);
      tp.clear();
      return tp.scalar(loss.record(tp, p.data(), g.data(), f2.batch(), gamma, align).loss);
    };
    std::vector<double> G(P.size(), 0.0);
    tp.clear();
    tp.backward(loss.record(tp, P.data(), G.data(), f2.batch(), gamma, align).loss);
    const double h = 1e-6;
    double worst = 0, largest = 0;
    for (size_t j = 0; j < P.size(); ++j) {
      const double p0 = P[j];
      P[j] = p0 + h;
      const double up = value(P);
      P[j] = p0 - h;
      const double dn = value(P);
      P[j] = p0;
      const double fd = (up - dn) / (2 * h);
      worst = std::max(worst, std::abs(fd - G[j]) / std::max(1.0, std::abs(fd)));
      largest = std::max(largest, std::abs(G[j]));
    }
    INFO((alone ? "alignment term alone" : "full loss") << ": worst relative error " << worst);
    CHECK(largest > 1e-2);  // the check has something to compare
    CHECK(worst < 1e-6);
  }
}

TEST_CASE("redsdf loss with align 0: the graph of before the alignment term, bitwise (value and gradients)",
          "[redsdf]") {
  Fixture fx;
  std::vector<float> x(fx.x.begin(), fx.x.end()), r(fx.radius.begin(), fx.radius.end()), y(fx.y.begin(), fx.y.end()),
      w(fx.w.begin(), fx.w.end());
  AlignedVector<float> ax(x.begin(), x.end()), ar(r.begin(), r.end()), ay(y.begin(), y.end()), aw(w.begin(), w.end());
  AlignedVector<float> g_old(fx.m.params.size(), 0.0f), g_new(g_old);
  Tape<float> t_old, t_new;
  const auto l_old = old_loss_graph(t_old, fx.m, g_old, ax.data(), ar.data(), ay.data(), aw.data(), fx.B, 0.02f);
  t_old.backward(l_old);
  RedsdfLoss<float> loss(fx.m.arch, fx.B);
  const auto l_new = loss.record(t_new, fx.m.params.data(), g_new.data(),
                                 {fx.B, ax.data(), ar.data(), ay.data(), aw.data()}, 0.02f, 0.0f);
  t_new.backward(l_new.loss);
  CHECK(t_new.size() == t_old.size());
  CHECK(t_new.scalar(l_new.loss) == t_old.scalar(l_old));
  CHECK(g_new == g_old);
}

TEST_CASE("sdf training with --align-weight: recorded in the config, data flags the shifted points", "[redsdf]") {
  SdfTrainConfig c = default_sdf_train_config("table");
  CHECK(c.align_weight == 0.0);
  c.align_weight = 0.5;
  const nlohmann::json j = c;
  CHECK(j.at("align_weight") == 0.5);
  CHECK(j.get<SdfTrainConfig>().align_weight == 0.5);
  nlohmann::json bad = j;
  bad["align_weight"] = -1.0;
  CHECK_THROWS_WITH(bad.get<SdfTrainConfig>(), Catch::Contains("align_weight"));
  nlohmann::json old = j;
  old.erase("align_weight");  // configs written before the term still load, as 0
  CHECK(old.get<SdfTrainConfig>().align_weight == 0.0);
  SdfDataConfig d = default_sdf_data_config();
  d.surface_points = 50;
  const SdfSamples s = make_static_sdf_samples(sdf_object_geometry("table"), d);
  REQUIRE(s.shifted.size() == size_t(s.n));
  const int shifted = 50 * int(d.epsilons.size());
  for (int i = 0; i < s.n; ++i) CHECK(s.shifted[size_t(i)] == (i < shifted ? 1 : 0));
  // A short run with the term: recorded in the manifest, finite, loadable.
  SdfTrainConfig t = default_sdf_train_config("shelf");
  t.arch.hidden = {16, 16, 16};
  t.arch.side_width = 8;
  t.data.surface_points = 100;
  t.batch = 256;
  t.max_epochs = 2;
  t.align_weight = 0.5;
  const auto dir = std::filesystem::temp_directory_path() / ("atacom_sdf_align_" + std::to_string(::getpid()));
  const nlohmann::json man = train_sdf(t, dir.string(), "test", false);
  CHECK(man.at("train_config").at("align_weight") == 0.5);
  CHECK(man.at("stop") == "max_epochs");
  CHECK(load_redsdf(dir.string(), "shelf").manifest.at("train_config").at("align_weight") == 0.5);
  std::filesystem::remove_all(dir);
}
