// PPO's rollout: T batch steps of N envs, stored time-major (row t * N + i),
// and generalised advantage estimation over it.
//
// Episode boundaries inside the rollout come from same-step autoreset: the
// row of a step that ended an episode is followed, in the same env's next
// row, by the next episode's first observation. GAE never carries across
// such a row. A terminated row bootstraps nothing; a truncated one
// bootstraps from the value of the episode's true last observation
// (EnvBuffers::final_obs), kept for those rows only.
#pragma once
#include <cstdint>
#include <iosfwd>
#include <vector>

#include "train/tensor.hpp"

namespace atacom {

struct PpoRollout {
  int T = 0, N = 0, D = 0, A = 0;
  int steps = 0;                   // batch steps stored so far, in [0, T]
  int finals = 0;                  // rows of final_obs in use
  AlignedVector<float> obs;        // (T*N x D) normalised observation acted on
  AlignedVector<float> sample;     // (T*N x A) the policy's pre-clip Gaussian sample u
  AlignedVector<float> logp;       // (T*N) log-density of u under the acting policy
  AlignedVector<float> reward;     // (T*N) reward x reward_scale
  std::vector<uint8_t> terminated; // (T*N) 1: no bootstrap
  std::vector<uint8_t> truncated;  // (T*N) 1: bootstrap from final_obs (not set when terminated)
  std::vector<int32_t> final_row;  // (T*N) row of final_obs for a truncated row, else -1
  AlignedVector<float> final_obs;  // (T*N x D) normalised true last observations of truncated rows
  AlignedVector<float> last_obs;   // (N x D) normalised observation after the last step (s_T)
  // Written by the update (value pass and GAE):
  AlignedVector<float> value;      // (T*N) V(obs) at the update's start
  AlignedVector<float> final_value;// (T*N) V(final_obs), rows [0, finals)
  AlignedVector<float> last_value; // (N) V(last_obs)
  AlignedVector<float> advantage;  // (T*N)
  AlignedVector<float> ret;        // (T*N) advantage + value: the value target
  // With a cost critic (PPO-Lagrangian, train/lagrangian_learner.hpp): the
  // step's 0/1 cost (EnvBuffers::cost) and the cost counterparts of the
  // arrays above, GAE'd the same way. Empty without.
  bool with_cost = false;
  AlignedVector<float> cost, cost_value, cost_final_value, cost_last_value, cost_advantage, cost_ret;

  void resize(int T, int N, int D, int A, bool with_cost = false);
  int rows() const { return steps * N; }
  // The rows stored so far (steps, finals and their arrays), for checkpoints
  // taken inside a rollout (the costs after the rest, with a cost critic
  // only); load() validates every flag and index.
  void save(std::ostream& out) const;
  void load(std::istream& in);
};

// GAE(lambda) over T x N, time-major. value (T*N) = V(s_t); last_value (N) =
// V(s_T); final_value[final_row[k]] = V(true last obs) of truncated row k.
// Per row: next = 0 (terminated), final value (truncated), V(s_{t+1})
// (otherwise, V(s_T) at t = T-1); delta = r + gamma next - V(s_t);
// A_t = delta + gamma lambda A_{t+1}, the carry cut at every ended episode.
// ret = A + V. Accumulates in float64; envs run in parallel blocks (each
// column is independent, so the bits do not depend on the threads).
void compute_gae(int T, int N, const float* reward, const float* value, const float* last_value,
                 const uint8_t* terminated, const uint8_t* truncated, const int32_t* final_row,
                 const float* final_value, double gamma, double lambda, float* advantage, float* ret);

}  // namespace atacom
