// The field list of EnvBuffers (include/atacom/env.hpp), in the order of the
// snapshot's BUFS section: it drives that section's writer and reader
// (src/core/snapshot.cpp), EnvBuffers::copy_values_from and the golden hash
// (tests/test_golden_hash.cpp). A new array of EnvBuffers goes here (and in
// EnvBuffers::resize, which knows its shape); the static_assert below fails
// until it does.
#pragma once
#include "atacom/env.hpp"
#include "src/core/record_fields.hpp"

namespace atacom {

struct EnvBufferFields {
  using Record = EnvBuffers;
  template <class V>
  static constexpr void each(V&& v) {
    v("obs", &EnvBuffers::obs);
    v("final_obs", &EnvBuffers::final_obs);
    v("reward", &EnvBuffers::reward);
    v("cost", &EnvBuffers::cost);
    v("terminated", &EnvBuffers::terminated);
    v("truncated", &EnvBuffers::truncated);
    v("constraints", &EnvBuffers::constraints);
    v("info", &EnvBuffers::info);
    v("episode_return", &EnvBuffers::episode_return);
    v("episode_length", &EnvBuffers::episode_length);
    // Snapshots of builds before it end at episode_length and held the
    // continuous cost in the cost slot (read_buffers_section converts them).
    v("cost_continuous", &EnvBuffers::cost_continuous, kFieldAppended);
  }
};

// Every member but the env count N (and its padding) is in the list.
static_assert(sizeof(EnvBuffers) - field_bytes<EnvBufferFields>() == alignof(std::vector<float>),
              "EnvBuffers has a member EnvBufferFields does not list");

}  // namespace atacom
