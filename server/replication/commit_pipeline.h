// The commit pipeline: a Deform admitted waits for its tick; the tick takes stamps in order up
// to its cost budget, sequences and logs them, syncs once (the durability point: an ack means
// durable and sequenced), and hands them to the apply worker in sequence order; what the worker
// finishes is published. It also answers Deforms across reconnects exactly once: the ledger of
// answers by resume key, and which connection of a key gets the answers now.
//
// It owns the queue, the sequence counters, the ledger and the apply worker. Storage is the
// core's (snapshots use it too) and is passed in; the core turns what it returns into frames.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "protocol/wire/messages.h"
#include "server/apply_worker.h"
#include "server/replication/deform_ledger.h"
#include "server/storage.h"

namespace loam::server {

// A Deform admitted, waiting for its tick.
struct PendingDeform {
  uint32_t client = 0;
  uint32_t client_seq = 0;
  QuantizedStamp stamp;
  uint64_t cost = 0;  // its sample updates (stamp_cost)
  uint64_t key = 0;   // the sender's resume key (0: none)
};

class CommitPipeline {
 public:
  // Sequences continue the terrain's; `apply_history_bytes` bounds the samples the worker
  // keeps from before each stamp (the history).
  CommitPipeline(TerrainState& terrain, size_t apply_history_bytes);

  // Admitted: waits for a tick, and the ledger knows it is pending.
  void queue(PendingDeform p);
  // Takes the tick's stamps in order up to `cost_budget` (at least one; none while a budget's
  // worth is already sequenced and waiting for the apply). The number taken.
  size_t take_tick(uint64_t cost_budget);
  // Logs the tick's stamps at the sequences after the last committed. An error is a broken
  // invariant (a sequence or tick out of order), not the disk: the tick's stamps are dropped.
  Status log(Storage& storage, uint64_t tick);

  // The tick's stamps after the durability point. Committed: the i-th got sequence
  // first_seq + i and waits for the apply. Refused (the log is not writable, or its sync
  // failed: sync_error): nothing of it is logged durably or applied.
  struct Commit {
    std::vector<PendingDeform> batch;
    std::optional<uint64_t> first_seq;
    std::optional<Error> sync_error;
  };
  Commit commit(Storage& storage);

  // The answer to a Deform (sequenced, or refused with `storage.unavailable`), recorded in the
  // ledger, and who gets it: the sender, or the newest connection of its resume key.
  struct Answer {
    uint32_t to = 0;
    wire::DeformAck ack;
  };
  Answer answer(const PendingDeform& p, std::optional<uint64_t> seq);
  // The resume keys' newest connections.
  void claim_key(uint64_t key, uint32_t client);
  void release_key(uint64_t key, uint32_t client);
  DeformLedger& ledger() { return ledger_; }
  const DeformLedger& ledger() const { return ledger_; }

  // Hands what the worker finished to `publish` (in sequence order) and starts what is
  // sequenced. True once the world is free (no apply runs).
  using Publish = std::function<void(std::vector<ApplyWorker::Output>)>;
  bool advance(const Publish& publish);
  // Waits for the apply in flight and applies everything sequenced.
  void finish(const Publish& publish);
  // The worker while it applies (the tick's wait), else null.
  ApplyWorker* applying() { return applier_->busy() ? applier_.get() : nullptr; }
  bool busy() const { return applier_->busy(); }
  // No apply runs and nothing sequenced waits for one: the world is at the last sequence.
  bool settled() const { return !applier_->busy() && to_apply_.empty(); }

  // Stops taking stamps: those queued were never acknowledged, so nothing promised is lost.
  void drop_queued() { queued_.clear(); }
  const std::vector<PendingDeform>& queued() const { return queued_; }
  const std::vector<PendingDeform>& committing() const { return committing_; }
  uint64_t sequenced_seq() const { return sequenced_seq_; }
  uint64_t published_seq() const { return published_seq_; }

 private:
  std::vector<PendingDeform> queued_;
  std::vector<PendingDeform> committing_;  // taken by take_tick, logged, waiting for commit
  // Sequenced, logged and acknowledged, waiting for the apply worker, in order.
  std::vector<ApplyWorker::Input> to_apply_;
  uint64_t to_apply_cost_ = 0;
  std::unique_ptr<ApplyWorker> applier_;
  uint64_t sequenced_seq_ = 0, published_seq_ = 0;
  DeformLedger ledger_{4096, 1024};
  std::map<uint64_t, uint32_t> key_owner_;  // resume key -> its newest connection
};

}  // namespace loam::server
