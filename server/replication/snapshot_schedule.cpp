#include "server/replication/snapshot_schedule.h"

#include <algorithm>
#include <chrono>

namespace loam::server {

namespace {

CoreDuration after(double s) {
  return std::chrono::duration_cast<CoreDuration>(std::chrono::duration<double>(s));
}

}  // namespace

SnapshotSchedule::SnapshotSchedule(const ServerConfig& config, CoreTime now)
    : every_stamps_(config.snapshot_every_stamps),
      interval_s_(config.snapshot_interval_s),
      dirty_bytes_(config.snapshot_dirty_bytes),
      last_(now) {}

bool SnapshotSchedule::due(CoreTime now, const WorldState& w, bool force) const {
  if (!force && now < retry_after_) return false;
  const uint64_t since = w.last_seq - w.snapshot_seq;
  if (since == 0 || w.last_seq == 0) return false;
  if (force) return true;
  const double age = std::chrono::duration<double>(now - last_).count();
  return (dirty_bytes_ > 0 && w.unpersisted_bytes >= dirty_bytes_) ||
         (every_stamps_ > 0 && since >= every_stamps_) || (interval_s_ > 0 && age >= interval_s_);
}

void SnapshotSchedule::began(CoreTime now) { started_ = last_ = now; }

double SnapshotSchedule::failed(CoreTime now) {
  backoff_s_ = backoff_s_ == 0 ? kBackoffMinS : std::min(backoff_s_ * 2.0, kBackoffMaxS);
  retry_after_ = now + after(backoff_s_);
  return backoff_s_;
}

double SnapshotSchedule::written(CoreTime now) {
  backoff_s_ = 0;
  return std::chrono::duration<double, std::milli>(now - started_).count();
}

void StorageRetry::sync_failed(CoreTime now) {
  backoff_s_ = kMinS;
  next_ = now + after(backoff_s_);
}

double StorageRetry::reopen_failed(CoreTime now) {
  backoff_s_ = std::min(backoff_s_ * 2.0, kMaxS);
  next_ = now + after(backoff_s_);
  return backoff_s_;
}

}  // namespace loam::server
