// The motion generator (docs/human.md): a random program of activities
// (walk, reach, phone, turn, pause) drawn from one seeded stream, rendered
// frame by frame at config.fps. Every change of root or posture follows a
// minimum-jerk profile S(u) = 10u^3 - 15u^4 + 6u^5 (zero speed and
// acceleration at both ends), the gait's amplitude follows the walking
// speed, and a small idle sway runs underneath everything, so the frames
// sample a C2 trajectory across every segment boundary.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <functional>
#include <stdexcept>

#include "envs/arm/human_motion.hpp"

namespace atacom {

namespace {


double smooth(double u) {  // minimum-jerk step, S(0) = 0, S(1) = 1
  u = std::clamp(u, 0.0, 1.0);
  return u * u * u * (10.0 + u * (-15.0 + 6.0 * u));
}
double smooth_integral(double u) {  // integral of S from 0 to u
  u = std::clamp(u, 0.0, 1.0);
  const double u4 = u * u * u * u;
  return u4 * (2.5 + u * (-3.0 + u));
}
double wrap_to_pi(double a) {  // into (-pi, pi]
  a = std::fmod(a + std::numbers::pi, 2.0 * std::numbers::pi);
  if (a < 0) a += 2.0 * std::numbers::pi;
  return a - std::numbers::pi;
}

using Posture = std::array<double, kHumanDofs>;

// What one frame is made of before gait and idle sway are added.
struct FrameState {
  double x = 0, y = 0, yaw = 0;
  Posture posture{};
  double gait = 0;        // gait amplitude (0 standing, ~1 at 1.2 m/s)
  double phase_rate = 0;  // gait phase speed, rad/s
};

class Generator {
 public:
  Generator(const HumanModel& m, const HumanMotionConfig& c) : m_(m), c_(c), rng_(c.seed, 0) {
    dt_ = 1.0 / c_.fps;
    const double top_x0 = c_.table_center.x() - c_.table_half.x(), top_x1 = c_.table_center.x() + c_.table_half.x();
    const double top_y0 = c_.table_center.y() - c_.table_half.y(), top_y1 = c_.table_center.y() + c_.table_half.y();
    table_lo_ = {top_x0, top_y0};
    table_hi_ = {top_x1, top_y1};
    table_top_ = c_.table_center.z() + c_.table_half.z();
    // Walking path: a U around the table, open towards the robot.
    corners_ = {Eigen::Vector2d(c_.x_min, top_y1 + c_.clearance), Eigen::Vector2d(top_x1 + c_.clearance, top_y1 + c_.clearance),
                Eigen::Vector2d(top_x1 + c_.clearance, top_y0 - c_.clearance), Eigen::Vector2d(c_.x_min, top_y0 - c_.clearance)};
    if (!(c_.x_min < top_x1)) throw std::invalid_argument("human_motion.x_min must lie before the table's far edge");
    path_len_ = 0;
    for (int i = 0; i < 3; ++i) {
      leg_start_[i] = path_len_;
      path_len_ += (corners_[i + 1] - corners_[i]).norm();
    }
    auto idx = [&](const char* n) { return m_.pose_index(n) - kHumanRootDofs; };
    for (const char* side : {"l", "r"}) {
      const int s = side[0] == 'l' ? 0 : 1;
      const std::string p(side);
      hip_[s] = idx(("hip_" + p + "_flexion").c_str());
      knee_[s] = idx(("knee_" + p + "_flexion").c_str());
      sh_flex_[s] = idx(("shoulder_" + p + "_flexion").c_str());
      sh_abd_[s] = idx(("shoulder_" + p + "_abduction").c_str());
      sh_rot_[s] = idx(("shoulder_" + p + "_rotation").c_str());
      elbow_[s] = idx(("elbow_" + p + "_flexion").c_str());
      wrist_[s] = idx(("wrist_" + p + "_flexion").c_str());
      tip_[s] = m_.joint_index("fingertip_" + p);
      clearance_caps_.push_back(m_.capsule_index("forearm_" + p));
      clearance_caps_.push_back(m_.capsule_index("hand_" + p));
    }
    pelvis_twist_ = idx("pelvis_twist");
    pelvis_lateral_ = idx("pelvis_lateral");
    lumbar_flex_ = idx("lumbar_flexion");
    lumbar_twist_ = idx("lumbar_twist");
    thoracic_flex_ = idx("thoracic_flexion");
    thoracic_twist_ = idx("thoracic_twist");
    neck_flex_ = idx("neck_flexion");
    neck_twist_ = idx("neck_twist");
    head_flex_ = idx("head_flexion");
    // Standing posture: elbows and knees slightly bent (inside their limits
    // under the idle sway), arms a little away from the trunk.
    neutral_.fill(0.0);
    for (int s = 0; s < 2; ++s) {
      neutral_[elbow_[s]] = 0.2;
      neutral_[knee_[s]] = 0.05;
      neutral_[sh_abd_[s]] = 0.06;
    }
    // Idle sway: three slow sinusoids per angle (amplitudes in rad).
    for (int d = 0; d < kHumanDofs; ++d) {
      const std::string& n = m_.dofs[static_cast<size_t>(d)].name;
      double amp = 0.01;
      if (n.rfind("neck", 0) == 0 || n.rfind("head", 0) == 0) amp = 0.03;
      else if (n.rfind("shoulder", 0) == 0 || n.rfind("elbow", 0) == 0 || n.rfind("wrist", 0) == 0) amp = 0.025;
      else if (n.rfind("knee", 0) == 0) amp = 0.008;
      for (auto& w : idle_[static_cast<size_t>(d)]) {
        w[0] = amp / 3.0 * rng_.uniform(0.5, 1.0);
        w[1] = 2.0 * std::numbers::pi * rng_.uniform(0.05, 0.35);
        w[2] = 2.0 * std::numbers::pi * rng_.uniform();
      }
    }
  }

