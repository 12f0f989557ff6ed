#include "gpu/tile_pages.h"

#include <climits>
#include <string>

#include "protocol/layer.h"

namespace loam::gpu {

namespace {
constexpr int64_t kFree = INT64_MIN;
}

// The layer table's GL numbers are GL's (protocol/ includes no GL header).
static_assert(CoarseLayer::kGlInternalFormat == GL_R16UI && CoarseLayer::kGlType == GL_UNSIGNED_SHORT);
static_assert(DetailLayer::kGlInternalFormat == GL_R8I && DetailLayer::kGlType == GL_BYTE);

PageFormat page_format(Layer layer) {
  const LayerInfo& l = layer_info(layer);
  return PageFormat{GLenum(l.gl_internal_format), GL_RED_INTEGER, GLenum(l.gl_type),
                    size_t(l.bytes_per_sample)};
}

Result<TilePages> TilePages::create(Layer layer, int32_t max_pages, int32_t initial_pages) {
  GLint max_layers = 0;
  glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
  if (max_pages < 1 || max_pages > max_layers) {
    return make_error(ErrorCode::kInvalidArgument, "gpu.max_pages",
                      std::to_string(max_pages) + " pages asked for; this GL offers 1.." +
                          std::to_string(max_layers) + " array layers");
  }
  TilePages p;
  p.layer_ = layer;
  p.max_pages_ = max_pages;
  p.grow(std::min(std::max(initial_pages, 1), max_pages));
  return p;
}

void TilePages::grow(int32_t capacity) {
  const PageFormat f = page_format(layer_);
  GlTexture t = make_texture(GL_TEXTURE_2D_ARRAY);
  glTextureStorage3D(t.get(), 1, f.internal_format, kTileSize, kTileSize, capacity);
  // Integer textures must not be filtered (texelFetch and image loads ignore it anyway).
  glTextureParameteri(t.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(t.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  if (texture_ && capacity_ > 0) {
    // Image stores into the old pages must land before they are copied.
    glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT | GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
    glCopyImageSubData(texture_.get(), GL_TEXTURE_2D_ARRAY, 0, 0, 0, 0, t.get(), GL_TEXTURE_2D_ARRAY, 0, 0, 0,
                       0, kTileSize, kTileSize, capacity_);
  }
  texture_ = std::move(t);
  for (int32_t i = capacity - 1; i >= capacity_; --i) free_.push_back(i);
  owner_.resize(size_t(capacity), kFree);
  last_use_.resize(size_t(capacity), 0);
  pins_.resize(size_t(capacity), 0);
  capacity_ = capacity;
}

std::optional<int32_t> TilePages::find(int32_t tx, int32_t ty) const {
  const auto it = table_.find(key(tx, ty));
  if (it == table_.end()) return std::nullopt;
  return it->second;
}

std::optional<TilePages::Slot> TilePages::acquire(int32_t tx, int32_t ty) {
  const int64_t k = key(tx, ty);
  ++clock_;
  if (const auto it = table_.find(k); it != table_.end()) {
    last_use_[size_t(it->second)] = clock_;
    return Slot{it->second, false};
  }
  if (free_.empty() && capacity_ < max_pages_) grow(std::min(max_pages_, capacity_ * 2));
  int32_t page = -1;
  if (!free_.empty()) {
    page = free_.back();
    free_.pop_back();
  } else {
    uint64_t oldest = UINT64_MAX;
    for (int32_t i = 0; i < capacity_; ++i) {
      if (pins_[size_t(i)] == 0 && last_use_[size_t(i)] < oldest) oldest = last_use_[size_t(i)], page = i;
    }
    if (page < 0) return std::nullopt;
    table_.erase(owner_[size_t(page)]);
    ++evictions_;
  }
  owner_[size_t(page)] = k;
  last_use_[size_t(page)] = clock_;
  table_[k] = page;
  return Slot{page, true};
}

void TilePages::drop(int32_t tx, int32_t ty) {
  const auto it = table_.find(key(tx, ty));
  if (it == table_.end() || pins_[size_t(it->second)] != 0) return;
  owner_[size_t(it->second)] = kFree;
  free_.push_back(it->second);
  table_.erase(it);
}

}  // namespace loam::gpu
