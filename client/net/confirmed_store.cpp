#include "client/net/confirmed_store.h"

#include <algorithm>
#include <cstring>

#include "protocol/codec/region_codec.h"
#include "protocol/layer.h"
#include "protocol/replication/event_rule.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_at_mip.h"
#include "protocol/stamps/stamp_kernel.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/tile_hash.h"
#include "protocol/tile_rect.h"
#include "protocol/world_layers.h"

namespace loam::client {

ConfirmedStore::ConfirmedStore(const WorldParams& params) : mirror_(params, 0) {
  mirror_.set_mip0_only(true);  // held mip tiles live in mip_tiles_
}

void ConfirmedStore::forget(const TileCoord& c) {
  wanted_.erase(c);
  versions_.erase(c);
  mip_tiles_.erase(c);
  if (layer_info(c.layer).has_base && c.mip == 0) initial_.erase({c.tx, c.ty});  // kept base samples
  // The mirror keeps only what is held: memory follows the subscription.
  if (c.mip == 0) mirror_.discard_tile(c.layer, c.tx, c.ty);
}

namespace {

// Whether c is a tile of row R's layer in the world (at a mip the layer has).
template <class R>
bool in_layer(const WorldParams& p, const TileCoord& c) {
  return c.layer == R::kLayer && R::tile_range(p, c.mip).contains(c.tx, c.ty);
}

template <class R>
Error not_in_layer(const TileCoord& c) {
  return make_error(ErrorCode::kInvalidArgument, "region.tile",
                    to_string(c) + " is not a " + R::kName + " tile of the world");
}

}  // namespace

template <class R>
Status ConfirmedStore::replace(const TileCoord& c, uint64_t version,
                               std::span<const typename R::Sample> samples) {
  if (samples.size() != size_t(kTileSamples))
    return make_error(ErrorCode::kInvalidArgument, "region", "not a whole tile");
  if (!in_layer<R>(mirror_.params(), c)) return not_in_layer<R>(c);
  if (!wanted_.count(c)) {  // sent before our Unsubscribe reached the server: not ours to hold
    ++counters_.regions_unwanted;
    return {};
  }
  if (c.mip == 0) {
    if (version != 0) keep_initial_of(c);
    (void)LayerOps<R>::write(mirror_, tile_rect(c.tx, c.ty), samples);
    mirror_.commit(version);
  } else if constexpr (R::kHasMips) {
    mip_tiles_[c].assign(samples.begin(), samples.end());
  }
  versions_[c] = version;
  record_region(c, version, {0, 0, kTileSize, kTileSize});
  after_region(version);
  return {};
}

void ConfirmedStore::record_region(const TileCoord& c, uint64_t version, const RectI& local) {
  if (!record_changes_) return;
  StoreChange ch;
  ch.kind = StoreChange::Kind::kRegion;
  ch.seq = version;
  ch.tile = c;
  ch.layer = c.layer;
  ch.rect = local.translated(int64_t(c.tx) * kTileSize, int64_t(c.ty) * kTileSize);
  changes_.push_back(ch);
}

Status ConfirmedStore::check_patch(const TileCoord& c, const RectI& rect, uint64_t base, uint64_t version,
                                   size_t samples) const {
  const auto held = this->version(c);
  if (!held || *held != base) {
    return make_error(ErrorCode::kInvalidArgument, "region.base_version",
                      to_string(c) + " is not held at version " + std::to_string(base));
  }
  if (rect.empty() || !RectI{0, 0, kTileSize, kTileSize}.contains(rect)) {
    return make_error(ErrorCode::kInvalidArgument, "region.rect", "not inside the tile");
  }
  if (samples != size_t(rect.area()))
    return make_error(ErrorCode::kInvalidArgument, "region", "sample count");
  if (version <= base)
    return make_error(ErrorCode::kInvalidArgument, "region.new_version", "not after the base");
  return {};
}

template <class R>
Status ConfirmedStore::patch(const TileCoord& c, const RectI& rect, uint64_t base, uint64_t version,
                             std::span<const typename R::Sample> samples) {
  LOAM_TRY(check_patch(c, rect, base, version, samples.size()));
  if (!in_layer<R>(mirror_.params(), c)) return not_in_layer<R>(c);
  if (c.mip == 0) {
    keep_initial_of(c);
    (void)LayerOps<R>::write(mirror_, rect.translated(int64_t(c.tx) * kTileSize, int64_t(c.ty) * kTileSize),
                             samples);
    mirror_.commit(version);
  } else if constexpr (R::kHasMips) {
    std::vector<typename R::Sample>& tile = mip_tiles_.at(c);
    for (int64_t y = rect.y0; y < rect.y1; ++y) {
      std::copy_n(samples.begin() + (y - rect.y0) * rect.width(), rect.width(),
                  tile.begin() + (y * kTileSize + rect.x0));
    }
  }
  versions_[c] = version;
  record_region(c, version, rect);
  ++counters_.regions_partial;
  after_region(version);
  return {};
}

template <class R>
std::vector<typename R::Sample> ConfirmedStore::held_rect(const TileCoord& c, const RectI& rect) const {
  if (!versions_.count(c) || c.layer != R::kLayer) return {};  // not held: no base to decode against
  if (c.mip == 0) {
    // An unstored tile of the mirror (detail) is all zero, which copy_tile_rect gives for it.
    return copy_tile_rect(mirror_.tile_samples<R>(c), rect);
  }
  if constexpr (R::kHasMips) {
    return copy_tile_rect(std::span<const typename R::Sample>(mip_tiles_.at(c)), rect);
  } else {
    return {};
  }
}

// The rows' instances (the layer table's rows, each with these entry points).
template Status ConfirmedStore::replace<CoarseLayer>(const TileCoord&, uint64_t, std::span<const uint16_t>);
template Status ConfirmedStore::replace<DetailLayer>(const TileCoord&, uint64_t, std::span<const int8_t>);
template Status ConfirmedStore::patch<CoarseLayer>(const TileCoord&, const RectI&, uint64_t, uint64_t,
                                                   std::span<const uint16_t>);
template Status ConfirmedStore::patch<DetailLayer>(const TileCoord&, const RectI&, uint64_t, uint64_t,
                                                   std::span<const int8_t>);
template std::vector<uint16_t> ConfirmedStore::held_rect<CoarseLayer>(const TileCoord&, const RectI&) const;
template std::vector<int8_t> ConfirmedStore::held_rect<DetailLayer>(const TileCoord&, const RectI&) const;

Status ConfirmedStore::apply_region(const wire::RegionUpdate& r, std::span<const uint8_t> payload) {
  return visit_layer(r.tile.layer, [&](auto row) -> Status {
    using R = decltype(row);
    using T = typename R::Sample;
    const uint32_t w = uint32_t(r.rect.width()), h = uint32_t(r.rect.height());
    std::vector<T> samples;
    if (r.encoding == wire::RegionEncoding::kRaw) {
      // Little-endian samples as they are in memory here (the protocol's byte order).
      if (payload.size() != size_t(w) * size_t(h) * sizeof(T))
        return make_error(ErrorCode::kCorrupt, "region.payload", "raw size");
      samples.resize(size_t(w) * size_t(h));
      if (!payload.empty()) std::memcpy(samples.data(), payload.data(), payload.size());
    } else {
      // A patch is coded against what this store holds: decoded here, nothing handed around.
      const std::vector<T> base = r.patch ? held_rect<R>(r.tile, r.rect) : std::vector<T>{};
      auto decoded = decode_samples<T>(payload, w, h, RegionRefs<T>{.base = base, .coarser = {}});
      if (!decoded) return decoded.error();
      samples = std::move(*decoded);
    }
    if (!r.patch) return replace<R>(r.tile, r.new_version, samples);
    return patch<R>(r.tile, r.rect, r.base_version, r.new_version, samples);
  });
}

// Events at or below a region's version are already in its tile (the server covers every
// tile such an event changed with a region), so they are dropped; later ones may now apply.
void ConfirmedStore::after_region(uint64_t version) {
  ++counters_.regions;
  for (auto it = buffer_.begin(); it != buffer_.end();) {
    if (it->first <= version) {
      it = buffer_.erase(it);
      ++counters_.events_dropped;
    } else {
      ++it;
    }
  }
  retry_buffered(last_textures_);
}

bool ConfirmedStore::try_apply(const wire::DeformEvent& e, const TextureRegistry* textures) {
  const auto held = [&](const TileCoord& c) { return version(c); };
  if (replication::event_fit(e, held) != replication::EventFit::kApply) return false;
  // The listed tiles this store holds and reproduces from the event (at every mip for a
  // per-sample stamp), each at its base version by the rule above.
  std::vector<TileCoord> mine;
  bool any_mip0 = false, any_mip = false;
  for (const wire::TileVersion& bv : e.base_versions) {
    if (!replication::event_reproduces_tile(e.stamp, bv.tile) || !versions_.count(bv.tile)) continue;
    mine.push_back(bv.tile);
    (bv.tile.mip == 0 ? any_mip0 : any_mip) = true;
  }
  if (mine.empty()) return true;  // nothing of ours changes: consumed
  if (e.stamp.kind == StampKind::kTexture && !(textures && textures->contains(e.stamp.texture_id))) {
    // The server applied it with an image we do not have yet: wait for it (textures_arrived).
    missing_textures_.insert(e.stamp.texture_id);
    return false;
  }
  if (any_mip0) {
    for (const TileCoord& c : mine) keep_initial_of(c);
    auto applied = apply_stamp_with_contact(mirror_, e.stamp, e.contact, textures);
    mirror_.commit(e.global_seq);
    // The stamp ran over its whole rect: tiles under it that are not held were written too.
    // Drop them again, so the mirror holds only what is held.
    if (applied && !applied->empty()) discard_unheld(e.stamp.layer, *applied);
    if (applied && record_changes_) {
      StoreChange ch;
      ch.kind = StoreChange::Kind::kEvent;
      ch.seq = e.global_seq;
      ch.layer = e.stamp.layer;
      ch.rect = *applied;
      ch.stamp = e.stamp;
      ch.origin_client_id = e.origin_client_id;
      changes_.push_back(ch);
    }
  }
  if (any_mip) {
    // The coarse mips this store holds: the stamp at each mip sample's mip-0 position.
    const WorldParams& p = mirror_.params();
    auto baked = bake_stamp(e.stamp, p, textures);
    if (check_quantized(e.stamp, p, {}, textures).ok() && baked) {
      set_contact(*baked, e.contact);
      for (const TileCoord& c : mine) {
        if (c.mip == 0) continue;
        const RectI r = apply_to_coarse_tile(*baked, p, c, mip_tiles_.at(c));
        if (!r.empty()) record_region(c, e.global_seq, r);
      }
    }
  }
  // A stamp that fails here failed the same way on the server: a no-op everywhere.
  for (const TileCoord& c : mine) versions_[c] = e.global_seq;
  return true;
}

void ConfirmedStore::discard_unheld(Layer layer, const RectI& rect) {
  const RectI tiles = tiles_overlapping(rect);
  for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
    for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
      if (!versions_.count({layer, 0, int32_t(tx), int32_t(ty)}))
        mirror_.discard_tile(layer, int32_t(tx), int32_t(ty));
    }
  }
}

