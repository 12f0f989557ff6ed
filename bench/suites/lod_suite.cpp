// Suite `lod`: what each level-of-detail scheme costs at a given screen error. The schemes
// render the same height source through the same GL path (llvmpipe here) and are scored by
// the same per-pixel evaluator (bench/screen_error.h):
//   - the full mesh (every sample; geomipmapping at a budget of 0 px), the baseline;
//   - geomipmapping (client/lod/geomipmap.h: de Boer's error metric, Wagner's geomorphing),
//     patches of 17, 33 and 65 vertices at several budgets, 8 px as Leitao & Carmo's Table 1;
//   - Ulrich's adaptive quadtree (client/lod/quadtree.h) over blocks of 32 and 64 samples;
//   - Loam's geometry clipmaps (level distance from view distance, not error);
//   - the error-driven clipmap (client/lod/error_clipmap.h): the clipmap's level regions drawn
//     as blocks chosen for a screen-space budget;
//   - Leitao & Carmo's tiled blocks at 8 px: block-based or quadtree-based simplification per
//     block, cracks closed by skirts or by index update.
// LOAM_LOD_ONLY="word;word" keeps the settings whose name holds a word; LOAM_LOD_ERROR_CLIPMAPS=
// "block,region,budget,exact_levels;..." replaces the error-driven clipmap's settings.
// Three recorded camera paths per terrain (the embedded crop and two DEMs of ../shared/data at
// their own resolution): a 60 s low-altitude walk, a high flight and a grazing view along the
// highest ridge. Per scheme and setting: screen error (mean, p99, max px) and vertical error
// (m); temporal pop, the largest per-frame change of the drawn surface seen from the camera
// that camera motion does not explain (the surface drawn with the previous frame's levels
// against this frame's, at fixed world points); triangles, draw calls, CPU and GPU ms per
// frame; and the update after a stamp.
#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "bench/harness.h"
#include "bench/lod/geomipmap_renderer.h"
#include "bench/lod/quadtree_renderer.h"
#include "bench/screen_error.h"
#include "client/render/clipmap_renderer.h"
#include "client/render/error_clipmap_renderer.h"
#include "client/render/offscreen_target.h"
#include "client/render/viewer_session.h"
#include "dem/default_terrain.h"
#include "dem/dem_import.h"
#include "dem/refined_default.h"
#include "gpu/egl_context.h"
#include "protocol/surface.h"

