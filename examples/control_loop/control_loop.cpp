// One robot, the ATACOM projector called once per tick of a 1 kHz loop.
//
// A unicycle (state q = (x, y, heading), controls a = (forward speed,
// turn rate) in [-1, 1]^2, scaled by v_max and w_max) drives in a 4 m x 4 m
// room with a round pillar: 5 constraints c(q) <= 0 (four walls and the
// pillar, each with the robot's radius). A nominal controller steers toward
// goals that lie behind the pillar or beyond the walls, so it keeps pushing
// into the constraints; the projector maps its action onto the tangent space
// of the constraint manifold every tick. The loop sleeps to absolute 1 ms
// deadlines (clock_nanosleep), times each projector call, and prints a
// latency histogram, the deadline misses and a JSON summary. Exit 1 if any
// constraint went above 1 mm.
//
// Usage: control_loop [--seconds S]   (default 5)
#include <time.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <atacom/projector.hpp>

namespace {

constexpr double kDt = 1e-3;                       // 1 kHz
constexpr double kHalfRoom = 2.0, kRadius = 0.2;   // m
constexpr double kPillarX = 0.6, kPillarY = 0.2, kPillarR = 0.4;
constexpr double kVMax = 1.0, kWMax = 3.0;         // m/s, rad/s

struct Robot {
  double x = -1.2, y = -1.0, th = 0.3;
};

// c (5) and J_q (5 x 3) at the robot's state; G (3 x 2).
void constraints(const Robot& r, double* c, double* Jq, double* G) {
  const double lim = kHalfRoom - kRadius;
  const double walls[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (int i = 0; i < 4; ++i) {
    c[i] = walls[i][0] * r.x + walls[i][1] * r.y - lim;
    Jq[i * 3 + 0] = walls[i][0];
    Jq[i * 3 + 1] = walls[i][1];
    Jq[i * 3 + 2] = 0.0;
  }
  const double dx = r.x - kPillarX, dy = r.y - kPillarY, d = std::max(std::hypot(dx, dy), 1e-9);
  c[4] = kPillarR + kRadius - d;
  Jq[12] = -dx / d;
  Jq[13] = -dy / d;
  Jq[14] = 0.0;
  const double g[6] = {kVMax * std::cos(r.th), 0.0, kVMax * std::sin(r.th), 0.0, 0.0, kWMax};
  std::copy(g, g + 6, G);
}

// Drive toward the goal: turn to face it, go forward when roughly facing it.
void nominal(const Robot& r, double gx, double gy, double* alpha) {
  const double heading = std::atan2(gy - r.y, gx - r.x);
  const double err = std::remainder(heading - r.th, 2.0 * M_PI);
  alpha[0] = std::clamp(2.0 * std::cos(err), -1.0, 1.0);
  alpha[1] = std::clamp(2.0 * err, -1.0, 1.0);
}

double since_us(const timespec& a, const timespec& b) {
  return (double(b.tv_sec - a.tv_sec) * 1e9 + double(b.tv_nsec - a.tv_nsec)) * 1e-3;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 5.0;
  for (int i = 1; i + 1 < argc; i += 2)
    if (!std::strcmp(argv[i], "--seconds")) seconds = std::atof(argv[i + 1]);
  if (!(seconds > 0.0 && seconds <= 3600.0)) {
    std::fprintf(stderr, "control_loop: --seconds must be in (0, 3600]\n");
    return 2;
  }
  const long ticks = std::lround(seconds / kDt);

  // Built once: the model (sizes, slack, gains) and a one-robot batch. K_c is
  // the error-correction gain in 1/s; the loop's rate does not change it.
  atacom::ProjectorModel model = atacom::default_projector_model(/*n=*/3, /*m=*/2, /*k=*/5);
  model.has_drift = false;  // f = 0: the robot stays where it is with a = 0
  atacom::ProjectorBatch batch(model, 1);
  atacom::ProjectOptions opt;
  opt.parallel = false;  // one robot: stay on this thread

  const double goals[4][2] = {{1.6, 0.4}, {2.5, -2.5}, {-1.5, 1.5}, {0.6, 1.2}};
  Robot robot;
  const std::array<double, 9> edges = {1, 2, 5, 10, 20, 50, 100, 1000, 1e300};  // us
  std::array<long, 9> hist{};
  std::vector<double> lat;
  lat.reserve(size_t(ticks));
  long missed = 0;
  double worst_c = -INFINITY, late_max_us = 0.0;

  timespec next;
  clock_gettime(CLOCK_MONOTONIC, &next);
  for (long t = 0; t < ticks; ++t) {
    const double* goal = goals[(t / 2000) % 4];  // a new goal every 2 s
    constraints(robot, batch.c.data(), batch.Jq.data(), batch.G.data());
    for (double c : batch.c) worst_c = std::max(worst_c, c);
    nominal(robot, goal[0], goal[1], batch.alpha.data());

    const auto t0 = std::chrono::steady_clock::now();
    atacom::project_batch(model, batch, opt);
    const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    lat.push_back(us);
    ++hist[size_t(std::upper_bound(edges.begin(), edges.end(), us) - edges.begin())];

    // Apply the safe control for one tick (explicit Euler, as a robot's velocity interface would).
    const double v = kVMax * batch.a[0], w = kWMax * batch.a[1];
    robot.x += kDt * v * std::cos(robot.th);
    robot.y += kDt * v * std::sin(robot.th);
    robot.th += kDt * w;

    // Sleep to the next absolute deadline; a tick that starts late is a miss.
    next.tv_nsec += 1000000;
    if (next.tv_nsec >= 1000000000) next.tv_nsec -= 1000000000, ++next.tv_sec;
    timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    if (since_us(next, now) > 0) ++missed;
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    clock_gettime(CLOCK_MONOTONIC, &now);
    late_max_us = std::max(late_max_us, since_us(next, now));
  }

  std::sort(lat.begin(), lat.end());
  auto pct = [&](double q) { return lat[std::min(lat.size() - 1, size_t(q * double(lat.size())))]; };
  std::printf("projector latency per tick (n = 3, m = 2, k = 5), %ld ticks at 1 kHz:\n", ticks);
  double lo = 0;
  for (size_t b = 0; b < edges.size(); ++b) {
    const int bar = hist[b] ? std::max(1, int(60.0 * double(hist[b]) / double(ticks))) : 0;
    if (edges[b] > 1e299) std::printf("  >= %5.0f us   %8ld %s\n", lo, hist[b], std::string(size_t(bar), '#').c_str());
    else std::printf("  %4.0f-%-5.0f us %8ld %s\n", lo, edges[b], hist[b], std::string(size_t(bar), '#').c_str());
    lo = edges[b];
  }
  std::printf("{\"example\": \"control_loop\", \"ticks\": %ld, \"p50_us\": %.3f, \"p99_us\": %.3f, \"max_us\": %.3f, "
              "\"deadline_misses\": %ld, \"max_wakeup_late_us\": %.1f, \"max_constraint\": %.6f}\n",
              ticks, pct(0.5), pct(0.99), lat.back(), missed, late_max_us, worst_c);
  if (worst_c > 1e-3) {
    std::fprintf(stderr, "control_loop: a constraint reached %.6f (> 1 mm)\n", worst_c);
    return 1;
  }
  return 0;
}
