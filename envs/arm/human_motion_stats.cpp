// Speed statistics of the motion library (envs/arm/human_motion_stats.hpp).
#include "envs/arm/human_motion_stats.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace atacom {

namespace {

struct Sides {
  int pelvis, wrist[2], tip[2];
};

Sides sides(const HumanModel& model) {
  return {model.joint_index("pelvis"),
          {model.joint_index("wrist_l"), model.joint_index("wrist_r")},
          {model.joint_index("fingertip_l"), model.joint_index("fingertip_r")}};
}

HumanFrameSpeeds speeds_at(const HumanMotionLibrary& lib, const HumanModel& model, const Sides& s, int frame) {
  double pose[kHumanPoseDim], rate[kHumanPoseDim];
  lib.sample(double(frame), pose, rate);
  for (double& r : rate) r *= lib.fps();  // per frame -> per second
  const HumanFkResult fk = human_fk_reference(model, pose, rate);
  HumanFrameSpeeds v;
  v.pelvis_horizontal = fk.p_dot[size_t(s.pelvis)].head<2>().norm();
  for (int k = 0; k < 2; ++k) {
    v.wrist = std::max(v.wrist, fk.p_dot[size_t(s.wrist[k])].norm());
    v.hand = std::max(v.hand, fk.p_dot[size_t(s.tip[k])].norm());
  }
  return v;
}

// Nearest-rank percentile of a sorted sample.
double pct(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0.0;
  const size_t rank = q <= 0.0 ? 1 : size_t(std::ceil(q * double(sorted.size())));  // 1-based
  return sorted[std::min(sorted.size(), rank) - 1];
}

nlohmann::json summary(std::vector<double> frames, std::vector<double> peaks) {
  std::sort(frames.begin(), frames.end());
  std::sort(peaks.begin(), peaks.end());
  auto r3 = [](double x) { return std::round(x * 1000.0) / 1000.0; };
  return {{"frames", frames.size()},
          {"p50", r3(pct(frames, 0.5))},
          {"p90", r3(pct(frames, 0.9))},
          {"p99", r3(pct(frames, 0.99))},
          {"max", r3(frames.empty() ? 0.0 : frames.back())},
          {"segments", peaks.size()},
          {"peak_median", r3(pct(peaks, 0.5))},
          {"peak_max", r3(peaks.empty() ? 0.0 : peaks.back())}};
}

}  // namespace

HumanFrameSpeeds human_frame_speeds(const HumanMotionLibrary& lib, const HumanModel& model, int frame) {
  return speeds_at(lib, model, sides(model), frame);
}

nlohmann::json human_motion_speed_stats(const HumanMotionLibrary& lib, const HumanModel& model) {
  const Sides s = sides(model);
  std::vector<HumanFrameSpeeds> v(size_t(lib.num_frames));
  for (int f = 0; f < lib.num_frames; ++f) v[size_t(f)] = speeds_at(lib, model, s, f);
  const double HumanFrameSpeeds::*field[3] = {&HumanFrameSpeeds::pelvis_horizontal, &HumanFrameSpeeds::wrist,
                                              &HumanFrameSpeeds::hand};
  const char* names[3] = {"pelvis_horizontal", "wrist", "hand"};
  nlohmann::json out = {{"fps", lib.fps()}, {"frames", lib.num_frames}, {"units", "m/s, data time"}};
  for (int q = 0; q < 3; ++q) {
    nlohmann::json per;
    std::vector<double> all, all_peaks;
    for (int a = 0; a < 5; ++a) {
      const HumanActivity act = static_cast<HumanActivity>(a);
      std::vector<double> frames, peaks;
      for (const HumanMotionSegment& seg : lib.segments) {
        if (seg.activity != act) continue;
        double peak = 0.0;
        for (int f = seg.begin; f < seg.end; ++f) {
          frames.push_back(v[size_t(f)].*field[q]);
          peak = std::max(peak, v[size_t(f)].*field[q]);
        }
        peaks.push_back(peak);
      }
      all.insert(all.end(), frames.begin(), frames.end());
      all_peaks.insert(all_peaks.end(), peaks.begin(), peaks.end());
      per[human_activity_name(act)] = summary(frames, peaks);
    }
    per["all"] = summary(all, all_peaks);
    out[names[q]] = per;
  }
  return out;
}

}  // namespace atacom