void ConfirmedStore::retry_buffered(const TextureRegistry* textures) {
  bool progress = true;
  while (progress) {
    progress = false;
    for (auto it = buffer_.begin(); it != buffer_.end(); ++it) {
      if (try_apply(it->second, textures)) {
        buffer_.erase(it);
        ++counters_.events_applied;
        progress = true;
        break;
      }
    }
  }
}

EventOutcome ConfirmedStore::on_event(const wire::DeformEvent& e, const TextureRegistry* textures) {
  last_textures_ = textures;
  if (try_apply(e, textures)) {
    ++counters_.events_applied;
    retry_buffered(textures);
    return EventOutcome::kApplied;
  }
  buffer_[e.global_seq] = e;
  ++counters_.events_buffered;
  return EventOutcome::kBuffered;
}

void ConfirmedStore::textures_arrived(const TextureRegistry* textures) {
  last_textures_ = textures;
  retry_buffered(textures);
}

std::vector<TileCoord> ConfirmedStore::tiles_waiting_for(uint64_t texture_id) const {
  std::vector<TileCoord> out;
  for (const auto& [seq, e] : buffer_) {
    if (e.stamp.kind != StampKind::kTexture || e.stamp.texture_id != texture_id) continue;
    for (const wire::TileVersion& bv : e.base_versions) {
      if (versions_.count(bv.tile)) out.push_back(bv.tile);
    }
  }
  return out;
}

