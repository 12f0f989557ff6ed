#include "server/replication/background_encoder.h"

#include <utility>

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

#include "protocol/codec/region_codec.h"
#include "protocol/layer.h"

namespace loam::server {

BackgroundEncoder::~BackgroundEncoder() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
}

bool BackgroundEncoder::submit(Job job) {
  {
    std::lock_guard lock(mutex_);
    if (queue_.size() >= max_queue_) return false;
    queue_.push_back(std::move(job));
    if (!worker_.joinable()) worker_ = std::thread([this] { run(); });
  }
  wake_.notify_one();
  return true;
}

std::vector<BackgroundEncoder::Done> BackgroundEncoder::take() {
  std::lock_guard lock(mutex_);
  return std::exchange(done_, {});
}

void BackgroundEncoder::wait_idle() {
  std::unique_lock lock(mutex_);
  idle_.wait(lock, [&] { return queue_.empty() && !busy_; });
}

void BackgroundEncoder::run() {
#ifdef __linux__
  // The lowest priority: on a small machine the re-encodes take only the time the tick thread
  // and the clients leave (Linux niceness is per thread).
  (void)setpriority(PRIO_PROCESS, pid_t(syscall(SYS_gettid)), 19);
#endif
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    Job job = std::move(queue_.front());
    queue_.pop_front();
    busy_ = true;
    lock.unlock();
    Result<std::vector<uint8_t>> payload = visit_layer(job.key.tile.layer, [&](auto row) {
      using R = decltype(row);
      return encode_region(RegionEncoding::kBest, std::span<const typename R::Sample>(samples_of<R>(job)),
                           job.width, job.height);
    });
    lock.lock();
    done_.push_back({job.key, std::move(payload)});
    busy_ = false;
    if (queue_.empty()) idle_.notify_all();
  }
}

}  // namespace loam::server
