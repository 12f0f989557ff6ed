#include "server/terrain_state.h"

#include <algorithm>

#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_kernel.h"

namespace loam::server {

TerrainState::TerrainState(World world, uint64_t last_seq, StampLimits limits)
    : world_(std::move(world)), limits_(limits), last_seq_(last_seq) {}

Status TerrainState::check(const QuantizedStamp& q) const {
  return check_quantized(q, world_.params(), limits_, textures_.get());
}

Result<AppliedStamp> TerrainState::apply(const QuantizedStamp& q, uint64_t seq, uint32_t client_id) {
  if (seq != last_seq_ + 1) {
    return make_error(ErrorCode::kInvalidArgument, "seq",
                      "expected " + std::to_string(last_seq_ + 1) + ", got " + std::to_string(seq));
  }
  // The limits in force (a replayed segment's recorded ones) decide, whatever the backend was
  // made with.
  if (Status st = check(q); !st.ok()) {
    last_seq_ = seq;
    return st.error();
  }
  AppliedStamp out;
  out.seq = seq;
  out.client_id = client_id;
  out.stamp = q;
  // Footprint contact reads every sample under the foot: those tiles are inputs even where
  // nothing changes, so a client needs them at the same versions to reproduce the stamp.
  std::vector<wire::TileVersion> read_only;
  if (q.kind == StampKind::kFootprint) {
    auto baked = bake_stamp(q, world_.params(), textures_.get());
    if (!baked) {
      last_seq_ = seq;
      return baked.error();
    }
    const RectI tiles = tiles_overlapping(baked->rect);
    for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
      for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
        const TileCoord c{q.layer, 0, int32_t(tx), int32_t(ty)};
        read_only.push_back({c, world_.tile_state(c).version});
      }
    }
  }
  auto changed = backend_ ? backend_->apply(world_, q) : apply_stamp(world_, q, textures_.get(), limits_);
  if (!changed && backend_) {
    // The stamp is logged already and passed check(): a backend failure (a lost GL context)
    // must not make it a no-op that recovery would then refuse. The CPU reference gives the
    // same integers; the backend's copy is brought up to date.
    backend_failures_.push_back(changed.error());
    changed = apply_stamp(world_, q, textures_.get(), limits_);
    if (changed) backend_->world_changed(world_, q.layer, *changed);
  }
  if (!changed) {
    // The sequence is consumed either way (it may already be in the log); replay does the
    // same, so a stamp that fails to apply is a no-op everywhere.
    last_seq_ = seq;
    return changed.error();
  }
  out.changes = world_.commit(seq);
  last_seq_ = seq;
  for (const TileChange& c : out.changes) out.base_versions.push_back({c.coord, c.base_version});
  for (const wire::TileVersion& r : read_only) {
    const bool listed = std::any_of(out.base_versions.begin(), out.base_versions.end(),
                                    [&](const wire::TileVersion& v) { return v.tile == r.tile; });
    if (!listed) out.base_versions.push_back(r);
  }
  std::sort(out.base_versions.begin(), out.base_versions.end(),
            [](const wire::TileVersion& a, const wire::TileVersion& b) { return a.tile < b.tile; });
  return out;
}

}  // namespace loam::server
