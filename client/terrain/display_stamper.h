// The GPU half a display terrain may have (client/terrain/display_terrain.h): a tile cache the
// shared stamp shaders run on. Nothing comes back from it: the display keeps its CPU copy by
// copying the confirmed store, and stamps the same stamps on the GPU copy, which the renderer
// reads its levels from. An interface, so the display itself needs no GL: the viewer gives it
// the GPU tile cache (display_gpu_stamper.h); the game library's display has none.
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

namespace loam::gpu {
class GpuStamper;
}

namespace loam::terrain {

class DisplayStamper {
 public:
  virtual ~DisplayStamper() = default;
  // Stamps the GPU copy (errors: kBusy while every page is held by this batch, kOversize). The
  // pages it stamped stay until end_batch(): the caller brings the mirror up to them first.
  virtual Status submit(const QuantizedStamp& q) = 0;
  // The mirror holds every stamp submitted since the last end_batch().
  virtual void end_batch() = 0;
  // The mirror's samples of `rect` changed on the CPU: the cache takes them (resident tiles).
  virtual void upload(World& world, Layer layer, const RectI& rect) = 0;
  // The tile left the display: its page is free.
  virtual void forget(World& world, Layer layer, int32_t tx, int32_t ty) = 0;
  // Whether the tile has a page now.
  virtual bool resident(Layer layer, int32_t tx, int32_t ty) const = 0;
  // The GPU copy of a rect (a synchronous readback: audits and tests only).
  virtual std::vector<int32_t> read(Layer layer, const RectI& rect) = 0;
  virtual gpu::GpuStamperMemory memory() const = 0;
  virtual gpu::GpuStamperTraffic traffic() const = 0;
  // The cache itself, for a renderer that fills its levels from the pages.
  virtual const gpu::GpuStamper& cache() const = 0;
};

// Makes the stamper for a display's mirror (which outlives it) and its stamp images.
using DisplayStamperFactory = std::function<Result<std::unique_ptr<DisplayStamper>>(
    const World& mirror, const TextureRegistry* textures)>;

}  // namespace loam::terrain
