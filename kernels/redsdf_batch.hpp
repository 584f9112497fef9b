// Batched float32 ReDSDF inference: d and grad_p d of many points in one pass.
//
// Points run in fixed blocks of kRedsdfBlock rows (independent of the thread
// count, so every result is identical for any number of threads). Per block:
// a forward pass through every layer as GEMMs, keeping the activations, then
// one fused backward pass for the input gradient only (no weight gradients):
// the seeds on f, b0 and b1 come from the blend's chain rule, so d is a
// scalar and one backward gives all of grad_p d. Cost ~ 2x the forward MACs
// (the first layer's backward only forms its 3 point columns).
//
// Scratch is one slot per TBB worker (plus one, under a mutex, for threads
// outside the arena), sized at construction; evaluate() never allocates.
#pragma once
#include <cstdint>
#include <mutex>
#include <vector>

#include "src/core/redsdf_model.hpp"

namespace atacom {

constexpr int kRedsdfBlock = 64;

class RedsdfBatch {
 public:
  explicit RedsdfBatch(const RedsdfModel& model);  // keeps a reference: the model must outlive it

  // p: (n x 3) points. pose: (n x P) per-point poses, or (1 x P) shared by all
  // points when pose_shared; null when P == 0. Writes d (n) and, when grad is
  // not null, grad (n x 3) = grad_p d.
  void evaluate(const float* p, const float* pose, bool pose_shared, int64_t n, float* d, float* grad);

  // The same on the calling thread only, for the rows [lo, hi) (a caller
  // that already runs its own parallel loop).
  // grad_pose (optional, needs grad): (n x P) = grad_pose d, from the same
  // backward pass (the first layer's backward then forms all its columns).
  void evaluate_range(const float* p, const float* pose, bool pose_shared, int64_t lo, int64_t hi, float* d,
                      float* grad, float* grad_pose = nullptr);

  const RedsdfModel& model() const { return *m_; }
  // FLOPs per point with gradient (2 per multiply-add, forward + input backward).
  double flops_per_point() const;

 private:
  struct Slot {
    AlignedVector<float> x;     // (block x in) inputs
    AlignedVector<float> acts;  // every layer's output, (block x width) each
    AlignedVector<float> ga, gb;  // (block x max width) backward ping-pong
    AlignedVector<float> gs;      // (block x side_width) side head's hidden gradient
    AlignedVector<float> seed_f;  // (block) dd/df
    AlignedVector<float> seed_b;  // (block x 2) dd/d(b0, b1)
  };
  void run_block(Slot& s, const float* p, const float* pose, bool pose_shared, int64_t lo, int rows, float* d,
                 float* grad, float* grad_pose) const;

  const RedsdfModel* m_;
  std::vector<size_t> act_off_;  // offsets of each layer's output in Slot::acts (trunk, head, side)
  int max_width_ = 0;
  std::vector<Slot> slots_;      // one per TBB worker, then one for threads outside the arena
  std::mutex external_mutex_;    // guards that last slot
};

}  // namespace atacom
