// The GPU stamper's tile cache (gpu/tile_pages.h): worlds wider than GL_MAX_TEXTURE_SIZE, page
// budgets small enough that every stamp evicts, and the limits a full cache answers with. The
// contract is the conformance tests': the GPU gives the CPU reference's integers, 0 mismatches.
#include <gtest/gtest.h>

#include <cstdio>
#include <vector>

#include "gl_test_context.h"
#include "gpu/gpu_stamper.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_mix.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"
#include "tests/support/world_compare.h"

namespace loam::gpu {
namespace {

// A rough base so stamps see varied samples; untouched tiles come from it on both sides.
World hills(const WorldParams& p) {
  World w(p, 20000);
  const RectI r = p.sample_rect();
  for (int64_t ty = r.y0; ty < r.y1; ty += kTileSize) {
    for (int64_t tx = r.x0; tx < r.x1; tx += kTileSize) {
      std::vector<uint16_t> s(static_cast<size_t>(kTileSamples));
      for (int64_t y = 0; y < kTileSize; ++y) {
        for (int64_t x = 0; x < kTileSize; ++x) {
          const int64_t gx = tx + x, gy = ty + y;
          s[size_t(y * kTileSize + x)] = uint16_t(30000 + (gx * 37 + gy * 53) % 9000 + ((gx ^ gy) & 63));
        }
      }
      w.write_coarse({tx, ty, tx + kTileSize, ty + kTileSize}, s);
    }
  }
  w.commit(0);
  return w;
}

struct PageRun {
  int stamps = 0, refused_oversize = 0;
  int64_t mismatches = 0;
};

// Seeded random stamps of every kind on both layers, each applied by the reference and the
// GPU; a stamp reaching more tiles than the page budget must be refused with kOversize.
PageRun run_paged(World& cpu, World& gpu_world, GpuStamper& g, int count, uint64_t seed) {
  PageRun run;
  loam::StampRng rng(seed);
  uint64_t seq = 1;
  while (run.stamps + run.refused_oversize < count) {
    const QuantizedStamp q = loam::random_quantized_stamp(rng, cpu.params(), {}, true);
    if (q.kind == StampKind::kTexture || !check_quantized(q, cpu.params()).ok()) continue;
    auto got = g.apply(gpu_world, q);
    if (!got) {
      EXPECT_EQ(got.error().code, ErrorCode::kOversize) << got.error().describe();
      ++run.refused_oversize;
      continue;
    }
    auto want = apply_stamp_reference(cpu, q);
    EXPECT_TRUE(want.ok()) << want.error().describe();
    if (!want.ok()) break;
    EXPECT_EQ(*want, *got) << "stamp " << run.stamps << " " << to_string(q.kind);
    cpu.commit(seq);
    gpu_world.commit(seq);
    ++seq;
    ++run.stamps;
  }
  run.mismatches = loam::test::sample_mismatches(cpu, gpu_world, Layer::kCoarse) +
                   loam::test::sample_mismatches(cpu, gpu_world, Layer::kDetail);
  return run;
}

// 72 x 2 tiles: 18432 samples across, beyond llvmpipe's GL_MAX_TEXTURE_SIZE of 16384 (a
// whole-world texture could not hold it), with a detail layer twice as wide again.
TEST(GpuTilePages, WorldWiderThanMaxTextureSizeStampsLikeTheCpu) {
  LOAM_REQUIRE_GL();
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  WorldParams p;
  p.tiles_x = int32_t((int64_t(max_size) + 2 * kTileSize) / kTileSize);
  p.tiles_y = 2;
  p.origin_tile_x = -p.tiles_x / 2;
  p.detail_factor = 2;
  World cpu = hills(p);
  World gpu_world = cpu;
  auto g = GpuStamper::create(gpu_world);
  ASSERT_TRUE(g.ok()) << g.error().describe();
  const PageRun run = run_paged(cpu, gpu_world, **g, 150, 77);
  const GpuStamperMemory m = (*g)->memory();
  std::printf(
      "world of %lld samples across: %d stamps, %lld mismatches; %d coarse + %d detail pages resident, "
      "%.1f MiB of pages\n",
      static_cast<long long>(p.sample_rect().width()), run.stamps, static_cast<long long>(run.mismatches),
      m.resident_pages[Layer::kCoarse], m.resident_pages[Layer::kDetail], double(m.page_bytes) / (1 << 20));
  EXPECT_GT(p.sample_rect().width(), max_size);
  EXPECT_GE(run.stamps, 100);
  EXPECT_EQ(run.mismatches, 0);
  EXPECT_EQ(cpu.world_hash(), gpu_world.world_hash());
  // Pages follow what was stamped, not the world: far fewer than its 144 coarse tiles.
  EXPECT_LT(m.resident_pages[Layer::kCoarse], p.tiles_x * p.tiles_y);
}

// Four pages per layer over a 6x6-tile world: nearly every stamp evicts and reloads tiles from
// the mirror, shockwaves apply page by page, and the result stays exact.
TEST(GpuTilePages, EvictedPagesReloadFromTheMirrorExactly) {
  LOAM_REQUIRE_GL();
  WorldParams p;
  p.tiles_x = 6;
  p.tiles_y = 6;
  p.origin_tile_x = -3;
  p.origin_tile_y = -2;
  p.detail_factor = 2;
  World cpu = hills(p);
  World gpu_world = cpu;
  GpuStamperOptions o;
  o.max_pages[Layer::kCoarse] = 4;
  o.max_pages[Layer::kDetail] = 4;
  auto g = GpuStamper::create(gpu_world, nullptr, {}, o);
  ASSERT_TRUE(g.ok()) << g.error().describe();
  const PageRun run = run_paged(cpu, gpu_world, **g, 300, 4242);
  const GpuStamperMemory m = (*g)->memory();
  std::printf("4-page budget: %d stamps, %d refused as over budget, %llu evictions, %lld mismatches\n",
              run.stamps, run.refused_oversize, static_cast<unsigned long long>(m.evictions),
              static_cast<long long>(run.mismatches));
  EXPECT_GE(run.stamps, 100);
  EXPECT_GT(run.refused_oversize, 0);
  EXPECT_GT(m.evictions, 100u);
  EXPECT_EQ(run.mismatches, 0);
  EXPECT_EQ(cpu.world_hash(), gpu_world.world_hash());
  EXPECT_LE(m.resident_pages[Layer::kCoarse], 4);
  EXPECT_LE(m.page_bytes, size_t(4) * kTileSamples * 3);
}

QuantizedStamp gaussian(int64_t cx, int64_t cy, int32_t radius) {
  QuantizedStamp q;
  q.kind = StampKind::kGaussian;
  q.center_x = int32_t(cx * 256);
  q.center_y = int32_t(cy * 256);
  q.radius = radius * 256;
  q.intensity = 500 * 256;
  return q;
}

// Pages awaiting a readback are never evicted: with every page pinned, submit answers kBusy
// and changes nothing; after collect() the same stamp goes through.
TEST(GpuTilePages, FullCacheOfUncollectedStampsAnswersBusyUntilCollected) {
  LOAM_REQUIRE_GL();
  WorldParams p;
  p.tiles_x = 4;
  p.tiles_y = 1;
  World cpu = hills(p);
  World gpu_world = cpu;
  GpuStamperOptions o;
  o.max_pages[Layer::kCoarse] = 2;
  auto g = GpuStamper::create(gpu_world, nullptr, {}, o);
  ASSERT_TRUE(g.ok()) << g.error().describe();
  const QuantizedStamp a = gaussian(256, 100, 20);  // tiles 0 and 1
  const QuantizedStamp b = gaussian(900, 100, 20);  // tile 3
  ASSERT_TRUE((*g)->submit(a).ok());
  auto busy = (*g)->submit(b);
  ASSERT_FALSE(busy.ok());
  EXPECT_EQ(busy.error().code, ErrorCode::kBusy);
  (*g)->collect(gpu_world);
  ASSERT_TRUE((*g)->submit(b).ok());
  (*g)->collect(gpu_world);
  ASSERT_TRUE(apply_stamp_reference(cpu, a).ok());
  ASSERT_TRUE(apply_stamp_reference(cpu, b).ok());
  EXPECT_EQ(loam::test::sample_mismatches(cpu, gpu_world, Layer::kCoarse), 0);
  // A stamp over three tiles can never fit two pages.
  auto over = (*g)->submit(gaussian(512, 100, 300));
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.error().code, ErrorCode::kOversize);
}

// A page budget beyond what the GL offers is a clear error at creation.
TEST(GpuTilePages, PageBudgetBeyondArrayLayersIsRefused) {
  LOAM_REQUIRE_GL();
  World w(WorldParams{}, 0);
  GpuStamperOptions o;
  o.max_pages[Layer::kCoarse] = 1 << 30;
  auto g = GpuStamper::create(w, nullptr, {}, o);
  ASSERT_FALSE(g.ok());
  EXPECT_EQ(g.error().field, "gpu.max_pages");
}

}  // namespace
}  // namespace loam::gpu
