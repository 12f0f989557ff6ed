#include "client/render/viewer_session.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "client/render/display_gpu_stamper.h"
#include "client/scene/start_view.h"
#include "dem/refined_default.h"
#include "gpu/gpu_stamper.h"
#include "protocol/layer.h"

namespace loam::render {

RendererConfig viewer_renderer_config(const ViewerOptions& options, const WorldParams& world) {
  RendererConfig rc = options.renderer;
  if (!(rc.view_distance > 0))
    rc.view_distance = scene::view_scale(world).view_distance_m;  // auto: the world's
  return rc;
}

ErrorClipmapConfig viewer_error_clipmap_config(const ViewerOptions& options, const WorldParams& world) {
  const RendererConfig rc = viewer_renderer_config(options, world);
  ErrorClipmapConfig ec = options.error_clipmap;
  ec.look = rc.look;
  ec.detail_size = rc.detail_size;
  ec.view_distance = rc.view_distance;
  return ec;
}

Result<std::unique_ptr<ViewerSession>> ViewerSession::connect(const std::string& host, uint16_t port,
                                                              const ViewerOptions& options,
                                                              std::optional<scene::Camera> initial) {
  std::unique_ptr<ViewerSession> v(new ViewerSession());
  v->client_.set_base_provider(generate_known_base);
  v->client_.set_tls(options.tls);
  LOAM_TRY(v->client_.connect(host, port, options.name, options.role, options.token));
  LOAM_TRY(v->client_.request_stamp_images());  // the tool panel's list, with previews
  const WorldParams& world = v->client_.welcome().world;
  // The coarsest mip first: a few tiles that show the whole world and set the materials.
  std::vector<TileCoord> top;
  const int32_t mips = world.mip_count();
  const RectI t = world.tile_range(mips - 1);
  for (int64_t ty = t.y0; ty < t.y1; ++ty) {
    for (int64_t tx = t.x0; tx < t.x1; ++tx)
      top.push_back({Layer::kCoarse, uint8_t(mips - 1), int32_t(tx), int32_t(ty)});
  }
  v->client_.store().record_changes(true);
  // Where this program cannot generate the initial terrain (an imported DEM), the store keeps
  // the version 0 of tiles edited in view: dug ground reads as dug there too.
  v->client_.store().keep_initial(v->client_.shared_base() == nullptr);
  LOAM_TRY(v->client_.subscribe(top));
  const bool loaded = v->client_.wait_until(
      [&] {
        for (const TileCoord& c : top) {
          if (!v->client_.store().holds(c)) return false;
        }
        return true;
      },
      options.connect_timeout);
  if (!loaded) {
    return make_error(
        ErrorCode::kIo, "viewer.connect",
        "the coarsest mip did not arrive within " + std::to_string(options.connect_timeout.count()) + " ms");
  }
  v->stamping_ = resolve_stamping(options.stamping, reinterpret_cast<const char*>(glGetString(GL_RENDERER)));
  auto display = terrain::DisplayTerrain::create(
      v->client_.store(),
      v->stamping_ == DisplayStamping::kGpu
          ? gpu_display_stamper(
                {.max_pages = PerLayer<int32_t>{{options.gpu_cache_pages, options.gpu_cache_pages}}})
          : terrain::DisplayStamperFactory{},
      &v->client_.textures());
  if (!display) return display.error();
  v->display_ = std::move(*display);
  v->audit_tiles_ = options.gpu_audit_tiles;
  v->display_->set_initial_base(v->client_.shared_base());  // the dug-material layer's reference
  (void)v->display_->sync(v->client_);                      // takes in the coarsest tiles
  v->snapshots_ = std::make_unique<query::SnapshotBuilder>(world);
  v->refresh_terrain({});
  const RendererConfig rc = viewer_renderer_config(options, world);
  v->view_distance_m_ = rc.view_distance;
  lod::InterestConfig ic = options.interest;
  if (options.lod == LodScheme::kError) {
    auto renderer = ErrorClipmapRenderer::create(*v->display_, viewer_error_clipmap_config(options, world));
    if (!renderer) return renderer.error();
    v->error_renderer_ = std::move(*renderer);
  } else {
    auto renderer = ClipmapRenderer::create(*v->display_, rc);
    if (!renderer) return renderer.error();
    v->renderer_ = std::move(*renderer);
    ic.n = v->renderer_->config().n;
    ic.levels = v->renderer_->levels();
    ic.pad = ClipmapRenderer::kLevelPad;
  }
  v->interest_ = std::make_unique<lod::ClipmapInterest>(world, ic);
  const terrain::HeightSource& ground = *v->display_;
  LOAM_TRY(
      v->follow(initial.value_or(scene::orbit_view(scene::view_scale(world), 0.0, [&](double x, double y) {
        return terrain::ground_height(ground, x, y);
      }))));
  return v;
}

Status ViewerSession::follow(const scene::Camera& camera) {
  const auto c = camera.lod_center.value_or(std::array<double, 2>{camera.x, camera.y});
  // The error-driven clipmap's regions where it will place them for this camera.
  const std::vector<RectI> regions =
      error_renderer_ ? error_renderer_->level_regions_for(camera) : std::vector<RectI>{};
  const lod::ClipmapInterest::Delta d = interest_->update(c[0], c[1], regions);
  if (!d.unsubscribe.empty()) LOAM_TRY(client_.unsubscribe(d.unsubscribe));
  // The focus travels with new subscriptions, and on its own once the camera has moved a
  // quarter of a mip-0 tile since it was last sent.
  const double moved = focus_sent_ ? std::hypot(c[0] - focus_sent_->x_m, c[1] - focus_sent_->y_m) : 1e300;
  const double step = 0.25 * kTileSize * client_.welcome().world.meters_per_sample;
  std::optional<wire::Focus> focus;
  if (!d.subscribe.empty() || moved > step) focus = wire::Focus{c[0], c[1]};
  if (focus) focus_sent_ = focus;
  if (!d.subscribe.empty() || focus) LOAM_TRY(client_.subscribe(d.subscribe, focus));
  return {};
}

Status ViewerSession::update(const scene::Camera& camera, std::chrono::milliseconds wait) {
  const Status pumped = client_.pump(wait);
  // Once a second, the HUD's session numbers: a Ping, a StatsRequest, the byte rate.
  if (const auto now = std::chrono::steady_clock::now(); pumped.ok() && now >= next_ping_) {
    const uint64_t in = client_.connection().bytes_in();
    if (next_ping_ != std::chrono::steady_clock::time_point{}) {
      bytes_in_per_s_ =
          double(in - bytes_in_at_ping_) / (1.0 + std::chrono::duration<double>(now - next_ping_).count());
    }
    bytes_in_at_ping_ = in;
    next_ping_ = now + std::chrono::seconds(1);
    (void)client_.ping();
    (void)client_.request_stats();
    // The sampled check of the GPU copy: a tile a second, read back and compared.
    audit_due_ = true;
  }
  LOAM_TRY(follow(camera));
  const std::vector<terrain::DisplayDirty> dirty = display_->sync(client_);
  // The display's GPU copy, where the levels take stamped samples from (tiles held at mip 0,
  // which the levels read as the display holds them).
  gpu::LevelFillSource fill;
  if (const gpu::GpuStamper* cache = display_->gpu_cache()) {
    fill.world = client_.welcome().world.sample_rect();
    fill.pages = &cache->pages(Layer::kCoarse);
    fill.page = [this, cache](int32_t tx, int32_t ty) -> std::optional<int32_t> {
      if (!client_.store().holds({Layer::kCoarse, 0, tx, ty})) return std::nullopt;
      return cache->pages(Layer::kCoarse).find(tx, ty);
    };
  }
  // The levels take each sample once: rects read on the CPU are merged where their union costs
  // no more than both (an event's changes to several held mips give nested extents), and a rect
  // inside one read on the CPU needs nothing of its own.
  std::vector<terrain::DisplayDirty> refresh;
  for (const terrain::DisplayDirty& d : dirty) {
    if (d.stamped_on_gpu) continue;
    terrain::DisplayDirty m = d;
    for (bool grew = true; grew;) {
      grew = false;
      for (auto it = refresh.begin(); it != refresh.end(); ++it) {
        const RectI u = it->rect.unite(m.rect);
        if (it->layer == m.layer && u.area() <= it->rect.area() + m.rect.area()) {
          m.rect = u;
          refresh.erase(it);
          grew = true;
          break;
        }
      }
    }
    refresh.push_back(m);
  }
  for (const terrain::DisplayDirty& d : dirty) {
    const bool covered = std::any_of(refresh.begin(), refresh.end(), [&](const terrain::DisplayDirty& o) {
      return !o.stamped_on_gpu && o.layer == d.layer && o.rect.contains(d.rect);
    });
    if (d.stamped_on_gpu && !covered) refresh.push_back(d);
  }
  for (const terrain::DisplayDirty& d : refresh) {
    // The levels read the layer with mips (level l its mip l); the detail region the other.
    if (!layer_info(d.layer).has_mips) {
      if (renderer_) renderer_->invalidate_detail(d.rect);
      if (error_renderer_) error_renderer_->invalidate_detail(d.rect);
    } else if (error_renderer_) {
      const ErrorClipmapUpdate u =
          error_renderer_->invalidate(d.rect, d.stamped_on_gpu && fill.pages ? &fill : nullptr);
      level_traffic_.texels_uploaded += uint64_t(u.texels);
      level_traffic_.texels_on_gpu += uint64_t(u.texels_on_gpu);
      level_traffic_.bytes_uploaded += u.bytes_uploaded;
    } else {
      renderer_->invalidate(d.rect);
    }
  }
  refresh_terrain(dirty);
  if (audit_due_ && audit_tiles_ > 0) {
    (void)display_->audit_gpu(size_t(audit_tiles_));
    audit_due_ = false;
  }
  return pumped;
}

void ViewerSession::refresh_terrain(const std::vector<terrain::DisplayDirty>& dirty) {
  std::vector<TileCoord> held;
  for (const TileCoord& c : client_.store().held()) {
    if (c.mip == 0) held.push_back(c);
  }
  // A settled right prediction changes no sample, but the snapshot's overlay count and sequence.
  if (terrain_ && dirty.empty() && held == terrain_held_ &&
      terrain_->stamp().own_stamps_shown == display_->overlay_size() &&
      terrain_->stamp().event_seq == client_.last_event_seq())
    return;
  std::vector<query::ChangedRect> changed;
  for (const terrain::DisplayDirty& d : dirty) changed.push_back({d.layer, d.rect});
  terrain_ =
      snapshots_->build(display_->world(), held, changed, client_.last_event_seq(), display_->overlay_size());
  terrain_held_ = std::move(held);
}

Status ViewerSession::reconnect(const std::string& host, uint16_t port) {
  LOAM_TRY(client_.reconnect(host, port));
  client_.store().keep_initial(client_.shared_base() == nullptr);
  display_->set_initial_base(client_.shared_base());
  return {};
}

FrameStats ViewerSession::render(const scene::Camera& camera, int32_t width, int32_t height) {
  if (!error_renderer_) return renderer_->render(camera, width, height);
  const ErrorClipmapFrameStats e = error_renderer_->render(camera, width, height);
  FrameStats f;
  f.triangles = e.triangles;
  f.draw_calls = e.draw_calls;
  f.pieces_culled = e.blocks_culled;
  f.texels_uploaded = e.texels_uploaded;
  f.shadow_triangles = e.shadow_triangles;
  f.lod_budget_px = e.select.tolerance_px;
  return f;
}

void ViewerSession::invalidate(const RectI& rect) {
  if (error_renderer_) {
    error_renderer_->invalidate(rect);
  } else {
    renderer_->invalidate(rect);
  }
}

int32_t ViewerSession::levels() const {
  return error_renderer_ ? error_renderer_->levels() : renderer_->levels();
}

RectI ViewerSession::level_region(int32_t l) const {
  return error_renderer_ ? error_renderer_->level_region(l) : renderer_->level_region(l);
}

std::array<float, 2> ViewerSession::sun() const {
  const TerrainLookConfig& c = renderer_ ? renderer_->look() : error_renderer_->look();
  return {c.sun_azimuth_degrees, c.sun_elevation_degrees};
}

void ViewerSession::set_sun(float azimuth_degrees, float elevation_degrees) {
  if (renderer_) renderer_->set_sun(azimuth_degrees, elevation_degrees);
  if (error_renderer_) error_renderer_->set_sun(azimuth_degrees, elevation_degrees);
}

Result<uint32_t> ViewerSession::deform(const QuantizedStamp& stamp) {
  auto seq = client_.deform(stamp);
  if (!seq) return seq.error();
  display_->predict(*seq, stamp);
  return seq;
}

bool ViewerSession::wait_settled(const scene::Camera& camera, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (!update(camera, std::chrono::milliseconds(20)).ok()) return false;
    bool held = display_->overlay_size() == 0 && client_.store().buffered() == 0;
    for (const TileCoord& c : interest_->subscribed()) held = held && client_.store().holds(c);
    if (held) return true;
    if (std::chrono::steady_clock::now() > deadline) return false;
  }
}

