// HeapTrimmer: hands the heap's free pages back to the system once a second, from a thread of
// its own, so the server's resident memory follows its caches' budgets.
//
// Tiles (128 KiB coarse, 64 KiB detail), encoded regions and the tick's scratch come and go all
// the time. Served by mmap each (a small M_MMAP_THRESHOLD), every free is a munmap, and on a
// multi-threaded process each munmap flushes the other cores' TLBs: 20 re-subscribing
// spectators spent 40% of the tick thread there (perf, under the fairness suite). Served from the
// heap, freed tiles are reused at once, and malloc_trim returns what stays free.
#pragma once

#include <condition_variable>
#include <mutex>
#include <thread>

namespace loam::server {

class HeapTrimmer {
 public:
  // Also sets the mmap threshold to 4 MiB: blocks that large (a snapshot's buffers) still go to
  // mmap; tiles and regions do not.
  HeapTrimmer();
  ~HeapTrimmer();
  HeapTrimmer(const HeapTrimmer&) = delete;
  HeapTrimmer& operator=(const HeapTrimmer&) = delete;

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace loam::server
