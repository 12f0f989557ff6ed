#include "server/terrain_state.h"

#include <algorithm>

#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_at_mip.h"
#include "protocol/stamps/stamp_kernel.h"

namespace loam::server {

TerrainState::TerrainState(World world, uint64_t last_seq, StampLimits limits)
    : world_(std::make_unique<World>(std::move(world))), limits_(limits), last_seq_(last_seq) {}

Status TerrainState::check(const QuantizedStamp& q) const {
  return check_quantized(q, world_->params(), limits_, textures_.get());
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
  // A footprint's contact is measured here on the mip-0 terrain, the same integers every
  // backend's pre-pass finds, and travels in the DeformEvent: clients then apply it at any
  // mip and need not hold every tile under the foot.
  if (q.kind == StampKind::kFootprint) {
    auto baked = bake_stamp(q, world_->params(), textures_.get());
    if (!baked) {
      last_seq_ = seq;
      return baked.error();
    }
    out.contact = footprint_contact_of(*baked, *world_);
  }
  auto changed = backend_ ? backend_->apply(*world_, q) : apply_stamp(*world_, q, textures_.get(), limits_);
  if (!changed && backend_) {
    // The stamp is logged already and passed check(): a backend failure (a lost GL context)
    // must not make it a no-op that recovery would then refuse. The CPU reference gives the
    // same integers; the backend's copy is brought up to date.
    backend_failures_.push_back(changed.error());
    changed = apply_stamp(*world_, q, textures_.get(), limits_);
    if (changed) backend_->world_changed(*world_, q.layer, *changed);
  }
  if (!changed) {
    // The sequence is consumed either way (it may already be in the log); replay does the
    // same, so a stamp that fails to apply is a no-op everywhere.
    last_seq_ = seq;
    return changed.error();
  }
  out.changes = world_->commit(seq);
  last_seq_ = seq;
  for (const TileChange& c : out.changes) out.base_versions.push_back({c.coord, c.base_version});
  return out;
}

}  // namespace loam::server
