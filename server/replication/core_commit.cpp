// The commit pipeline, part of ReplicationCore: a tick's stamps sequenced and logged, one sync
// (the durability point), their acks, the apply on the worker in sequence order, and once
// applied the history and the events fanned out (one encoding for all). run_tick is the order
// of a tick's phases.
#include "server/replication/core_detail.h"
#include "server/replication/replication_core.h"

namespace loam::server {

using namespace core_detail;

void ReplicationCore::acknowledge(const PendingDeform& p, std::optional<uint64_t> seq) {
  wire::DeformAck ack;
  ack.client_seq = p.client_seq;
  ack.accepted = seq.has_value();
  if (seq) {
    ack.global_seq = *seq;
  } else {
    ack.reject_code = wire::WireErrorCode::kIo;
    ack.field = "storage.unavailable";
  }
  if (p.key != 0) ledger_.answered(p.key, ack);
  // The sender, or the newest connection of its resume key when it has reconnected since.
  ClientId to = p.client;
  if (p.key != 0) {
    if (const auto k = key_owner_.find(p.key); k != key_owner_.end()) to = k->second;
  }
  const auto it = clients_.find(to);
  if (it == clients_.end()) return;
  Client& c = it->second;
  if (to == p.client && c.unacked > 0) --c.unacked;  // its slot; a new connection never took one
  send(c, ack);
}

bool ReplicationCore::begin_tick(CoreTime now) {
  if (stopping_ || failed_) return false;
  ++tick_;
  // This tick's stamps, in order, up to the tick's cost budget (at least one): the rest wait,
  // and all wait while a tick's worth is already sequenced and waiting for the apply worker.
  size_t n = 0;
  uint64_t spent = 0;
  while (n < pending_.size() && to_apply_cost_ < config_.tick_stamp_cost &&
         (n == 0 || spent + pending_[n].cost <= config_.tick_stamp_cost))
    spent += pending_[n++].cost;
  committing_.assign(std::make_move_iterator(pending_.begin()),
                     std::make_move_iterator(pending_.begin() + ptrdiff_t(n)));
  pending_.erase(pending_.begin(), pending_.begin() + ptrdiff_t(n));
  last_batch_ = committing_.size();
  tick_start_counters_ = world_counters_;
  tick_base_tiles_read_ = tick_edited_tiles_loaded_ = 0;
  if (!storage_.writable()) try_resume_storage(now);
  if (committing_.empty() || !storage_.writable()) return true;
  // 1. Sequence and log the whole tick (commit() syncs it once: the durability point).
  uint64_t seq = sequenced_seq_;
  for (const PendingDeform& p : committing_) {
    const Status st = storage_.append({++seq, tick_, p.client, p.stamp});
    if (!st.ok()) {  // a broken invariant (sequence or tick), not the disk
      note("fatal", {{"error", st.error().describe()}});
      failed_ = true;
      committing_.clear();
      shutdown("log append failed", now, 0);
      return false;
    }
  }
  return true;
}

void ReplicationCore::refuse(const std::vector<PendingDeform>& batch) {
  for (const PendingDeform& p : batch) {
    ++stats_.deforms_rejected;
    ++stats_.deforms_rejected_by[wire::to_string(wire::WireErrorCode::kIo)];
    acknowledge(p, std::nullopt);
  }
}

bool ReplicationCore::commit(CoreTime now) {
  if (committing_.empty() || failed_) return false;
  const std::vector<PendingDeform> batch = std::exchange(committing_, {});
  if (!storage_.writable()) {
    refuse(batch);
    return false;
  }
  if (const Status st = storage_.sync(); !st.ok()) {
    // A full disk or an I/O error: nothing of this tick is durable (the writer cut the file
    // back), so nothing of it is applied or acknowledged. The server keeps serving reads and
    // hashes, refuses edits, and retries the log with a growing interval.
    note("storage_unavailable",
         {{"error", st.error().describe()}, {"refused", std::to_string(batch.size())}});
    ++stats_.storage_failures;
    resume_backoff_s_ = kResumeBackoffMinS;
    next_resume_try_ = now + after(resume_backoff_s_);
    refuse(batch);
    return false;
  }
  // 2. Acknowledge: durable and sequenced is what an ack promises, so the acks leave now,
  // before the tick's stamps are applied (a costly one delays only the events and regions).
  for (const PendingDeform& p : batch) {
    ++stats_.deforms_accepted;
    acknowledge(p, ++sequenced_seq_);
    to_apply_.push_back({sequenced_seq_, p.client, p.stamp});
    to_apply_cost_ += p.cost;
  }
  return true;
}

bool ReplicationCore::advance_apply() {
  while (true) {
    if (applier_->busy()) {
      auto done = applier_->take();
      if (!done) return false;
      publish(std::move(*done));
    }
    if (to_apply_.empty()) return true;
    applier_->start(std::exchange(to_apply_, {}));
    to_apply_cost_ = 0;
  }
}

void ReplicationCore::finish_applying() {
  while (!advance_apply()) applier_->wait();
}

bool run_tick(ReplicationCore& core, CoreTime now, UnixMicros wall, const TickHooks& hooks) {
  const auto done = [&](TickPhase p) {
    if (hooks.phase_done) hooks.phase_done(p);
  };
  if (!core.begin_tick(now)) return false;
  done(TickPhase::kLogged);
  const bool acks = core.commit(now);
  done(TickPhase::kSynced);
  if (core.failed()) return false;
  if (acks && hooks.acks_ready) hooks.acks_ready();
  done(TickPhase::kCommitted);
  bool world_free = core.advance_apply();
  while (!world_free) {
    ApplyWorker* worker = core.applying();
    if (worker == nullptr || !hooks.wait_for_apply || !hooks.wait_for_apply(*worker)) break;
    world_free = core.advance_apply();
  }
  done(TickPhase::kApplied);
  // The apply goes on: what needs its result waits for a later tick.
  if (!world_free) return false;
  core.stream(now, hooks.unsent);
  done(TickPhase::kStreamed);
  core.persist(now, wall);
  done(TickPhase::kPersisted);
  core.trim();
  done(TickPhase::kTrimmed);
  return true;
}

// 3. Applied (on the worker, in order): the history, the events (one encoding for every
// client), the plans.
void ReplicationCore::publish(std::vector<ApplyWorker::Output> applied) {
  for (ApplyWorker::Output& o : applied) {
    published_seq_ = o.seq;
    for (const Error& e : o.backend_failures)
      note("backend_error", {{"seq", std::to_string(o.seq)}, {"error", e.describe()}, {"fallback", "cpu"}});
    if (!o.applied) {
      note("apply_error", {{"seq", std::to_string(o.seq)}, {"error", o.applied.error().describe()}});
      continue;
    }
    const AppliedStamp& a = *o.applied;
    history_.record(a.changes, o.before);
    wire::DeformEvent ev;
    ev.global_seq = a.seq;
    ev.origin_client_id = a.client_id;
    ev.stamp = a.stamp;
    ev.contact = a.contact;
    ev.base_versions = a.base_versions;
    if (ev.base_versions.size() > wire::kMaxEventTiles) ev.base_versions.clear();  // regions only
    FramePtr frame = encode(ev, out_);
    if (!frame) ev.base_versions.clear();  // no event then: the plan sends regions
    for (auto& [id, c] : clients_) {
      if (c.state != Client::State::kReady) continue;
      if (!c.tiles.plan_event(ev, a.changes)) continue;
      if (frame) {
        send_frame(id, frame);
        ++stats_.events_sent;
      }
    }
  }
}

}  // namespace loam::server
