// Exactly once across reconnects: what became of each client's recent Deforms, by the resume
// key its Hello carries. A Deform resent on a new connection with the same key and client_seq
// is answered with its first answer (or, still waiting for its tick, answered once when it
// commits) and never applied again. Bounded: the last `per_key` Deforms of the last `keys`
// keys. Pure.
#pragma once

#include <cstdint>
#include <list>
#include <map>
#include <optional>

#include "protocol/wire/messages.h"

namespace loam::server {

class DeformLedger {
 public:
  DeformLedger(size_t keys, size_t per_key) : max_keys_(keys), per_key_(per_key) {}

  enum class Seen { kNew, kPending, kAnswered };
  struct Lookup {
    Seen seen = Seen::kNew;
    wire::DeformAck ack;  // kAnswered: the answer it got
  };
  Lookup lookup(uint64_t key, uint32_t client_seq) const;
  // Whether it holds anything of `key` (answers of an earlier connection of the same client).
  bool knows(uint64_t key) const { return keys_.count(key) != 0; }
  // Admitted, waiting for a tick.
  void admitted(uint64_t key, uint32_t client_seq);
  // Its answer (accepted with its global sequence, or refused).
  void answered(uint64_t key, const wire::DeformAck& ack);

 private:
  struct Entry {
    std::map<uint32_t, std::optional<wire::DeformAck>> deforms;  // client_seq -> answer (none: pending)
    std::list<uint64_t>::iterator lru;
  };
  Entry& touch(uint64_t key);

  size_t max_keys_, per_key_;
  std::map<uint64_t, Entry> keys_;
  std::list<uint64_t> lru_;  // most recently used first
};

}  // namespace loam::server
