#include "src/core/redsdf_model.hpp"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string_view>

#include "atacom/rng.hpp"
#include "src/core/binary_container.hpp"
#include "src/core/config_json.hpp"
#include "src/core/fs_util.hpp"

namespace atacom {

namespace {
constexpr char kRedsdfMagic[8] = {'A', 'T', 'R', 'D', 'S', 'D', 'F', '1'};
constexpr int kMaxWidth = 4096, kMaxLayers = 16, kMaxPose = 512;

void add_layer(std::vector<RedsdfLayer>& v, size_t& n, int in, int out, bool relu) {
  RedsdfLayer l{in, out, n, n + size_t(in) * out, relu};
  n += size_t(in) * out + out;
  v.push_back(l);
}
}  // namespace

void RedsdfArch::validate() const {
  if (pose_dim < 0 || pose_dim > kMaxPose)
    throw std::invalid_argument("redsdf.pose_dim is " + std::to_string(pose_dim) + ", must be in [0, 512]");
  if (hidden.size() < 2 || int(hidden.size()) > kMaxLayers)
    throw std::invalid_argument("redsdf.hidden has " + std::to_string(hidden.size()) + " layers, must have 2 to 16");
  for (int w : hidden)
    if (w < 1 || w > kMaxWidth)
      throw std::invalid_argument("redsdf.hidden width " + std::to_string(w) + " must be in [1, 4096]");
  if (trunk_layers < 1 || trunk_layers >= int(hidden.size()))
    throw std::invalid_argument("redsdf.trunk_layers is " + std::to_string(trunk_layers) +
                                ", must be in [1, len(hidden) - 1] = [1, " + std::to_string(hidden.size() - 1) + "]");
  if (side_width < 1 || side_width > kMaxWidth)
    throw std::invalid_argument("redsdf.side_width is " + std::to_string(side_width) + ", must be in [1, 4096]");
  if (!centre.allFinite()) throw std::invalid_argument("redsdf.centre must be finite");
}

void to_json(nlohmann::json& j, const RedsdfArch& a) {
  j = {{"pose_dim", a.pose_dim},
       {"hidden", a.hidden},
       {"trunk_layers", a.trunk_layers},
       {"side_width", a.side_width},
       {"centre", {a.centre.x(), a.centre.y(), a.centre.z()}}};
}

void from_json(const nlohmann::json& j, RedsdfArch& a) {
  ConfigReader r(j, "redsdf");
  r.get("pose_dim", a.pose_dim);
  r.get("hidden", a.hidden);
  r.get("trunk_layers", a.trunk_layers);
  r.get("side_width", a.side_width);
  std::vector<double> c{a.centre.x(), a.centre.y(), a.centre.z()};
  r.get("centre", c);
  if (c.size() != 3) throw std::invalid_argument("redsdf.centre must have 3 numbers");
  a.centre = {c[0], c[1], c[2]};
  r.finish();
  a.validate();
}

RedsdfLayout::RedsdfLayout(const RedsdfArch& a) {
  a.validate();
  size_t n = 0;
  int in = a.input_dim();
  for (int i = 0; i < a.trunk_layers; ++i) {
    add_layer(trunk, n, in, a.hidden[size_t(i)], true);
    in = a.hidden[size_t(i)];
  }
  const int t = in;
  for (size_t i = size_t(a.trunk_layers); i < a.hidden.size(); ++i) {
    add_layer(head, n, in, a.hidden[i], true);
    in = a.hidden[i];
  }
  add_layer(head, n, in, 1, false);
  add_layer(side, n, t, a.side_width, true);
  add_layer(side, n, a.side_width, 2, false);
  num_params = n;
}

double RedsdfLayout::forward_macs() const {
  double m = 0;
  for (const auto* v : {&trunk, &head, &side})
    for (const RedsdfLayer& l : *v) m += double(l.in) * l.out;
  return m;
}

RedsdfModel::RedsdfModel(const RedsdfArch& a) : arch(a), layout(a), params(layout.num_params, 0.0f) {}

void init_redsdf(RedsdfModel& m, uint64_t seed) {
  Rng rng(seed, 0x5df);
  for (const auto* v : {&m.layout.trunk, &m.layout.head, &m.layout.side})
    for (const RedsdfLayer& l : *v) {
      const double gain = l.relu ? std::sqrt(2.0) : 1.0;
      const double bound = gain * std::sqrt(6.0 / double(l.in + l.out));
      for (size_t i = 0; i < size_t(l.in) * l.out; ++i) m.params[l.w + i] = float(rng.uniform(-bound, bound));
      for (int i = 0; i < l.out; ++i) m.params[l.b + size_t(i)] = 0.0f;
    }
}

void save_redsdf(const RedsdfModel& m, const std::string& dir) {
  if (m.params.size() != m.layout.num_params) throw std::runtime_error("save_redsdf: parameter count mismatch");
  nlohmann::json man = m.manifest;
  man["arch"] = m.arch;
  man["num_params"] = m.layout.num_params;
  man["format"] = "atacom redsdf v1";
  ContainerWriter c(std::string_view(kRedsdfMagic, sizeof kRedsdfMagic), std::nullopt);
  c.section(man.dump());
  c.section(std::string_view(reinterpret_cast<const char*>(m.params.data()), m.params.size() * sizeof(float)),
            sizeof(float));
  const std::string body = c.finish();
  uint64_t sum = 0;
  std::memcpy(&sum, body.data() + body.size() - sizeof(sum), sizeof(sum));
  std::filesystem::create_directories(dir);
  write_file_atomic(dir + "/redsdf.bin", body);
  man["checksum_fnv1a"] = [&] {
    char buf[20];
    std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(sum));
    return std::string(buf);
  }();
  write_file_atomic(dir + "/manifest.json", man.dump(2) + "\n");
}

