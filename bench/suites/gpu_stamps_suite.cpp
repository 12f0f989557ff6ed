// Suite `gpu-stamps`: the GPU stamp backend (forced through EGL, so llvmpipe here and the
// same binary on a real GPU) against the scalar CPU reference, per radius 1..200 m, with the
// mismatch count next to every time; dirty-rect readback against whole-map readback; and a
// 500x500-texel stamp with its normals against the 1.8 ms of the 2010 reference system.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "gpu/egl_context.h"
#include "gpu/gl_handle.h"
#include "gpu/gpu_stamper.h"
#include "gpu/normal_pass.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_kernel.h"
#include "protocol/world.h"

namespace loam::bench {
namespace {

World bench_world(int32_t tiles) {
  WorldParams p;
  p.tiles_x = tiles;
  p.tiles_y = tiles;
  const RectI r = p.sample_rect();
  std::vector<uint16_t> s(size_t(r.area()));
  for (int64_t y = 0; y < r.height(); ++y) {
    for (int64_t x = 0; x < r.width(); ++x)
      s[size_t(y * r.width() + x)] = uint16_t(30000 + (x * 7 + y * 3) % 5000);
  }
  return std::move(World::from_samples(p, s).value());
}

QuantizedStamp gaussian_at(const World& w, double radius_m, int i) {
  QuantizedStamp q;
  const RectI r = w.params().sample_rect();
  q.kind = StampKind::kGaussian;
  q.center_x = (r.x0 + r.width() / 2) * 256 + 77;
  q.center_y = (r.y0 + r.height() / 2) * 256 + 13;
  q.radius = uint32_t(radius_m / w.params().meters_per_sample * 256.0);
  q.intensity = (i % 2 ? -1 : 1) * 2000 * 256;  // alternate, so the terrain does not saturate
  return q;
}

int64_t mismatches(const World& a, const World& b) {
  const RectI r = a.params().sample_rect();
  std::vector<uint16_t> x(size_t(r.area())), y(size_t(r.area()));
  a.read_coarse(r, x);
  b.read_coarse(r, y);
  int64_t n = 0;
  for (size_t i = 0; i < x.size(); ++i) n += x[i] != y[i];
  return n;
}

std::string ratio_text(double r) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", r);
  return b;
}

std::string ms(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4f", s * 1e3);
  return b;
}

int run_gpu_stamps(const Context& ctx, Report& report) {
  auto egl = gpu::EglContext::create(gpu::EglPreference::kAny);
  if (!egl) {
    report.paragraph("Skipped: no EGL display gives an OpenGL 4.5 core context (" + egl.error().describe() +
                     ").");
    std::printf("  skipped: %s\n", egl.error().describe().c_str());
    return 0;
  }
  const std::string renderer = egl->renderer();
  const int32_t tiles = ctx.quick ? 2 : 8;
  World cpu = bench_world(tiles);
  World gpu_world = cpu;
  auto stamper = gpu::GpuStamper::create(gpu_world);
  if (!stamper) {
    std::fprintf(stderr, "gpu-stamps: %s\n", stamper.error().describe().c_str());
    return 1;
  }
  gpu::GpuStamper& g = **stamper;
  const MeasureOptions opts{
      .warmup = 2, .min_runs = 5, .max_runs = 400, .min_seconds = ctx.quick ? 0.02 : 0.3};

  Table table("stamps", {"radius m", "rect samples", "GPU stage", "CPU scalar ms", "CPU optimized ms",
                         "GPU stamp ms", "GPU stamp + readback ms", "GPU+readback / CPU", "mismatches"});
  Series s_fast{"CPU optimized (stamp_fast)", {}};
  Series s_cpu{"CPU scalar reference", {}}, s_gpu{"GPU stamp only", {}},
      s_gpu_rb{"GPU stamp + dirty-rect readback", {}};
  int failures = 0;
  double worst_ratio = 0;
  double gpu_fixed_s = 0, cpu_fixed_s = 0;  // the most a stamp of radius <= 5 m takes: its fixed cost
  std::string passing, failing;             // radii within / beyond the llvmpipe target
  for (double radius : {1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0}) {
    int i = 0;
    const Timing t_cpu = measure(
        ctx, [&] { (void)apply_stamp_reference(cpu, gaussian_at(cpu, radius, i++)); }, opts);
    i = 0;
    const Timing t_fast = measure(
        ctx, [&] { (void)apply_stamp(cpu, gaussian_at(cpu, radius, i++)); }, opts);
    i = 0;
    const Timing t_gpu_rb = measure(
        ctx, [&] { (void)g.apply(gpu_world, gaussian_at(cpu, radius, i++)); }, opts);
    // GPU only: stamp and wait for the GPU, no readback into the mirror (collected later).
    World scratch = gpu_world;
    i = 0;
    const Timing t_gpu = measure(
        ctx,
        [&] {
          (void)g.submit(gaussian_at(cpu, radius, i++));
          glFinish();
        },
        opts);
    g.collect(scratch);
    g.upload(gpu_world, Layer::kCoarse, gpu_world.params().sample_rect());  // back in step with the mirror
    // Bring both worlds to the same state and count mismatches of one more stamp each.
    gpu_world = cpu;
    g.upload(gpu_world, Layer::kCoarse, gpu_world.params().sample_rect());
    const QuantizedStamp q = gaussian_at(cpu, radius, 0);
    (void)apply_stamp(cpu, q);
    (void)g.apply(gpu_world, q);
    const int64_t m = mismatches(cpu, gpu_world);
    failures += m != 0;
    cpu.commit(1);
    gpu_world.commit(1);
    const double ratio = t_gpu_rb.median_s / t_cpu.median_s;
    worst_ratio = std::max(worst_ratio, ratio);
    if (radius <= 5.0) {
      gpu_fixed_s = std::max(gpu_fixed_s, t_gpu_rb.median_s);
      cpu_fixed_s = std::max(cpu_fixed_s, t_fast.median_s);
    }
    std::string& list = ratio <= 1.5 ? passing : failing;
    list += (list.empty() ? "" : ", ") + std::to_string(int(radius));
    const auto baked = bake_stamp(q, cpu.params());
    const int64_t samples = baked.ok() ? baked->rect.area() : 0;
    const char* stage = g.path_for(samples) == gpu::StampPath::kVertex ? "vertex" : "compute";
    char rbuf[16];
    std::snprintf(rbuf, sizeof rbuf, "%.2f", ratio);
    table.add_row({std::to_string(int(radius)), std::to_string(samples), stage, ms(t_cpu.median_s),
                   ms(t_fast.median_s), ms(t_gpu.median_s), ms(t_gpu_rb.median_s), rbuf, std::to_string(m)});
    s_cpu.points.push_back({radius, t_cpu.median_s * 1e3});
    s_fast.points.push_back({radius, t_fast.median_s * 1e3});
    s_gpu.points.push_back({radius, t_gpu.median_s * 1e3});
    s_gpu_rb.points.push_back({radius, t_gpu_rb.median_s * 1e3});
    std::printf(
        "  radius %5.0f m (%s): CPU scalar %.3f ms, optimized %.3f ms, GPU %.3f ms, GPU+readback %.3f ms "
        "(x%.2f), %lld mismatches\n",
        radius, stage, t_cpu.median_s * 1e3, t_fast.median_s * 1e3, t_gpu.median_s * 1e3,
        t_gpu_rb.median_s * 1e3, ratio, (long long)m);
  }

  // Readback: the dirty rect of a 100 m stamp against the whole coarse layer.
  Table rb("readback", {"what", "samples", "ms", "rate"});
  const RectI world_rect = cpu.params().sample_rect();
  // The stamper keeps tile pages; the normal pass and this readback read one texture of the
  // whole (small) bench world, filled from the pages on the GPU.
  gpu::GlTexture heights = gpu::make_texture(GL_TEXTURE_2D);
  glTextureStorage2D(heights.get(), 1, GL_R16UI, GLsizei(world_rect.width()), GLsizei(world_rect.height()));
  glTextureParameteri(heights.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(heights.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  g.collect(gpu_world);
  (void)g.copy_to(Layer::kCoarse, world_rect, heights.get(), 0, 0);
  for (const auto& [what, rect] :
       {std::pair{std::string("dirty rect (201x201)"),
                  RectI{world_rect.x0 + 500, world_rect.y0 + 500, world_rect.x0 + 701, world_rect.y0 + 701}},
        std::pair{std::string("whole map"), world_rect}}) {
    gpu::GlBuffer pbo = gpu::make_buffer();
    const size_t bytes = size_t(rect.area()) * 2;
    glNamedBufferStorage(pbo.get(), GLsizeiptr(bytes), nullptr, GL_MAP_READ_BIT | GL_CLIENT_STORAGE_BIT);
    std::vector<uint16_t> out(size_t(rect.area()));
    const Timing t = measure(
        ctx,
        [&] {
          glPixelStorei(GL_PACK_ALIGNMENT, 1);
          glBindBuffer(GL_PIXEL_PACK_BUFFER, pbo.get());
          glGetTextureSubImage(heights.get(), 0, GLint(rect.x0 - world_rect.x0),
                               GLint(rect.y0 - world_rect.y0), 0, GLsizei(rect.width()),
                               GLsizei(rect.height()), 1, GL_RED_INTEGER, GL_UNSIGNED_SHORT, GLsizei(bytes),
                               nullptr);
          glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
          const void* p = glMapNamedBufferRange(pbo.get(), 0, GLsizeiptr(bytes), GL_MAP_READ_BIT);
          std::memcpy(out.data(), p, bytes);
          glUnmapNamedBuffer(pbo.get());
        },
        opts);
    rb.add_row({what, std::to_string(rect.area()), ms(t.median_s), format_rate(double(bytes) / t.median_s)});
    std::printf("  readback %s: %.3f ms\n", what.c_str(), t.median_s * 1e3);
  }

  // A 500x500-texel stamp (radius 250 samples) with its normals, three ways: on the GPU's own
  // clock (GL_TIMESTAMP queries before the stamp and after the normal pass: what the 2010
  // reference's 1.8 ms measured; any bubble between the commands counts too, so it is an upper
  // bound), to completion on the host's clock (glFinish), and with the stamp's rect read back
  // into the World mirror. Timestamps rather than GL_TIME_ELAPSED: llvmpipe reports 0 for the
  // latter around work it runs at dispatch.
  Table big_table("big_stamp", {"what", "median ms", "p10..p90 ms", "runs"});
  std::string big_gpu_ms = "n/a";
  auto normals = gpu::NormalPass::create(gpu_world.params());
  if (normals && world_rect.width() >= 600) {
    const QuantizedStamp big = gaussian_at(cpu, 250.0 * cpu.params().meters_per_sample, 0);
    const RectI r{big.center_x / 256 - 250, big.center_y / 256 - 250, big.center_x / 256 + 251,
                  big.center_y / 256 + 251};
    GLuint queries[2] = {0, 0};
    glCreateQueries(GL_TIMESTAMP, 2, queries);
    std::vector<double> gpu_s, done_s, mirror_s;
    const int runs = ctx.quick ? 5 : 200;
    for (int run = -2; run < runs; ++run) {  // two warm-up runs
      const auto t0 = std::chrono::steady_clock::now();
      glQueryCounter(queries[0], GL_TIMESTAMP);
      (void)g.submit(big);
      // The normals read 4 samples around the rect: those come to the world texture too.
      const RectI nr = gpu::normals_rect_for(gpu_world.params(), r);
      const RectI in = RectI{nr.x0 - 4, nr.y0 - 4, nr.x1 + 4, nr.y1 + 4}.intersect(world_rect);
      (void)g.copy_to(Layer::kCoarse, in, heights.get(), int32_t(in.x0 - world_rect.x0),
                      int32_t(in.y0 - world_rect.y0));
      (*normals)->update(heights.get(), nr);
      glQueryCounter(queries[1], GL_TIMESTAMP);
      glFinish();
      const auto t1 = std::chrono::steady_clock::now();
      g.collect(gpu_world);
      const auto t2 = std::chrono::steady_clock::now();
      GLuint64 begin_ns = 0, end_ns = 0;
      glGetQueryObjectui64v(queries[0], GL_QUERY_RESULT, &begin_ns);
      glGetQueryObjectui64v(queries[1], GL_QUERY_RESULT, &end_ns);
      const GLuint64 elapsed_ns = end_ns > begin_ns ? end_ns - begin_ns : 0;
      if (run < 0) continue;
      gpu_s.push_back(double(elapsed_ns) * 1e-9);
      done_s.push_back(std::chrono::duration<double>(t1 - t0).count());
      mirror_s.push_back(std::chrono::duration<double>(t2 - t0).count());
    }
    glDeleteQueries(2, queries);
    for (const auto& [what, samples] :
         {std::pair{std::string("stamp + normals, GPU clock (timestamp queries)"), &gpu_s},
          std::pair{std::string("stamp + normals to completion (glFinish)"), &done_s},
          std::pair{std::string("stamp + normals + readback into the mirror"), &mirror_s}}) {
      const Timing t = summarize(*samples);
      big_table.add_row({what, ms(t.median_s), ms(t.p10_s) + ".." + ms(t.p90_s), std::to_string(t.runs)});
      std::printf("  500x500 %s: %.3f ms (2010 reference: 1.8 ms)\n", what.c_str(), t.median_s * 1e3);
    }
    big_gpu_ms = ms(summarize(gpu_s).median_s);
  }

  report.paragraph(
      "Renderer: " + renderer + ". World " + std::to_string(world_rect.width()) + "x" +
      std::to_string(world_rect.height()) +
      " coarse samples at 1 m. Gaussian stamps on the coarse layer at the map centre, alternating sign. "
      "`CPU scalar` is loam::apply_stamp_reference (stamp_sample per sample), `CPU optimized` "
      "loam::apply_stamp (the fast kernel, stamp_fast.h). "
      "`GPU stage` is where GpuStamper runs the kernel for that rect (StampPath::kAuto: on a software "
      "renderer the vertex stage up to GpuStamper::kVertexPathMaxSamples samples, compute above). "
      "`GPU stamp` is the stamp until glFinish; `GPU stamp + readback` is GpuStamper::apply: bake, draw "
      "or dispatch, PBO readback of the stamp's rect and its write into the World mirror. Mismatches: "
      "texels that differ from the CPU reference after one more stamp (must be 0). Times are medians "
      "of repeated runs on a shared 2-core machine. Target on llvmpipe: GPU + readback <= 1.5x the "
      "scalar CPU time. Within it: radius " +
      (passing.empty() ? std::string("none") : passing) +
      " m; beyond it: " + (failing.empty() ? std::string("none") : "radius " + failing + " m") +
      " (worst ratio " + ratio_text(worst_ratio) +
      "). Per-stamp fixed cost (stamps of radius 1-5 m, whose "
      "work is a few hundred samples): GPU + readback " +
      fmt(gpu_fixed_s * 1e6, 1) + " us, CPU optimized " + fmt(cpu_fixed_s * 1e6, 1) +
      " us (the profile table is baked once per profile on both paths: bake_stamp's per-thread memo).");
  report.table(std::move(table));
  report.table(std::move(rb));
  report.paragraph(
      "500x500-texel stamp with its FD4 normals (the 2010 reference system needed 1.8 ms; "
      "the target applies on a real GPU). GPU clock: " +
      big_gpu_ms + " ms on " + renderer + ".");
  report.table(std::move(big_table));
  report.plot({"gpu_stamps_time.png",
               "Stamp time against radius (" + renderer + ")",
               "radius (m)",
               "milliseconds",
               true,
               true,
               {s_cpu, s_fast, s_gpu, s_gpu_rb},
               {}});
  return failures;
}

}  // namespace

static SuiteRegistration gpu_stamps_registration(
    "gpu-stamps", "GPU stamps (forced EGL) vs the CPU reference per radius, readback, 500^2 stamp + normals",
    run_gpu_stamps);

}  // namespace loam::bench