  HumanMotionLibrary run() {
    HumanMotionLibrary lib;
    lib.config = c_;
    // Start on the far side, facing the table, standing.
    u_ = leg_start_[1] + rng_.uniform(0.2, 0.8) * (leg_start_[2] - leg_start_[1]);
    s_.posture = neutral_;
    const Eigen::Vector2d p0 = path_point(u_);
    s_.x = p0.x();
    s_.y = p0.y();
    s_.yaw = facing_table_yaw();
    emit();
    while (static_cast<int>(frames_.size() / kHumanPoseDim) < c_.frames) {
      const int begin = segments_.empty() ? 0 : segments_.back().end;
      const double r = rng_.uniform();
      HumanActivity a;
      if (r < 0.34) a = HumanActivity::Walk;
      else if (r < 0.58) a = HumanActivity::Reach;
      else if (r < 0.75) a = HumanActivity::Phone;
      else if (r < 0.85) a = HumanActivity::Turn;
      else a = HumanActivity::Pause;
      switch (a) {
        case HumanActivity::Walk: walk(); break;
        case HumanActivity::Reach: reach(); break;
        case HumanActivity::Phone: phone(); break;
        case HumanActivity::Turn: turn_to(s_.yaw + (rng_.uniform() < 0.5 ? -1 : 1) * rng_.uniform(0.5, std::numbers::pi)); break;
        case HumanActivity::Pause: hold(rng_.uniform(1.0, 3.0)); break;
      }
      const int end = static_cast<int>(frames_.size() / kHumanPoseDim);
      if (end > begin) segments_.push_back({a, begin, end});
    }
    lib.num_frames = static_cast<int>(frames_.size() / kHumanPoseDim);
    lib.frames = std::move(frames_);
    lib.segments = segments_;
    const int S = static_cast<int>(lib.segments.size());
    const int n_test = std::clamp(static_cast<int>(std::ceil(c_.test_fraction * S)), 1, S - 1);
    lib.test_begin = lib.segments[static_cast<size_t>(S - n_test)].begin;
    return lib;
  }

