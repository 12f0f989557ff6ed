// Incremental snapshots (protocol/snapshot/snapshot_store.h): a snapshot writes only the tiles
// changed since the previous one, loads back to the same world at every mip, lets the world
// evict edited tiles and read them back unchanged, refuses damage, keeps the files near the
// live tiles by compaction, and prunes to its retention.
#include "protocol/snapshot/snapshot_store.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <vector>

#include "protocol/base/tile_base.h"
#include "protocol/snapshot/snapshot.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_mix.h"
#include "protocol/stamps/texture_registry.h"
#include "protocol/tile_hash.h"
#include "protocol/world.h"
#include "tests/support/small_refined.h"
#include "tests/support/world_compare.h"

namespace loam {
namespace {

namespace fs = std::filesystem;

// A 4 x 3 tile world on a refined source, so untouched tiles are the base's and edits differ.
struct Fixture {
  WorldParams params;
  std::shared_ptr<const RefinedTileBase> base;
  fs::path dir;
  TextureRegistry textures;

  explicit Fixture(const char* name) {
    test::SmallRefinedSpec spec;
    spec.source_w = 9, spec.source_h = 7, spec.levels = 7, spec.source_seed = 11, spec.seed = 9;
    spec.amplitude = 200, spec.tiles_x = 4, spec.tiles_y = 3;
    const test::SmallRefined r = test::small_refined(spec);
    EXPECT_TRUE(r.base != nullptr);
    params = r.params;
    base = r.base;
    dir = fs::temp_directory_path() / (std::string("loam_snapshot_store_") + name);
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~Fixture() { fs::remove_all(dir); }

  // `n` random stamps (both layers) with centers in [x0, x1) x [y0, y1) metres, committed one
  // sequence each from `seq` + 1.
  void stamp(World& w, uint64_t& seq, int n, double x0, double y0, double x1, double y1, uint64_t seed) {
    StampRng rng(seed);
    RandomStampOptions o = random_stamp_options(params);
    o.x0 = x0, o.y0 = y0, o.x1 = x1, o.y1 = y1;
    o.max_radius = 30.5;
    o.kinds = {StampKind::kGaussian, StampKind::kCrater, StampKind::kFlatten};
    o.min_intensity[Layer::kCoarse] = 0.5;
    o.min_intensity[Layer::kDetail] = 0.1;
    for (int i = 0; i < n; ++i) {
      auto q = random_valid_stamp(rng, o, params);
      ASSERT_TRUE(q.ok()) << q.error().describe();
      ASSERT_TRUE(apply_stamp(w, *q).ok());
      w.commit(++seq);
    }
  }
};

void expect_same_world(const World& a, const World& b) {
  EXPECT_EQ(a.world_hash(), b.world_hash());
  EXPECT_EQ(test::first_tile_difference(a, b), std::nullopt);
}

TEST(SnapshotStore, ASecondSnapshotWritesOnlyTheTilesChangedSinceTheFirst) {
  Fixture f("incremental");
  World w(f.params, f.base);
  uint64_t seq = 0;
  f.stamp(w, seq, 40, 0, 0, 1024, 768, 1);
  auto store = SnapshotStore::open(f.dir.string());
  auto first = store->write(w, seq, 1, f.textures);
  ASSERT_TRUE(first.ok()) << first.error().describe();
  EXPECT_EQ(first->tiles_written, w.edited_tiles().size());
  EXPECT_TRUE(w.unpersisted_tiles().empty());
  EXPECT_EQ(w.unpersisted_bytes(), 0u);

  // Stamps in one corner change a few tiles (and the mips above them).
  const uint64_t before = seq;
  std::vector<TileCoord> changed_since;
  StampRng rng(7);
  f.stamp(w, seq, 5, 20, 20, 60, 60, 2);
  for (const World::EditedTileInfo& t : w.edited_tiles())
    if (t.state.version > before) changed_since.push_back(t.coord);
  ASSERT_FALSE(changed_since.empty());
  EXPECT_EQ(w.unpersisted_tiles(), changed_since);
  auto second = store->write(w, seq, 2, f.textures);
  ASSERT_TRUE(second.ok()) << second.error().describe();
  EXPECT_EQ(second->tiles_written, changed_since.size());
  EXPECT_LT(second->tiles_written, first->tiles_written);
  // The bound the world-scale suite checks at scale: at most twice the changed tiles' bytes,
  // plus the index (a fixed 54 bytes an edited tile) and the manifest.
  EXPECT_LE(second->written_bytes, 2 * second->tile_bytes + second->index_bytes + 4096);

  auto loaded = read_snapshot(second->path, f.base);
  ASSERT_TRUE(loaded.ok()) << loaded.error().describe();
  expect_same_world(loaded->world, w);
  // The first snapshot still loads to the world as it was then.
  auto older = read_snapshot(first->path, f.base);
  ASSERT_TRUE(older.ok()) << older.error().describe();
  EXPECT_EQ(older->manifest.last_seq, before);
}

TEST(SnapshotStore, AnEditedTileEvictedAndReadBackHashesTheSame) {
  Fixture f("evict");
  World w(f.params, f.base);
  uint64_t seq = 0;
  f.stamp(w, seq, 60, 0, 0, 1024, 768, 3);
  const World reference = w;  // every tile resident, no store
  auto store = SnapshotStore::open(f.dir.string());
  ASSERT_TRUE(store->write(w, seq, 1, f.textures).ok());
  ASSERT_GT(w.edited_bytes(), 0u);
  w.set_base_cache_budget(0);
  w.trim_base_cache();
  EXPECT_EQ(w.edited_bytes(), 0u) << "every edited tile is persisted, so all are evictable";
  EXPECT_EQ(w.resident_persisted_bytes(), 0u);
  EXPECT_EQ(w.world_hash(), reference.world_hash()) << "the hash needs no tile";
  expect_same_world(w, reference);
  EXPECT_GT(w.edited_tiles_loaded(), 0u);

  // A stamp on an evicted tile reads it back, changes it, and the tile is dirty again until
  // the next snapshot; trimming never drops it.
  w.trim_base_cache();
  World ref2 = reference;
  uint64_t seq2 = seq;
  f.stamp(w, seq, 3, 300, 300, 400, 400, 4);
  f.stamp(ref2, seq2, 3, 300, 300, 400, 400, 4);
  ASSERT_GT(w.unpersisted_bytes(), 0u);
  w.trim_base_cache();
  EXPECT_GE(w.edited_bytes(), w.unpersisted_bytes()) << "dirty tiles stay resident";
  expect_same_world(w, ref2);
}

TEST(SnapshotStore, ADamagedTilesFileIsAnErrorNamingItAndAnOlderSnapshotStillLoads) {
  Fixture f("damage");
  World w(f.params, f.base);
  uint64_t seq = 0;
  f.stamp(w, seq, 30, 0, 0, 1024, 768, 5);
  auto store = SnapshotStore::open(f.dir.string());
  auto first = store->write(w, seq, 1, f.textures);
  ASSERT_TRUE(first.ok());
  f.stamp(w, seq, 5, 600, 500, 700, 600, 6);
  auto second = store->write(w, seq, 2, f.textures);
  ASSERT_TRUE(second.ok());

  // Flip a byte inside the second tiles file's first record payload.
  const std::string tiles =
      (fs::path(snapshot_tiles_dir(f.dir.string())) / snapshot_tiles_file_name(2)).string();
  {
    std::fstream io(tiles, std::ios::in | std::ios::out | std::ios::binary);
    io.seekp(16 + 30 + 40);
    char c = 0;
    io.read(&c, 1);
    io.seekp(16 + 30 + 40);
    c = char(c ^ 0x5a);
    io.write(&c, 1);
  }
  auto bad = read_snapshot(second->path, f.base);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().field.find("tiles-"), std::string::npos) << bad.error().describe();
  auto older = read_snapshot(first->path, f.base);
  EXPECT_TRUE(older.ok()) << "the first snapshot names only the first file";

