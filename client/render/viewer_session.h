// A connected viewer: the network client (confirmed store), the display terrain (store +
// overlay, stamped on the GPU), the tiles the clipmap needs (subscribed as the camera moves)
// and the terrain renderer fed from the display: the classic clipmap or the error-driven one
// (--lod). The windowed viewer, `loam-client render
// --server` and the end-to-end tests drive it the same way: update() once per frame, then
// render(). Needs the GL 4.5 context current for every call; not thread-safe.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "client/lod/clipmap_interest.h"
#include "client/net/terrain_client.h"
#include "client/query/snapshot_builder.h"
#include "client/render/clipmap_renderer.h"
#include "client/render/display_stamping.h"
#include "client/render/error_clipmap_renderer.h"
#include "client/render/lod_scheme.h"
#include "client/terrain/display_terrain.h"
#include "protocol/result.h"

namespace loam::render {

// The viewer's cap on the error-driven clipmap's triangles (--lod-triangles): what a frame
// at 1920 x 1080 is held to where the terrain is too rough for the budget.
inline constexpr int64_t kViewerMaxTriangles = 500'000;
inline ErrorClipmapConfig viewer_error_clipmap_defaults() {
  ErrorClipmapConfig c;
  c.max_triangles = kViewerMaxTriangles;
  return c;
}

struct ViewerOptions {
  LodScheme lod = LodScheme::kError;
  RendererConfig renderer;  // the classic clipmap's (and the view distance of both)
  ErrorClipmapConfig error_clipmap = viewer_error_clipmap_defaults();  // the error-driven clipmap's
  lod::InterestConfig interest;  // n and levels are taken from the renderer
  DisplayStamping stamping = DisplayStamping::kGpu;
  // The display's GPU tile cache, in pages of 256 x 256 samples per layer (a coarse page is
  // 128 KiB, a detail page 64 KiB): tiles past it are evicted, least recently used first, and
  // filled again from the CPU copy when next stamped (`view --gpu-cache-mb`).
  int32_t gpu_cache_pages = 1024;
  // Tiles of the display's GPU copy read back and compared with its CPU copy each second: the
  // sampled check (0: none).
  int32_t gpu_audit_tiles = 1;
  wire::Role role = wire::Role::kPlayer;
  std::string name = "viewer";
  std::optional<wire::AccessToken> token;  // needed where the server has tokens
  transport::TlsClientOptions tls;
  std::chrono::milliseconds connect_timeout{10000};
};

// What a viewer with `options` draws `world` with: the classic clipmap's configuration (its
// view distance resolved: 0 takes the world's, start_view.h) and the error-driven clipmap's
// (the look, the detail region and the view distance are the viewer's whichever scheme draws).
// The `lod` suite's viewer rows are made from the same.
RendererConfig viewer_renderer_config(const ViewerOptions& options, const WorldParams& world);
ErrorClipmapConfig viewer_error_clipmap_config(const ViewerOptions& options, const WorldParams& world);

// What the levels took in after the display changed (not region moves), cumulative.
struct LevelTraffic {
  uint64_t texels_uploaded = 0;  // read on the CPU and uploaded
  uint64_t texels_on_gpu = 0;    // filled from the display's GPU tile cache
  uint64_t bytes_uploaded = 0;
};

struct ViewerStats {
  uint64_t tiles_subscribed = 0, tiles_held = 0;
  uint64_t regions = 0, events_applied = 0, hash_checks = 0, hash_mismatches = 0;
  size_t overlay = 0;  // own stamps shown, not settled yet
  terrain::DisplayCounters display;
  // Terrain memory: GPU (the renderer's level textures plus the display's tile pages) and CPU
  // (the confirmed store's and the display's held tiles).
  size_t gpu_terrain_bytes = 0, gpu_page_bytes = 0;
  int32_t gpu_pages_resident = 0;
  size_t cpu_terrain_bytes = 0;
  // What the terrain moved over the bus, cumulative: the display's GPU copy (pages filled,
  // rects uploaded, stamp constants; read back: the audit's tiles), and the levels' updates
  // after changes (samples uploaded, or filled GPU to GPU, and the bytes that took).
  gpu::GpuStamperTraffic display_traffic;
  LevelTraffic level_traffic;
  // The session (refreshed once a second): round trip (-1: none yet), bytes in per second
  // against the budget the server streams within (0: none), the server's tick times.
  double rtt_ms = -1, bytes_in_per_s = 0;
  uint32_t server_tick_p50_us = 0, server_tick_p99_us = 0, server_clients = 0;
  uint32_t budget_bytes_per_s = 0;  // what the server streams to this client within (0: not known yet)
};

// Whether each clipmap level's region is held at the level's own mip (or finer), as of the
// last render: a level that is not shows a coarser mip there while its tiles load.
struct LevelCoverage {
  int32_t levels = 0, levels_lacking = 0;
  double longest_wait_s = 0;  // how long the level lacking tiles longest has lacked them
};

class ViewerSession {
 public:
  // Connects, subscribes to the coarsest mip and waits for it (it sets the material range),
  // then creates the renderer and subscribes what `camera` needs (a renderer view distance of 0 takes the
  // world's, start_view.h) (default: the start view, start_view.h: the orbit's eye east of the world's
  // centre, over the coarsest tiles' ground).
  static Result<std::unique_ptr<ViewerSession>> connect(const std::string& host, uint16_t port,
                                                        const ViewerOptions& options,
                                                        std::optional<scene::Camera> camera = std::nullopt);

