// The field list of NavBatch, in the order of the nav snapshot's NAVS
// section (src/core/record_fields.hpp): it drives that section's writer and
// reader (NavEnv::save_state / load_state). A new NavBatch array goes here
// and in NavBatch::resize (envs/nav/nav_batch.hpp); the static_assert fails until it does.
#pragma once
#include "envs/nav/nav_batch.hpp"
#include "src/core/record_fields.hpp"
#include "src/core/snapshot.hpp"

namespace atacom {

struct NavStateFields {
  using Record = NavBatch;
  static constexpr uint32_t kTag = snapshot_tag("NAVS");
  static constexpr const char* kName = "state";
  template <class V>
  static constexpr void each(V&& v) {
    v("tiago", &NavBatch::tiago);
    v("tiago_vel", &NavBatch::tiago_vel);
    v("fetch", &NavBatch::fetch);
    v("fetch_vel", &NavBatch::fetch_vel);
    v("fetch_cmd", &NavBatch::fetch_cmd);
    v("goal", &NavBatch::goal);
    v("fetch_goal", &NavBatch::fetch_goal);
    v("prev_action", &NavBatch::prev_action);
    v("t", &NavBatch::t);
    v("return", &NavBatch::ret);
    v("rng", &NavBatch::rng);
  }
};

// Every member but the env count N (and its padding) and the step's scratch
// arrays (written and read inside one nav_step_range call, not state) is in the list.
static_assert(sizeof(NavBatch) - field_bytes<NavStateFields>() - sizeof(NavBatch::act) - sizeof(NavBatch::nan) -
                      sizeof(NavBatch::hit_wall) - sizeof(NavBatch::hit_fetch) ==
                  alignof(std::vector<double>),
              "NavBatch has a member NavStateFields does not list");

}  // namespace atacom
