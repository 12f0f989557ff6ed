// CommitPipeline (server/replication/commit_pipeline.h) on its own, over a real log in a
// temporary folder: a tick's stamps taken up to its cost budget, logged and synced at the next
// sequences (durable: a reopened folder recovers them), applied in order, and each Deform
// answered once, to the newest connection of its resume key.
#include "server/replication/commit_pipeline.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "protocol/stamps/stamp_validate.h"

namespace loam::server {
namespace {

class CommitPipelineTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("loam_commit_pipeline_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    auto opened = open_storage(dir_.string(), "", {});
    ASSERT_TRUE(opened.ok()) << opened.error().describe();
    opened_ = std::make_unique<OpenedStorage>(std::move(*opened));
    pipeline_ = std::make_unique<CommitPipeline>(opened_->terrain, 1u << 20);
  }
  void TearDown() override {
    pipeline_.reset();
    opened_.reset();
    std::filesystem::remove_all(dir_);
  }
  PendingDeform deform(uint32_t client, uint32_t client_seq, uint64_t cost, uint64_t key = 0) const {
    StampParams s;
    s.kind = StampKind::kCrater;
    s.center_x = 100.0 + 10.0 * client_seq;
    s.center_y = 200.0;
    s.radius = 12;
    s.intensity = 1.5;
    s.shape = 0.3;
    auto q = validate_stamp(s, opened_->terrain.world().params(), opened_->terrain.limits());
    EXPECT_TRUE(q.ok());
    return {client, client_seq, *q, cost, key};
  }
  // The whole tick: take, log, commit.
  CommitPipeline::Commit tick(uint64_t budget, uint64_t tick) {
    pipeline_->take_tick(budget);
    EXPECT_TRUE(pipeline_->log(opened_->storage, tick).ok());
    return pipeline_->commit(opened_->storage);
  }

  std::filesystem::path dir_;
  std::unique_ptr<OpenedStorage> opened_;
  std::unique_ptr<CommitPipeline> pipeline_;
};

TEST_F(CommitPipelineTest, ATickTakesStampsInOrderUpToItsCostBudgetAndAtLeastOne) {
  pipeline_->queue(deform(1, 1, 700));
  pipeline_->queue(deform(1, 2, 200));
  pipeline_->queue(deform(2, 1, 200));
  pipeline_->queue(deform(2, 2, 5000));
  EXPECT_EQ(pipeline_->take_tick(1000), 2u) << "700 + 200 fit, the third would not";
  ASSERT_TRUE(pipeline_->log(opened_->storage, 1).ok());
  const auto first = pipeline_->commit(opened_->storage);
  ASSERT_TRUE(first.first_seq);
  EXPECT_EQ(*first.first_seq, 1u);
  EXPECT_EQ(first.batch.size(), 2u);
  // A budget's worth waits for the apply: no stamp is taken until the worker has it.
  EXPECT_EQ(pipeline_->take_tick(900), 0u);
  EXPECT_FALSE(pipeline_->settled());
  pipeline_->finish([](std::vector<ApplyWorker::Output>) {});
  EXPECT_TRUE(pipeline_->settled());
  // One stamp over the whole budget still goes, alone.
  EXPECT_EQ(pipeline_->take_tick(100), 1u);
  EXPECT_EQ(pipeline_->committing()[0].client_seq, 1u);
  EXPECT_EQ(pipeline_->take_tick(100), 1u);
  EXPECT_EQ(pipeline_->committing()[0].cost, 5000u);
  EXPECT_TRUE(pipeline_->queued().empty());
}

TEST_F(CommitPipelineTest, CommittedStampsAreDurableSequencedAndAppliedInOrder) {
  for (uint32_t i = 1; i <= 5; ++i) pipeline_->queue(deform(1, i, 10));
  const auto c = tick(1u << 20, 1);
  ASSERT_TRUE(c.first_seq);
  EXPECT_EQ(*c.first_seq, 1u);
  EXPECT_EQ(pipeline_->sequenced_seq(), 5u);
  EXPECT_EQ(pipeline_->published_seq(), 0u) << "sequenced is not applied";
  std::vector<uint64_t> published;
  pipeline_->finish([&](std::vector<ApplyWorker::Output> out) {
    for (const auto& o : out) {
      EXPECT_TRUE(o.applied.ok());
      published.push_back(o.seq);
    }
  });
  EXPECT_EQ(published, (std::vector<uint64_t>{1, 2, 3, 4, 5}));
  EXPECT_EQ(pipeline_->published_seq(), 5u);
  EXPECT_EQ(opened_->terrain.last_seq(), 5u);
  const uint64_t hash = opened_->terrain.world().world_hash();
  // The sync was the durability point: the folder reopened recovers all five.
  pipeline_.reset();
  opened_.reset();
  auto again = open_storage(dir_.string(), "", {});
  ASSERT_TRUE(again.ok()) << again.error().describe();
  EXPECT_EQ(again->terrain.last_seq(), 5u);
  EXPECT_EQ(again->terrain.world().world_hash(), hash);
}

TEST_F(CommitPipelineTest, AnAnswerGoesToTheNewestConnectionOfItsKeyAndTheLedgerKeepsIt) {
  pipeline_->claim_key(77, 1);
  pipeline_->queue(deform(1, 9, 10, 77));
  EXPECT_EQ(pipeline_->ledger().lookup(77, 9).seen, DeformLedger::Seen::kPending);
  // The client reconnects before its tick: the new connection takes the key.
  pipeline_->claim_key(77, 2);
  pipeline_->release_key(77, 1);  // the old one leaving does not take the key back
  const auto c = tick(1u << 20, 1);
  ASSERT_TRUE(c.first_seq);
  const CommitPipeline::Answer a = pipeline_->answer(c.batch[0], *c.first_seq);
  EXPECT_EQ(a.to, 2u);
  EXPECT_TRUE(a.ack.accepted);
  EXPECT_EQ(a.ack.global_seq, 1u);
  EXPECT_EQ(a.ack.client_seq, 9u);
  const DeformLedger::Lookup seen = pipeline_->ledger().lookup(77, 9);
  EXPECT_EQ(seen.seen, DeformLedger::Seen::kAnswered);
  EXPECT_EQ(seen.ack.global_seq, 1u);
  // Without a key the sender gets it; a refusal says why.
  const CommitPipeline::Answer refused = pipeline_->answer(deform(3, 4, 10), std::nullopt);
  EXPECT_EQ(refused.to, 3u);
  EXPECT_FALSE(refused.ack.accepted);
  EXPECT_EQ(refused.ack.reject_code, wire::WireErrorCode::kIo);
  EXPECT_EQ(refused.ack.field, "storage.unavailable");
  pipeline_->release_key(77, 2);
  EXPECT_EQ(pipeline_->answer(c.batch[0], *c.first_seq).to, 1u) << "no owner left: the sender";
  pipeline_->finish([](std::vector<ApplyWorker::Output>) {});
}

TEST_F(CommitPipelineTest, QueuedStampsAreDroppedAtShutdownAndNothingOfThemIsLogged) {
  pipeline_->queue(deform(1, 1, 10));
  pipeline_->queue(deform(1, 2, 10));
  pipeline_->drop_queued();
  EXPECT_EQ(pipeline_->take_tick(1u << 20), 0u);
  const auto c = pipeline_->commit(opened_->storage);
  EXPECT_TRUE(c.batch.empty());
  EXPECT_FALSE(c.first_seq);
  EXPECT_EQ(pipeline_->sequenced_seq(), 0u);
}

}  // namespace
}  // namespace loam::server
