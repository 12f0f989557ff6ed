// The terrain as a viewer shows it: the confirmed store's state plus the user's own stamps
// that the server has not settled yet (the overlay), so a crater appears the moment it is
// made. It is kept in the CPU mirror the clipmap levels read (a HeightSource) and, in a viewer,
// in a GPU tile cache (a DisplayStamper: the shared stamp shaders, bit-exact with the CPU
// reference). The display itself needs no GL: without a stamper it stamps on the CPU.
//
// Nothing is read back from the GPU copy. The CPU copy follows the store by copying; the GPU
// copy by stamping the same stamps with the shared shaders (bit-exact with the reference, as
// the conformance tests prove), so an event costs the GPU its stamp's constants and the CPU a
// copy of the samples it changed, and the renderer fills its levels from the GPU copy. Own
// stamps are stamped on both (the GPU first: a page it fills fresh reads the CPU copy), and a
// stamp the cache cannot take (every page held, or more tiles than its budget) is uploaded from
// the CPU copy instead. audit_gpu() reads back a few tiles and compares them (a sampled check,
// never per event).
//
// Each frame, sync() follows the client:
//   - events the confirmed store applied are followed where the display equals the confirmed
//     state under the stamp's whole reach: the CPU copy takes the samples they changed from the
//     store, the GPU copy stamps them;
//   - where the display cannot follow so (a region replaced a tile, an event fell where the
//     overlay is), the confirmed samples are copied in and uploaded ("stale" rects);
//   - an own stamp is retired once the server rejected it, or its event has arrived and been
//     applied (or covered by a region); its reach is then rebuilt from the store, and every
//     overlay stamp overlapping a rebuilt rect is re-applied, in order. A correction is a texel
//     of a settled prediction where the confirmed result differs from what was shown with the
//     other stamps' events of the same sync applied on top: 0 when the server applied our
//     stamp on the state we predicted on (or the stamps commute), more when it ordered another
//     stamp first and they do not commute (saturation, min/max blends, footprint contact).
// Only held tiles are meaningful: an own stamp is predicted only where every mip-0 tile of
// its layer under its reach is held. Mip l samples come from mip 0 where that tile is held
// (decimation makes them equal), else from a held mip-l tile, else the nearest held coarser
// mip (an approximation shown only while tiles load). Memory follows the subscription: the
// display copies only the tiles the store holds (CPU copy and GPU pages), and drops those the
// store forgot at the next sync; the GPU pages are a bounded cache (gpu/tile_pages.h), so no
// world is too large for it.
//
// With a GPU stamper the GL 4.5 context it was created in must be current for every call; not
// thread-safe. The store must outlive it.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <vector>

#include "client/net/confirmed_store.h"
#include "client/net/terrain_client.h"
#include "client/terrain/display_stamper.h"
#include "client/terrain/height_source.h"
#include "protocol/result.h"
#include "protocol/stamps/texture_registry.h"
#include "protocol/world.h"

namespace loam::terrain {

struct DisplayCounters {
  uint64_t events_stamped = 0;     // confirmed events stamped on the display's GPU copy
  uint64_t events_copied = 0;      // confirmed events followed by copying alone (no GPU copy, or
                                   // the overlay or a region in the way)
  uint64_t predicted = 0;          // own stamps drawn as overlay
  uint64_t not_predicted = 0;      // own stamps over tiles not held (shown when confirmed)
  uint64_t retired = 0;            // overlay stamps settled (applied, rejected or timed out)
  uint64_t rejected = 0;           // ... of which the server rejected
  uint64_t abandoned = 0;          // ... of which the connection was lost before their ack
  uint64_t corrections = 0;        // texels of the overlay that differed from the confirmed result
  uint64_t divergent_texels = 0;   // GPU copy != CPU copy, found by audit_gpu() (repaired)
  uint64_t gpu_tiles_audited = 0;  // tiles audit_gpu() compared
  uint64_t texels_copied = 0;      // samples copied from the store into the display
  uint64_t tiles_forgotten = 0;    // tiles dropped because the store no longer holds them
};

// What the display holds: its CPU copy of the held tiles and its GPU tile cache.
struct DisplayMemory {
  size_t cpu_bytes = 0;
  gpu::GpuStamperMemory gpu;  // zero without a GPU stamper
};

// Samples of the display that changed (a layer's global mip-0 grid), for the renderer.
struct DisplayDirty {
  Layer layer = Layer::kCoarse;
  RectI rect;
  // The GPU copy changed these samples by stamping (the renderer may take them from there);
  // false: copied in on the CPU (and uploaded to the GPU copy where resident).
  bool stamped_on_gpu = false;
};

class DisplayTerrain final : public HeightSource {
 public:
  // `gpu` makes the display's GPU tile cache (empty: the display stamps on the CPU alone).
  static Result<std::unique_ptr<DisplayTerrain>> create(const client::ConfirmedStore& store,
                                                        const DisplayStamperFactory& gpu,
                                                        const TextureRegistry* textures = nullptr);
  ~DisplayTerrain() override;
  DisplayTerrain(const DisplayTerrain&) = delete;
  DisplayTerrain& operator=(const DisplayTerrain&) = delete;

