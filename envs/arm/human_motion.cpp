#include "envs/arm/human_motion.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "src/core/binary_io.hpp"
#include "src/core/config_json.hpp"
#include "src/core/data_dir.hpp"
#include "src/core/fs_util.hpp"

namespace atacom {

namespace {
using nlohmann::json;

constexpr const char* kActivityNames[] = {"walk", "reach", "phone", "turn", "pause"};
constexpr const char* kSplitNames[] = {"train", "test", "all"};
constexpr const char* kFormat = "atacom-human-motion";

json point_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
Eigen::Vector3d read_vec(ConfigReader& r, const std::string& key) {
  const json& a = r.at(key);
  if (!a.is_array() || a.size() != 3 || !a[0].is_number() || !a[1].is_number() || !a[2].is_number())
    throw std::invalid_argument(r.path(key) + ": expected 3 numbers");
  return {a[0].get<double>(), a[1].get<double>(), a[2].get<double>()};
}

bool little_endian() {
  const uint32_t one = 1;
  unsigned char b;
  std::memcpy(&b, &one, 1);
  return b == 1;
}
}  // namespace

std::string human_activity_name(HumanActivity a) { return kActivityNames[static_cast<int>(a)]; }
HumanActivity parse_human_activity(const std::string& s) {
  for (int i = 0; i < 5; ++i)
    if (s == kActivityNames[i]) return static_cast<HumanActivity>(i);
  throw std::invalid_argument("unknown human activity '" + printable_text(s) + "' (known: walk, reach, phone, turn, pause)");
}
std::string human_split_name(HumanSplit s) { return kSplitNames[static_cast<int>(s)]; }
HumanSplit parse_human_split(const std::string& s) {
  for (int i = 0; i < 3; ++i)
    if (s == kSplitNames[i]) return static_cast<HumanSplit>(i);
  throw std::invalid_argument("unknown human motion split '" + printable_text(s) + "' (known: train, test, all)");
}

HumanMotionConfig default_human_motion_config() { return HumanMotionConfig{}; }

HumanMotionBounds human_motion_bounds() { return HumanMotionBounds{}; }

void to_json(json& j, const HumanMotionConfig& c) {
  j = {{"seed", c.seed},
       {"frames", c.frames},
       {"fps", c.fps},
       {"test_fraction", c.test_fraction},
       {"table_center", point_json(c.table_center)},
       {"table_half", point_json(c.table_half)},
       {"clearance", c.clearance},
       {"x_min", c.x_min},
       {"walk_speed_min", c.walk_speed_min},
       {"walk_speed_max", c.walk_speed_max},
       {"walk_accel", c.walk_accel},
       {"turn_rate_min", c.turn_rate_min},
       {"turn_rate_max", c.turn_rate_max},
       {"joint_speed", c.joint_speed}};
}

void from_json(const json& j, HumanMotionConfig& c) {
  ConfigReader r(j, "human_motion");
  const json& seed = r.at("seed");
  if (!seed.is_number_unsigned()) throw std::invalid_argument("human_motion.seed: expected a non-negative integer");
  c.seed = seed.get<uint64_t>();
  c.frames = r.integer("frames");
  c.fps = r.number("fps");
  c.test_fraction = r.number("test_fraction");
  c.table_center = read_vec(r, "table_center");
  c.table_half = read_vec(r, "table_half");
  c.clearance = r.number("clearance");
  c.x_min = r.number("x_min");
  c.walk_speed_min = r.number("walk_speed_min");
  c.walk_speed_max = r.number("walk_speed_max");
  c.walk_accel = r.number("walk_accel");
  c.turn_rate_min = r.number("turn_rate_min");
  c.turn_rate_max = r.number("turn_rate_max");
  c.joint_speed = r.number("joint_speed");
  r.finish();
  if (c.frames < 100 || c.frames > 1000000) throw std::invalid_argument("human_motion.frames must be in [100, 1e6]");
  if (!(c.fps >= 10.0 && c.fps <= 240.0)) throw std::invalid_argument("human_motion.fps must be in [10, 240]");
  if (!(c.test_fraction > 0.0 && c.test_fraction < 0.5))
    throw std::invalid_argument("human_motion.test_fraction must be in (0, 0.5)");
  if (!(c.table_half.minCoeff() > 0.0)) throw std::invalid_argument("human_motion.table_half must be positive");
  if (!(c.clearance >= 0.3 && c.clearance <= 1.5)) throw std::invalid_argument("human_motion.clearance must be in [0.3, 1.5] m");
  if (!(c.walk_speed_min >= 0.3 && c.walk_speed_min <= c.walk_speed_max && c.walk_speed_max <= 1.4))
    throw std::invalid_argument("human_motion: need 0.3 <= walk_speed_min <= walk_speed_max <= 1.4 m/s");
  if (!(c.walk_accel >= 0.2 && c.walk_accel <= 1.4)) throw std::invalid_argument("human_motion.walk_accel must be in [0.2, 1.4]");
  if (!(c.turn_rate_min > 0.2 && c.turn_rate_min <= c.turn_rate_max && c.turn_rate_max <= 2.0))
    throw std::invalid_argument("human_motion: need 0.2 < turn_rate_min <= turn_rate_max <= 2 rad/s");
  if (!(c.joint_speed > 0.2 && c.joint_speed <= 3.0)) throw std::invalid_argument("human_motion.joint_speed must be in (0.2, 3]");
}

void HumanMotionLibrary::split_range(HumanSplit s, int& lo, int& hi) const {
  switch (s) {
    case HumanSplit::Train: lo = 0; hi = test_begin; return;
    case HumanSplit::Test: lo = test_begin; hi = num_frames; return;
    case HumanSplit::All: lo = 0; hi = num_frames; return;
  }
  lo = 0;
  hi = num_frames;
}

void HumanMotionLibrary::sample(double t, double* pose, double* rate) const {
  const int F = num_frames;
  auto frame = [&](int i) { return &frames[static_cast<size_t>(std::clamp(i, 0, F - 1)) * kHumanPoseDim]; };
  if (!(t > 0.0)) t = 0.0;  // also NaN
  if (t >= F - 1) {
    const float* f = frame(F - 1);
    for (int d = 0; d < kHumanPoseDim; ++d) {
      pose[d] = f[d];
      if (rate) rate[d] = 0.0;
    }
    return;
  }
  const int i = static_cast<int>(t);
  const double u = t - i, u2 = u * u, u3 = u2 * u;
  // Cubic Hermite between frames i and i+1 with tangents (f[i+1] - f[i-1]) / 2
  // (one-sided at the library's ends): C1 across frames.
  const double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
  const double d00 = 6 * u2 - 6 * u, d10 = 3 * u2 - 4 * u + 1, d01 = -6 * u2 + 6 * u, d11 = 3 * u2 - 2 * u;
  const float *f0 = frame(i - 1), *f1 = frame(i), *f2 = frame(i + 1), *f3 = frame(i + 2);
  const double s1 = i == 0 ? 1.0 : 0.5, s2 = i + 2 > F - 1 ? 1.0 : 0.5;
  for (int d = 0; d < kHumanPoseDim; ++d) {
    const double p1 = f1[d], p2 = f2[d];
    const double m1 = s1 * (double(f2[d]) - double(f0[d])), m2 = s2 * (double(f3[d]) - double(f1[d]));
    pose[d] = h00 * p1 + h10 * m1 + h01 * p2 + h11 * m2;
    if (rate) rate[d] = d00 * p1 + d10 * m1 + d01 * p2 + d11 * m2;
  }
}

uint64_t HumanMotionLibrary::checksum() const { return bin::fnv1a(frames.data(), frames.size() * sizeof(float)); }

void save_human_motion(const HumanMotionLibrary& lib, const HumanModel& model, const std::string& bin_path,
                       const std::string& json_path) {
  if (!little_endian()) throw std::runtime_error("human motion files are little-endian; this machine is not");
  if (lib.frames.size() != static_cast<size_t>(lib.num_frames) * kHumanPoseDim)
    throw std::runtime_error("human motion library: frames hold the wrong number of values");
  write_file_atomic(bin_path, std::string(reinterpret_cast<const char*>(lib.frames.data()),
                                          lib.frames.size() * sizeof(float)));
  json segs = json::array();
  for (const HumanMotionSegment& s : lib.segments) segs.push_back({human_activity_name(s.activity), s.begin, s.end});
  const HumanMotionBounds b = human_motion_bounds();
  json names = json::array();
  for (int i = 0; i < kHumanPoseDim; ++i) names.push_back(model.pose_name(i));
  std::ostringstream hex;
  hex << std::hex << lib.checksum();
  const json m = {
      {"format", kFormat},
      {"generator", "atacom human-motion (envs/arm/human_motion_gen.cpp)"},
      {"version", lib.version},
      {"config", lib.config},
      {"fps", lib.fps()},
      {"num_frames", lib.num_frames},
      {"pose_dim", kHumanPoseDim},
      {"pose_names", names},
      {"units", "x, y, z m; yaw and joint angles rad (kernels/human_kernels.hpp, data/human_dofs.json)"},
      {"dtype", "float32 little-endian, row-major (num_frames x pose_dim)"},
      {"bytes", lib.frames.size() * sizeof(float)},
      {"fnv1a64", hex.str()},
      {"test_begin", lib.test_begin},
      {"segments", segs},
      {"bounds",
       {{"walk_speed_min", b.walk_speed_min},
        {"walk_speed_max", b.walk_speed_max},
        {"root_accel", b.root_accel},
        {"vertical_speed", b.vertical_speed},
        {"yaw_rate", b.yaw_rate},
        {"yaw_accel", b.yaw_accel},
        {"joint_speed", b.joint_speed},
        {"joint_accel", b.joint_accel},
        {"point_speed", b.point_speed}}}};
  write_file_atomic(json_path, m.dump(1) + "\n");
}

HumanMotionLibrary load_human_motion(const std::string& bin_path, const std::string& json_path) {
  if (!little_endian()) throw std::runtime_error("human motion files are little-endian; this machine is not");
  json m;
  {
    std::ifstream in(json_path);
    if (!in) throw std::runtime_error("cannot open human motion manifest '" + json_path + "'");
    try {
      m = json::parse(in);
    } catch (const json::exception& e) {
      throw std::runtime_error("cannot parse '" + json_path + "': " + e.what());
    }
  }
  HumanMotionLibrary lib;
  const std::string where = "human motion manifest '" + json_path + "'";
  try {
    if (m.at("format").get<std::string>() != kFormat) throw std::runtime_error(where + ": not an " + kFormat + " file");
    lib.version = m.at("version").get<int>();
    if (lib.version != kHumanMotionVersion)
      throw std::runtime_error(where + ": generator version " + std::to_string(lib.version) + ", this build reads " +
                               std::to_string(kHumanMotionVersion) + " (regenerate with atacom human-motion)");
    from_json(m.at("config"), lib.config);
    lib.num_frames = m.at("num_frames").get<int>();
    if (m.at("pose_dim").get<int>() != kHumanPoseDim)
      throw std::runtime_error(where + ": pose_dim must be " + std::to_string(kHumanPoseDim));
    lib.test_begin = m.at("test_begin").get<int>();
    for (const json& s : m.at("segments")) {
      if (!s.is_array() || s.size() != 3) throw std::runtime_error(where + ": segments are [activity, begin, end]");
      lib.segments.push_back({parse_human_activity(s[0].get<std::string>()), s[1].get<int>(), s[2].get<int>()});
    }
  } catch (const json::exception& e) {
    throw std::runtime_error(where + ": " + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(where + ": " + e.what());
  }
  if (lib.num_frames < 4 || lib.num_frames > 10000000) throw std::runtime_error(where + ": implausible num_frames");
  int expect = 0;
  for (const HumanMotionSegment& s : lib.segments) {
    if (s.begin != expect || s.end <= s.begin) throw std::runtime_error(where + ": segments must be consecutive");
    expect = s.end;
  }
  if (expect != lib.num_frames) throw std::runtime_error(where + ": segments must cover every frame");
  bool boundary = false;
  for (const HumanMotionSegment& s : lib.segments) boundary = boundary || s.begin == lib.test_begin;
  if (!boundary || lib.test_begin == 0) throw std::runtime_error(where + ": test_begin must be a later segment's start");
  std::ifstream in(bin_path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open human motion frames '" + bin_path + "'");
  const size_t n = static_cast<size_t>(lib.num_frames) * kHumanPoseDim;
  lib.frames.resize(n);
  in.read(reinterpret_cast<char*>(lib.frames.data()), static_cast<std::streamsize>(n * sizeof(float)));
  if (!in || in.gcount() != static_cast<std::streamsize>(n * sizeof(float)) || in.peek() != EOF)
    throw std::runtime_error("'" + bin_path + "' does not hold exactly " + std::to_string(lib.num_frames) + " x " +
                             std::to_string(kHumanPoseDim) + " float32 values");
  std::ostringstream hex;
  hex << std::hex << lib.checksum();
  if (hex.str() != m.at("fnv1a64").get<std::string>())
    throw std::runtime_error("'" + bin_path + "' does not match the checksum in '" + json_path + "'");
  for (float v : lib.frames)
    if (!std::isfinite(v)) throw std::runtime_error("'" + bin_path + "' holds a non-finite value");
  return lib;
}

HumanMotionLibrary load_default_human_motion() {
  return load_human_motion(data_file("human_motion.bin"), data_file("human_motion.json"));
}

double human_episode_start(const HumanMotionLibrary& lib, const HumanReplayConfig& replay, int steps, Rng& rng) {
  int lo = 0, hi = 0;
  lib.split_range(replay.split, lo, hi);
  const double span = std::max(0.0, replay.frames_per_step) * std::max(0, steps);
  const double last = (hi - 1) - span;  // latest start whose episode stays inside
  if (!(last > lo)) return lo;
  return rng.uniform(static_cast<double>(lo), last);
}

void human_motion_range(const HumanMotionLibrary& lib, const HumanReplayConfig& replay, double dt, const double* t,
                        HumanBatch& B, int begin, int end) {
  int lo = 0, hi = 0;
  lib.split_range(replay.split, lo, hi);
  const double per_second = replay.frames_per_step / dt;
  for (int e = begin; e < end; ++e) {
    const size_t se = static_cast<size_t>(e);
    double* pose = &B.pose[se * kHumanPoseDim];
    double* rate = &B.pose_rate[se * kHumanPoseDim];
    const double te = t[e];
    const bool held = !(te >= lo && te < hi - 1);  // clamped (or NaN): the human stands still
    lib.sample(te >= lo ? std::min(te, double(hi - 1)) : double(lo), pose, rate);
    for (int d = 0; d < kHumanPoseDim; ++d) rate[d] = held ? 0.0 : rate[d] * per_second;
  }
}

}  // namespace atacom
