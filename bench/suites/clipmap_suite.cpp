// Suite `clipmap`: the clipmap renderer's cost against the error it makes. For each level size
// n over the embedded terrain and five views: frame time (steady, and flying with strip
// uploads), triangles and draw calls; and the error of the rendered surface against the
// full-resolution terrain (protocol/surface.h's bilinear mip-0 surface): for every terrain
// pixel, the point under it (from the depth buffer) is moved to the true surface height and
// projected back, and the distance in pixels is the screen-space error (mean, p99, max), next
// to the vertical error in meters.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "bench/screen_error.h"
#include "client/render/clipmap_renderer.h"
#include "client/render/offscreen_target.h"
#include "dem/default_terrain.h"
#include "gpu/egl_context.h"
#include "protocol/surface.h"

namespace loam::bench {
namespace {

struct View {
  double x, y, dz, tx, ty, tdz;  // heights above the ground under them
};

// Over plains, valleys, the plateau's cliffs and the whole world.
const View kViews[] = {{560, 1180, 12, 1100, 900, 10},
                       {1500, 300, 120, 700, 700, 0},
                       {655, 505, 28, 615, 472, 0},
                       {900, 1300, 300, 1000, 700, 0},
                       {200, 200, 60, 900, 900, 0}};

// One renderer over the five views: each view's steady frame time (median of repeated frames)
// and the per-view sums of what it drew; `after_view` sees each view's last frame (its depth).
struct ViewsRun {
  std::vector<double> steady_s;
  int64_t triangles = 0, shadow_triangles = 0;
  int64_t draw_calls = 0;
  double median_ms() const {
    std::vector<double> s = steady_s;
    std::sort(s.begin(), s.end());
    return s[s.size() / 2] * 1e3;
  }
};

ViewsRun run_views(const Context& ctx, const World& world, render::ClipmapRenderer& r,
                   render::OffscreenTarget& target, int32_t w, int32_t h, double view_distance,
                   const MeasureOptions& opts,
                   const std::function<void(const scene::Camera&)>& after_view = {}) {
  ViewsRun run;
  for (const View& v : kViews) {
    scene::Camera cam = scene::look_at(v.x, v.y, height_at(world, v.x, v.y) + v.dz, v.tx, v.ty,
                                       height_at(world, v.tx, v.ty) + v.tdz);
    cam.near_m = 1.0;
    cam.far_m = 2.0 * view_distance;
    render::FrameStats fs;
    const Timing t = measure(
        ctx,
        [&] {
          target.begin(0.5f, 0.6f, 0.75f, 0.0f);
          fs = r.render(cam, w, h);
          glFinish();
        },
        opts);
    run.steady_s.push_back(t.median_s);
    run.triangles += fs.triangles;
    run.shadow_triangles += fs.shadow_triangles;
    run.draw_calls += fs.draw_calls;
    if (after_view) after_view(cam);
  }
  return run;
}

int run_clipmap(const Context& ctx, Report& report) {
  auto egl = gpu::EglContext::create(gpu::EglPreference::kAny);
  if (!egl || !egl->make_current().ok()) {
    report.paragraph("Skipped: no EGL display gives an OpenGL 4.5 core context.");
    return 0;
  }
  auto imported = load_default_terrain();
  if (!imported) {
    std::fprintf(stderr, "clipmap: %s\n", imported.error().describe().c_str());
    return 1;
  }
  const World& world = imported->world;
  terrain::WorldHeightSource source(world);
  const int32_t w = ctx.quick ? 320 : 1280, h = ctx.quick ? 180 : 720;
  auto target = render::OffscreenTarget::create(w, h);
  if (!target) return 1;
  const std::vector<int32_t> sizes =
      ctx.quick ? std::vector<int32_t>{31} : std::vector<int32_t>{31, 63, 127, 255};
  Table table("clipmap", {"n", "morph", "levels", "triangles", "draw calls", "frame ms (steady)",
                          "frame ms (flying)", "texels/frame flying", "error px mean", "error px p50",
                          "error px p99", "error px max", "error m mean", "error m max"});
  Series s_err{"screen-space error p99 (px)", {}}, s_ms{"frame time, steady (ms)", {}};
  const MeasureOptions opts{
      .warmup = 1, .min_runs = ctx.quick ? 2 : 5, .max_runs = 50, .min_seconds = ctx.quick ? 0.02 : 0.3};
  struct Config {
    int32_t n;
    bool morph;
  };
  std::vector<Config> configs;
  for (int32_t n : sizes) configs.push_back({n, true});
  // Without morphing at the default size; the smoke run (--quick) at its smallest, which runs
  // the same code.
  configs.push_back({ctx.quick ? sizes.front() : 127, false});
  for (const Config& c : configs) {
    render::RendererConfig cfg;
    cfg.n = c.n;
    cfg.morph = c.morph;
    // The geometry's cost and error alone; the shading's is the second table.
    cfg.look.materials = false;
    cfg.look.shadows = false;
    auto r = render::ClipmapRenderer::create(source, cfg);
    if (!r) {
      std::fprintf(stderr, "clipmap: %s\n", r.error().describe().c_str());
      return 1;
    }
    std::vector<double> px, m;
    const ViewsRun views = run_views(
        ctx, world, **r, *target, w, h, cfg.view_distance, opts,
        [&](const scene::Camera& cam) { add_screen_errors(world, cam, w, h, target->read_depth(), px, m); });
    // Flying: 2 m per frame toward the first view's target (strip uploads every frame).
    const View& v = kViews[0];
    std::vector<double> fly;
    int64_t texels = 0;
    const int frames = ctx.quick ? 5 : 40;
    for (int i = 0; i < frames; ++i) {
      const double f = 2.0 * i / std::hypot(v.tx - v.x, v.ty - v.y);
      const double x = v.x + (v.tx - v.x) * f, y = v.y + (v.ty - v.y) * f;
      scene::Camera cam = scene::look_at(x, y, height_at(world, x, y) + v.dz, v.tx, v.ty,
                                         height_at(world, v.tx, v.ty) + v.tdz);
      cam.far_m = 2.0 * cfg.view_distance;
      const auto t0 = std::chrono::steady_clock::now();
      target->begin(0.5f, 0.6f, 0.75f, 0.0f);
      texels += (*r)->render(cam, w, h).texels_uploaded;
      glFinish();
      fly.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(fly.begin(), fly.end());
    const double steady_ms = views.median_ms(), fly_ms = fly[fly.size() / 2] * 1e3;
    const ErrorStats e = summarize_errors(px, m);
    const int64_t tri_per_view = views.triangles / int64_t(std::size(kViews));
    table.add_row({std::to_string(c.n), c.morph ? "on" : "off", std::to_string((*r)->levels()),
                   std::to_string(tri_per_view),
                   std::to_string(views.draw_calls / int64_t(std::size(kViews))), fmt(steady_ms), fmt(fly_ms),
                   std::to_string(texels / frames), fmt(e.mean_px, 3), fmt(e.p50_px, 3), fmt(e.p99_px),
                   fmt(e.max_px), fmt(e.mean_m, 3), fmt(e.max_m)});
    if (c.morph) {
      s_err.points.push_back({double(tri_per_view), e.p99_px});
      s_ms.points.push_back({double(tri_per_view), steady_ms});
    }
    std::printf(
        "  n %d morph %s: %lld triangles, %.1f ms steady, %.1f ms flying, error p99 %.2f px, mean %.3f m\n",
        c.n, c.morph ? "on" : "off", (long long)tri_per_view, steady_ms, fly_ms, e.p99_px, e.mean_m);
  }
  // Materials and shadows: what the shading costs at n = 127 over the same views (the
  // geometry and its error are the same in every row).
  Table shading("shading", {"materials", "anisotropy", "shadows", "shadow map", "triangles (view)",
                            "triangles (shadow pass)", "draw calls", "frame ms (steady)", "added ms",
                            "renderer GPU MiB"});
  struct Shading {
    bool materials;
    float anisotropy;
    bool shadows;
    int32_t shadow_size;
  };
  double bare_ms = 0;
  std::vector<Shading> shadings{Shading{false, 0, false, 0}, Shading{true, 1, false, 0},
                                Shading{true, 8, false, 0}, Shading{true, 0, true, 1024},
                                Shading{true, 0, true, 2048}};
  // The smoke run: bare against everything on (the other rows differ only in a parameter).
  if (ctx.quick) shadings = {shadings.front(), shadings[3]};
  for (const Shading& sh : shadings) {
    render::RendererConfig cfg;
    cfg.look.materials = sh.materials;
    cfg.look.anisotropy = sh.anisotropy;
    cfg.look.shadows = sh.shadows;
    if (sh.shadows) cfg.look.shadow_size = sh.shadow_size;
    auto r = render::ClipmapRenderer::create(source, cfg);
    if (!r) {
      std::fprintf(stderr, "clipmap: %s\n", r.error().describe().c_str());
      return 1;
    }
    const ViewsRun views = run_views(ctx, world, **r, *target, w, h, cfg.view_distance, opts);
    const double ms = views.median_ms();
    if (!sh.materials && !sh.shadows) bare_ms = ms;
    const int64_t n_views = int64_t(std::size(kViews));
    shading.add_row({sh.materials ? "on" : "off",
                     sh.materials ? fmt((*r)->anisotropy(), 0) + (sh.anisotropy == 0 ? " (auto)" : "") : "-",
                     sh.shadows ? "on" : "off", sh.shadows ? std::to_string(sh.shadow_size) + "^2" : "-",
                     std::to_string(views.triangles / n_views),
                     std::to_string(views.shadow_triangles / n_views),
                     std::to_string(views.draw_calls / n_views), fmt(ms), fmt(ms - bare_ms),
                     fmt(double((*r)->gpu_bytes()) / (1 << 20))});
    std::printf("  materials %s aniso %.0f shadows %s (%d): %.1f ms steady, %lld shadow triangles\n",
                sh.materials ? "on" : "off", double((*r)->anisotropy()), sh.shadows ? "on" : "off",
                sh.shadow_size, ms, (long long)(views.shadow_triangles / n_views));
  }
  report.paragraph(
      "Renderer: " + egl->renderer() + ". " + std::to_string(w) + "x" + std::to_string(h) +
      " pixels, the embedded terrain (2 m/sample, 364 m of relief, cliffs to 85 degrees), view "
      "distance 4 km (the level count follows it), detail 512^2, five views (plains, cliffs, close, "
      "high, corner), shaded by the bare colour bands (no materials, no shadows: the geometry's own "
      "cost). Frame time is render + glFinish, median over repeated frames of each view "
      "(steady: level textures current) and over " +
      std::to_string(ctx.quick ? 5 : 40) +
      " frames flying 2 m per frame (toroidal strip uploads and their normal maps every frame). "
      "Error: each terrain pixel's point moved to the full-resolution bilinear surface's height and "
      "projected back; pixels, and meters vertically. Per-view averages of triangles and draw calls.");
  report.table(std::move(table));
  report.paragraph(
      "Materials and shadows at n = 127 (the defaults: materials on, anisotropy auto, a 2048^2 shadow "
      "map over 2 x 3 km around the camera), the same five views: frame time against the bare colour "
      "bands. Materials sample tiling detail textures (four materials at two scales, a slow variation "
      "mixing them) and the level's change layer, trilinear or anisotropic; auto anisotropy is 8 on a "
      "GPU and 1 on a software rasterizer. The shadow pass draws the levels again from the sun (culled "
      "to the map's square), depth only; draw calls count both passes.");
  report.table(std::move(shading));
  report.plot({"clipmap_error.png",
               "Clipmap: screen-space error p99 and frame time against triangles (" + egl->renderer() + ")",
               "triangles drawn per frame",
               "p99 error (px) / frame time (ms)",
               true,
               true,
               {s_err, s_ms},
               {}});
  return 0;
}

}  // namespace

LOAM_BENCH_SUITE(clipmap,
                 "clipmap renderer: frame time and triangles against screen-space error, per level size",
                 run_clipmap);

}  // namespace loam::bench
