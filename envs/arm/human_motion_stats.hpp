// Speed statistics of the human's motion library (docs/human.md, section
// "Speeds against published human speeds"): per frame, the pelvis's
// horizontal speed (walking), and the wrist's and the fingertip's ("hand")
// speed of the faster side, from the exact rates of the interpolated
// playback (human_fk_reference with the pose rate), in data time.
#pragma once
#include <nlohmann/json.hpp>

#include "envs/arm/human_model.hpp"
#include "envs/arm/human_motion.hpp"

namespace atacom {

// Per-frame speeds (m/s, data time) of one library frame.
struct HumanFrameSpeeds {
  double pelvis_horizontal = 0.0;  // |(vx, vy)| of the pelvis joint
  double wrist = 0.0;              // max over both sides of |v| of the wrist joint
  double hand = 0.0;               // max over both sides of |v| of the fingertip end site
};
HumanFrameSpeeds human_frame_speeds(const HumanMotionLibrary& lib, const HumanModel& model, int frame);

// For every quantity ("pelvis_horizontal", "wrist", "hand") and every frame
// set ("all" and each activity): percentiles p50 / p90 / p99 and the max over
// the frames, and the median and max of the per-segment peaks ("peaks": one
// value per segment of that activity, e.g. a walk's cruise speed or a reach's
// peak hand speed). Also fps and the frame count.
nlohmann::json human_motion_speed_stats(const HumanMotionLibrary& lib, const HumanModel& model);

}  // namespace atacom