  // A missing file, a truncated index, a foreign base and an unknown format are errors too.
  fs::remove(tiles);
  auto missing = read_snapshot(second->path, f.base);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound) << missing.error().describe();
  const fs::path index = fs::path(first->path) / "index.bin";
  fs::resize_file(index, fs::file_size(index) - 3);
  auto truncated = read_snapshot(first->path, f.base);
  ASSERT_FALSE(truncated.ok());
  EXPECT_EQ(truncated.error().code, ErrorCode::kCorrupt) << truncated.error().describe();
  auto foreign = read_snapshot(first->path, nullptr);
  ASSERT_FALSE(foreign.ok());
}

TEST(SnapshotStore, RepeatedEditsOfTheSameTilesKeepTheFilesWithinTwiceTheLiveBytes) {
  Fixture f("compaction");
  World w(f.params, f.base);
  uint64_t seq = 0;
  f.stamp(w, seq, 40, 0, 0, 1024, 768, 8);  // every tile edited once
  auto store = SnapshotStore::open(f.dir.string());
  ASSERT_TRUE(store->write(w, seq, 1, f.textures).ok());
  uint64_t moved = 0;
  for (int round = 0; round < 24; ++round) {
    // Each round rewrites a different corner, so old files turn sparse.
    const double x = (round % 4) * 256.0, y = ((round / 4) % 3) * 256.0;
    f.stamp(w, seq, 4, x + 20, y + 20, x + 230, y + 230, 100 + uint64_t(round));
    auto written = store->write(w, seq, uint32_t(2 + round), f.textures);
    ASSERT_TRUE(written.ok()) << written.error().describe();
    EXPECT_LE(written->moved_bytes, written->tile_bytes) << "compaction stays within the changed bytes";
    if (written->tile_bytes > written->index_bytes + 4096) {
      EXPECT_LE(written->written_bytes, 2 * written->tile_bytes) << "round " << round;
    }
    moved += written->moved_bytes;
    ASSERT_TRUE(store->prune(RetentionPolicy{1}).ok());
  }
  EXPECT_GT(moved, 0u) << "sparse files were compacted";
  // Files named by the one kept snapshot.
  EXPECT_LE(store->file_bytes(), 2 * store->live_bytes() + (uint64_t(1) << 20))
      << "files " << store->file_bytes() << " live " << store->live_bytes();
  auto loaded = read_snapshot(list_snapshots(f.dir.string()).front(), f.base);
  ASSERT_TRUE(loaded.ok()) << loaded.error().describe();
  expect_same_world(loaded->world, w);
}

TEST(SnapshotStore, PruneKeepsTheNewestSnapshotsAndEveryFileTheyName) {
  Fixture f("prune");
  World w(f.params, f.base);
  uint64_t seq = 0;
  auto store = SnapshotStore::open(f.dir.string());
  std::vector<World> worlds;
  for (int i = 0; i < 6; ++i) {
    f.stamp(w, seq, 6, 100.0 * i, 50, 100.0 * i + 120, 700, 200 + uint64_t(i));
    ASSERT_TRUE(store->write(w, seq, uint32_t(i + 1), f.textures).ok());
    worlds.push_back(w);
    auto pruned = store->prune(RetentionPolicy{2});
    ASSERT_TRUE(pruned.ok());
    if (i >= 2) {
      EXPECT_EQ(pruned->snapshots_removed, 1u);
      EXPECT_EQ(pruned->oldest_needed_segment, uint32_t(i));  // the older kept one's next segment
    }
  }
  const auto kept = list_snapshots(f.dir.string());
  ASSERT_EQ(kept.size(), 2u);
  for (size_t k = 0; k < kept.size(); ++k) {
    auto loaded = read_snapshot(kept[k], f.base);
    ASSERT_TRUE(loaded.ok()) << loaded.error().describe();
    expect_same_world(loaded->world, worlds[worlds.size() - 1 - k]);
  }
}

TEST(SnapshotStore, ASnapshotLoadedInANewStoreContinuesIncrementallyWithImagesAndZeroedDetail) {
  Fixture f("continue");
  World w(f.params, f.base);
  uint64_t seq = 0;
  f.stamp(w, seq, 30, 0, 0, 1024, 768, 9);
  std::vector<uint16_t> img(16 * 8);
  for (size_t i = 0; i < img.size(); ++i) img[i] = uint16_t(i * 500);
  ASSERT_TRUE(f.textures.add(16, 8, img).ok());
  // A detail tile written and zeroed again keeps its version without samples.
  const int8_t d = 7, zero = 0;
  w.write_detail({40, 40, 41, 41}, std::span(&d, 1));
  w.commit(++seq);
  w.write_detail({40, 40, 41, 41}, std::span(&zero, 1));
  w.commit(++seq);
  const TileCoord zeroed{Layer::kDetail, 0, 0, 0};
  ASSERT_EQ(w.tile_state(zeroed).version, seq);
  auto path = write_snapshot(f.dir.string(), w, seq, 1, f.textures);
  ASSERT_TRUE(path.ok()) << path.error().describe();

  auto store = SnapshotStore::open(f.dir.string());
  auto loaded = store->load(*path, f.base);
  ASSERT_TRUE(loaded.ok()) << loaded.error().describe();
  ASSERT_EQ(loaded->textures.size(), 1u);
  EXPECT_EQ(loaded->textures[0].samples, img);
  World& w2 = loaded->world;
  EXPECT_EQ(w2.tile_state(zeroed).version, seq);
  EXPECT_TRUE(w2.unpersisted_tiles().empty());
  uint64_t seq2 = seq;
  f.stamp(w2, seq2, 2, 500, 300, 560, 360, 10);
  f.stamp(w, seq, 2, 500, 300, 560, 360, 10);
  const size_t changed = w2.unpersisted_tiles().size();
  auto next = store->write(w2, seq2, 2, f.textures);
  ASSERT_TRUE(next.ok()) << next.error().describe();
  EXPECT_EQ(next->tiles_written, changed);
  EXPECT_EQ(next->images_written, 0u) << "the image is stored once";
  auto again = read_snapshot(next->path, f.base);
  ASSERT_TRUE(again.ok()) << again.error().describe();
  expect_same_world(again->world, w);
  EXPECT_EQ(again->textures.size(), 1u);
}

}  // namespace
}  // namespace loam