std::vector<TileCoord> ConfirmedStore::tiles_behind() const {
  std::set<TileCoord> out;
  for (const auto& [seq, e] : buffer_) {
    for (const wire::TileVersion& bv : e.base_versions) {
      if (versions_.count(bv.tile)) out.insert(bv.tile);
    }
  }
  return {out.begin(), out.end()};
}

std::vector<TileCoord> ConfirmedStore::check_hashes(const wire::TileHashes& h) {
  std::vector<TileCoord> mismatched;
  for (const wire::TileHashEntry& e : h.entries) {
    const auto v = version(e.tile);
    if (!v || *v != e.version) continue;  // not comparable yet
    ++counters_.hash_checks;
    if (hash(e.tile) != e.hash) {
      ++counters_.hash_mismatches;
      mismatched.push_back(e.tile);
    }
  }
  return mismatched;
}

std::optional<uint64_t> ConfirmedStore::version(const TileCoord& c) const {
  const auto it = versions_.find(c);
  if (it == versions_.end()) return std::nullopt;
  return it->second;
}

void ConfirmedStore::keep_initial_of(const TileCoord& c) {
  if (!keep_initial_ || !layer_info(c.layer).has_base || c.mip != 0) return;  // only a base's tiles
  const auto v = version(c);
  if (!v || *v != 0 || initial_.count({c.tx, c.ty})) return;
  const auto samples = mirror_.coarse_tile(0, c.tx, c.ty);
  initial_.emplace(std::pair{c.tx, c.ty}, std::vector<uint16_t>(samples.begin(), samples.end()));
}

