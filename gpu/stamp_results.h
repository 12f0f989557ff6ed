// What a GPU stamper reports, without GL: its completed readbacks, the memory it holds and
// the bytes it moved.
// Separate from gpu_stamper.h so code that only consumes them (a display that may or may not
// stamp on a GPU) needs no GL headers.
#pragma once

#include <cstddef>
#include <cstdint>

#include "protocol/geometry.h"
#include "protocol/layer.h"

namespace loam::gpu {

// One completed readback: the samples of `layer` that changed (global layer sample rect).
struct StampReadback {
  uint64_t ticket = 0;
  Layer layer = Layer::kCoarse;
  RectI changed;
};

// What the stamper holds on the GPU.
struct GpuStamperMemory {
  size_t page_bytes = 0;               // both layers' page arrays
  size_t scratch_bytes = 0;            // wave fields, vertex-pass copies, readback buffers
  PerLayer<int32_t> resident_pages{};  // resident tiles of each layer
  uint64_t evictions = 0;
  size_t total() const { return page_bytes + scratch_bytes; }
};

// What crossed the bus, cumulative: bytes uploaded (pages filled from the mirror, rects
// uploaded, each stamp's constants) and bytes read back (readbacks and synchronous reads).
struct GpuStamperTraffic {
  uint64_t bytes_uploaded = 0;
  uint64_t bytes_read_back = 0;
  uint64_t page_fills = 0;
};

}  // namespace loam::gpu
