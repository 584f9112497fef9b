#include "src/experiments/demo.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "atacom/rng.hpp"
#include "src/core/svg.hpp"
#include "atacom/system.hpp"
#include "src/core/config_json.hpp"
#include "src/core/limits.hpp"

namespace atacom {

namespace {

// The world. Constraints act on the robot's look-ahead point p + d h(theta),
// whose velocity map from (v, omega) has full rank, so every row can be
// pushed back in every heading; a disc of radius R + d around it covers the robot.
struct World {
  double half_w = 2.5, half_h = 2.0;
  double R = 0.2, d = 0.1, margin = 0.05;
  // The moving disc sweeps [-0.9, 0.9] x [-0.5, 0.5] and always leaves more
  // than a robot's width (0.7 m) to the walls and the pillar, so it can never
  // pin a robot: every collision avoided or not is the controller's doing.
  double pillar_x = -1.8, pillar_y = -1.3, pillar_r = 0.25;
  double disc_r = 0.3, disc_ax = 0.9, disc_ay = 0.5, disc_wx = 0.21, disc_wy = 0.29;
  DiffDriveSystem sys{1.0, M_PI / 3.0};
  double dt = 1.0 / 30.0;
  static constexpr int k = 6;  // 4 walls, pillar, moving disc

  void disc(double t, double* o, double* od) const {
    o[0] = disc_ax * std::cos(disc_wx * t);
    o[1] = disc_ay * std::sin(disc_wy * t);
    od[0] = -disc_ax * disc_wx * std::sin(disc_wx * t);
    od[1] = disc_ay * disc_wy * std::cos(disc_wy * t);
  }
  // Ground truth: does the robot's disc touch a wall, the pillar or the disc?
  bool collides(double x, double y, double t) const {
    if (std::abs(x) + R > half_w || std::abs(y) + R > half_h) return true;
    if (std::hypot(x - pillar_x, y - pillar_y) < R + pillar_r) return true;
    double o[2], od[2];
    disc(t, o, od);
    return std::hypot(x - o[0], y - o[1]) < R + disc_r;
  }
  // Constraint rows and Jacobians for one robot (c: k, Jq: k x 3, Jx: k x 2).
  void constraints(double x, double y, double th, double t, double* c, double* Jq, double* Jx, double* xdot) const {
    const double ch = std::cos(th), sh = std::sin(th);
    const double px = x + d * ch, py = y + d * sh;
    const double J[2][3] = {{1, 0, -d * sh}, {0, 1, d * ch}};
    const double reach = R + d + margin;
    for (int i = 0; i < k * 3; ++i) Jq[i] = 0.0;
    for (int i = 0; i < k * 2; ++i) Jx[i] = 0.0;
    const double sgn[4] = {1, -1, 1, -1};
    const double pos[4] = {px, px, py, py};
    const double lim[4] = {half_w, half_w, half_h, half_h};
    for (int r = 0; r < 4; ++r) {
      c[r] = sgn[r] * pos[r] + reach - lim[r];
      for (int col = 0; col < 3; ++col) Jq[r * 3 + col] = sgn[r] * J[r / 2][col];
    }
    auto disc_row = [&](int r, double ox, double oy, double radius, bool moving) {
      const double dx = px - ox, dy = py - oy, dist = std::max(std::hypot(dx, dy), 1e-9);
      const double ux = dx / dist, uy = dy / dist;
      c[r] = radius + reach - dist;
      for (int col = 0; col < 3; ++col) Jq[r * 3 + col] = -(ux * J[0][col] + uy * J[1][col]);
      if (moving) {
        Jx[r * 2 + 0] = ux;
        Jx[r * 2 + 1] = uy;
      }
    };
    disc_row(4, pillar_x, pillar_y, pillar_r, false);
    double o[2];
    disc(t, o, xdot);
    disc_row(5, o[0], o[1], disc_r, true);
  }
};

struct Robots {
  std::vector<double> x, y, th, t0;  // (N) pose and the env's clock offset
  std::vector<double> alpha;          // (N x 2) held random action
  std::vector<int> hold;              // (N) steps left to hold alpha
  std::vector<Rng> rng;               // (N) per-robot streams
};

void spawn(const World& w, Robots& r, int i, double t) {
  double c[World::k], Jq[World::k * 3], Jx[World::k * 2], xd[2];
  for (int tries = 0; tries < 10000; ++tries) {
    r.x[i] = r.rng[i].uniform(-w.half_w, w.half_w);
    r.y[i] = r.rng[i].uniform(-w.half_h, w.half_h);
    r.th[i] = r.rng[i].uniform(-M_PI, M_PI);
    w.constraints(r.x[i], r.y[i], r.th[i], t, c, Jq, Jx, xd);
    double mx = c[0];
    for (int j = 1; j < World::k; ++j) mx = std::max(mx, c[j]);
    if (mx < -0.05) return;
  }
}

nlohmann::json run_mode(const World& w, const DemoConfig& cfg, bool atacom,
                        std::vector<std::vector<std::pair<double, double>>>& paths) {
  const int N = cfg.envs;
  ProjectorModel model = default_projector_model(3, 2, World::k, 2);
  model.beta.assign(World::k, 5.0);
  model.K_c = 1.0 / w.dt;
  model.has_drift = false;
  ProjectorBatch pb(model, N);
  Robots r;
  r.x.resize(N); r.y.resize(N); r.th.resize(N); r.t0.resize(N);
  r.alpha.assign(size_t(N) * 2, 0.0);
  r.hold.assign(N, 0);
  for (int i = 0; i < N; ++i) {
    r.rng.emplace_back(cfg.seed, i);
    r.t0[i] = r.rng[i].uniform(0.0, 100.0);
    spawn(w, r, i, r.t0[i]);
  }
  paths.assign(std::min(cfg.trajectories, N), {});
  std::vector<int> collisions(N, 0);
  std::vector<double> maxc(N, -1e300);
  const auto t_start = std::chrono::steady_clock::now();
  for (int step = 0; step < cfg.steps; ++step) {
    parallel_blocks(N, kEnvBlock, [&](int64_t lo, int64_t hi) {
      for (int64_t i = lo; i < hi; ++i) {
        if (r.hold[i] == 0) {
          r.alpha[2 * i] = r.rng[i].uniform(-1.0, 1.0);
          r.alpha[2 * i + 1] = r.rng[i].uniform(-1.0, 1.0);
          r.hold[i] = 1 + static_cast<int>(r.rng[i].below(20));
        }
        --r.hold[i];
        pb.alpha[2 * i] = r.alpha[2 * i];
        pb.alpha[2 * i + 1] = r.alpha[2 * i + 1];
        const double t = r.t0[i] + step * w.dt;
        const double q[3] = {r.x[i], r.y[i], r.th[i]};
        w.sys.eval(q, pb.f.data() + 3 * i, pb.G.data() + 6 * i);
        w.constraints(r.x[i], r.y[i], r.th[i], t, pb.c.data() + World::k * i, pb.Jq.data() + World::k * 3 * i,
                      pb.Jx.data() + World::k * 2 * i, pb.xdot.data() + 2 * i);
      }
      if (atacom) project_range(model, pb, static_cast<int>(lo), static_cast<int>(hi));
      for (int64_t i = lo; i < hi; ++i) {
        const double* a = atacom ? pb.a.data() + 2 * i : pb.alpha.data() + 2 * i;
        // Actuators saturate: the command is clipped to [-1, 1] in both modes.
        const double v = w.sys.v_max * std::clamp(a[0], -1.0, 1.0);
        const double om = w.sys.w_max * std::clamp(a[1], -1.0, 1.0);
        // Exact unicycle step for constant (v, omega) over dt.
        if (std::abs(om) > 1e-9) {
          const double th1 = r.th[i] + om * w.dt;
          r.x[i] += v / om * (std::sin(th1) - std::sin(r.th[i]));
          r.y[i] -= v / om * (std::cos(th1) - std::cos(r.th[i]));
          r.th[i] = std::remainder(th1, 2 * M_PI);
        } else {
          r.x[i] += v * w.dt * std::cos(r.th[i]);
          r.y[i] += v * w.dt * std::sin(r.th[i]);
        }
        const double t = r.t0[i] + (step + 1) * w.dt;
        double c[World::k], Jq[World::k * 3], Jx[World::k * 2], xd[2];
        w.constraints(r.x[i], r.y[i], r.th[i], t, c, Jq, Jx, xd);
        for (int j = 0; j < World::k; ++j) maxc[i] = std::max(maxc[i], c[j]);
        if (w.collides(r.x[i], r.y[i], t)) {
          ++collisions[i];
          spawn(w, r, static_cast<int>(i), t);  // the robot is carried back to a free spot
          if (i < static_cast<int64_t>(paths.size())) paths[i].emplace_back(NAN, NAN);  // break the drawn path
        }
      }
    });
    for (size_t p = 0; p < paths.size(); ++p) paths[p].emplace_back(r.x[p], r.y[p]);
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  long total = 0;
  int robots_hit = 0;
  double mc = -1e300;
  for (int i = 0; i < N; ++i) {
    total += collisions[i];
    robots_hit += collisions[i] > 0;
    mc = std::max(mc, maxc[i]);
  }
  return {{"steps", static_cast<long>(N) * cfg.steps},
          {"collisions", total},
          {"robots_with_collisions", robots_hit},
          {"max_constraint", mc},
          {"wall_s", secs},
          {"per_s", static_cast<double>(N) * cfg.steps / secs}};
}

void draw_world(const World& w, SvgCanvas& svg, double x_off) {
  svg.rect(x_off - w.half_w, -w.half_h, x_off + w.half_w, w.half_h, "#fafafa", "#333");
  svg.circle(x_off + w.pillar_x, w.pillar_y, w.pillar_r, "#888");
  // The region the moving disc sweeps, and the disc itself at t = 0.
  svg.rect(x_off - w.disc_ax - w.disc_r, -w.disc_ay - w.disc_r, x_off + w.disc_ax + w.disc_r, w.disc_ay + w.disc_r,
           "#fde0e0", "#e8a0a0");
  double o[2], od[2];
  w.disc(0.0, o, od);
  svg.circle(x_off + o[0], o[1], w.disc_r, "#d9534f", "none", 0.6);
  svg.text(x_off, w.disc_ay + w.disc_r + 0.08, "moving disc sweeps this area", 10, "middle", "#a33");
}

}  // namespace

DemoConfig default_demo_config() { return DemoConfig{}; }

void to_json(nlohmann::json& j, const DemoConfig& c) {
  j = {{"envs", c.envs}, {"steps", c.steps}, {"seed", c.seed}, {"trajectories", c.trajectories}};
}

void from_json(const nlohmann::json& j, DemoConfig& c) {
  DemoConfig d;
  ConfigReader r(j, "demo");
  r.get("envs", d.envs, range::closed(1, limits::kMaxEnvs));
  r.get("steps", d.steps, range::closed(1, limits::kMaxHorizon));
  r.get("seed", d.seed);
  r.get("trajectories", d.trajectories, range::closed(0, limits::kMaxEnvs));
  r.finish();
  c = d;
}

DemoResult run_demo(const DemoConfig& cfg) {
  if (cfg.envs < 1) throw std::invalid_argument("demo: --envs must be >= 1");
  if (cfg.steps < 1) throw std::invalid_argument("demo: --steps must be >= 1");
  if (cfg.trajectories < 0) throw std::invalid_argument("demo: --trajectories must be >= 0");
  const World w;
  std::vector<std::vector<std::pair<double, double>>> with, without;
  DemoResult res;
  res.summary["config"] = cfg;
  res.summary["atacom"] = run_mode(w, cfg, true, with);
  res.summary["no_atacom"] = run_mode(w, cfg, false, without);

  // Two rooms side by side: with ATACOM (left), without (right).
  const double gap = 1.0, W = 2 * w.half_w;
  SvgCanvas svg(1000, 460, -w.half_w, w.half_w + gap + W, -w.half_h - 0.4, w.half_h + 0.3, 20);
  static const char* colors[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf", "#bcbd22"};
  for (int side = 0; side < 2; ++side) {
    const double off = side ? W + gap : 0.0;
    draw_world(w, svg, off);
    const auto& paths = side ? without : with;
    for (size_t p = 0; p < paths.size(); ++p) {
      std::vector<std::pair<double, double>> pts;
      for (const auto& [x, y] : paths[p]) {
        if (std::isnan(x)) {  // a collision: mark it and start a new piece
          if (!pts.empty()) svg.circle(pts.back().first, pts.back().second, 0.06, "#d62728");
          svg.polyline(pts, colors[p % 8], 1.0, 0.8);
          pts.clear();
          continue;
        }
        pts.emplace_back(x + off, y);
      }
      svg.polyline(pts, colors[p % 8], 1.0, 0.8);
    }
    const auto& s = res.summary[side ? "no_atacom" : "atacom"];
    svg.text(off, -w.half_h - 0.3,
             std::string(side ? "without ATACOM" : "with ATACOM") + ": " + std::to_string(s["collisions"].get<long>()) +
                 " collisions in " + std::to_string(s["steps"].get<long>()) + " steps",
             14, "middle");
  }
  res.svg = svg.str();
  return res;
}

}  // namespace atacom