std::span<const uint16_t> ConfirmedStore::initial_coarse(int32_t tx, int32_t ty) const {
  const TileCoord c{Layer::kCoarse, 0, tx, ty};
  const auto v = version(c);
  if (!v) return {};
  if (*v == 0) return mirror_.coarse_tile(0, tx, ty);
  const auto it = initial_.find({tx, ty});
  if (it == initial_.end()) return {};
  return it->second;
}

std::span<const uint16_t> ConfirmedStore::coarse_samples(const TileCoord& c) const {
  if (!versions_.count(c) || c.layer != Layer::kCoarse) return {};
  if (c.mip == 0) return mirror_.coarse_tile(0, c.tx, c.ty);
  return mip_tiles_.at(c);
}

uint64_t ConfirmedStore::hash(const TileCoord& c) const {
  if (!versions_.count(c)) return 0;
  return visit_layer(c.layer, [&](auto row) {
    using R = decltype(row);
    if constexpr (R::kHasMips) {
      if (c.mip != 0) return LayerOps<R>::hash(mip_tiles_.at(c));
    }
    return LayerOps<R>::hash(mirror_.tile_samples<R>(c));
  });
}

std::vector<TileCoord> ConfirmedStore::wanted() const {
  std::vector<TileCoord> out;
  for (const auto& [c, w] : wanted_) out.push_back(c);
  return out;
}

std::vector<TileCoord> ConfirmedStore::held() const {
  std::vector<TileCoord> out;
  for (const auto& [c, v] : versions_) out.push_back(c);
  return out;
}

}  // namespace loam::client
