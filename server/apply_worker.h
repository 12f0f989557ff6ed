// Applies sequenced stamps to the terrain off the I/O thread, in sequence order. The core logs
// and acknowledges a tick's stamps (durable and sequenced), hands them here, and goes on
// answering pings, handshakes and acks while a costly stamp runs; what needs the applied
// result (events, regions, hashes, snapshots) waits for the job to finish.
//
// The core never waits on it with a deadline: it takes a finished job or says it is waiting
// (ReplicationCore::applying()), and the transport, which owns the clock, waits here up to its
// apply wait (wait_until). Only shutdown and tests wait without a deadline (wait).
// While a job runs the worker owns the TerrainState's world: the owner touches it only while
// busy() is false (it reads its parameters and textures, which never change, at any time).
// Either backend runs here: the GPU backend makes its context current for each call.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "protocol/result.h"
#include "server/replication/tile_history.h"
#include "server/terrain_state.h"

namespace loam::server {

class ApplyWorker {
 public:
  struct Input {
    uint64_t seq = 0;
    uint32_t client = 0;
    QuantizedStamp stamp;
  };
  struct Output {
    uint64_t seq = 0;
    Result<AppliedStamp> applied = make_error(ErrorCode::kInvalidArgument, "apply", "not run");
    std::vector<TileSamples> before;  // the samples the stamp may change, as they were (history)
    std::vector<Error> backend_failures;
  };

  // `before_samples`: the largest reach whose samples are kept for the history (read_reach).
  ApplyWorker(TerrainState& terrain, uint64_t before_samples);
  ~ApplyWorker();
  ApplyWorker(const ApplyWorker&) = delete;
  ApplyWorker& operator=(const ApplyWorker&) = delete;

  // A job started and its outputs not yet taken.
  bool busy() const { return busy_; }
  // Starts applying `job` (consecutive sequences after the terrain's last); requires !busy().
  void start(std::vector<Input> job);
  // The job's outputs once it has finished; nullopt while it runs (or when no job was started).
  // Never blocks.
  std::optional<std::vector<Output>> take();
  // Blocks until the job started has finished (at once when none runs).
  void wait();
  // Blocks until the job has finished or `deadline` has passed; true when it has finished (or
  // none runs). The transport's apply wait.
  bool wait_until(std::chrono::steady_clock::time_point deadline);

 private:
  std::vector<Output> run(const std::vector<Input>& job);
  void loop();

  TerrainState& terrain_;
  uint64_t before_samples_;
  bool busy_ = false;  // owner's thread only
  std::mutex mutex_;
  std::condition_variable wake_, done_cv_;
  std::optional<std::vector<Input>> job_;
  std::optional<std::vector<Output>> done_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace loam::server