 private:
  // ------------------------------------------------------------ frames
  void emit() {
    const double t = frame_count() * dt_;
    // Gait: hips and arms swing in antiphase, knees flex early in swing,
    // pelvis and chest counter-rotate, the root bobs twice per cycle.
    const double g = s_.gait, ph = phase_;
    const double sn = std::sin(ph);
    Posture a = s_.posture;
    for (int s = 0; s < 2; ++s) {
      const double side = s == 0 ? 1.0 : -1.0;  // the right leg is half a cycle later
      const double bump = 0.5 * (1.0 + std::cos(ph + (s == 0 ? 0.0 : std::numbers::pi) + std::numbers::pi / 4));
      a[hip_[s]] += g * (0.05 + 0.40 * side * sn);
      a[knee_[s]] += g * (0.03 + 0.85 * bump * bump);
      a[sh_flex_[s]] += g * (-0.25 * side * sn);
      a[elbow_[s]] += g * (0.10 + 0.08 * side * sn);
    }
    a[pelvis_twist_] += g * (-0.08 * sn);
    a[thoracic_twist_] += g * (0.12 * sn);
    a[pelvis_lateral_] += g * (0.04 * std::sin(2.0 * ph));
    a[lumbar_flex_] += g * 0.05;
    for (int d = 0; d < kHumanDofs; ++d)
      for (const auto& w : idle_[static_cast<size_t>(d)]) a[static_cast<size_t>(d)] += w[0] * std::sin(w[1] * t + w[2]);
    const double z = -0.025 * g * 0.5 * (1.0 - std::cos(2.0 * ph));
    frames_.push_back(static_cast<float>(s_.x));
    frames_.push_back(static_cast<float>(s_.y));
    frames_.push_back(static_cast<float>(z));
    frames_.push_back(static_cast<float>(s_.yaw));
    for (double v : a) frames_.push_back(static_cast<float>(v));
  }
  int frame_count() const { return static_cast<int>(frames_.size() / kHumanPoseDim); }

  // Render a phase of duration T: state(t) for t in (0, T], one frame per dt.
  void play(double T, const std::function<void(double, FrameState&)>& state) {
    const int n = std::max(1, static_cast<int>(std::ceil(T / dt_ - 1e-9)));
    double rate0 = s_.phase_rate;
    for (int k = 1; k <= n; ++k) {
      state(std::min(k * dt_, T), s_);
      phase_ += 0.5 * (rate0 + s_.phase_rate) * dt_;  // trapezoid: the phase is as smooth as its rate
      rate0 = s_.phase_rate;
      emit();
    }
  }

  // ------------------------------------------------------------ primitives
  void turn_to(double target) {
    const double delta = wrap_to_pi(target - s_.yaw);
    if (std::abs(delta) < 0.02) return;
    const double w = rng_.uniform(c_.turn_rate_min, c_.turn_rate_max);
    // Peak yaw rate 1.875 |delta| / T <= w, peak yaw acceleration
    // 5.77 |delta| / T^2 <= kYawAccel.
    constexpr double kYawAccel = 6.0;
    const double T = std::max({0.6, 1.875 * std::abs(delta) / w, std::sqrt(5.7735 * std::abs(delta) / kYawAccel)});
    const double y0 = s_.yaw;
    play(T, [&](double t, FrameState& s) {
      const double u = t / T;
      s.yaw = y0 + delta * smooth(u);
      const double rate = std::abs(delta) * 30.0 * u * u * (1 - u) * (1 - u) / T;  // |yaw rate|
      s.gait = 0.3 * rate / c_.turn_rate_max;  // small steps on the spot
      s.phase_rate = 4.0 * rate;               // one gait cycle per quarter turn
    });
  }

