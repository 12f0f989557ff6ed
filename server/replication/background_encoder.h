// The best-mode encoder off the tick thread: a tile region already sent in the fast mode and
// wanted again (a tile many clients join on, or kept long in the cache) is re-encoded in the
// best mode (~35x slower, ~6% smaller, docs/codec.md) on a worker thread, so the tick never
// waits for it. The owner submits copies of the samples and collects finished payloads; a full
// queue refuses new jobs rather than grow.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <thread>
#include <vector>

#include "protocol/result.h"
#include "server/replication/region_key.h"

namespace loam::server {

class BackgroundEncoder {
 public:
  struct Job {
    RegionKey key;
    uint32_t width = 0, height = 0;
    std::vector<uint16_t> coarse;  // coarse tiles
    std::vector<int8_t> detail;    // detail tiles
  };
  struct Done {
    RegionKey key;
    Result<std::vector<uint8_t>> payload;
  };

  explicit BackgroundEncoder(size_t max_queue) : max_queue_(max_queue) {}
  ~BackgroundEncoder();
  BackgroundEncoder(const BackgroundEncoder&) = delete;
  BackgroundEncoder& operator=(const BackgroundEncoder&) = delete;

  // Queues a job (the worker starts on the first); false when the queue is full.
  bool submit(Job job);
  // The payloads finished since the last call.
  std::vector<Done> take();
  // Waits until every submitted job is finished (tests, shutdown).
  void wait_idle();

 private:
  void run();

  size_t max_queue_;
  std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::deque<Job> queue_;
  std::vector<Done> done_;
  bool busy_ = false, stop_ = false;
  std::thread worker_;
};

}  // namespace loam::server
