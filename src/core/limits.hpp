// Upper limits on sizes that come from user input (configs, flags, filter
// lines), checked before anything is allocated, and the machine-memory check
// for the few allocations that scale with a product of them (replay buffer,
// networks). docs/security.md lists them; a value beyond a limit is an error
// naming the key, never a bare std::bad_alloc.
#pragma once
#include <cstdint>
#include <string>

namespace atacom::limits {

constexpr int64_t kMaxSteps = 1'000'000'000'000;    // env steps of a run or a rollout (10^12)
constexpr int kMaxEnvs = 1 << 20;                   // parallel envs of a run or a rollout
constexpr int kMaxEvalEpisodes = 100'000;           // evaluation episodes (one env each)
constexpr int kMaxShelfTrials = 100'000;            // shelf-real trials (one env each)
constexpr int kMaxHorizon = 10'000'000;             // episode length of any env
constexpr int64_t kMaxReplayCapacity = int64_t{1} << 30;  // transitions
constexpr int kMaxBatchSize = 1 << 16;              // SAC minibatch
constexpr int kMaxMlpWidth = 8192;                  // one hidden layer
constexpr int kMaxMlpLayers = 16;                   // hidden layers
constexpr int64_t kMaxMlpParams = int64_t{1} << 27; // parameters of one network (512 MB as float)
constexpr int kMaxThreads = 1024;                   // --threads (above the machine's count: clamped)
constexpr int kMaxRenderSteps = 10'000;             // `atacom render`: steps of the one episode a page shows

// `atacom filter`
constexpr int64_t kFilterDefaultLineBytes = int64_t{4} << 20;  // longest input line by default (4 MiB)
constexpr int64_t kFilterMaxLineBytes = int64_t{1} << 30;      // longest --max-line-bytes (1 GiB)
constexpr int kFilterMaxDim = 1024;                            // n, m, k and p of one request

// Physical memory of this machine in bytes (0 when unknown).
uint64_t physical_memory_bytes();

// Throws std::invalid_argument "<what> needs <X> GB, more than this machine's
// <Y> GB of memory" when `bytes` exceeds the physical memory. The message
// names the keys to reduce (`what` says them, e.g. "sac.replay_capacity =
// 100000000 (replay buffer)").
void require_memory(double bytes, const std::string& what);

}  // namespace atacom::limits