  // One frame's network and display work: handles what arrived (waiting up to `wait` for
  // the first message), follows the camera's tiles, brings the display up to the store and
  // refreshes the clipmap levels it changed. An error means the connection is gone.
  Status update(const scene::Camera& camera, std::chrono::milliseconds wait = std::chrono::milliseconds(0));
  FrameStats render(const scene::Camera& camera, int32_t width, int32_t height);
  // After a lost connection: joins again (the same world), subscribes what is held at the
  // versions held, so only what changed meanwhile travels; the display keeps showing the last
  // confirmed state, and own stamps never acknowledged are dropped from the overlay.
  Status reconnect(const std::string& host, uint16_t port);

  // Sends the user's stamp and shows it at once (where the tiles under it are held).
  Result<uint32_t> deform(const QuantizedStamp& stamp);

  // Pumps until every tile the camera needs is held and no own stamp awaits the server.
  bool wait_settled(const scene::Camera& camera, std::chrono::milliseconds timeout);

  client::TerrainClient& client() { return client_; }
  terrain::DisplayTerrain& display() { return *display_; }
  LodScheme lod() const { return error_renderer_ ? LodScheme::kError : LodScheme::kClassic; }
  // Where the display stamps (kAuto resolved).
  DisplayStamping stamping() const { return stamping_; }
  // The classic clipmap renderer; null when the error-driven clipmap draws.
  ClipmapRenderer* classic() { return renderer_.get(); }
  // The error-driven clipmap renderer; null when the classic clipmap draws.
  ErrorClipmapRenderer* error_clipmap() { return error_renderer_.get(); }
  // Re-reads `rect` (mip-0 samples) of the display into whichever renderer draws: what update()
  // does for the display's changes, for a change made beside it.
  void invalidate(const RectI& rect);
  int32_t levels() const;
  // Level l's region (the world's grid at spacing 2^l) as of the last render.
  RectI level_region(int32_t l) const;
  double view_distance_m() const { return view_distance_m_; }
  // The sun (degrees: azimuth clockwise from north, elevation above the horizon).
  std::array<float, 2> sun() const;
  void set_sun(float azimuth_degrees, float elevation_degrees);
  const lod::ClipmapInterest& interest() const { return *interest_; }
  // The display as the game library's queries see it (heights, rays, sweeps: the walk mode),
  // brought up to date by update().
  const query::TerrainSnapshot& terrain() const { return *terrain_; }
  ViewerStats stats() const;
  // After render(): which levels lack tiles of their mip now, and for how long.
  LevelCoverage coverage();

 private:
  ViewerSession() = default;
  Status follow(const scene::Camera& camera);
  void refresh_terrain(const std::vector<terrain::DisplayDirty>& dirty);

  client::TerrainClient client_;
  std::unique_ptr<terrain::DisplayTerrain> display_;
  std::unique_ptr<ClipmapRenderer> renderer_;
  std::unique_ptr<ErrorClipmapRenderer> error_renderer_;
  double view_distance_m_ = 0;
  DisplayStamping stamping_ = DisplayStamping::kGpu;
  bool audit_due_ = false;  // audit the display's GPU copy at the next update
  int32_t audit_tiles_ = 1;
  LevelTraffic level_traffic_;
  std::unique_ptr<lod::ClipmapInterest> interest_;
  std::unique_ptr<query::SnapshotBuilder> snapshots_;
  std::shared_ptr<const query::TerrainSnapshot> terrain_;
  std::vector<TileCoord> terrain_held_;  // the mip-0 tiles terrain_ holds
  std::chrono::steady_clock::time_point next_ping_{};
  uint64_t bytes_in_at_ping_ = 0;
  double bytes_in_per_s_ = 0;
  std::optional<wire::Focus> focus_sent_;  // the focus the server last heard
  std::vector<std::optional<std::chrono::steady_clock::time_point>> lacking_since_;  // per level
};

}  // namespace loam::render
