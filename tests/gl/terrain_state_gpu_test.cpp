// The server's terrain (server/terrain_state.h) on the GPU stamp backend, the way the server
// holds it: the backend is made for the recovered state, which is then moved into the server.
// The GPU stamper fills its pages from that World, so the World must not move with it; and
// the server applies from its apply worker, so the backend must work from any thread.
#include <gtest/gtest.h>

#include <cstdio>
#include <future>
#include <optional>
#include <vector>

#include "gl_test_context.h"
#include "gpu/stamp_backend.h"
#include "protocol/stamps/stamp_mix.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"
#include "server/terrain_state.h"

namespace loam::server {
namespace {

// 2x2 tiles of ridges, so a page filled from anything but this World differs from it.
World ridged_world() {
  WorldParams p;
  p.tiles_x = 2;
  p.tiles_y = 2;
  p.detail_factor = 2;
  const RectI r = p.sample_rect();
  std::vector<uint16_t> s(size_t(r.area()));
  for (int64_t y = 0; y < r.height(); ++y) {
    for (int64_t x = 0; x < r.width(); ++x)
      s[size_t(y * r.width() + x)] = uint16_t(20000 + (x * 13 + y * 7) % 9000);
  }
  World w = std::move(World::from_samples(p, s).value());
  w.commit(0);
  return w;
}

TEST(TerrainStateGpu, StampsOnTheGpuBackendMatchTheCpuAfterTheStateIsMovedAndFromAnyThread) {
  LOAM_REQUIRE_GL();
  TerrainState cpu(ridged_world(), 0);
  std::optional<TerrainState> recovered;
  recovered.emplace(ridged_world(), 0);
  auto backend = gpu::make_stamp_backend(gpu::BackendKind::kGpu, recovered->world(), &recovered->textures());
  ASSERT_TRUE(backend.ok()) << backend.error().describe();
  recovered->set_backend(std::move(*backend));
  // As serve() hands the recovered state to the Server.
  TerrainState served = std::move(*recovered);
  recovered.reset();

  loam::StampRng rng(916);
  int applied = 0;
  uint64_t seq = 0;
  while (applied < 60) {
    const QuantizedStamp q = loam::random_quantized_stamp(rng, cpu.world().params(), {}, false);
    if (!cpu.check(q).ok()) continue;
    ++seq;
    const auto want = cpu.apply(q, seq, 1);
    // Every other stamp from a thread of its own, as the apply worker runs it.
    const auto got = seq % 2 == 0
                         ? std::async(std::launch::async, [&] { return served.apply(q, seq, 1); }).get()
                         : served.apply(q, seq, 1);
    ASSERT_EQ(want.ok(), got.ok()) << "seq " << seq;
    if (!want.ok()) continue;
    ++applied;
    ASSERT_EQ(want->changes.size(), got->changes.size()) << "seq " << seq << " " << to_string(q.kind);
    ASSERT_EQ(cpu.world().world_hash(), served.world().world_hash())
        << "seq " << seq << " (" << to_string(q.kind) << ", " << to_string(q.layer) << ")";
  }
  EXPECT_TRUE(served.take_backend_failures().empty());
  std::printf("%d stamps on the GPU backend of a moved terrain state, world hash %016llx as on the CPU\n",
              applied, static_cast<unsigned long long>(served.world().world_hash()));
}

}  // namespace
}  // namespace loam::server
