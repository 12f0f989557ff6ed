#include "server/replication/region_frames.h"

#include "protocol/codec/region_codec.h"
#include "protocol/tile_rect.h"
#include "protocol/wire/framing.h"
#include "protocol/wire/messages.h"

namespace loam::server {

namespace {

RegionKey key_of(const World& world, const TileCoord& c, std::optional<uint64_t> base, const RectI& rect) {
  return RegionKey{c, base.value_or(0), world.tile_state(c).version, rect, base.has_value()};
}

// The samples of `rect` now and, for a patch the history can rebuild, at `base`; encoded as a
// delta then, else in the fast mode.
template <typename T>
Result<std::vector<uint8_t>> encode_samples(std::vector<T> now, std::optional<std::vector<T>> before,
                                            const RectI& rect, bool* delta) {
  const uint32_t w = uint32_t(rect.width()), h = uint32_t(rect.height());
  if (delta) *delta = before.has_value();
  if (before)
    return encode_region(RegionEncoding::kDelta, std::span<const T>(now), w, h,
                         RegionRefs<T>{.base = *before, .coarser = {}});
  return encode_region(RegionEncoding::kFast, std::span<const T>(now), w, h);
}

}  // namespace

Result<Frames> region_frames_of(const RegionKey& key, std::span<const uint8_t> payload) {
  wire::RegionUpdate header;
  header.tile = key.tile;
  header.rect = key.rect;
  header.patch = key.patch;
  header.base_version = key.base;
  header.new_version = key.version;
  header.encoding = wire::RegionEncoding::kCodec;
  auto chunks = wire::chunk_region(header, payload);
  LOAM_TRY(chunks);
  Frames frames;
  for (const wire::RegionUpdate& r : *chunks) {
    auto frame = wire::encode_frame(r, wire::kAbsoluteMaxFrameBytes);
    LOAM_TRY(frame);
    frames.push_back(std::make_shared<const std::vector<uint8_t>>(std::move(*frame)));
  }
  return frames;
}

Result<Frames> encode_region_frames(const World& world, const TileHistory* history, const TileCoord& c,
                                    std::optional<uint64_t> base, const RectI& rect, bool* delta) {
  Result<std::vector<uint8_t>> payload = [&]() -> Result<std::vector<uint8_t>> {
    return visit_layer(c.layer, [&](auto row) {
      using R = decltype(row);
      std::vector<typename R::Sample> now = copy_tile_rect(world.tile_samples<R>(c), rect);
      std::optional<std::vector<typename R::Sample>> before;
      if (base && history) before = history->samples_at<R>(c, *base, rect, now);
      return encode_samples(std::move(now), std::move(before), rect, delta);
    });
  }();
  LOAM_TRY(payload);
  return region_frames_of(key_of(world, c, base, rect), *payload);
}

void RegionFrames::use(const World& world, const RegionKey& key, Entry& e) {
  ++e.uses;
  if (e.best || key.patch || best_after_uses_ == 0 || e.uses < best_after_uses_) return;
  BackgroundEncoder::Job job;
  job.key = key;
  job.width = uint32_t(key.rect.width());
  job.height = uint32_t(key.rect.height());
  visit_layer(key.tile.layer, [&](auto row) {
    using R = decltype(row);
    samples_of<R>(job) = copy_tile_rect(world.tile_samples<R>(key.tile), key.rect);
  });
  e.best = best_.submit(std::move(job));  // a full queue: asked again on a later use
}

Frames RegionFrames::cached(const World& world, const TileCoord& c, std::optional<uint64_t> base,
                            const RectI& rect) {
  const RegionKey key = key_of(world, c, base, rect);
  const auto it = entries_.find(key);
  if (it == entries_.end()) return {};
  ++counters_.hits;
  lru_.splice(lru_.begin(), lru_, it->second.lru);
  use(world, key, it->second);
  return it->second.frames;
}

Result<Frames> RegionFrames::get(const World& world, const TileHistory* history, const TileCoord& c,
                                 std::optional<uint64_t> base, const RectI& rect, bool* encoded) {
  if (encoded) *encoded = false;
  if (Frames hit = cached(world, c, base, rect); !hit.empty()) return hit;
  bool delta = false;
  auto frames = encode_region_frames(world, history, c, base, rect, &delta);
  LOAM_TRY(frames);
  ++counters_.encodes;
  if (delta) ++counters_.delta_encodes;
  if (encoded) *encoded = true;
  uint64_t bytes = 0;
  for (const auto& f : *frames) bytes += f->size();
  if (bytes > max_bytes_) return frames;  // larger than the whole cache: used once, not kept
  while (counters_.bytes_held + bytes > max_bytes_ && !lru_.empty()) {
    const auto victim = entries_.find(lru_.back());
    counters_.bytes_held -= victim->second.bytes;
    entries_.erase(victim);
    lru_.pop_back();
    ++counters_.evictions;
  }
  const RegionKey key = key_of(world, c, base, rect);
  lru_.push_front(key);
  Entry& e = entries_.emplace(key, Entry{*frames, bytes, lru_.begin(), 0, false}).first->second;
  counters_.bytes_held += bytes;
  use(world, key, e);
  return frames;
}

void RegionFrames::adopt_best() {
  for (BackgroundEncoder::Done& d : best_.take()) {
    const auto it = entries_.find(d.key);
    if (it == entries_.end() || !d.payload) continue;  // evicted meanwhile; or kept fast
    auto frames = region_frames_of(d.key, *d.payload);
    if (!frames) continue;
    uint64_t bytes = 0;
    for (const auto& f : *frames) bytes += f->size();
    Entry& e = it->second;
    if (bytes >= e.bytes) continue;  // the fast payload was as small: keep it
    ++counters_.best_upgrades;
    counters_.best_bytes_saved += e.bytes - bytes;
    counters_.bytes_held -= e.bytes - bytes;
    e.frames = std::move(*frames);
    e.bytes = bytes;
  }
}

void RegionFrames::finish_best() {
  best_.wait_idle();
  adopt_best();
}

}  // namespace loam::server
