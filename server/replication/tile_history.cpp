#include "server/replication/tile_history.h"

#include <type_traits>

#include "protocol/tile_rect.h"

namespace loam::server {

std::vector<TileSamples> read_reach(const World& world, Layer layer, const RectI& reach0,
                                    uint64_t max_samples) {
  const WorldParams& p = world.params();
  // Every (tile, global rect) first, so that nothing is copied when the total is too large.
  struct Part {
    TileCoord tile;
    RectI local;
  };
  std::vector<Part> parts;
  uint64_t total = 0;
  auto cover = [&](Layer l, int32_t mip, const RectI& global, const RectI& tile_range) {
    const RectI tiles = tiles_overlapping(global).intersect(tile_range);
    for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
      for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
        const RectI local = global.intersect(tile_rect(int32_t(tx), int32_t(ty)))
                                .translated(-tx * kTileSize, -ty * kTileSize);
        if (local.empty()) continue;
        total += uint64_t(local.area());
        parts.push_back({TileCoord{l, uint8_t(mip), int32_t(tx), int32_t(ty)}, local});
      }
    }
  };
  return visit_layer(layer, [&](auto row) {
    using R = decltype(row);
    // A layer with mips: every mip's samples the reach's mip-0 samples feed.
    if constexpr (R::kHasMips) {
      for (int32_t m = 0; m < p.mip_count() && total <= max_samples; ++m)
        cover(layer, m, mip_samples_reaching(p, m, reach0), R::tile_range(p, m));
    } else {
      cover(layer, 0, reach0.intersect(R::sample_rect(p)), R::tile_range(p, 0));
    }
    std::vector<TileSamples> out;
    if (total > max_samples) return out;
    out.reserve(parts.size());
    for (const Part& part : parts) {
      TileSamples s{part.tile, part.local, {}, {}};
      samples_of<R>(s) = copy_tile_rect(world.tile_samples<R>(part.tile), part.local);
      out.push_back(std::move(s));
    }
    return out;
  });
}

namespace {

// Copies the samples of `part` from `src` (row-major over src_rect) into `dst` (row-major over
// dst_rect); both rects contain `part`, all in one grid.
template <typename T>
void copy_sub(std::span<const T> src, const RectI& src_rect, std::span<T> dst, const RectI& dst_rect,
              const RectI& part) {
  for (int64_t y = part.y0; y < part.y1; ++y) {
    const T* s = src.data() + (y - src_rect.y0) * src_rect.width() + (part.x0 - src_rect.x0);
    T* d = dst.data() + (y - dst_rect.y0) * dst_rect.width() + (part.x0 - dst_rect.x0);
    std::copy(s, s + part.width(), d);
  }
}

}  // namespace

void TileHistory::forget(std::map<TileCoord, Entry>::iterator it) {
  for (const Change& ch : it->second.changes) bytes_ -= ch.bytes();
  lru_.erase(it->second.lru);
  tiles_.erase(it);
}

void TileHistory::record(std::span<const TileChange> changes, std::span<const TileSamples> before) {
  if (per_tile_ == 0 || max_tiles_ == 0) return;
  for (const TileChange& c : changes) {
    auto it = tiles_.find(c.coord);
    if (it == tiles_.end()) {
      if (tiles_.size() >= max_tiles_) forget(tiles_.find(lru_.back()));
      lru_.push_front(c.coord);
      it = tiles_.emplace(c.coord, Entry{{}, lru_.begin()}).first;
    } else {
      lru_.splice(lru_.begin(), lru_, it->second.lru);
    }
    Change rec{c, false, {}, {}};
    for (const TileSamples& s : before) {
      if (s.tile != c.coord || !s.rect.contains(c.rect)) continue;
      rec.kept = visit_layer(c.coord.layer, [&](auto row) {
        using R = decltype(row);
        const auto& from = samples_of<R>(s);
        if (size_t(s.rect.area()) != from.size()) return false;
        auto& to = samples_of<R>(rec);
        to.resize(size_t(c.rect.area()));
        copy_sub<typename R::Sample>(from, s.rect, to, c.rect, c.rect);
        return true;
      });
      break;
    }
    std::deque<Change>& list = it->second.changes;
    bytes_ += rec.bytes();
    list.push_back(std::move(rec));
    if (list.size() > per_tile_) {
      bytes_ -= list.front().bytes();
      list.pop_front();
    }
  }
  while (bytes_ > max_bytes_ && !lru_.empty()) forget(tiles_.find(lru_.back()));
}

std::optional<RectI> TileHistory::changed_since(const TileCoord& c, uint64_t held) const {
  const auto it = tiles_.find(c);
  if (it == tiles_.end()) return std::nullopt;
  const std::deque<Change>& list = it->second.changes;
  if (!list.empty() && list.back().change.new_version == held) return RectI{};
  // Versions chain: each change's base is the previous one's new version. Find the change made
  // right after `held` and unite the rects from there on.
  RectI rect;
  bool found = false;
  for (const Change& ch : list) {
    if (ch.change.base_version == held) found = true;
    if (found) rect = rect.unite(ch.change.rect);
  }
  return found ? std::optional<RectI>(rect) : std::nullopt;
}

template <class R>
std::optional<std::vector<typename R::Sample>> TileHistory::samples_at(
    const TileCoord& c, uint64_t held, const RectI& rect, std::span<const typename R::Sample> current) const {
  using T = typename R::Sample;
  if (current.size() != size_t(rect.area())) return std::nullopt;
  const auto it = tiles_.find(c);
  if (it == tiles_.end()) return std::nullopt;
  const std::deque<Change>& list = it->second.changes;
  std::vector<T> out(current.begin(), current.end());
  if (!list.empty() && list.back().change.new_version == held) return out;
  for (auto ch = list.rbegin(); ch != list.rend(); ++ch) {
    const std::vector<T>* before = &samples_of<R>(*ch);
    if (!ch->kept || !rect.contains(ch->change.rect) || before->size() != size_t(ch->change.rect.area()))
      return std::nullopt;
    copy_sub<T>(*before, ch->change.rect, out, rect, ch->change.rect);
    if (ch->change.base_version == held) return out;
  }
  return std::nullopt;
}

bool TileHistory::can_rebuild(const TileCoord& c, uint64_t held) const {
  const auto it = tiles_.find(c);
  if (it == tiles_.end()) return false;
  const std::deque<Change>& list = it->second.changes;
  if (!list.empty() && list.back().change.new_version == held) return true;
  for (auto ch = list.rbegin(); ch != list.rend(); ++ch) {
    if (!ch->kept) return false;
    if (ch->change.base_version == held) return true;
  }
  return false;
}

template std::optional<std::vector<uint16_t>> TileHistory::samples_at<CoarseLayer>(
    const TileCoord&, uint64_t, const RectI&, std::span<const uint16_t>) const;
template std::optional<std::vector<int8_t>> TileHistory::samples_at<DetailLayer>(
    const TileCoord&, uint64_t, const RectI&, std::span<const int8_t>) const;

}  // namespace loam::server