LevelCoverage ViewerSession::coverage() {
  const WorldParams& w = client_.welcome().world;
  const client::ConfirmedStore& store = client_.store();
  const int32_t mips = w.mip_count();
  LevelCoverage cov;
  cov.levels = levels();
  lacking_since_.resize(size_t(cov.levels));
  const auto now = std::chrono::steady_clock::now();
  for (int32_t l = 0; l < cov.levels; ++l) {
    // Level l's region in the grid of the mip it reads (levels past the coarsest mip read it).
    const int32_t m = std::min(l, mips - 1);
    const int64_t up = int64_t(1) << (l - m);
    const RectI r = level_region(l);
    const RectI region{r.x0 * up, r.y0 * up, r.x1 * up, r.y1 * up};
    const RectI tiles = tiles_overlapping(region).intersect(w.tile_range(m));
    bool lacking = false;
    for (int64_t ty = tiles.y0; ty < tiles.y1 && !lacking; ++ty) {
      for (int64_t tx = tiles.x0; tx < tiles.x1 && !lacking; ++tx) {
        lacking = !store.holds({Layer::kCoarse, uint8_t(m), int32_t(tx), int32_t(ty)});
      }
    }
    std::optional<std::chrono::steady_clock::time_point>& since = lacking_since_[size_t(l)];
    if (!lacking) {
      since.reset();
      continue;
    }
    if (!since) since = now;
    ++cov.levels_lacking;
    cov.longest_wait_s = std::max(cov.longest_wait_s, std::chrono::duration<double>(now - *since).count());
  }
  return cov;
}

