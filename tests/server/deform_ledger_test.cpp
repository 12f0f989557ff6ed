// The Deform ledger (server/replication/deform_ledger.h): answers by resume key and client
// sequence, bounded per key and in keys.
#include "server/replication/deform_ledger.h"

#include <gtest/gtest.h>

namespace loam::server {
namespace {

wire::DeformAck answer(uint32_t seq, uint64_t global) {
  wire::DeformAck a;
  a.client_seq = seq;
  a.accepted = true;
  a.global_seq = global;
  return a;
}

TEST(DeformLedger, RemembersPendingThenAnsweredDeformsPerKey) {
  DeformLedger ledger(8, 8);
  EXPECT_FALSE(ledger.knows(1));
  EXPECT_EQ(ledger.lookup(1, 5).seen, DeformLedger::Seen::kNew);
  ledger.admitted(1, 5);
  EXPECT_TRUE(ledger.knows(1));
  EXPECT_EQ(ledger.lookup(1, 5).seen, DeformLedger::Seen::kPending);
  ledger.answered(1, answer(5, 77));
  const DeformLedger::Lookup l = ledger.lookup(1, 5);
  EXPECT_EQ(l.seen, DeformLedger::Seen::kAnswered);
  EXPECT_EQ(l.ack.global_seq, 77u);
  EXPECT_EQ(ledger.lookup(2, 5).seen, DeformLedger::Seen::kNew);  // another key's 5 is its own
}

TEST(DeformLedger, KeepsTheNewestDeformsOfTheMostRecentKeys) {
  DeformLedger ledger(2, 3);
  for (uint32_t s = 1; s <= 5; ++s) ledger.answered(10, answer(s, s));
  EXPECT_EQ(ledger.lookup(10, 2).seen, DeformLedger::Seen::kNew);  // the oldest went
  EXPECT_EQ(ledger.lookup(10, 3).seen, DeformLedger::Seen::kAnswered);
  EXPECT_EQ(ledger.lookup(10, 5).seen, DeformLedger::Seen::kAnswered);
  ledger.admitted(20, 1);
  ledger.admitted(10, 6);  // 10 is the most recent now
  ledger.admitted(30, 1);  // a third key: 20, the least recently used, is forgotten
  EXPECT_FALSE(ledger.knows(20));
  EXPECT_TRUE(ledger.knows(10));
  EXPECT_TRUE(ledger.knows(30));
}

}  // namespace
}  // namespace loam::server
