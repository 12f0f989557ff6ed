#include "server/replication/region_frames.h"

#include "protocol/codec/region_codec.h"
#include "protocol/tile_rect.h"
#include "protocol/wire/framing.h"
#include "protocol/wire/messages.h"

namespace loam::server {

Result<Frames> encode_region_frames(const World& world, const TileCoord& c, std::optional<uint64_t> base,
                                    const RectI& rect) {
  const int32_t rw = int32_t(rect.width()), rh = int32_t(rect.height());
  Result<std::vector<uint8_t>> payload =
      c.layer == Layer::kCoarse
          ? encode_region(
                RegionEncoding::kFast,
                std::span<const uint16_t>(copy_tile_rect(world.coarse_tile(c.mip, c.tx, c.ty), rect)), rw, rh)
          : encode_region(RegionEncoding::kFast,
                          std::span<const int8_t>(copy_tile_rect(world.detail_tile(c.tx, c.ty), rect)), rw,
                          rh);
  LOAM_TRY(payload);
  wire::RegionUpdate header;
  header.tile = c;
  header.rect = rect;
  header.patch = base.has_value();
  header.base_version = base.value_or(0);
  header.new_version = world.tile_state(c).version;
  header.encoding = wire::RegionEncoding::kCodec;
  auto chunks = wire::chunk_region(header, *payload);
  LOAM_TRY(chunks);
  Frames frames;
  for (const wire::RegionUpdate& r : *chunks) {
    auto frame = wire::encode_frame(r, wire::kAbsoluteMaxFrameBytes);
    LOAM_TRY(frame);
    frames.push_back(std::make_shared<const std::vector<uint8_t>>(std::move(*frame)));
  }
  return frames;
}

Frames RegionFrames::cached(const World& world, const TileCoord& c, std::optional<uint64_t> base,
                            const RectI& rect) {
  const RegionKey key{c, base.value_or(0), world.tile_state(c).version, rect, base.has_value()};
  const auto it = entries_.find(key);
  if (it == entries_.end()) return {};
  ++counters_.hits;
  lru_.splice(lru_.begin(), lru_, it->second.lru);
  return it->second.frames;
}

Result<Frames> RegionFrames::get(const World& world, const TileCoord& c, std::optional<uint64_t> base,
                                 const RectI& rect, bool* encoded) {
  if (encoded) *encoded = false;
  if (Frames hit = cached(world, c, base, rect); !hit.empty()) return hit;
  auto frames = encode_region_frames(world, c, base, rect);
  LOAM_TRY(frames);
  ++counters_.encodes;
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
  const RegionKey key{c, base.value_or(0), world.tile_state(c).version, rect, base.has_value()};
  lru_.push_front(key);
  entries_.emplace(key, Entry{*frames, bytes, lru_.begin()});
  counters_.bytes_held += bytes;
  return frames;
}

}  // namespace loam::server
