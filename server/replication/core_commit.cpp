// The commit pipeline, part of ReplicationCore: the tick's phases around CommitPipeline
// (commit_pipeline.h): its acks and refusals sent, the storage retried after a failed sync, and
// once applied the history and the events fanned out (one encoding for all). run_tick is the
// order of a tick's phases.
#include "server/replication/core_detail.h"
#include "server/replication/replication_core.h"

namespace loam::server {

using namespace core_detail;

void ReplicationCore::acknowledge(const PendingDeform& p, std::optional<uint64_t> seq) {
  const CommitPipeline::Answer a = commits_.answer(p, seq);
  const auto it = clients_.find(a.to);
  if (it == clients_.end()) return;
  Client& c = it->second;
  if (a.to == p.client) Admission::acknowledged(c.allowance);  // a new connection never took a slot
  send(c, a.ack);
}

bool ReplicationCore::begin_tick(CoreTime now) {
  if (stopping_ || failed_) return false;
  ++tick_;
  last_batch_ = commits_.take_tick(config_.tick_stamp_cost);
  tick_start_counters_ = world_counters_;
  tick_base_tiles_read_ = tick_edited_tiles_loaded_ = 0;
  if (!storage_.writable()) try_resume_storage(now);
  if (commits_.committing().empty() || !storage_.writable()) return true;
  // 1. Sequence and log the whole tick (commit() syncs it once: the durability point).
  if (const Status st = commits_.log(storage_, tick_); !st.ok()) {
    note("fatal", {{"error", st.error().describe()}});
    failed_ = true;
    shutdown("log append failed", now, 0);
    return false;
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
  if (commits_.committing().empty() || failed_) return false;
  const CommitPipeline::Commit done = commits_.commit(storage_);
  if (!done.first_seq) {
    if (done.sync_error) {
      // A full disk or an I/O error: nothing of this tick is durable, so nothing of it is
      // applied or acknowledged. The server keeps serving reads and hashes, refuses edits, and
      // retries the log with a growing interval.
      note("storage_unavailable",
           {{"error", done.sync_error->describe()}, {"refused", std::to_string(done.batch.size())}});
      ++stats_.storage_failures;
      storage_retry_.sync_failed(now);
    }
    refuse(done.batch);
    return false;
  }
  // 2. Acknowledge: durable and sequenced is what an ack promises, so the acks leave now,
  // before the tick's stamps are applied (a costly one delays only the events and regions).
  uint64_t seq = *done.first_seq;
  for (const PendingDeform& p : done.batch) {
    ++stats_.deforms_accepted;
    acknowledge(p, seq++);
  }
  return true;
}

bool ReplicationCore::advance_apply() { return commits_.advance(publisher()); }

void ReplicationCore::finish_applying() { commits_.finish(publisher()); }

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
