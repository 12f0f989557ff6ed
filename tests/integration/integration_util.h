// Shared helpers of the integration tests: temporary data folders, seeded random stamps
// that pass validation, and the expected world rebuilt by replaying the server's own log.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <string>

#include "client/net/terrain_client.h"
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

// A random stamp that validates against the world: gaussians, craters (some volume
// conserving), footprints, flattens, small shockwaves, and detail-layer gaussians.
inline QuantizedStamp random_stamp(std::mt19937& rng, const WorldParams& w) {
  const RectI r = w.sample_rect();
  std::uniform_real_distribution<double> ux(double(r.x0) * w.meters_per_sample,
                                            double(r.x1 - 1) * w.meters_per_sample);
  std::uniform_real_distribution<double> uy(double(r.y0) * w.meters_per_sample,
                                            double(r.y1 - 1) * w.meters_per_sample);
  std::uniform_real_distribution<double> radius(2.0, 40.0), depth(-3.0, 3.0), unit(0.0, 1.0);
  for (int attempt = 0; attempt < 100; ++attempt) {
    StampParams p;
    const uint32_t pick = uint32_t(rng() % 12);
    p.center_x = ux(rng);
    p.center_y = uy(rng);
    p.radius = radius(rng);
    p.rotation = unit(rng) * 6.28;
    p.intensity = depth(rng);
    if (pick < 4) {
      p.kind = StampKind::kGaussian;
    } else if (pick < 7) {
      p.kind = StampKind::kCrater;
      p.intensity = std::abs(p.intensity) + 0.5;
      p.shape = 0.3;
      p.volume_conserving = pick == 6;
    } else if (pick < 9) {
      p.kind = StampKind::kFootprint;
      p.intensity = 0.3;
      p.radius = 3.0;
    } else if (pick == 9) {
      p.kind = StampKind::kFlatten;
      p.intensity = 0.5;
      p.target = 20.0;
    } else if (pick == 10) {
      p.kind = StampKind::kShockwave;
      p.radius = 6.0;
      p.intensity = 0.5;
      p.steps = 20;
      p.speed = 0.5;
      p.damping = 0.05;
    } else {
      p.kind = StampKind::kGaussian;
      p.layer = Layer::kDetail;
      p.radius = 1.5;
      p.intensity = 0.05;
    }
    auto q = validate_stamp(p, w);
    if (q) return *q;
  }
  ADD_FAILURE() << "could not make a valid random stamp";
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
