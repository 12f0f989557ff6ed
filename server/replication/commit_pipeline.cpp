#include "server/replication/commit_pipeline.h"

namespace loam::server {

CommitPipeline::CommitPipeline(TerrainState& terrain, size_t apply_history_bytes)
    : applier_(std::make_unique<ApplyWorker>(terrain, apply_history_bytes)),
      sequenced_seq_(terrain.last_seq()),
      published_seq_(terrain.last_seq()) {}

void CommitPipeline::queue(PendingDeform p) {
  if (p.key != 0) ledger_.admitted(p.key, p.client_seq);
  queued_.push_back(std::move(p));
}

size_t CommitPipeline::take_tick(uint64_t cost_budget) {
  // The rest wait, and all wait while a tick's worth is already waiting for the apply worker.
  size_t n = 0;
  uint64_t spent = 0;
  while (n < queued_.size() && to_apply_cost_ < cost_budget &&
         (n == 0 || spent + queued_[n].cost <= cost_budget))
    spent += queued_[n++].cost;
  committing_.assign(std::make_move_iterator(queued_.begin()),
                     std::make_move_iterator(queued_.begin() + ptrdiff_t(n)));
  queued_.erase(queued_.begin(), queued_.begin() + ptrdiff_t(n));
  return n;
}

Status CommitPipeline::log(Storage& storage, uint64_t tick) {
  uint64_t seq = sequenced_seq_;
  for (const PendingDeform& p : committing_) {
    if (Status st = storage.append({++seq, tick, p.client, p.stamp}); !st.ok()) {
      committing_.clear();
      return st;
    }
  }
  return {};
}

CommitPipeline::Commit CommitPipeline::commit(Storage& storage) {
  Commit c;
  c.batch = std::exchange(committing_, {});
  if (c.batch.empty() || !storage.writable()) return c;
  if (Status st = storage.sync(); !st.ok()) {
    // Nothing of this tick is durable (the writer cut the file back).
    c.sync_error = st.error();
    return c;
  }
  c.first_seq = sequenced_seq_ + 1;
  for (const PendingDeform& p : c.batch) {
    to_apply_.push_back({++sequenced_seq_, p.client, p.stamp});
    to_apply_cost_ += p.cost;
  }
  return c;
}

CommitPipeline::Answer CommitPipeline::answer(const PendingDeform& p, std::optional<uint64_t> seq) {
  Answer a;
  a.ack.client_seq = p.client_seq;
  a.ack.accepted = seq.has_value();
  if (seq) {
    a.ack.global_seq = *seq;
  } else {
    a.ack.reject_code = wire::WireErrorCode::kIo;
    a.ack.field = "storage.unavailable";
  }
  a.to = p.client;
  if (p.key != 0) {
    ledger_.answered(p.key, a.ack);
    if (const auto k = key_owner_.find(p.key); k != key_owner_.end()) a.to = k->second;
  }
  return a;
}

void CommitPipeline::claim_key(uint64_t key, uint32_t client) {
  if (key != 0) key_owner_[key] = client;
}

void CommitPipeline::release_key(uint64_t key, uint32_t client) {
  if (const auto k = key_owner_.find(key); k != key_owner_.end() && k->second == client) key_owner_.erase(k);
}

bool CommitPipeline::advance(const Publish& publish) {
  while (true) {
    if (applier_->busy()) {
      auto done = applier_->take();
      if (!done) return false;
      if (!done->empty()) published_seq_ = done->back().seq;
      publish(std::move(*done));
    }
    if (to_apply_.empty()) return true;
    applier_->start(std::exchange(to_apply_, {}));
    to_apply_cost_ = 0;
  }
}

void CommitPipeline::finish(const Publish& publish) {
  while (!advance(publish)) applier_->wait();
}

}  // namespace loam::server
