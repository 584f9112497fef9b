// The human's motion library: ~18k frames at 30 Hz of a person moving next to
// the HRI table, generated deterministically from a seed (no capture data is
// public; docs/human.md describes the generator and its bounds), stored in
// data/human_motion.bin (float32 poses) with data/human_motion.json (seed,
// generator version, segments, split, checksum).
//
// Playback: poses between frames are Catmull-Rom (C1) interpolations of the
// stored frames, and pose rates their analytic derivatives, so the capsule
// velocities of kernels/human_kernels.hpp are the exact time derivatives of
// the positions the env sees. The last 15% of the segments are held out
// (HumanSplit::Test) for evaluation.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "atacom/rng.hpp"
#include "envs/arm/human_model.hpp"

namespace atacom {

inline constexpr int kHumanMotionVersion = 2;  // bump when the generator's output changes

enum class HumanActivity : uint8_t { Walk = 0, Reach = 1, Phone = 2, Turn = 3, Pause = 4 };
std::string human_activity_name(HumanActivity a);
HumanActivity parse_human_activity(const std::string& s);  // throws std::invalid_argument

enum class HumanSplit : uint8_t { Train = 0, Test = 1, All = 2 };
std::string human_split_name(HumanSplit s);
HumanSplit parse_human_split(const std::string& s);  // throws std::invalid_argument

struct HumanMotionSegment {
  HumanActivity activity = HumanActivity::Pause;
  int begin = 0, end = 0;  // frames [begin, end)
};

// Generator settings (the one default factory: default_human_motion_config).
// Positions in the robot's base frame (x forward, z up), SI units.
struct HumanMotionConfig {
  uint64_t seed = 2023;
  int frames = 18000;                  // at least this many frames (the last activity completes)
  double fps = 30.0;
  double test_fraction = 0.15;         // share of the segments (the last ones) held out
  Eigen::Vector3d table_center{0.8, -0.15, 0.4};  // HRI table box (reference section 4.4)
  Eigen::Vector3d table_half{0.4, 0.4, 0.4};
  double clearance = 0.42;             // walking path: pelvis axis to the table's edge, m
  double x_min = 0.55;                 // the path's ends on the robot's side (x), m
  double walk_speed_min = 0.6;         // cruise speed of a walk, sampled in [min, max] m/s
  double walk_speed_max = 1.3;
  double walk_accel = 1.0;             // peak of the smooth speed ramps, m/s^2
  double turn_rate_min = 1.2;          // peak yaw rate of a turn, sampled in [min, max] rad/s
  double turn_rate_max = 2.0;
  double joint_speed = 1.8;            // peak joint speed of posture changes, rad/s
};
HumanMotionConfig default_human_motion_config();
void to_json(nlohmann::json& j, const HumanMotionConfig& c);
void from_json(const nlohmann::json& j, HumanMotionConfig& c);  // strict keys

// Bounds the generator guarantees (by construction, checked by the tests
// with finite differences of the stored frames), in data time (one frame =
// 1 / fps seconds; playback at another rate scales every speed by it).
struct HumanMotionBounds {
  double walk_speed_min = 0.3;        // every walk's peak horizontal speed lies in [min, max], m/s
  double walk_speed_max = 1.4;
  double root_accel = 1.1;            // horizontal acceleration of the root, m/s^2 (ramps peak at walk_accel)
  double vertical_speed = 0.15;       // |dz/dt| of the root (gait bob), m/s
  double yaw_rate = 2.05;             // rad/s (turns peak at turn_rate_max)
  double yaw_accel = 6.2;             // rad/s^2 (turns peak at 6)
  double joint_speed = 3.0;           // any joint angle, rad/s
  double joint_accel = 25.0;          // any joint angle, rad/s^2
  double point_speed = 3.5;           // any capsule end point, m/s (the swinging ankles are fastest)
};
HumanMotionBounds human_motion_bounds();

struct HumanMotionLibrary {
  int version = kHumanMotionVersion;
  HumanMotionConfig config;
  int num_frames = 0;
  std::vector<float> frames;                 // (num_frames x 38) poses, kernels/human_kernels.hpp layout
  std::vector<HumanMotionSegment> segments;  // consecutive, covering [0, num_frames)
  int test_begin = 0;                        // first frame of the held-out split (a segment start)

  double fps() const { return config.fps; }
  // Frame range [lo, hi) of a split.
  void split_range(HumanSplit s, int& lo, int& hi) const;
  // Pose at frame time t (fractional frames), clamped into [0, num_frames - 1],
  // and its derivative per frame (0 outside the library). Catmull-Rom.
  void sample(double t, double* pose, double* rate_per_frame) const;
  // FNV-1a of the frame bytes (the manifest's checksum).
  uint64_t checksum() const;
};

// Deterministic: the same config gives the same bytes (same binary).
HumanMotionLibrary generate_human_motion(const HumanModel& model, const HumanMotionConfig& config);

// Writes bin_path (float32 little-endian frames) and the manifest json_path,
// both atomically. Throws std::runtime_error on failure.
void save_human_motion(const HumanMotionLibrary& lib, const HumanModel& model, const std::string& bin_path,
                       const std::string& json_path);
// Reads and checks (sizes, checksum, version); throws std::runtime_error naming the problem.
HumanMotionLibrary load_human_motion(const std::string& bin_path, const std::string& json_path);
// The project's library: data/human_motion.bin + data/human_motion.json.
HumanMotionLibrary load_default_human_motion();

// Playback for the envs. frames_per_step: library frames per env step; 1 =
// real time for a 30 Hz env (the reference advances one frame every 2 env
// steps, 0.5: half the speeds of docs/human.md at 30 Hz).
struct HumanReplayConfig {
  double frames_per_step = 1.0;
  HumanSplit split = HumanSplit::Train;
};

// Start frame of an episode of `steps` env steps, uniform over the starts
// that keep the whole episode inside the split (the split's first frame if
// it is shorter than the episode).
double human_episode_start(const HumanMotionLibrary& lib, const HumanReplayConfig& replay, int steps, Rng& rng);

// For envs [begin, end): batch.pose and batch.pose_rate (per second of env
// time: rate per frame x frames_per_step / dt) at frame times t (N), each
// clamped into its split. Calling thread, no allocation.
void human_motion_range(const HumanMotionLibrary& lib, const HumanReplayConfig& replay, double dt, const double* t,
                        HumanBatch& batch, int begin, int end);

}  // namespace atacom