  void walk_leg(const Eigen::Vector2d& to) {
    const Eigen::Vector2d from(s_.x, s_.y);
    const double L = (to - from).norm();
    if (L < 1e-6) return;
    const Eigen::Vector2d dir = (to - from) / L;
    double v = rng_.uniform(c_.walk_speed_min, c_.walk_speed_max);
    // Speed ramps S(t / Ta) reach v with peak acceleration 1.875 v / Ta.
    double Ta = 1.875 * v / c_.walk_accel;
    if (v * Ta > L) {  // too short to reach cruise speed: lower it
      v = std::sqrt(L * c_.walk_accel / 1.875);
      Ta = 1.875 * v / c_.walk_accel;
    }
    const double Tc = (L - v * Ta) / v;
    const double T = 2 * Ta + Tc;
    play(T, [&](double t, FrameState& s) {
      double d, sp;
      if (t < Ta) {
        d = v * Ta * smooth_integral(t / Ta);
        sp = v * smooth(t / Ta);
      } else if (t < Ta + Tc) {
        d = 0.5 * v * Ta + v * (t - Ta);
        sp = v;
      } else {
        const double r = (T - t) / Ta;
        d = L - v * Ta * smooth_integral(r);
        sp = v * smooth(r);
      }
      s.x = from.x() + dir.x() * d;
      s.y = from.y() + dir.y() * d;
      s.gait = sp / 1.2;
      s.phase_rate = 2.0 * std::numbers::pi * sp / (0.8 + 0.4 * sp);  // stride 0.8 + 0.4 v m per cycle
    });
    s_.x = to.x();
    s_.y = to.y();
  }

  void posture_to(const Posture& target, double T_min) {
    const Posture p0 = s_.posture;
    double maxd = 0;
    for (int d = 0; d < kHumanDofs; ++d) maxd = std::max(maxd, std::abs(target[d] - p0[d]));
    const double T = std::max(T_min, 1.875 * maxd / c_.joint_speed);  // peak joint speed <= joint_speed
    play(T, [&](double t, FrameState& s) {
      const double sm = smooth(t / T);
      for (int d = 0; d < kHumanDofs; ++d) s.posture[d] = p0[d] + (target[d] - p0[d]) * sm;
      s.gait = 0;
      s.phase_rate = 0;
    });
    s_.posture = target;
  }

  // Stand for T seconds; wobble(t) (zero with zero derivatives at both ends)
  // is added to the posture.
  void hold(double T, const std::function<void(double, Posture&)>& wobble = nullptr) {
    const Posture p0 = s_.posture;
    play(T, [&](double t, FrameState& s) {
      s.posture = p0;
      if (wobble) wobble(t, s.posture);
      s.gait = 0;
      s.phase_rate = 0;
    });
    s_.posture = p0;
  }

  // ------------------------------------------------------------ activities
  Eigen::Vector2d path_point(double u) const {
    u = std::clamp(u, 0.0, path_len_);
    int i = 2;
    while (i > 0 && u < leg_start_[i]) --i;
    const Eigen::Vector2d a = corners_[i], b = corners_[i + 1];
    return a + (b - a).normalized() * (u - leg_start_[i]);
  }

  double facing_table_yaw() const {
    const Eigen::Vector2d p(s_.x, s_.y);
    const Eigen::Vector2d q(std::clamp(p.x(), table_lo_.x(), table_hi_.x()), std::clamp(p.y(), table_lo_.y(), table_hi_.y()));
    return std::atan2(q.y() - p.y(), q.x() - p.x());
  }

  void walk() {
    double target = u_;
    for (int tries = 0; tries < 50 && std::abs(target - u_) < 0.6; ++tries) target = rng_.uniform(0.0, path_len_);
    if (std::abs(target - u_) < 0.6) target = u_ < 0.5 * path_len_ ? path_len_ : 0.0;
    // Legs along the U: through every corner between u_ and target.
    std::vector<double> stops;
    if (target > u_) {
      for (int i = 1; i <= 2; ++i)
        if (leg_start_[i] > u_ + 1e-9 && leg_start_[i] < target - 1e-9) stops.push_back(leg_start_[i]);
    } else {
      for (int i = 2; i >= 1; --i)
        if (leg_start_[i] < u_ - 1e-9 && leg_start_[i] > target + 1e-9) stops.push_back(leg_start_[i]);
    }
    stops.push_back(target);
    for (double u : stops) {
      const Eigen::Vector2d to = path_point(u);
      const Eigen::Vector2d d = to - Eigen::Vector2d(s_.x, s_.y);
      if (d.norm() < 0.05) {
        u_ = u;
        continue;
      }
      turn_to(std::atan2(d.y(), d.x()));
      walk_leg(to);
      u_ = u;
    }
  }

