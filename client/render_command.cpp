#include "client/render_command.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "client/render/clipmap_renderer.h"
#include "client/render/offscreen_target.h"
#include "client/render/reversed_depth.h"
#include "client/render/viewer_session.h"
#include "dem/default_terrain.h"
#include "dem/dem_import.h"
#include "gpu/egl_context.h"
#include "protocol/snapshot/snapshot.h"

namespace loam::render {

namespace {

int fail(const std::string& what, int code = 1) {
  std::fprintf(stderr, "loam-client render: %s\n", what.c_str());
  return code;
}

// The local world to render: the embedded terrain, a DEM file, or a snapshot (a snapshot
// folder, or a data folder: its newest snapshot).
Result<World> load_local_world(const RenderCommandOptions& o) {
  if (!o.snapshot.empty()) {
    std::string path = o.snapshot;
    if (!std::filesystem::exists(std::filesystem::path(path) / "manifest.json")) {
      const auto found = list_snapshots(path);
      if (found.empty())
        return make_error(ErrorCode::kNotFound, path, "is neither a snapshot nor a data folder with one");
      path = found.front();
    }
    auto snap = read_snapshot(path);
    if (!snap) return snap.error();
    return std::move(snap->world);
  }
  Result<ImportedWorld> imported = make_error(ErrorCode::kNotFound, "dem", "not loaded");
  if (o.dem.empty()) {
    imported = load_default_terrain();
  } else {
    auto raster = read_dem_file(o.dem);
    if (!raster) return raster.error();
    imported = import_dem(*raster);
  }
  if (!imported) return imported.error();
  return std::move(imported->world);
}

Result<std::vector<std::array<double, 6>>> camera_frames(const RenderCommandOptions& o) {
  std::vector<std::array<double, 6>> frames;
  if (o.path.empty()) {
    frames.push_back({o.camera[0], o.camera[1], o.camera[2], o.look[0], o.look[1], o.look[2]});
    if (const auto why =
            scene::look_at_problem(o.camera[0], o.camera[1], o.camera[2], o.look[0], o.look[1], o.look[2]))
      return make_error(ErrorCode::kInvalidArgument, "--camera/--look", *why);
    return frames;
  }
  std::ifstream in(o.path);
  if (!in) return make_error(ErrorCode::kIo, o.path, "cannot read the camera path");
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    std::array<double, 6> f{};
    if (!(ls >> f[0] >> f[1] >> f[2] >> f[3] >> f[4] >> f[5])) {
      return make_error(ErrorCode::kInvalidArgument, o.path,
                        "bad line \"" + line + "\" (want x y z tx ty tz)");
    }
    if (const auto why = scene::look_at_problem(f[0], f[1], f[2], f[3], f[4], f[5]))
      return make_error(ErrorCode::kInvalidArgument, o.path + ":" + std::to_string(line_no), *why);
    frames.push_back(f);
  }
  if (frames.empty()) return make_error(ErrorCode::kInvalidArgument, o.path, "no camera in the path");
  return frames;
}

}  // namespace