namespace loam::bench {
namespace {

using clock_type = std::chrono::steady_clock;

// The median; -1 for none.
double median(std::vector<double> v) {
  if (v.empty()) return -1.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Terrain {
  std::string name;
  World world;
  bool viewer_only = false;  // only the viewer rows draw it
};

// The main job's world (dem/refined_default.h): a window `side` samples square at its full 1 m
// around its centre, where the viewer starts, copied into a World the evaluator, the paths and
// the pop measure can read whole.
Result<World> refined_window(int64_t side) {
  auto base = refined_default_base();
  if (!base) return base.error();
  const WorldParams& big = refined_default_params();
  World full(big, *base);
  full.set_base_cache_budget(size_t(64) << 20);
  const RectI all = big.sample_rect();
  const int64_t x0 = (all.x0 + all.x1 - side) / 2 / kTileSize * kTileSize,
                y0 = (all.y0 + all.y1 - side) / 2 / kTileSize * kTileSize;
  std::vector<uint16_t> samples(size_t(side * side));
  for (int64_t y = 0; y < side; y += kTileSize) {  // a row of tiles at a time, the cache trimmed
    full.read_coarse({x0, y0 + y, x0 + side, y0 + y + kTileSize},
                     std::span<uint16_t>(samples).subspan(size_t(y * side), size_t(kTileSize * side)));
    full.trim_base_cache();
  }
  WorldParams p = big;
  p.origin_tile_x = p.origin_tile_y = 0;
  p.tiles_x = p.tiles_y = int32_t(side / kTileSize);
  return World::from_samples(p, samples);
}

// A recorded path: the cameras of the scored frames, each with the camera one frame (1/30 s)
// before it, whose levels the pop is measured against.
struct Path {
  std::string name;
  std::vector<scene::Camera> frames, previous;
};

// `above_ground` sets the near plane: a quarter of it (at least 0.5 m). With reversed float
// depth the near plane hardly matters to precision; the error evaluator reads that depth.
scene::Camera camera_at(double x, double y, double z, double heading, double pitch_deg, double far_m,
                        double above_ground) {
  const double p = pitch_deg * M_PI / 180.0;
  scene::Camera c = scene::look_at(x, y, z, x + std::cos(heading) * std::cos(p) * 100.0,
                                   y + std::sin(heading) * std::cos(p) * 100.0, z + std::sin(p) * 100.0);
  c.fov_y_degrees = 60;
  c.near_m = std::max(0.5, 0.25 * above_ground);
  c.far_m = far_m;
  return c;
}

std::vector<Path> paths_for(const World& world, int frames) {
  const WorldParams& p = world.params();
  const RectI r = p.sample_rect();
  const double mps = p.meters_per_sample;
  const double x0 = double(r.x0) * mps, y0 = double(r.y0) * mps;
  const double wm = double(r.width() - 1) * mps, hm = double(r.height() - 1) * mps;
  const double diag = std::hypot(wm, hm), far_m = 2.0 * diag;
  // The highest sample: the ridge the grazing path runs along.
  std::vector<uint16_t> s(size_t(r.area()));
  world.read_coarse(r, s);
  const size_t top = size_t(std::max_element(s.begin(), s.end()) - s.begin());
  const double peak_x = x0 + double(int64_t(top) % r.width()) * mps,
               peak_y = y0 + double(int64_t(top) / r.width()) * mps;
  double max_h = 0;
  for (uint16_t v : s) max_h = std::max(max_h, p.height_offset + double(v) * p.meters_per_unit);

  std::vector<Path> out;
  struct Motion {
    const char* name;
    std::function<scene::Camera(double t)> at;  // t in seconds, 0..60
  };
  const double heading = std::atan2(0.3, 1.0);
  const std::vector<Motion> motions = {
      // Walking pace with the eye 1.8 m above the ground, looking ahead and slightly down.
      {"walk",
       [&](double t) {
         const double x = x0 + 0.3 * wm + 1.4 * t * std::cos(heading),
                      y = y0 + 0.5 * hm + 1.4 * t * std::sin(heading);
         // 1.8 m above every scheme's surface there: between 30 m samples the triangles and the
         // bilinear surface can differ by meters, and an eye below the drawn surface is no walk.
         const double ground = std::max({truth_height(world, x, y, Truth::kBilinear),
                                         truth_height(world, x, y, Truth::kTriangles),
                                         truth_height(world, x, y, Truth::kUnionJack)});
         return camera_at(x, y, ground + 1.8, heading, -5, far_m, 1.8);
       }},
      // Across half the world in a minute, high above the highest point, 30 degrees down.
      {"flight",
       [&](double t) {
         const double x = x0 + 0.15 * wm + 0.5 * wm * t / 60.0, y = y0 + 0.25 * hm + 0.4 * hm * t / 60.0;
         const double z = max_h + 0.08 * diag;
         return camera_at(x, y, z, std::atan2(0.4 * hm, 0.5 * wm), -30, far_m, z - max_h);
       }},
      // Along the highest ridge, 3 m above it, looking level toward the world's centre.
      {"ridge",
       [&](double t) {
         const double cx = x0 + 0.5 * wm, cy = y0 + 0.5 * hm;
         const double h = std::atan2(cy - peak_y, cx - peak_x);
         const double x = peak_x + 4.0 * t * std::cos(h + M_PI / 2),
                      y = peak_y + 4.0 * t * std::sin(h + M_PI / 2);
         const double ground = height_at(world, x, y),
                      z = std::max(ground, height_at(world, peak_x, peak_y)) + 3.0;
         return camera_at(x, y, z, h, -1, far_m, z - ground);
       }},
  };
  for (const Motion& m : motions) {
    Path path{m.name, {}, {}};
    for (int i = 0; i < frames; ++i) {
      const double t = frames == 1 ? 30.0 : 60.0 * double(i) / double(frames - 1);
      path.frames.push_back(m.at(t));
      path.previous.push_back(m.at(std::max(0.0, t - 1.0 / 30.0)));
    }
    out.push_back(std::move(path));
  }
  return out;
}

// One scheme at one setting, behind the three things the suite asks of it.
class Scheme {
 public:
  virtual ~Scheme() = default;
  // Draws the frame as a viewer would (levels chosen for `cam`); returns LOD CPU ms if known.
  virtual void frame(const scene::Camera& cam, int32_t w, int32_t h, int64_t& triangles, int32_t& draws,
                     double& lod_ms) = 0;
  // Draws `cam`'s view with the levels `lod` (seen in a viewport `lod_height` high) chooses.
  virtual void draw_with_levels_of(const scene::Camera& lod, int32_t lod_height, const scene::Camera& cam,
                                   int32_t w, int32_t h) = 0;
  // The update after a stamp over `rect`: what it recomputed (text) is set.
  virtual void stamp(const RectI& rect, std::string& what) = 0;
  // The scheme's own full-resolution triangulation, its error's reference.
  virtual Truth truth() const = 0;
};

class ClipmapScheme final : public Scheme {
 public:
  explicit ClipmapScheme(std::unique_ptr<render::ClipmapRenderer> r) : r_(std::move(r)) {}
  void frame(const scene::Camera& cam, int32_t w, int32_t h, int64_t& triangles, int32_t& draws,
             double& lod_ms) override {
    const render::FrameStats s = r_->render(cam, w, h);
    triangles = s.triangles, draws = s.draw_calls, lod_ms = -1;
  }
  void draw_with_levels_of(const scene::Camera& lod, int32_t, const scene::Camera& cam, int32_t w,
                           int32_t h) override {
    scene::Camera c = cam;
    c.lod_center = std::array<double, 2>{lod.x, lod.y};
    r_->render(c, w, h);
  }
  void stamp(const RectI& rect, std::string& what) override {
    r_->invalidate(rect);
    what = "levels' textures and normals over the rect";
  }
  Truth truth() const override { return Truth::kTriangles; }

 private:
  std::unique_ptr<render::ClipmapRenderer> r_;
};

// A scheme whose renderer splits choosing its mesh from drawing it (geomipmapping, the
// quadtree, the error-driven clipmap): select() for one camera, draw() for another.
template <typename Renderer>
class SelectingScheme final : public Scheme {
 public:
  using Stamp = std::function<std::string(Renderer&, const RectI&)>;
  SelectingScheme(std::unique_ptr<Renderer> r, Stamp stamp, Truth truth)
      : r_(std::move(r)), stamp_(std::move(stamp)), truth_(truth) {}
  void frame(const scene::Camera& cam, int32_t w, int32_t h, int64_t& triangles, int32_t& draws,
             double& lod_ms) override {
    const auto s = r_->render(cam, w, h);
    triangles = s.triangles, draws = s.draw_calls, lod_ms = s.cpu_ms;
  }
  void draw_with_levels_of(const scene::Camera& lod, int32_t lod_height, const scene::Camera& cam, int32_t w,
                           int32_t h) override {
    r_->select(lod, lod_height);
    r_->draw(cam, w, h);
  }
  void stamp(const RectI& rect, std::string& what) override { what = stamp_(*r_, rect); }
  Truth truth() const override { return truth_; }

 private:
  std::unique_ptr<Renderer> r_;
  Stamp stamp_;
  Truth truth_;
};

// A setting's factory: the renderer made with `cfg`, behind SelectingScheme.
template <typename Renderer, typename Config>
std::function<Result<std::unique_ptr<Scheme>>(const terrain::HeightSource&)> selecting(
    Config cfg, typename SelectingScheme<Renderer>::Stamp stamp, Truth truth) {
  return [cfg, stamp, truth](const terrain::HeightSource& src) -> Result<std::unique_ptr<Scheme>> {
    auto r = Renderer::create(src, cfg);
    if (!r) return r.error();
    return std::unique_ptr<Scheme>(new SelectingScheme<Renderer>(std::move(*r), stamp, truth));
  };
}

// The error-driven clipmap's update after a stamp over `rect`, as the report names it.
std::string error_clipmap_stamp(render::ErrorClipmapRenderer& r, const RectI& rect) {
  const render::ErrorClipmapUpdate u = r.invalidate(rect);
  return std::to_string(u.blocks) + " blocks' error bounds, " + std::to_string(u.texels) + " level samples";
}

struct Setting {
  std::string scheme, setting;
  std::function<Result<std::unique_ptr<Scheme>>(const terrain::HeightSource&)> make;
};

std::vector<Setting> settings(bool quick) {
  std::vector<Setting> out;
  // Every scheme below is scored against the union-jack triangulation of every sample (the
  // quadtree's subdivided level-1 squares split every cell through the square's centre).
  auto geomipmap = [](int32_t n, double tol, bool skirts = false) {
    render::GeomipmapConfig cfg;
    cfg.patch_size = n;
    cfg.tolerance_px = tol;
    cfg.skirts = skirts;
    return selecting<render::GeomipmapRenderer>(
        cfg,
        [](render::GeomipmapRenderer& r, const RectI& rect) {
          return std::to_string(r.invalidate(rect).patches) + " patches' error bounds";
        },
        Truth::kUnionJack);
  };
  out.push_back({"full mesh", "every sample", geomipmap(65, 0.0)});
  const std::vector<std::pair<int32_t, double>> geo =
      quick ? std::vector<std::pair<int32_t, double>>{{17, 1.0}, {33, 8.0}}
            : std::vector<std::pair<int32_t, double>>{{17, 1.0}, {17, 2.0}, {17, 4.0}, {17, 8.0},
                                                      {33, 1.0}, {33, 8.0}, {65, 1.0}, {65, 8.0}};
  for (const auto& [n, tol] : geo)
    out.push_back({"geomipmap " + std::to_string(n), fmt(tol, 0) + " px", geomipmap(n, tol)});
  auto quadtree = [](int32_t block, double tol, bool skirts = false) {
    render::QuadtreeConfig cfg;
    cfg.block_size = block;
    cfg.tolerance_px = tol;
    cfg.skirts = skirts;
    // The rebuild of the blocks a stamp touched happens in the next selection.
    return selecting<render::QuadtreeRenderer>(
        cfg,
        [](render::QuadtreeRenderer& r, const RectI& rect) {
          return std::to_string(r.invalidate(rect)) + " squares' error bounds";
        },
        Truth::kUnionJack);
  };
  const std::vector<std::pair<int32_t, double>> quad =
      quick ? std::vector<std::pair<int32_t, double>>{{64, 1.0}}
            : std::vector<std::pair<int32_t, double>>{{64, 1.0}, {64, 2.0}, {64, 8.0}, {32, 1.0}};
  for (const auto& [b, tol] : quad)
    out.push_back({"quadtree " + std::to_string(b), fmt(tol, 0) + " px", quadtree(b, tol)});
  // Leitao & Carmo's tiled blocks at their Table 1's 8 px: block-based (a level per block, the
  // geomipmap rows at 8 px being its index-update form) and quadtree-based (a restricted
  // quadtree per block; restricted across blocks is the index update), cracks closed by
  // skirts or by index update.
  for (int32_t n : quick ? std::vector<int32_t>{17} : std::vector<int32_t>{17, 33, 65})
    out.push_back(
        {"tiled blocks, block-based, skirts", std::to_string(n) + ", 8 px", geomipmap(n, 8.0, true)});
  for (int32_t b : quick ? std::vector<int32_t>{16} : std::vector<int32_t>{16, 32, 64})
    out.push_back(
        {"tiled blocks, quadtree-based, skirts", std::to_string(b + 1) + ", 8 px", quadtree(b, 8.0, true)});
  for (int32_t b : quick ? std::vector<int32_t>{} : std::vector<int32_t>{16, 32, 64})
    out.push_back({"tiled blocks, quadtree-based, index update", std::to_string(b + 1) + ", 8 px",
                   quadtree(b, 8.0, false)});
  auto error_clipmap = [](int32_t block, int32_t region, double tol, int32_t exact) {
    render::ErrorClipmapConfig cfg;
    // The schemes compared in their geometry: the colour bands alone, as the others draw.
    cfg.look.materials = cfg.look.shadows = false;
    cfg.detail_size = 0;
    cfg.block_size = block;
    cfg.region = region;
    cfg.tolerance_px = tol;
    cfg.exact_levels = exact;
    return selecting<render::ErrorClipmapRenderer>(cfg, error_clipmap_stamp, Truth::kUnionJack);
  };
  // Block size, region (level samples held per side; 1024 holds these worlds whole), budget,
  // exact levels.
  std::vector<std::array<int32_t, 4>> ecm =
      quick ? std::vector<std::array<int32_t, 4>>{{9, 512, 1, 3}}
            : std::vector<std::array<int32_t, 4>>{{9, 1024, 1, 3},  {9, 1024, 2, 3}, {9, 1024, 4, 3},
                                                  {17, 1024, 1, 3}, {9, 512, 1, 3},  {9, 256, 1, 3}};
  if (const char* e = std::getenv("LOAM_LOD_ERROR_CLIPMAPS")) {
    // Extra settings to explore: "block,region,tolerance,exact_levels;..."
    ecm.clear();
    for (std::string_view rest = e; !rest.empty();) {
      const size_t semi = rest.find(';');
      const std::string one(rest.substr(0, semi));
      std::array<int32_t, 4> v{};
      if (std::sscanf(one.c_str(), "%d,%d,%d,%d", &v[0], &v[1], &v[2], &v[3]) == 4) ecm.push_back(v);
      rest = semi == std::string_view::npos ? std::string_view{} : rest.substr(semi + 1);
    }
  }
  for (const auto& [b, region, tol, exact] : ecm)
    out.push_back({"error clipmap " + std::to_string(b),
                   fmt(tol, 0) + " px, region " + std::to_string(region) +
                       (exact == 3 ? "" : ", exact to level " + std::to_string(exact)),
                   error_clipmap(b, region, double(tol), exact)});
  return out;
}

// Screen errors pooled over terrains and paths without keeping every pixel: a histogram of
// 200 log-spaced bins per decade from 1e-4 px (p99 to within 1.2%), exact mean and maximum.
class ErrorHistogram {
 public:
  void add(double px, double m) {
    const double l = std::log10(std::max(px, 1e-4)) + 4.0;
    ++bins_[size_t(std::clamp(l * 200.0, 0.0, double(bins_.size() - 1)))];
    ++count_, sum_px_ += px, sum_m_ += m;
    max_px_ = std::max(max_px_, px), max_m_ = std::max(max_m_, m);
  }
  ErrorStats stats() const {
    ErrorStats s;
    s.pixels = count_;
    if (count_ == 0) return s;
    s.mean_px = sum_px_ / double(count_), s.mean_m = sum_m_ / double(count_);
    s.max_px = max_px_, s.max_m = max_m_;
    auto quantile = [&](double q) {
      const int64_t want = int64_t(q * double(count_ - 1));
      int64_t seen = 0;
      for (size_t b = 0; b < bins_.size(); ++b) {
        seen += bins_[b];
        if (seen > want) return std::min(max_px_, std::pow(10.0, (double(b) + 1.0) / 200.0 - 4.0));
      }
      return max_px_;
    };
    s.p50_px = quantile(0.5), s.p99_px = quantile(0.99);
    return s;
  }

 private:
  std::array<int64_t, 1601> bins_{};
  int64_t count_ = 0;
  double sum_px_ = 0, sum_m_ = 0, max_px_ = 0, max_m_ = 0;
};

struct Pooled {
  ErrorHistogram errors;
  double pop_max = 0;
  int64_t triangles = 0;
  int64_t draws = 0;
  int frames = 0;
  std::vector<double> frame_ms, cpu_ms, lod_ms;
};

// The largest screen change (px) of the drawn surface between the levels of `prev` and of
// `cur`, both drawn top-down at fixed world points, as `cur` sees them.
double pop_px(Scheme& s, const World& world, const render::OffscreenTarget& top, const scene::Camera& prev,
              const scene::Camera& cur, int32_t w, int32_t h) {
  const WorldParams& p = world.params();
  const RectI r = p.sample_rect();
  const double mps = p.meters_per_sample;
  scene::Camera o;
  o.x = (double(r.x0) + double(r.width() - 1) / 2.0) * mps;
  o.y = (double(r.y0) + double(r.height() - 1) / 2.0) * mps;
  o.z = 20000;
  o.fx = 0, o.fy = 0, o.fz = -1;
  o.ux = 0, o.uy = -1, o.uz = 0;
  o.ortho_half_height = double(r.height() - 1) * mps / 2.0;
  o.near_m = 1, o.far_m = 40000;
  std::vector<float> depth[2];
  for (int k = 0; k < 2; ++k) {
    top.begin(0, 0, 0, 0);
    s.draw_with_levels_of(k == 0 ? prev : cur, h, o, top.width(), top.height());
    depth[k] = top.read_depth();
  }
  const glm::mat4 vp = scene::view_projection(cur, w, h);
  const double k_px = lod::pixels_per_radian(h, cur.fov_y_degrees);
  const double half_w = o.ortho_half_height * double(top.width()) / double(top.height());
  double worst = 0;
  for (int32_t y = 0; y < top.height(); ++y) {
    for (int32_t x = 0; x < top.width(); ++x) {
      const size_t i = size_t(y) * size_t(top.width()) + size_t(x);
      if (depth[0][i] <= scene::kBackgroundDepth || depth[1][i] <= scene::kBackgroundDepth) continue;
      const double za = o.z - scene::view_distance(o, depth[0][i]);
      const double zb = o.z - scene::view_distance(o, depth[1][i]);
      if (za == zb) continue;
      const double wx = o.x - half_w + (double(x) + 0.5) * 2.0 * half_w / double(top.width());
      const double wy =
          o.y - o.ortho_half_height + (double(y) + 0.5) * 2.0 * o.ortho_half_height / double(top.height());
      const glm::vec4 clip = vp * glm::vec4(float(wx - cur.x), float(-(wy - cur.y)), float(zb - cur.z), 1.0f);
      if (clip.w <= 0 || std::abs(clip.x) > clip.w || std::abs(clip.y) > clip.w || std::abs(clip.z) > clip.w)
        continue;
      const double d =
          std::sqrt((wx - cur.x) * (wx - cur.x) + (wy - cur.y) * (wy - cur.y) + (zb - cur.z) * (zb - cur.z));
      worst = std::max(worst, std::abs(zb - za) * k_px / d);
    }
  }
  return worst;
}

int run_lod(const Context& ctx, Report& report) {
  // A run of some settings (LOAM_LOD_ONLY) writes lod-<its words>.md beside the full report.
  if (const char* only = std::getenv("LOAM_LOD_ONLY")) {
    std::string name = "lod-";
    for (const char c : std::string_view(only)) {
      const bool keep = std::isalnum(static_cast<unsigned char>(c)) != 0;
      if (keep || (name.back() != '-'))
        name += keep ? char(std::tolower(static_cast<unsigned char>(c))) : '-';
    }
    while (name.back() == '-') name.pop_back();
    report.rename(name);
    report.paragraph("Only the settings whose name holds one of `" + std::string(only) +
                     "` (`LOAM_LOD_ONLY`); every scheme's is [lod.md](lod.md).");
  }
  auto egl = gpu::EglContext::create(gpu::EglPreference::kAny);
  if (!egl || !egl->make_current().ok()) {
    report.paragraph("Skipped: no EGL display gives an OpenGL 4.5 core context.");
    return 0;
  }
  std::vector<Terrain> terrains;
  {
    auto imported = load_default_terrain();
    if (!imported) {
      std::fprintf(stderr, "lod: %s\n", imported.error().describe().c_str());
      return 1;
    }
    terrains.push_back({"embedded crop (2 m)", std::move(imported->world)});
  }
  std::string shared_note;
  if (!ctx.quick) {
    for (const char* name : {"frontrange_srtm3_758", "kilauea_utm30m_857x793"}) {
      const std::string path = ctx.shared_data_dir + "/" + name + ".png";
      if (!std::filesystem::exists(path)) {
        std::printf("lod: SKIPPING %s: %s is absent\n", name, path.c_str());
        shared_note += " `" + std::string(name) + "` skipped: " + path + " is absent.";
        continue;
      }
      auto dem = read_dem_file(path);
      if (!dem) {
        std::fprintf(stderr, "lod: %s\n", dem.error().describe().c_str());
        return 1;
      }
      auto imported = import_dem(*dem);
      if (!imported) {
        std::fprintf(stderr, "lod: %s\n", imported.error().describe().c_str());
        return 1;
      }
      terrains.push_back(
          {std::string(name) + " (" + fmt(imported->world.params().meters_per_sample, 0) + " m)",
           std::move(imported->world)});
    }
    // Where users meet the viewer: the main job's world, 16 km of it.
    auto refined = refined_window(16384);
    if (!refined) {
      std::fprintf(stderr, "lod: %s\n", refined.error().describe().c_str());
      return 1;
    }
    terrains.push_back({"refined world, 16 km of it (1 m)", std::move(*refined), true});
  }
  const int32_t w = ctx.quick ? 320 : 1920, h = ctx.quick ? 180 : 1080;
  const int frames = ctx.quick ? 2 : 8;
  auto target = render::OffscreenTarget::create(w, h);
  if (!target) return 1;

  Table table("lod", {"terrain", "path", "scheme", "setting", "triangles", "draw calls", "frame ms", "CPU ms",
                      "LOD ms", "error px mean", "error px p99", "error px max", "error m mean",
                      "error m max", "pop px max", "stamp update ms", "stamp recomputes"});
  std::vector<Setting> all = settings(ctx.quick);
  std::map<std::string, Pooled> pooled;  // scheme + setting
  std::vector<std::string> order;
  for (const Terrain& terrain : terrains) {
    terrain::WorldHeightSource source(terrain.world);
    const WorldParams& p = terrain.world.params();
    const RectI wr = p.sample_rect();
    const double diag = std::hypot(double(wr.width()), double(wr.height())) * p.meters_per_sample;
    std::vector<Setting> here = all;
    // What `loam-client view` draws on this world, exactly (render/viewer_session.h): its default
    // scheme, and the other --lod; the look included.
    const render::ViewerOptions viewer;
    auto named = [&](render::LodScheme lod) {
      return std::string("--lod ") + render::to_string(lod) + (lod == viewer.lod ? " (the default)" : "");
    };
    here.push_back({"viewer", named(render::LodScheme::kClassic),
                    [&p, viewer](const terrain::HeightSource& src) -> Result<std::unique_ptr<Scheme>> {
                      auto r =
                          render::ClipmapRenderer::create(src, render::viewer_renderer_config(viewer, p));
                      if (!r) return r.error();
                      return std::unique_ptr<Scheme>(new ClipmapScheme(std::move(*r)));
                    }});
    here.push_back({"viewer", named(render::LodScheme::kError),
                    selecting<render::ErrorClipmapRenderer>(render::viewer_error_clipmap_config(viewer, p),
                                                            error_clipmap_stamp, Truth::kUnionJack)});
    // The clipmaps at the clipmap suite's larger sizes, their view distance the world's diagonal.
    for (int32_t n : ctx.quick ? std::vector<int32_t>{127} : std::vector<int32_t>{127, 255}) {
      here.push_back({"clipmap", "n " + std::to_string(n),
                      [n, diag](const terrain::HeightSource& src) -> Result<std::unique_ptr<Scheme>> {
                        render::RendererConfig cfg;
                        cfg.n = n;
                        cfg.view_distance = diag;
                        auto r = render::ClipmapRenderer::create(src, cfg);
                        if (!r) return r.error();
                        return std::unique_ptr<Scheme>(new ClipmapScheme(std::move(*r)));
                      }});
    }
    if (terrain.viewer_only) std::erase_if(here, [](const Setting& st) { return st.scheme != "viewer"; });
    if (const char* only = std::getenv("LOAM_LOD_ONLY")) {
      // Explore a few settings: those whose "scheme setting" contains one of the ';'-separated words.
      std::vector<Setting> kept;
      for (const Setting& st : here) {
        const std::string name = st.scheme + " " + st.setting;
        for (std::string_view rest = only; !rest.empty();) {
          const size_t semi = rest.find(';');
          if (name.find(std::string(rest.substr(0, semi))) != std::string::npos) {
            kept.push_back(st);
            break;
          }
          rest = semi == std::string_view::npos ? std::string_view{} : rest.substr(semi + 1);
        }
      }
      here = std::move(kept);
    }
    const int32_t tw = int32_t(std::min<int64_t>(1024, wr.width()));
    const int32_t th = int32_t(double(tw) * double(wr.height()) / double(wr.width()));
    auto top = render::OffscreenTarget::create(tw, th);
    if (!top) return 1;
    const std::vector<Path> paths = paths_for(terrain.world, frames);
    // A 65 x 65-sample stamp at the world's centre (the heights stay: the update's cost is
    // the same whatever it wrote).
    const int64_t cx = (wr.x0 + wr.x1) / 2, cy = (wr.y0 + wr.y1) / 2;
    const RectI stamp_rect{cx - 32, cy - 32, cx + 33, cy + 33};
    for (size_t si = 0; si < here.size(); ++si) {
      const Setting& st = here[si];
      auto made = st.make(source);
      if (!made) {
        std::fprintf(stderr, "lod: %s %s: %s\n", st.scheme.c_str(), st.setting.c_str(),
                     made.error().describe().c_str());
        return 1;
      }
      Scheme& scheme = **made;
      const std::string key = st.scheme + " | " + st.setting;
      if (!pooled.count(key)) order.push_back(key);
      Pooled& pool = pooled[key];
      std::string what;
      // The stamp's update is timed with the scheme's data in place: a frame looking at the
      // stamp's rect first (a clipmap's levels exist only once drawn).
      {
        const double mps = p.meters_per_sample;
        const double sx = double(cx) * mps, sy = double(cy) * mps;
        scene::Camera look = scene::look_at(sx - 200.0, sy - 200.0, height_at(terrain.world, sx, sy) + 300.0,
                                            sx, sy, height_at(terrain.world, sx, sy));
        look.far_m = 2.0 * diag;
        int64_t t = 0;
        int32_t d = 0;
        double l = 0;
        target->begin(0.5f, 0.6f, 0.75f, 0.0f);
        scheme.frame(look, w, h, t, d, l);
        glFinish();
      }
      const Timing stamp_t = measure(ctx,
                                     [&] {
                                       scheme.stamp(stamp_rect, what);
                                       glFinish();
                                     },
                                     {.warmup = 1, .min_runs = 3, .max_runs = 20, .min_seconds = 0.05});
      for (size_t pi = 0; pi < paths.size(); ++pi) {
        // A smoke run (--quick) draws each setting along one path, the paths in turn: every
        // scheme and every path still runs, a third of the frames.
        if (ctx.quick && pi != si % paths.size()) continue;
        const Path& path = paths[pi];
        std::vector<double> px, m, frame_ms, cpu_ms, lod_ms;
        int64_t triangles = 0, draws = 0;
        double pop = 0;
        for (size_t f = 0; f < path.frames.size(); ++f) {
          const scene::Camera& cam = path.frames[f];
          int64_t t = 0;
          int32_t d = 0;
          double lms = 0;
          // Best of three: the first frame at a new place uploads (clipmaps) and builds index
          // buffers (geomipmapping).
          double best = 1e30, best_cpu = 0;
          for (int rep = 0; rep < (ctx.quick ? 1 : 3); ++rep) {
            const auto t0 = clock_type::now();
            target->begin(0.5f, 0.6f, 0.75f, 0.0f);
            scheme.frame(cam, w, h, t, d, lms);
            const double cpu = ms_since(t0);
            glFinish();
            const double total = ms_since(t0);
            if (total < best) best = total, best_cpu = cpu;
          }
          frame_ms.push_back(best);
          cpu_ms.push_back(best_cpu);
          if (lms >= 0) lod_ms.push_back(lms);
          triangles += t, draws += d;
          add_screen_errors(terrain.world, cam, w, h, target->read_depth(), px, m, scheme.truth());
          pop = std::max(pop, pop_px(scheme, terrain.world, *top, path.previous[f], cam, w, h));
        }
        const size_t nf = path.frames.size();
        for (size_t i = 0; i < px.size(); ++i) pool.errors.add(px[i], m[i]);
        pool.pop_max = std::max(pool.pop_max, pop);
        pool.triangles += triangles, pool.draws += draws, pool.frames += int(nf);
        pool.frame_ms.insert(pool.frame_ms.end(), frame_ms.begin(), frame_ms.end());
        pool.cpu_ms.insert(pool.cpu_ms.end(), cpu_ms.begin(), cpu_ms.end());
        pool.lod_ms.insert(pool.lod_ms.end(), lod_ms.begin(), lod_ms.end());
        const ErrorStats e = summarize_errors(px, m);
        const double lod_med = median(lod_ms);
        table.add_row({terrain.name, path.name, st.scheme, st.setting,
                       std::to_string(triangles / int64_t(nf)), std::to_string(draws / int64_t(nf)),
                       fmt(median(frame_ms), 1), fmt(median(cpu_ms), 2), lod_med < 0 ? "-" : fmt(lod_med, 2),
                       fmt(e.mean_px, 3), fmt(e.p99_px), fmt(e.max_px), fmt(e.mean_m, 3), fmt(e.max_m),
                       fmt(pop), fmt(stamp_t.median_s * 1e3, 3), what});
        std::printf("  %s, %s, %s %s: %lld triangles, error p99 %.2f px, max %.1f px, pop %.2f px, %.1f ms\n",
                    terrain.name.c_str(), path.name.c_str(), st.scheme.c_str(), st.setting.c_str(),
                    static_cast<long long>(triangles / int64_t(nf)), e.p99_px, e.max_px, pop,
                    median(frame_ms));
      }
    }
  }

  Table summary("lod_summary", {"scheme", "setting", "triangles (mean)", "draw calls (mean)",
                                "frame ms (median)", "CPU ms (median)", "LOD ms (median)", "error px mean",
                                "error px p99", "error px max", "error m mean", "error m max", "pop px max"});
  std::map<std::string, Series> series;
  for (const std::string& key : order) {
    Pooled& pool = pooled[key];
    const ErrorStats e = pool.errors.stats();
    const std::string scheme = key.substr(0, key.find(" | ")), setting = key.substr(key.find(" | ") + 3);
    const double tris = double(pool.triangles) / std::max(1, pool.frames);
    const double lod_med = median(pool.lod_ms);
    summary.add_row({scheme, setting, fmt(tris, 0), fmt(double(pool.draws) / std::max(1, pool.frames), 0),
                     fmt(median(pool.frame_ms), 1), fmt(median(pool.cpu_ms), 2),
                     lod_med < 0 ? "-" : fmt(lod_med, 2), fmt(e.mean_px, 3), fmt(e.p99_px), fmt(e.max_px),
                     fmt(e.mean_m, 3), fmt(e.max_m), fmt(pool.pop_max)});
    Series& s = series[scheme];
    s.title = scheme;
    s.points.push_back({tris, std::max(e.p99_px, 1e-3)});
  }
  report.paragraph(
      "Renderer: " + egl->renderer() + ", " + std::to_string(w) + "x" + std::to_string(h) + " pixels, " +
      std::to_string(frames) +
      " scored frames per path (evenly over its 60 s). Terrains: the embedded crop and, at their own "
      "resolution, two DEMs of `../shared/data`; for the viewer rows alone (the full mesh there would be "
      "537 M triangles), the main job's world: the 16 x 16 km of the refined default around its centre, "
      "at its 1 m." +
      shared_note +
      " Paths: `walk`, 1.4 m/s with the eye 1.8 m above the ground, looking 5 degrees down; `flight`, across "
      "half the world in 60 s high above its highest point, 30 degrees down; `ridge`, 4 m/s along the "
      "highest "
      "ridge 3 m above it, looking level toward the centre (grazing). Error: each terrain pixel's point "
      "moved "
      "to the height of the scheme's own full-resolution triangulation of the samples (clipmaps: every cell "
      "split one way; geomipmapping: the union-jack split) and projected back (px), and the vertical "
      "distance "
      "(m). Against the bilinear surface instead, a walk 1.8 m above 2 m samples shows about 117 px at p99 "
      "for "
      "every scheme, the full mesh included: the difference between bilinear patches and triangles under the "
      "feet, which no level of detail changes. Pixels within half a sample of the world's edge (where the "
      "clipmap stands its earth skirt) are not scored. Pop: the surface drawn with the levels of the frame "
      "1/30 s earlier against this frame's, both "
      "top-down at fixed world points, the height change seen from this frame's camera (px; hidden points "
      "included). Frame ms: render + glFinish, best of 3; CPU ms: the render call alone; LOD ms: level "
      "selection, culling and per-patch uploads (geomipmapping), subdivision and the rebuilt blocks' meshes "
      "and uploads (quadtree), the level regions' moves and uploads, block selection, culling and the "
      "instance upload (error-driven clipmap); on llvmpipe the draw calls run the "
      "vertex stage on the calling thread, so the render call's time is mostly the GPU's work. The near "
      "plane is a quarter of the eye's height above the ground (at least 0.5 m), and depth is reversed "
      "float depth (32-bit float, clip depth 0..1 with the far plane at 0), which resolves centimetres "
      "10 km away: the evaluator reads it, and the full mesh's own error is the floor it measures. The stamp "
      "update re-reads a 65 x 65-sample "
      "rect at the world's centre, timed after a frame that looks at it: clipmaps re-upload it to every "
      "level holding it with its normals, "
      "geomipmapping re-uploads it and recomputes the error bounds of the patches it touches, the "
      "error-driven clipmap re-reads it into every level region holding it and recomputes the blocks "
      "holding it at every level.");
  report.table(std::move(summary));
  Plot plot{report.name() + "_error.png",
            "Screen-space error p99 against triangles, every scheme (" + egl->renderer() + ")",
            "triangles drawn per frame",
            "p99 screen error (px)",
            true,
            true,
            {},
            {}};
  for (auto& [name, s] : series) {
    std::sort(s.points.begin(), s.points.end());
    plot.series.push_back(s);
  }
  report.plot(std::move(plot));
  report.paragraph("Per terrain and path:");
  report.table(std::move(table));
  return 0;
}

}  // namespace

LOAM_BENCH_SUITE(lod,
                 "level-of-detail schemes against screen error: full mesh, geomipmapping, quadtree, clipmaps",
                 run_lod);

}  // namespace loam::bench
