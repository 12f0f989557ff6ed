// The GPU half a display terrain may have (client/terrain/display_terrain.h): a tile cache the
// shared stamp shaders run on, whose changed samples come back into the display's CPU mirror.
// An interface, so the display itself needs no GL: the viewer gives it the GPU tile cache
// (display_gpu_stamper.h); the game library's display stamps on the CPU alone.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "gpu/stamp_results.h"
#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/texture_registry.h"
#include "protocol/world.h"

namespace loam::terrain {

class DisplayStamper {
 public:
  virtual ~DisplayStamper() = default;
  // Queues a stamp (errors: kBusy while every page awaits a readback, kOversize).
  virtual Result<uint64_t> submit(const QuantizedStamp& q) = 0;
  // Completed stamps, their samples written into `world` (the display's mirror).
  virtual std::vector<gpu::StampReadback> collect(World& world) = 0;
  // The mirror's samples of `rect` changed on the CPU: the cache takes them.
  virtual void upload(World& world, Layer layer, const RectI& rect) = 0;
  // The tile left the display: its page is free.
  virtual void forget(World& world, Layer layer, int32_t tx, int32_t ty) = 0;
  virtual gpu::GpuStamperMemory memory() const = 0;
};

// Makes the stamper for a display's mirror (which outlives it) and its stamp images.
using DisplayStamperFactory = std::function<Result<std::unique_ptr<DisplayStamper>>(
    const World& mirror, const TextureRegistry* textures)>;

}  // namespace loam::terrain