int run_render_command(const RenderCommandOptions& o) {
  // The cameras first: a view that has no matrix is refused before any GL is set up.
  auto frames = camera_frames(o);
  if (!frames) return fail(frames.error().describe(), 2);
  auto ctx = gpu::EglContext::create();
  if (!ctx) return fail(ctx.error().describe(), 2);
  if (const Status st = ctx->make_current(); !st.ok()) return fail(st.error().describe(), 2);
  auto camera_of = [&](const std::array<double, 6>& f) {
    scene::Camera cam = scene::look_at(f[0], f[1], f[2], f[3], f[4], f[5]);
    cam.fov_y_degrees = o.fov_y_degrees;
    cam.far_m = o.view_distance * 2.0;
    return cam;
  };
  RendererConfig cfg;
  cfg.n = o.n;
  cfg.levels = o.levels;
  cfg.view_distance = o.view_distance;
  cfg.morph = o.morph;
  auto target = OffscreenTarget::create(o.width, o.height);
  if (!target) return fail(target.error().describe());

  // Either a live session (what the server's confirmed tiles show) or a local world.
  std::unique_ptr<ViewerSession> live;
  std::optional<World> world;
  std::unique_ptr<terrain::WorldHeightSource> source;
  std::unique_ptr<ClipmapRenderer> local;
  std::string what;
  if (!o.server.empty()) {
    const size_t colon = o.server.rfind(':');
    unsigned port = 0;
    if (colon == std::string::npos || std::sscanf(o.server.c_str() + colon + 1, "%u", &port) != 1 ||
        port == 0 || port > 65535) {
      return fail("--server wants HOST:PORT, got " + o.server, 2);
    }
    ViewerOptions vo;
    vo.lod = LodScheme::kClassic;  // the renderer these frames are drawn with
    vo.renderer = cfg;
    vo.role = wire::Role::kSpectator;
    vo.name = "render";
    vo.token = o.token;
    vo.tls = o.tls;
    auto v =
        ViewerSession::connect(o.server.substr(0, colon), uint16_t(port), vo, camera_of(frames->front()));
    if (!v) return fail(v.error().describe());
    live = std::move(*v);
    if (!live->wait_settled(camera_of(frames->front()), std::chrono::seconds(30))) {
      return fail("the tiles of the first view did not all arrive within 30 s");
    }
    what = "session at " + o.server;
  } else {
    auto w = load_local_world(o);
    if (!w) return fail(w.error().describe());
    world.emplace(std::move(*w));
    source = std::make_unique<terrain::WorldHeightSource>(*world);
    auto r = ClipmapRenderer::create(*source, cfg);
    if (!r) return fail(r.error().describe());
    local = std::move(*r);
    what = !o.snapshot.empty() ? o.snapshot : o.dem.empty() ? "default terrain" : o.dem;
  }
  ClipmapRenderer& renderer = live ? *live->classic() : *local;
  std::printf("render: %s, %dx%d, n %d, %d levels, morph %s, renderer %s\n", what.c_str(), o.width, o.height,
              o.n, renderer.levels(), o.morph ? "on" : "off", ctx->renderer().c_str());
  for (size_t i = 0; i < frames->size(); ++i) {
    const scene::Camera cam = camera_of((*frames)[i]);
    // A live view follows the camera: the tiles it now needs arrive before the frame is drawn.
    if (live && i > 0 && !live->wait_settled(cam, std::chrono::seconds(30))) {
      return fail("the tiles of frame " + std::to_string(i) + " did not all arrive within 30 s");
    }
    const auto t0 = std::chrono::steady_clock::now();
    target->begin(0.50f, 0.60f, 0.75f, 0.0f);
    const FrameStats s = renderer.render(cam, o.width, o.height);
    glFinish();
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::string file = o.out;
    if (frames->size() > 1) {
      char suffix[32];
      std::snprintf(suffix, sizeof suffix, "_%04zu", i);
      const size_t dot = file.rfind('.');
      file = dot == std::string::npos ? file + suffix : file.substr(0, dot) + suffix + file.substr(dot);
    }
    if (const Status st = write_png(file, o.width, o.height, target->read_rgba()); !st.ok()) {
      return fail(st.error().describe());
    }
    std::printf(
        "frame %zu: %.2f ms, %lld triangles, %d draw calls, %d pieces culled, %lld texels uploaded -> %s\n",
        i, ms, (long long)s.triangles, s.draw_calls, s.pieces_culled, (long long)s.texels_uploaded,
        file.c_str());
  }
  if (live) {
    const ViewerStats st = live->stats();
    std::printf(
        "session: %llu tiles held of %llu subscribed, %llu regions, %llu events applied, %llu hash checks, "
        "%llu mismatches\n",
        (unsigned long long)st.tiles_held, (unsigned long long)st.tiles_subscribed,
        (unsigned long long)st.regions, (unsigned long long)st.events_applied,
        (unsigned long long)st.hash_checks, (unsigned long long)st.hash_mismatches);
  }
  return 0;
}

}  // namespace loam::render
