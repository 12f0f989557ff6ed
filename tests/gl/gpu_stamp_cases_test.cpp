// Hard cases of GPU stamping, each against the CPU reference: the shockwave at the Courant
// cap for a thousand steps, stamps centred on a four-tile corner, the asynchronous readback
// pipeline, the shaders' float-estimate helpers on the inputs where their correction
// matters, the vertex-stage path's care for the caller's GL state, the normal pass, and the
// backend factory. Mismatch counts are printed.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "gl_test_context.h"
#include "gpu/gpu_stamper.h"
#include "gpu/normal_pass.h"
#include "gpu/shader_library.h"
#include "gpu/stamp_backend.h"
#include "protocol/normal_map.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_profile.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"
#include "tests/support/world_compare.h"

namespace loam::gpu {
namespace {

World sloped_world(int32_t tiles, int32_t origin, int32_t detail_factor = 2) {
  WorldParams p;
  p.origin_tile_x = origin;
  p.origin_tile_y = origin;
  p.tiles_x = tiles;
  p.tiles_y = tiles;
  p.detail_factor = detail_factor;
  const RectI r = p.sample_rect();
  std::vector<uint16_t> s(size_t(r.area()));
  for (int64_t y = 0; y < r.height(); ++y) {
    for (int64_t x = 0; x < r.width(); ++x) {
      // A ramp with a cliff: steep slopes and flat ground both appear in the normals.
      s[size_t(y * r.width() + x)] = uint16_t(20000 + x * 13 + y * 7 + (x > r.width() / 2 ? 9000 : 0));
    }
  }
  return std::move(World::from_samples(p, s).value());
}

// The fastest speed that needs no sub-steps: nu^2 as close to the 0.49 cap as Q16 allows.
uint16_t speed_at_cap() {
  uint16_t s = 45000;
  while (shockwave_substeps(uint16_t(s + 1)) == 1) ++s;
  return s;
}

// Regression guard for the wave equation near its stability limit: the integer leapfrog is
// only bounded below nu^2 = 1/2, so rounding differences would grow step after step; a
// thousand steps at the cap on both layers must still agree exactly.
TEST(GpuShockwave, ThousandStepsAtTheCourantCapMatchCpuOnBothLayers) {
  LOAM_REQUIRE_GL();
  const uint16_t speed = speed_at_cap();
  for (Layer layer : {Layer::kCoarse, Layer::kDetail}) {
    for (uint16_t damping : {uint16_t(0), uint16_t(300)}) {
      World cpu = sloped_world(1, 0);
      World gpu_world = cpu;
      auto g = GpuStamper::create(gpu_world);
      ASSERT_TRUE(g.ok()) << g.error().describe();
      QuantizedStamp q;
      q.kind = StampKind::kShockwave;
      q.layer = layer;
      const RectI r = layer_sample_rect(cpu.params(), layer);
      q.center_x = (r.x0 + r.width() / 3) * 256 + 77;
      q.center_y = (r.y0 + r.height() / 2) * 256 + 200;
      q.radius = 9 * 256 + 31;
      q.intensity = (layer == Layer::kCoarse ? 4000 : 100) * 256;
      q.speed = speed;
      q.steps = 1000;
      q.damping = damping;
      ASSERT_TRUE(check_quantized(q, cpu.params()).ok());
      auto want = apply_stamp(cpu, q);
      auto got = (*g)->apply(gpu_world, q);
      ASSERT_TRUE(want.ok() && got.ok());
      const int64_t m = loam::test::sample_mismatches(cpu, gpu_world, layer);
      std::printf(
          "shockwave %s, nu^2 = %d/65536 (cap %d), 1000 steps, damping %d: %lld mismatches, changed "
          "%lldx%lld\n",
          to_string(layer), shockwave_nu2_q16(speed, 1), kWaveNu2CapQ16, damping, static_cast<long long>(m),
          static_cast<long long>(want->width()), static_cast<long long>(want->height()));
      EXPECT_EQ(m, 0);
      EXPECT_EQ(*want, *got);
      EXPECT_FALSE(want->empty());
    }
  }
}

// Speeds above the cap split every step into sub-steps; the GPU must split identically.
TEST(GpuShockwave, SpeedAboveTheCapSplitsIntoSubstepsLikeCpu) {
  LOAM_REQUIRE_GL();
  World cpu = sloped_world(1, 0);
  World gpu_world = cpu;
  auto g = GpuStamper::create(gpu_world);
  ASSERT_TRUE(g.ok());
  QuantizedStamp q;
  q.kind = StampKind::kShockwave;
  q.center_x = 128 * 256;
  q.center_y = 100 * 256;
  q.radius = 6 * 256;
  q.intensity = 65535 * 256;  // saturating
  q.speed = 65535;
  q.steps = 300;
  ASSERT_GT(shockwave_substeps(q.speed), 1);
  ASSERT_TRUE(apply_stamp(cpu, q).ok());
  ASSERT_TRUE((*g)->apply(gpu_world, q).ok());
  const int64_t m = loam::test::sample_mismatches(cpu, gpu_world, Layer::kCoarse);
  std::printf("shockwave at speed 65535/65536 (%d sub-steps): %lld mismatches\n", shockwave_substeps(q.speed),
              static_cast<long long>(m));
  EXPECT_EQ(m, 0);
}

// Four tiles meet at the origin; a stamp centred there is split four ways by the CPU
// reference and evaluated as one rect on the GPU.
TEST(GpuStamp, GpuStampAcrossFourTileCornerMatchesCpu) {
  LOAM_REQUIRE_GL();
  World cpu = sloped_world(2, -1);
  World gpu_world = cpu;
  auto g = GpuStamper::create(gpu_world);
  ASSERT_TRUE(g.ok());
  int64_t total = 0;
  uint64_t seq = 1;
  for (Layer layer : {Layer::kCoarse, Layer::kDetail}) {
    for (StampKind kind : {StampKind::kGaussian, StampKind::kCrater, StampKind::kFootprint,
                           StampKind::kFlatten, StampKind::kShockwave}) {
      QuantizedStamp q;
      q.kind = kind;
      q.layer = layer;
      q.center_x = 0;  // exactly on the corner, then a hair off it
      q.center_y = kind == StampKind::kCrater ? 1 : 0;
      q.radius = 37 * 256 + 5;
      q.intensity = layer == Layer::kCoarse ? 3000 * 256 : 60 * 256;
      if (kind != StampKind::kGaussian && kind != StampKind::kShockwave) q.shape = 30000;  // theirs only
      if (kind == StampKind::kFlatten) q.target = layer == Layer::kCoarse ? 21000 : -20;   // add: no target
      if (kind == StampKind::kFlatten) q.intensity = 50000;
      if (kind == StampKind::kCrater) q.flags = kStampFlagVolumeConserving;
      if (kind == StampKind::kShockwave) {
        q.speed = 30000;
        q.steps = 20;
      }
      ASSERT_TRUE(check_quantized(q, cpu.params()).ok()) << to_string(kind);
      auto want = apply_stamp(cpu, q);
      auto got = (*g)->apply(gpu_world, q);
      ASSERT_TRUE(want.ok() && got.ok());
      EXPECT_EQ(*want, *got) << to_string(kind) << " " << to_string(layer);
      const auto cw = cpu.commit(seq), gw = gpu_world.commit(seq);
      ++seq;
      ASSERT_EQ(cw.size(), gw.size());
      for (size_t i = 0; i < cw.size(); ++i) {
        EXPECT_TRUE(cw[i].coord == gw[i].coord && cw[i].rect == gw[i].rect) << to_string(cw[i].coord);
      }
      const int64_t m = loam::test::sample_mismatches(cpu, gpu_world, layer);
      EXPECT_EQ(m, 0) << to_string(kind) << " " << to_string(layer);
      total += m;
    }
  }
  std::printf("four-tile corner, every per-sample kind and shockwave, both layers: %lld mismatches\n",
              static_cast<long long>(total));
  EXPECT_EQ(cpu.world_hash(), gpu_world.world_hash());
}

// submit() never touches the World; collect() brings it to exactly the CPU result.
TEST(GpuStamp, MirrorIsUntouchedUntilCollectThenMatchesCpu) {
  LOAM_REQUIRE_GL();
  World cpu = sloped_world(2, 0);
  World gpu_world = cpu;
  auto g = GpuStamper::create(gpu_world);
  ASSERT_TRUE(g.ok());
  const uint64_t before = gpu_world.world_hash();
  for (int i = 0; i < 20; ++i) {
    QuantizedStamp q;
    q.kind = i % 3 == 0 ? StampKind::kCrater : StampKind::kGaussian;
    q.layer = i % 2 ? Layer::kDetail : Layer::kCoarse;
    q.center_x = (40 + i * 21) * 256 * (q.layer == Layer::kDetail ? 2 : 1);
    q.center_y = (250 + i * 3) * 256 * (q.layer == Layer::kDetail ? 2 : 1);
    q.radius = 30 * 256;
    q.intensity = (i % 2 ? -50 : 5000) * 256;
    ASSERT_TRUE(apply_stamp(cpu, q).ok());
    ASSERT_TRUE((*g)->submit(q).ok());
  }
  EXPECT_EQ((*g)->pending(), 20u);
  EXPECT_FALSE(gpu_world.has_pending());
  EXPECT_EQ(gpu_world.world_hash(), before);
  const auto done = (*g)->collect(gpu_world);
  EXPECT_EQ(done.size(), 20u);
  cpu.commit(1);
  gpu_world.commit(1);
  EXPECT_EQ(cpu.world_hash(), gpu_world.world_hash());
}

// Runs shaders/stamp_helpers_test.comp.glsl (MODE `mode`) over `inputs`; one int each.
std::vector<int32_t> run_helper_shader(int mode, const std::vector<int32_t>& inputs) {
  const std::string_view files[] = {"stamp_common.glsl", "stamp_helpers_test.comp.glsl"};
  const ShaderDefine defines[] = {{"KIND", "1"}, {"MODE", std::to_string(mode)}};
  auto program = build_compute_program_from(files, defines);
  EXPECT_TRUE(program.ok()) << (program.ok() ? "" : program.error().describe());
  if (!program.ok()) return {};
  const size_t n = inputs.size() / 2;
  GlBuffer in = make_buffer(), out = make_buffer();
  glNamedBufferStorage(in.get(), GLsizeiptr(inputs.size() * 4), inputs.data(), 0);
  glNamedBufferStorage(out.get(), GLsizeiptr(n * 4), nullptr, GL_DYNAMIC_STORAGE_BIT);
  glUseProgram(program->get());
  glProgramUniform1i(program->get(), glGetUniformLocation(program->get(), "count"), GLint(n));
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, in.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, out.get());
  glDispatchCompute(GLuint((n + 63) / 64), 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  std::vector<int32_t> got(n);
  glGetNamedBufferSubData(out.get(), 0, GLsizeiptr(n * 4), got.data());
  return got;
}

// The stamp shaders take square roots and the Q16 quotient u = (dist << 16) / r from a float
// estimate plus one exact integer step each way (llvmpipe has no vector integer divide).
// Random stamps rarely land where a step could be needed; these inputs are those: every
// perfect square below 2^29 and its neighbours, and every dist < r for small r and for the
// largest reduced radii.
TEST(GpuStamp, ShaderSquareRootAndQuotientEstimatesAreCorrectedToTheExactInteger) {
  LOAM_REQUIRE_GL();
  std::vector<int32_t> roots;
  for (int64_t k = 0; k * k < (int64_t(1) << 29); ++k) {
    for (int64_t v : {k * k - 1, k * k, k * k + 1}) {
      if (v >= 0 && v < (int64_t(1) << 29)) roots.insert(roots.end(), {int32_t(v), 0});
    }
  }
  roots.insert(roots.end(), {(1 << 29) - 1, 0});
  const std::vector<int32_t> got_roots = run_helper_shader(0, roots);
  ASSERT_EQ(got_roots.size(), roots.size() / 2);
  int64_t root_mismatches = 0;
  for (size_t i = 0; i < got_roots.size(); ++i) {
    root_mismatches += got_roots[i] != int32_t(isqrt32(uint32_t(roots[2 * i])));
  }
  std::vector<int32_t> quotients;
  std::vector<int32_t> radii;
  for (int32_t r = 1; r <= 600; ++r) radii.push_back(r);
  for (int32_t r : {1000, 4095, 4096, 8191, 8192, 12800, 16381, 16383}) radii.push_back(r);
  for (int32_t r : radii) {
    for (int32_t dist = 0; dist < r; ++dist) quotients.insert(quotients.end(), {dist, r});
  }
  const std::vector<int32_t> got_quotients = run_helper_shader(1, quotients);
  ASSERT_EQ(got_quotients.size(), quotients.size() / 2);
  int64_t quotient_mismatches = 0;
  for (size_t i = 0; i < got_quotients.size(); ++i) {
    const uint32_t want = (uint32_t(quotients[2 * i]) << 16) / uint32_t(quotients[2 * i + 1]);
    quotient_mismatches += got_quotients[i] != int32_t(want);
  }
  std::printf("shader helpers: %zu square roots, %lld mismatches; %zu Q16 quotients, %lld mismatches\n",
              got_roots.size(), static_cast<long long>(root_mismatches), got_quotients.size(),
              static_cast<long long>(quotient_mismatches));
  EXPECT_EQ(root_mismatches, 0);
  EXPECT_EQ(quotient_mismatches, 0);
}

// The vertex-stage path draws, so it binds a framebuffer and a vertex array of its own and
// needs rasterizer discard off (it would skip the vertex stage too); a renderer sharing the
// context must find its own bindings afterwards, and the stamp must still be exact.
TEST(GpuStamp, VertexPathRestoresTheCallersFramebufferVertexArrayAndRasterizerDiscard) {
  LOAM_REQUIRE_GL();
  World cpu = sloped_world(1, 0);
  World gpu_world = cpu;
  auto g = GpuStamper::create(gpu_world, nullptr, {}, GpuStamperOptions{StampPath::kVertex});
  ASSERT_TRUE(g.ok()) << g.error().describe();
  GLuint fbo = 0, vao = 0;
  glCreateFramebuffers(1, &fbo);
  const GlFramebuffer own_fbo(fbo);
  glNamedFramebufferParameteri(fbo, GL_FRAMEBUFFER_DEFAULT_WIDTH, 4);
  glNamedFramebufferParameteri(fbo, GL_FRAMEBUFFER_DEFAULT_HEIGHT, 4);
  glCreateVertexArrays(1, &vao);
  const GlVertexArray own_vao(vao);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo);
  glBindVertexArray(vao);
  glEnable(GL_RASTERIZER_DISCARD);
  QuantizedStamp q;
  q.kind = StampKind::kCrater;
  q.center_x = 100 * 256 + 31;
  q.center_y = 120 * 256 + 200;
  q.radius = 12 * 256;
  q.intensity = 4000 * 256;
  q.shape = 20000;
  auto want = apply_stamp(cpu, q);
  auto got = (*g)->apply(gpu_world, q);
  GLint bound_fbo = 0, bound_vao = 0;
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &bound_fbo);
  glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &bound_vao);
  const bool discard = glIsEnabled(GL_RASTERIZER_DISCARD);
  glDisable(GL_RASTERIZER_DISCARD);
  glBindVertexArray(0);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  ASSERT_TRUE(want.ok() && got.ok());
  EXPECT_FALSE(want->empty());
  EXPECT_EQ(*want, *got);
  EXPECT_EQ(GLuint(bound_fbo), fbo);
  EXPECT_EQ(GLuint(bound_vao), vao);
  EXPECT_TRUE(discard);
  EXPECT_EQ(loam::test::sample_mismatches(cpu, gpu_world, Layer::kCoarse), 0);
}

