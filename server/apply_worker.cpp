#include "server/apply_worker.h"

#include "protocol/stamps/stamp_apply.h"

namespace loam::server {

ApplyWorker::ApplyWorker(TerrainState& terrain, uint64_t before_samples)
    : terrain_(terrain), before_samples_(before_samples) {
  thread_ = std::thread([this] { loop(); });
}

ApplyWorker::~ApplyWorker() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void ApplyWorker::start(std::vector<Input> job) {
  busy_ = true;
  {
    std::lock_guard lock(mutex_);
    job_ = std::move(job);
  }
  wake_.notify_one();
}

std::optional<std::vector<ApplyWorker::Output>> ApplyWorker::take() {
  if (!busy_) return std::nullopt;
  std::lock_guard lock(mutex_);
  if (!done_) return std::nullopt;
  busy_ = false;
  return std::exchange(done_, std::nullopt);
}

void ApplyWorker::wait() {
  if (!busy_) return;
  std::unique_lock lock(mutex_);
  done_cv_.wait(lock, [&] { return done_.has_value(); });
}

bool ApplyWorker::wait_until(std::chrono::steady_clock::time_point deadline) {
  if (!busy_) return true;
  std::unique_lock lock(mutex_);
  return done_cv_.wait_until(lock, deadline, [&] { return done_.has_value(); });
}

std::vector<ApplyWorker::Output> ApplyWorker::run(const std::vector<Input>& job) {
  std::vector<Output> out;
  out.reserve(job.size());
  for (const Input& in : job) {
    Output o;
    o.seq = in.seq;
    // The samples the stamp may change, as they are now: the tile history keeps them so that a
    // client behind gets a delta against what it holds.
    if (auto reach =
            stamp_reach(in.stamp, terrain_.world().params(), &terrain_.textures(), terrain_.limits()))
      o.before = read_reach(terrain_.world(), in.stamp.layer, *reach, before_samples_);
    o.applied = terrain_.apply(in.stamp, in.seq, in.client);
    o.backend_failures = terrain_.take_backend_failures();
    out.push_back(std::move(o));
  }
  return out;
}

void ApplyWorker::loop() {
  while (true) {
    std::vector<Input> job;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stop_ || job_.has_value(); });
      if (stop_) return;
      job = std::move(*job_);
      job_.reset();
    }
    std::vector<Output> out = run(job);
    {
      std::lock_guard lock(mutex_);
      done_ = std::move(out);
    }
    done_cv_.notify_all();
  }
}

}  // namespace loam::server
