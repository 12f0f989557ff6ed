// Shockwave stamps: N steps of a damped 2D wave equation, applied atomically.
//
// The state is the displacement w from the terrain at the stamp's sequence number, in Q8
// layer units (int32), starting from the stamp's Gaussian pulse at rest. Each step is the
// explicit leapfrog
//   w' = w + (w - w_prev) - round(d * (w - w_prev)) + round(nu^2 * L(w)),
// L the 5-point Laplacian, d and nu^2 in Q16, products in int64, w clamped to +-2^30. A step
// can only reach one cell further, so step n updates only the pulse's box grown by n cells,
// with w = 0 outside it and outside the world: the result equals an unbounded simulation
// clipped at the world's edge. nu^2 is capped at 0.49 (kWaveNu2CapQ16): a faster requested
// speed splits every step into k sub-steps with nu^2 / k^2 each (shockwave_substeps). After
// the last step the terrain becomes saturate(old + round(w)).
#pragma once

#include <cstdint>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"

namespace loam {

class World;

// A rectangular wave state with a one-cell border of zeros (never written).
struct WaveField {
  int64_t width = 0, height = 0;   // interior size
  std::vector<int32_t> cur, prev;  // (width + 2) * (height + 2), Q8 layer units

  WaveField(int64_t w, int64_t h);
  int32_t& at(std::vector<int32_t>& v, int64_t x, int64_t y) {
    return v[size_t((y + 1) * (width + 2) + x + 1)];
  }
  int32_t get(int64_t x, int64_t y) const { return cur[size_t((y + 1) * (width + 2) + x + 1)]; }
};

// One explicit step over the interior cells in `active` (interior coordinates).
void wave_step(WaveField& f, const RectI& active, int32_t nu2_q16, int32_t damping_q16);

struct BakedStamp;

// The cells a shockwave may change: its pulse's rect grown by one cell per (sub-)step,
// clipped to the layer (`world_rect`). `b` is the stamp's baked Gaussian pulse.
RectI shockwave_box(const BakedStamp& b, const RectI& world_rect);

// Applies a shockwave stamp (which must pass check_quantized) and returns the changed rect.
Result<RectI> apply_shockwave(World& world, const QuantizedStamp& q);

}  // namespace loam