RedsdfModel load_redsdf(const std::string& dir_or_file, const std::string& expected_object) {
  const std::string path = std::filesystem::is_directory(dir_or_file) ? dir_or_file + "/redsdf.bin" : dir_or_file;
  auto fail = [&](const std::string& why) -> RedsdfModel {
    throw std::runtime_error("learned SDF file " + path + ": " + why);
  };
  std::ifstream f(path, std::ios::binary);
  if (!f) return fail("cannot be opened (missing? train one with `atacom sdf-train`)");
  ContainerReader c(f, "learned SDF file " + path + ": ", false);
  if (c.magic() != std::string_view(kRedsdfMagic, sizeof kRedsdfMagic)) return fail("not a ReDSDF weight file (bad magic)");
  c.read({{"manifest"}, {"parameters", sizeof(float)}});
  c.expect_end();
  RedsdfModel m;
  try {
    m.manifest = parse_json_strict(c.section(0), "manifest");
    m.arch = m.manifest.at("arch").get<RedsdfArch>();
    m.layout = RedsdfLayout(m.arch);
  } catch (const std::exception& e) {
    return fail(std::string("inconsistent manifest: ") + e.what());
  }
  const std::string& p = c.section(1);
  if (p.size() != m.layout.num_params * sizeof(float))
    return fail("holds " + std::to_string(p.size() / sizeof(float)) + " parameters, its architecture has " +
                std::to_string(m.layout.num_params));
  m.params.resize(m.layout.num_params);
  std::memcpy(m.params.data(), p.data(), p.size());
  for (float v : m.params)
    if (!std::isfinite(v)) return fail("non-finite parameter");
  if (!expected_object.empty() && m.object() != expected_object)
    return fail("holds object '" + m.object() + "', expected '" + expected_object + "'");
  return m;
}

double redsdf_reference(const RedsdfModel& m, const Eigen::Vector3d& p, const double* pose, Eigen::Vector3d* grad) {
  using V = std::vector<double>;
  const float* P = m.params.data();
  auto fwd = [&](const RedsdfLayer& l, const V& x) {
    V y(size_t(l.out));
    for (int o = 0; o < l.out; ++o) {
      double s = P[l.b + size_t(o)];
      for (int i = 0; i < l.in; ++i) s += x[size_t(i)] * double(P[l.w + size_t(i) * l.out + o]);
      y[size_t(o)] = l.relu ? std::max(s, 0.0) : s;
    }
    return y;
  };
  // Backward of one layer for input gradients: gx = W (gy * relu'(y)).
  auto bwd = [&](const RedsdfLayer& l, const V& y, V gy) {
    V gx(size_t(l.in), 0.0);
    for (int o = 0; o < l.out; ++o) {
      if (l.relu && y[size_t(o)] <= 0.0) gy[size_t(o)] = 0.0;
      for (int i = 0; i < l.in; ++i) gx[size_t(i)] += double(P[l.w + size_t(i) * l.out + o]) * gy[size_t(o)];
    }
    return gx;
  };
  V x{p.x(), p.y(), p.z()};
  for (int i = 0; i < m.arch.pose_dim; ++i) x.push_back(pose[i]);
  std::vector<V> acts{x};
  for (const auto& l : m.layout.trunk) acts.push_back(fwd(l, acts.back()));
  const size_t t_idx = acts.size() - 1;
  for (const auto& l : m.layout.head) acts.push_back(fwd(l, acts.back()));
  const V s1 = fwd(m.layout.side[0], acts[t_idx]);
  const V bb = fwd(m.layout.side[1], s1);
  const double f = acts.back()[0];
  const Eigen::Vector3d dp = p - m.arch.centre;
  const double n = dp.norm();
  const double sg0 = 1.0 / (1.0 + std::exp(-bb[0])), sg1 = 1.0 / (1.0 + std::exp(-bb[1]));
  const double alpha = std::max(bb[0], 0.0) + std::log1p(std::exp(-std::abs(bb[0]))) + 1.0;
  const double rho = sg1 + 0.5;
  const double sigma = 1.0 / (1.0 + std::exp(-alpha * (n - rho)));
  const double d = (1.0 - sigma) * f + sigma * n;
  if (!grad) return d;
  const double ds = sigma * (1.0 - sigma) * (n - f);  // dd/dsigma * dsigma/dz
  // Head: seed (1 - sigma) on f, back to the trunk features.
  V g{1.0 - sigma};
  for (size_t k = m.layout.head.size(); k-- > 0;) g = bwd(m.layout.head[k], acts[t_idx + 1 + k], g);
  V gs = bwd(m.layout.side[1], bb, V{ds * (n - rho) * sg0, -ds * alpha * sg1 * (1.0 - sg1)});
  gs = bwd(m.layout.side[0], s1, gs);
  for (size_t i = 0; i < g.size(); ++i) g[i] += gs[i];
  for (size_t k = m.layout.trunk.size(); k-- > 0;) g = bwd(m.layout.trunk[k], acts[k + 1], g);
  const double cn = sigma + ds * alpha;  // explicit dependence on n
  const Eigen::Vector3d gn = n > 0 ? Eigen::Vector3d(dp / n) : Eigen::Vector3d::Zero();
  *grad = Eigen::Vector3d(g[0], g[1], g[2]) + cn * gn;
  return d;
}

}  // namespace atacom
