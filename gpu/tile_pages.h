// A layer's GPU tile cache: 256x256-texel pages in one 2D array texture (R16UI for the coarse
// layer, R8I for the detail layer) and the page table that maps a tile to its page. Nothing is
// whole-world: memory is the pages resident, at most `max_pages`, whatever the world's size
// (GL_MAX_TEXTURE_SIZE no longer bounds it; GL_MAX_ARRAY_TEXTURE_LAYERS bounds the pages).
//
// Pages are handed out by acquire(): a tile already resident keeps its page; otherwise a free
// page, else the array grows (doubling, layers copied on the GPU), else the least recently
// used page that is not pinned is taken. The caller fills a fresh page. A page is pinned while
// the GPU copy may be newer than the copy its tile is uploaded from (a stamp whose readback is
// not collected), so an eviction never loses a sample. Pure bookkeeping plus the texture: the
// stamper (gpu_stamper.h) decides what to upload and when.
//
// Needs the GL 4.5 context it was created in to be current for create(), acquire() (growth)
// and destruction. Not thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <unordered_map>
#include <vector>

#include "gpu/gl_handle.h"
#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam::gpu {

struct PageFormat {
  GLenum internal_format;  // GL_R16UI or GL_R8I
  GLenum format;           // GL_RED_INTEGER
  GLenum type;             // GL_UNSIGNED_SHORT or GL_BYTE
  size_t texel_bytes;
};
PageFormat page_format(Layer layer);

class TilePages {
 public:
  struct Slot {
    int32_t page = -1;   // the array layer holding the tile
    bool fresh = false;  // newly assigned: the caller must fill it
  };

  // Errors: max_pages < 1 or above GL_MAX_ARRAY_TEXTURE_LAYERS.
  static Result<TilePages> create(Layer layer, int32_t max_pages, int32_t initial_pages = 16);
  TilePages(TilePages&&) noexcept = default;
  TilePages& operator=(TilePages&&) noexcept = default;

  // The page of tile (tx, ty) (the layer's tile grid), or none.
  std::optional<int32_t> find(int32_t tx, int32_t ty) const;
  // A page for the tile, marked used now. None: every page is pinned and the array is at
  // max_pages.
  std::optional<Slot> acquire(int32_t tx, int32_t ty);
  // Forgets the tile's page (its next acquire is fresh). Pinned pages are kept.
  void drop(int32_t tx, int32_t ty);
  void pin(int32_t page) { ++pins_[size_t(page)]; }
  void unpin(int32_t page) { --pins_[size_t(page)]; }

  GLuint texture() const { return texture_.get(); }
  Layer layer() const { return layer_; }
  int32_t capacity() const { return capacity_; }
  int32_t max_pages() const { return max_pages_; }
  int32_t resident() const { return int32_t(table_.size()); }
  size_t bytes() const { return size_t(capacity_) * kTileSize * kTileSize * page_format(layer_).texel_bytes; }
  uint64_t evictions() const { return evictions_; }

 private:
  TilePages() = default;
  static int64_t key(int32_t tx, int32_t ty) {
    return int64_t((uint64_t(uint32_t(tx)) << 32) | uint32_t(ty));
  }
  void grow(int32_t capacity);

  Layer layer_ = Layer::kCoarse;
  int32_t max_pages_ = 0, capacity_ = 0;
  GlTexture texture_;
  std::unordered_map<int64_t, int32_t> table_;  // tile -> page
  std::vector<int64_t> owner_;                  // page -> tile key (INT64_MIN: free)
  std::vector<uint64_t> last_use_;
  std::vector<int32_t> pins_;
  std::vector<int32_t> free_;
  uint64_t clock_ = 0, evictions_ = 0;
};

}  // namespace loam::gpu