  // Fingertip position of `side` for root at the current place and angles p.
  Eigen::Vector3d fingertip(int side, const Posture& p) const {
    double pose[kHumanPoseDim] = {s_.x, s_.y, 0.0, s_.yaw};
    for (int d = 0; d < kHumanDofs; ++d) pose[kHumanRootDofs + d] = p[d];
    const HumanFkResult fk = human_fk_reference(m_, pose);
    return fk.p[static_cast<size_t>(tip_[side])];
  }

  // Lowest clearance above the table top of both forearms and hands (their
  // radii included) where they are over the table (1 m when none is).
  double table_clearance(const Posture& p) const {
    double pose[kHumanPoseDim] = {s_.x, s_.y, 0.0, s_.yaw};
    for (int d = 0; d < kHumanDofs; ++d) pose[kHumanRootDofs + d] = p[d];
    const HumanFkResult fk = human_fk_reference(m_, pose);
    double worst = 1.0;
    for (const int c : clearance_caps_) {
      const size_t sc = static_cast<size_t>(c);
      for (int k = 0; k <= 4; ++k) {
        const Eigen::Vector3d q = fk.a[sc] + 0.25 * k * (fk.b[sc] - fk.a[sc]);
        const bool over = q.x() > table_lo_.x() - 0.05 && q.x() < table_hi_.x() + 0.05 && q.y() > table_lo_.y() - 0.05 &&
                          q.y() < table_hi_.y() + 0.05;
        if (over) worst = std::min(worst, q.z() - m_.capsules[sc].radius - table_top_);
      }
    }
    return worst;
  }

  // An object on the table within reach of where the human stands.
  Eigen::Vector3d sample_object() {
    const Eigen::Vector2d p(s_.x, s_.y), f(std::cos(s_.yaw), std::sin(s_.yaw));
    for (int tries = 0; tries < 200; ++tries) {
      const Eigen::Vector2d o(rng_.uniform(table_lo_.x() + 0.05, table_hi_.x() - 0.05),
                              rng_.uniform(table_lo_.y() + 0.05, table_hi_.y() - 0.05));
      const Eigen::Vector2d d = o - p;
      const double r = d.norm();
      if (r < 0.4 || r > 0.85 || d.dot(f) < 0.5 * r) continue;  // in front, within 60 degrees
      return {o.x(), o.y(), table_top_ + 0.06};
    }
    const double yaw = facing_table_yaw();
    return {s_.x + 0.6 * std::cos(yaw), s_.y + 0.6 * std::sin(yaw), table_top_ + 0.06};
  }

  struct Reach {
    Posture lift, at;  // forearm raised (elbow bent only); fingertip at the object
  };

