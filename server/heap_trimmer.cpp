#include "server/heap_trimmer.h"

#include <malloc.h>

#include <chrono>

namespace loam::server {

HeapTrimmer::HeapTrimmer() {
  mallopt(M_MMAP_THRESHOLD, 4 * 1024 * 1024);
  thread_ = std::thread([this] {
    std::unique_lock lock(mu_);
    while (!cv_.wait_for(lock, std::chrono::seconds(1), [this] { return stop_; })) {
      lock.unlock();
      malloc_trim(0);
      lock.lock();
    }
  });
}

HeapTrimmer::~HeapTrimmer() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

}  // namespace loam::server
