// Shared helpers of the integration tests: temporary data folders, seeded random stamps
// that pass validation, and the expected world rebuilt by replaying the server's own log.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "client/net/terrain_client.h"
#include "dem/default_terrain.h"
#include "dem/dem_export.h"
#include "protocol/stamps/stamp_mix.h"
#include "protocol/stamps/stamp_validate.h"
#include "server/replay.h"
#include "server/storage.h"

namespace loam::test {

inline std::string temp_data_dir(const std::string& tag) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const auto dir = std::filesystem::temp_directory_path() /
                   ("loam_it_" + std::string(info->name()) + "_" + tag + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

// The embedded default terrain exported as a 16-bit PNG with its sidecar (same spacing), in
// `dir`: a DEM for `loam-server serve --dem`, whose initial terrain no client generates.
inline std::string default_terrain_png(const std::string& dir) {
  const std::string png = dir + "/terrain.png";
  auto w = load_default_terrain();
  EXPECT_TRUE(w.ok());
  if (w.ok()) {
    EXPECT_TRUE(export_png16(w->world, w->world.params().sample_rect(), png).ok());
  }
  return png;
}

// A random stamp that validates against the world and changes it: every kind but texture (no
// image is registered), some craters volume conserving, and gaussians on the detail layer.
// Shockwaves stay small (a test server applies them under the sanitizers), and so do
// footprints: a client holding only some of the tiles a footprint lists buffers its event
// until a region covers it, and none comes where the footprint changed none of its tiles.
inline QuantizedStamp random_stamp(StampRng& rng, const WorldParams& w) {
  RandomStampOptions o = random_stamp_options(w);
  // Every stamp changes the terrain, so every accepted one reaches its subscribers as an event.
  o.min_radius = 2.0;
  o.max_radius = 30.5;
  o.blends = {BlendMode::kAdd, BlendMode::kSubtract};
  o.max_intensity[Layer::kCoarse] = 2.0;
  o.max_intensity[Layer::kDetail] = 0.25;
  o.min_intensity[Layer::kCoarse] = 0.1;
  o.min_intensity[Layer::kDetail] = 0.02;
  o.min_flatten_strength = 0.2;
  o.layer_kinds[Layer::kDetail] = {StampKind::kGaussian};
  o.max_radius_of_kind[size_t(StampKind::kShockwave)] = 6.0;
  o.max_radius_of_kind[size_t(StampKind::kFootprint)] = 3.0;
  auto q = random_valid_stamp(rng, o, w);
  if (q) return *q;
  ADD_FAILURE() << "could not make a valid random stamp: " << q.error().describe();
  return {};
}

// The world after `until_seq`, rebuilt from the data folder's log.
inline World replayed_world(const std::string& data_dir, uint64_t until_seq) {
  auto r = server::replay_log(server::list_segments(data_dir), data_dir, until_seq);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().describe());
  EXPECT_EQ(r->last_seq, until_seq);
  return std::move(r->world);
}

// Every tile the client holds has the expected world's hash.
inline ::testing::AssertionResult store_matches(client::TerrainClient& c, const World& expected) {
  size_t checked = 0;
  for (const TileCoord& t : c.store().held()) {
    const uint64_t want = expected.tile_state(t).hash;
    if (c.store().hash(t) != want) {
      return ::testing::AssertionFailure()
             << "tile " << to_string(t) << " at version " << *c.store().version(t)
             << " differs (expected version " << expected.tile_state(t).version << ")";
    }
    ++checked;
  }
  if (checked == 0) return ::testing::AssertionFailure() << "client holds no tiles";
  return ::testing::AssertionSuccess();
}

}  // namespace loam::test