  // Reach postures for an object: random search, then local refinement, over
  // trunk lean and twist and the reaching arm's angles. The hand first comes
  // up by bending the elbow alone (it swings up in front of the body, above
  // the table's edge), then reaches; the free arm hangs vertically whatever
  // the lean; neither hand nor forearm may pass through the table top on the
  // way neutral -> lift -> at (checked at intermediate postures).
  Reach reach_postures(int side, const Eigen::Vector3d& obj) {
    struct Range { int dof; double lo, hi; };
    const std::array<Range, 7> ranges = {{{lumbar_flex_, 0.0, 0.6},
                                          {lumbar_twist_, -0.3, 0.3},
                                          {sh_flex_[side], 0.3, 1.9},
                                          {sh_abd_[side], -0.05, 0.6},
                                          {sh_rot_[side], -0.3, 0.5},
                                          {elbow_[side], 0.08, 0.9},
                                          {wrist_[side], -0.4, 0.2}}};
    const int free = 1 - side;
    auto make = [&](const std::array<double, 7>& x) {
      Reach r;
      Posture& p = r.at;
      p = neutral_;
      for (size_t i = 0; i < ranges.size(); ++i) p[ranges[i].dof] = x[i];
      p[thoracic_flex_] = 0.4 * x[0];
      p[neck_flex_] = 0.3 + 0.3 * x[0];                       // look at the object
      p[sh_flex_[free]] = -(p[lumbar_flex_] + p[thoracic_flex_]);  // free arm hangs vertically
      r.lift = neutral_;
      r.lift[elbow_[side]] = 1.7;
      return r;
    };
    auto blend = [&](const Posture& a, const Posture& b, double u) {
      Posture c;
      for (int d = 0; d < kHumanDofs; ++d) c[d] = a[d] + (b[d] - a[d]) * u;
      return c;
    };
    auto cost = [&](const std::array<double, 7>& x) {
      const Reach r = make(x);
      const double miss = (fingertip(side, r.at) - obj).squaredNorm();
      double clear = 1.0;
      for (const double u : {0.2, 0.4, 0.6, 0.8, 1.0}) clear = std::min(clear, table_clearance(blend(r.lift, r.at, u)));
      const double pen = clear < kMinClearance ? (kMinClearance - clear) * (kMinClearance - clear) * 1000.0 : 0.0;
      return miss + pen + 0.002 * (x[0] * x[0] + x[1] * x[1]);
    };
    std::array<double, 7> best{};
    double best_cost = INFINITY;
    for (int k = 0; k < 300; ++k) {
      std::array<double, 7> x;
      for (size_t i = 0; i < ranges.size(); ++i) x[i] = rng_.uniform(ranges[i].lo, ranges[i].hi);
      const double cst = cost(x);
      if (cst < best_cost) {
        best_cost = cst;
        best = x;
      }
    }
    for (int k = 0; k < 300; ++k) {
      const double scale = 0.15 * std::pow(0.02 / 0.15, k / 299.0);
      std::array<double, 7> x = best;
      for (size_t i = 0; i < ranges.size(); ++i)
        x[i] = std::clamp(x[i] + scale * (2.0 * rng_.uniform() - 1.0), ranges[i].lo, ranges[i].hi);
      const double cst = cost(x);
      if (cst < best_cost) {
        best_cost = cst;
        best = x;
      }
    }
    return make(best);
  }

  void reach() {
    turn_to(facing_table_yaw());
    const int reaches = rng_.uniform() < 0.3 ? 2 : 1;
    for (int r = 0; r < reaches; ++r) {
      // Objects until a reach keeps the hands kMinClearance above the table
      // (its best posture may still miss the object a little); else stand.
      bool ok = false;
      Reach p;
      for (int tries = 0; tries < 5 && !ok; ++tries) {
        const Eigen::Vector3d obj = sample_object();
        // The arm on the object's side.
        const Eigen::Vector2d f(std::cos(s_.yaw), std::sin(s_.yaw)), left(-f.y(), f.x());
        const double lateral = (obj.head<2>() - Eigen::Vector2d(s_.x, s_.y)).dot(left);
        const int side = std::abs(lateral) < 0.05 ? (rng_.uniform() < 0.5 ? 0 : 1) : (lateral > 0 ? 0 : 1);
        p = reach_postures(side, obj);
        ok = path_clearance({neutral_, p.lift, p.at}) >= kMinClearance;
      }
      if (!ok) {
        hold(rng_.uniform(0.5, 1.5));
        continue;
      }
      posture_to(p.lift, rng_.uniform(0.6, 0.9));
      posture_to(p.at, rng_.uniform(0.7, 1.1));
      hold(rng_.uniform(0.3, 1.2));
      posture_to(p.lift, rng_.uniform(0.7, 1.1));
      posture_to(neutral_, rng_.uniform(0.6, 0.9));
    }
  }

  // Smallest table clearance of forearms and hands along the joint-space
  // path through the postures (samples every 1/8 of each leg).
  double path_clearance(const std::vector<Posture>& path) const {
    double clear = 1.0;
    for (size_t i = 0; i + 1 < path.size(); ++i)
      for (int k = 1; k <= 8; ++k) {
        Posture p;
        for (int d = 0; d < kHumanDofs; ++d) p[d] = path[i][d] + (path[i + 1][d] - path[i][d]) * (k / 8.0);
        clear = std::min(clear, table_clearance(p));
      }
    return clear;
  }