  const WorldParams& params() const override { return display_.params(); }
  void read(int32_t mip, const RectI& rect, std::span<uint16_t> out) const override;
  // Detail offsets of a rect of the detail grid; 0 where the detail tile is not held.
  void read_detail(const RectI& rect, std::span<int8_t> out) const;

  // The session's initial terrain (the base every tile's version 0 is, where the client can
  // generate it): read_change() measures against it, for the renderer's dug-material layer.
  // Without one it measures against what the store kept of each tile's version 0
  // (ConfirmedStore::keep_initial: ground edited while held, and own stamps on tiles still at
  // version 0); where neither is known, or the store keeps nothing, ground reads as unchanged
  // (read_change() answers false when there is no reference at all).
  void set_initial_base(std::shared_ptr<const TileBase> base);
  bool read_change(int32_t mip, const RectI& rect, std::span<float> out) const override;

  // Shows the user's own stamp, sent as `client_seq`, at once. Returns false (nothing shown
  // until the server confirms it) where the stamp is invalid or reaches a tile not held.
  bool predict(uint32_t client_seq, const QuantizedStamp& q);

  // Brings the display up to the client's store and acks; returns what changed on display.
  std::vector<DisplayDirty> sync(client::TerrainClient& client);

  // The store's changes the last sync() took in, oldest first (events and regions): what a
  // game's deformation hooks hear of.
  const std::vector<client::StoreChange>& last_changes() const { return last_changes_; }
  size_t overlay_size() const { return pending_.size(); }
  const DisplayCounters& counters() const { return counters_; }
  DisplayMemory memory() const;
  // Bytes the GPU copy took and gave (zero without one).
  gpu::GpuStamperTraffic gpu_traffic() const;
  // The GPU tile cache (null without one): a renderer fills its levels from its pages, which
  // hold what the CPU copy holds for every resident tile after sync().
  const gpu::GpuStamper* gpu_cache() const;
  // Reads back up to `max_tiles` resident tiles of the GPU copy (the next ones in turn), compares
  // them with the CPU copy and repairs any difference (counters: divergent_texels). Returns
  // the texels that differed. A synchronous readback of 128 KiB a coarse tile: a sampled check
  // (the viewer audits one tile a second), and a full one in tests.
  uint64_t audit_gpu(size_t max_tiles);
  const World& world() const { return display_; }
  bool on_gpu() const { return stamper_ != nullptr; }
  // Own stamps whose event never comes (the tiles were unsubscribed meanwhile) retire after this.
  void set_retire_timeout(std::chrono::milliseconds t) { retire_timeout_ = t; }