// kAuto sends a stamp to the vertex stage only on a software renderer and only up to
// kVertexPathMaxSamples; the forced paths ignore the size.
TEST(GpuStamp, AutoPathUsesTheVertexStageOnlyForSmallStampsOnSoftwareRenderers) {
  LOAM_REQUIRE_GL();
  World w = sloped_world(1, 0);
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const bool software = renderer != nullptr && is_software_renderer(renderer);
  auto automatic = GpuStamper::create(w);
  auto compute = GpuStamper::create(w, nullptr, {}, GpuStamperOptions{StampPath::kCompute});
  auto vertex = GpuStamper::create(w, nullptr, {}, GpuStamperOptions{StampPath::kVertex});
  ASSERT_TRUE(automatic.ok() && compute.ok() && vertex.ok());
  const int64_t limit = GpuStamper::kVertexPathMaxSamples;
  EXPECT_EQ((*automatic)->path_for(1), software ? StampPath::kVertex : StampPath::kCompute);
  EXPECT_EQ((*automatic)->path_for(limit), software ? StampPath::kVertex : StampPath::kCompute);
  EXPECT_EQ((*automatic)->path_for(limit + 1), StampPath::kCompute);
  for (int64_t n : {int64_t(1), limit, limit + 1, int64_t(1) << 26}) {
    EXPECT_EQ((*compute)->path_for(n), StampPath::kCompute);
    EXPECT_EQ((*vertex)->path_for(n), StampPath::kVertex);
  }
}