  void phone() {
    // Phone postures (hand up by the elbow first, then the rest) until one
    // keeps the hands kMinClearance above the table; else just stand.
    Posture p, lift;
    bool ok = false;
    const double yaw0 = s_.yaw;
    double yaw = yaw0;
    for (int tries = 0; tries < 8 && !ok; ++tries) {
      yaw = rng_.uniform() < 0.5 ? yaw0 + rng_.uniform(-std::numbers::pi / 2, std::numbers::pi / 2) : yaw0;
      const int side = rng_.uniform() < 0.5 ? 0 : 1;
      p = neutral_;
      p[sh_flex_[side]] = rng_.uniform(0.2, 0.5);
      p[sh_rot_[side]] = rng_.uniform(0.3, 0.6);
      p[elbow_[side]] = rng_.uniform(1.5, 1.9);
      p[wrist_[side]] = rng_.uniform(-0.4, 0.0);
      p[neck_flex_] = rng_.uniform(0.4, 0.7);
      p[head_flex_] = rng_.uniform(0.1, 0.3);
      p[thoracic_flex_] = rng_.uniform(0.0, 0.1);
      lift = neutral_;
      lift[elbow_[side]] = p[elbow_[side]];
      s_.yaw = yaw;  // the clearance is checked where the human will face
      ok = path_clearance({neutral_, lift, p}) >= kMinClearance;
      s_.yaw = yaw0;
    }
    if (!ok) {
      hold(rng_.uniform(1.0, 3.0));
      return;
    }
    turn_to(yaw);
    posture_to(lift, rng_.uniform(0.6, 0.9));
    posture_to(p, rng_.uniform(0.6, 1.0));
    const double T = rng_.uniform(3.0, 8.0), amp = rng_.uniform(0.05, 0.12), f = rng_.uniform(0.1, 0.25);
    const int neck = neck_twist_;
    hold(T, [=](double t, Posture& q) {
      const double w = std::sin(std::numbers::pi * t / T);
      q[neck] += amp * w * w * std::sin(2.0 * std::numbers::pi * f * t);  // glances around, C2 at both ends
    });
    posture_to(lift, rng_.uniform(0.6, 1.0));
    posture_to(neutral_, rng_.uniform(0.6, 0.9));
  }

  // Hands and forearms stay this far above the table top along every planned
  // posture path (the idle sway then moves them by about 1 cm at most).
  static constexpr double kMinClearance = 0.03;

  const HumanModel& m_;
  HumanMotionConfig c_;
  Rng rng_;
  double dt_ = 0;
  Eigen::Vector2d table_lo_, table_hi_;
  double table_top_ = 0;
  std::array<Eigen::Vector2d, 4> corners_;
  double leg_start_[3] = {0, 0, 0};
  double path_len_ = 0;
  std::vector<int> clearance_caps_;  // forearms and hands
  int hip_[2], knee_[2], sh_flex_[2], sh_abd_[2], sh_rot_[2], elbow_[2], wrist_[2], tip_[2];
  int pelvis_twist_, pelvis_lateral_, lumbar_flex_, lumbar_twist_, thoracic_flex_, thoracic_twist_, neck_flex_,
      neck_twist_, head_flex_;
  Posture neutral_{};
  std::array<std::array<std::array<double, 3>, 3>, kHumanDofs> idle_{};  // (amp, omega, phase) x 3 per angle
  // state
  FrameState s_;
  double u_ = 0;      // position along the path, m
  double phase_ = 0;  // gait phase, rad
  std::vector<float> frames_;
  std::vector<HumanMotionSegment> segments_;
};

}  // namespace

HumanMotionLibrary generate_human_motion(const HumanModel& model, const HumanMotionConfig& config) {
  nlohmann::json j = config;
  HumanMotionConfig checked;
  from_json(j, checked);  // the same range checks as a manifest's config
  Generator g(model, config);
  return g.run();
}

}  // namespace atacom