 private:
  struct Pending {
    uint32_t client_seq = 0;
    QuantizedStamp stamp;
    RectI reach;  // the stamp layer's global samples it may change
    bool acked = false, accepted = false, abandoned = false;
    uint64_t global_seq = 0;
    std::chrono::steady_clock::time_point ack_time{};
    // This sync: it leaves the overlay (settled), or it is stamped again over the copied
    // confirmed samples (it stays, and a stale rect reached under it).
    bool retire = false, reapply = false;
  };
  // What a settled, accepted prediction should have become (compared after the copy).
  struct Expected {
    Layer layer = Layer::kCoarse;
    RectI rect;
    std::vector<int32_t> samples;
  };
  // One sync's rects per layer: copied from the store and uploaded (stale), under the
  // predictions that stay (overlay), and changed by events followed (copied on the CPU alone:
  // the GPU copy stamped them).
  struct SyncRects {
    PerLayer<std::vector<RectI>> stale, overlay, followed;
    // Per stale rect: whether it needs the levels only where copying the confirmed samples
    // changed the display (a settled prediction's reach, an event's rect: held tiles the levels
    // show as the display holds them; a right prediction changes nothing). A region's rect
    // always does (the levels may have shown a coarser mip there).
    PerLayer<std::vector<bool>> quiet;
    void add_stale(Layer layer, const RectI& r, bool is_quiet = false) {
      stale[layer].push_back(r);
      quiet[layer].push_back(is_quiet);
    }
  };
  DisplayTerrain(const client::ConfirmedStore& store, const TextureRegistry* textures);

  bool holds_mip0(Layer layer, const RectI& reach) const;
  void stamp(const QuantizedStamp& q);  // an own stamp: on the GPU copy, then the CPU copy
  void finish(std::vector<DisplayDirty>& dirty);
  // Returns the samples that changed; uploads them (the rect) where asked and any changed.
  int64_t copy_from_store(Layer layer, const RectI& rect, bool upload);
  // Drops the display's copy (CPU and GPU) of tiles the store no longer holds, except under
  // an own stamp still shown: memory follows the subscription.
  void forget_unheld();
  // Where the samples of mip-0 tile (tx, ty) come from for a mip-`mip` level: the display's
  // mip 0 where held, else a held mip tile (empty: nothing held there yet).
  struct TileSource {
    int32_t mip = 0;
    std::span<const uint16_t> samples;
  };
  TileSource source_for(int32_t mip, int32_t tx, int32_t ty) const;
  // Whether mip-0 coarse tile (tx, ty) may differ from the initial base: held past version 0,
  // or under an own stamp shown. Others read as unchanged without asking the base.
  bool may_have_changed(int32_t tx, int32_t ty) const;
  const uint16_t* base_tile(int32_t tx, int32_t ty) const;  // mip 0, cached
  // What a settled prediction should become if it was right: the displayed samples of its
  // reach with this sync's events of other stamps (in server order) applied on top.
  std::vector<int32_t> expected_after(const Pending& p,
                                      const std::vector<client::StoreChange>& changes) const;

  // sync()'s phases, in order.
  void settle(client::TerrainClient& client, std::chrono::steady_clock::time_point now);
  std::vector<Expected> plan_settled(const std::vector<client::StoreChange>& changes, SyncRects& rects);
  void follow_changes(const std::vector<client::StoreChange>& changes, SyncRects& rects,
                      std::vector<DisplayDirty>& dirty);
  void spread_under_overlay(SyncRects& rects);
  void copy_and_reapply(const SyncRects& rects, std::vector<DisplayDirty>& dirty);
  void count_and_retire(const std::vector<Expected>& expected);

  const client::ConfirmedStore* store_;
  const TextureRegistry* textures_;
  World display_;
  std::unique_ptr<DisplayStamper> stamper_;
  std::vector<DisplayDirty> cpu_done_;
  size_t audit_cursor_ = 0;
  std::vector<Pending> pending_;
  std::vector<client::StoreChange> last_changes_;
  std::shared_ptr<const TileBase> initial_base_;
  // Mip-0 base tiles read_change() asked for: few (only tiles that changed), dropped together
  // when they pass 64 (8 MiB).
  mutable std::map<std::pair<int32_t, int32_t>, std::vector<uint16_t>> base_tiles_;
  DisplayCounters counters_;
  std::chrono::milliseconds retire_timeout_{5000};
};

}  // namespace loam::terrain