// The normal pass against protocol/normal_map.h over rects that touch every world edge.
TEST(GpuNormals, NormalPassMatchesCpuNormalMapIncludingWorldEdges) {
  LOAM_REQUIRE_GL();
  World w = sloped_world(2, -1);
  QuantizedStamp q;
  q.kind = StampKind::kCrater;
  q.center_x = 5 * 256;
  q.center_y = -3 * 256;
  q.radius = 60 * 256;
  q.intensity = 20000 * 256;
  q.shape = 40000;
  ASSERT_TRUE(apply_stamp(w, q).ok());
  w.commit(1);
  auto g = GpuStamper::create(w);
  auto n = NormalPass::create(w.params());
  ASSERT_TRUE(g.ok() && n.ok()) << (n.ok() ? "" : n.error().describe());
  const RectI all = w.params().sample_rect();
  // The stamper's pages, copied on the GPU into one texture of the whole world.
  GlTexture heights = make_texture(GL_TEXTURE_2D);
  glTextureStorage2D(heights.get(), 1, GL_R16UI, GLsizei(all.width()), GLsizei(all.height()));
  glTextureParameteri(heights.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(heights.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  ASSERT_TRUE((*g)->copy_to(Layer::kCoarse, all, heights.get(), 0, 0));
  (*n)->update(heights.get(), all);
  const std::vector<uint32_t> got = (*n)->read(all);
  const std::vector<uint32_t> want = generate_normal_map(w, all);
  ASSERT_EQ(got.size(), want.size());
  int64_t mismatches = 0, off_by_more = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    if (got[i] == want[i]) continue;
    ++mismatches;
    const int dx = int(int16_t(got[i] & 0xFFFF)) - int(int16_t(want[i] & 0xFFFF));
    const int dy = int(int16_t(got[i] >> 16)) - int(int16_t(want[i] >> 16));
    if (std::abs(dx) > 1 || std::abs(dy) > 1) ++off_by_more;
  }
  std::printf("normal pass: %zu samples, %lld packed mismatches (%lld by more than 1 LSB)\n", got.size(),
              static_cast<long long>(mismatches), static_cast<long long>(off_by_more));
  EXPECT_EQ(mismatches, 0);
  EXPECT_EQ(normals_rect_for(w.params(), RectI{0, 0, 1, 1}), (RectI{-4, -4, 5, 5}));
}

TEST(GpuBackend, ForcedGpuBackendMatchesCpuBackend) {
  LOAM_REQUIRE_GL();
  World a = sloped_world(1, 0), b = a;
  auto gpu = make_stamp_backend(BackendKind::kGpu, b);
  ASSERT_TRUE(gpu.ok()) << gpu.error().describe();
  auto cpu = make_stamp_backend(BackendKind::kCpu, a);
  ASSERT_TRUE(cpu.ok());
  EXPECT_STREQ((*gpu)->name(), "gpu");
  EXPECT_STREQ((*cpu)->name(), "cpu");
  EXPECT_FALSE((*gpu)->renderer().empty());
  QuantizedStamp q;
  q.center_x = 100 * 256;
  q.center_y = 90 * 256;
  q.radius = 50 * 256;
  q.intensity = 9000 * 256;
  auto ra = (*cpu)->apply(a, q);
  auto rb = (*gpu)->apply(b, q);
  ASSERT_TRUE(ra.ok() && rb.ok());
  EXPECT_EQ(*ra, *rb);
  // A region written into the World outside the backend reaches the GPU copy.
  std::vector<uint16_t> flat(16 * 16, 1234);
  a.write_coarse({10, 10, 26, 26}, flat);
  b.write_coarse({10, 10, 26, 26}, flat);
  (*gpu)->world_changed(b, Layer::kCoarse, {10, 10, 26, 26});
  q.center_x = 18 * 256;
  q.center_y = 18 * 256;
  ASSERT_TRUE((*cpu)->apply(a, q).ok() && (*gpu)->apply(b, q).ok());
  a.commit(1);
  b.commit(1);
  EXPECT_EQ(a.world_hash(), b.world_hash());
  // A bad stamp is rejected with the reference's error and leaves the world alone.
  q.radius = 0;
  EXPECT_FALSE((*gpu)->apply(b, q).ok());
}

}  // namespace
}  // namespace loam::gpu
