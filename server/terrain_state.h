// The server's authoritative terrain: the World, registered stamp textures, stamp limits and
// the global sequence. apply() runs one accepted stamp and reports what a DeformEvent needs:
// every tile it changed (all layers and mips) with its version before, and a footprint's
// contact height (so clients apply it at every mip without the samples under the foot).
// Pure logic over protocol/: no sockets, no files.
#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "gpu/stamp_backend.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/stamps/texture_registry.h"
#include "protocol/wire/messages.h"
#include "protocol/world.h"

namespace loam::server {

struct AppliedStamp {
  uint64_t seq = 0;
  uint32_t client_id = 0;
  QuantizedStamp stamp;
  // Every changed tile (all layers and mips) with its version before the stamp, sorted.
  std::vector<wire::TileVersion> base_versions;
  FootprintContact contact;         // footprint: measured on the mip-0 terrain before the stamp
  std::vector<TileChange> changes;  // from World::commit, sorted by tile
};

class TerrainState {
 public:
  TerrainState(World world, uint64_t last_seq, StampLimits limits = {});

  // The World and the textures are heap-held so their addresses survive moving the
  // TerrainState: a backend keeps pointers to both (the GPU stamper fills its pages from the
  // World), and the server is built by moving the recovered state in after the backend.
  const World& world() const { return *world_; }
  World& mutable_world() { return *world_; }
  TextureRegistry& textures() { return *textures_; }
  const TextureRegistry& textures() const { return *textures_; }
  const StampLimits& limits() const { return limits_; }
  // Recovery and replay apply each log segment under the limits it recorded.
  void set_limits(const StampLimits& limits) { limits_ = limits; }
  uint64_t last_seq() const { return last_seq_; }

  // Checks a stamp that arrived from the wire against the world and limits.
  Status check(const QuantizedStamp& q) const;
  // Applies a checked stamp as sequence `seq` (must be last_seq() + 1).
  Result<AppliedStamp> apply(const QuantizedStamp& q, uint64_t seq, uint32_t client_id);
  // Evaluates stamps with `backend` from now on (made for this world); null: the CPU reference.
  void set_backend(std::unique_ptr<gpu::StampBackend> backend) { backend_ = std::move(backend); }
  const gpu::StampBackend* backend() const { return backend_.get(); }
  // Backend failures since the last call (each stamp was then applied by the CPU reference).
  std::vector<Error> take_backend_failures() { return std::exchange(backend_failures_, {}); }

 private:
  std::unique_ptr<World> world_;
  std::unique_ptr<TextureRegistry> textures_ = std::make_unique<TextureRegistry>();
  StampLimits limits_;
  uint64_t last_seq_ = 0;
  std::unique_ptr<gpu::StampBackend> backend_;
  std::vector<Error> backend_failures_;
};

}  // namespace loam::server
