#include "server/replication/deform_ledger.h"

namespace loam::server {

DeformLedger::Lookup DeformLedger::lookup(uint64_t key, uint32_t client_seq) const {
  const auto k = keys_.find(key);
  if (k == keys_.end()) return {};
  const auto d = k->second.deforms.find(client_seq);
  if (d == k->second.deforms.end()) return {};
  if (!d->second) return {Seen::kPending, {}};
  return {Seen::kAnswered, *d->second};
}

DeformLedger::Entry& DeformLedger::touch(uint64_t key) {
  auto it = keys_.find(key);
  if (it == keys_.end()) {
    if (keys_.size() >= max_keys_ && !lru_.empty()) {
      keys_.erase(lru_.back());
      lru_.pop_back();
    }
    lru_.push_front(key);
    it = keys_.emplace(key, Entry{{}, lru_.begin()}).first;
  } else {
    lru_.splice(lru_.begin(), lru_, it->second.lru);
  }
  return it->second;
}

void DeformLedger::admitted(uint64_t key, uint32_t client_seq) {
  if (max_keys_ == 0 || per_key_ == 0) return;
  Entry& e = touch(key);
  e.deforms[client_seq] = std::nullopt;
  // The oldest sequence numbers go first (a client's numbers only grow).
  while (e.deforms.size() > per_key_) e.deforms.erase(e.deforms.begin());
}

void DeformLedger::answered(uint64_t key, const wire::DeformAck& ack) {
  if (max_keys_ == 0 || per_key_ == 0) return;
  Entry& e = touch(key);
  e.deforms[ack.client_seq] = ack;
  while (e.deforms.size() > per_key_) e.deforms.erase(e.deforms.begin());
}

}  // namespace loam::server