ViewerStats ViewerSession::stats() const {
  ViewerStats s;
  s.tiles_subscribed = interest_->subscribed().size();
  const client::ConfirmedStore& store = client_.store();
  s.tiles_held = store.held().size();
  const auto& k = store.counters();
  s.regions = k.regions;
  s.events_applied = k.events_applied;
  s.hash_checks = k.hash_checks;
  s.hash_mismatches = k.hash_mismatches;
  s.overlay = display_->overlay_size();
  s.display = display_->counters();
  const terrain::DisplayMemory m = display_->memory();
  s.gpu_page_bytes = m.gpu.total();
  s.gpu_pages_resident = 0;
  for (const int32_t n : m.gpu.resident_pages) s.gpu_pages_resident += n;
  s.gpu_terrain_bytes =
      m.gpu.total() + (error_renderer_ ? error_renderer_->gpu_bytes() : renderer_->gpu_bytes());
  s.cpu_terrain_bytes = m.cpu_bytes + store.held_bytes();
  s.display_traffic = display_->gpu_traffic();
  s.level_traffic = level_traffic_;
  s.rtt_ms = client_.rtt_ms().value_or(-1.0);
  s.bytes_in_per_s = bytes_in_per_s_;
  if (const auto& st = client_.server_stats()) {
    s.server_tick_p50_us = st->tick_p50_us;
    s.server_tick_p99_us = st->tick_p99_us;
    s.server_clients = st->clients;
    s.budget_bytes_per_s = st->client_bytes_per_second;
  }
  return s;
}

}  // namespace loam::render
