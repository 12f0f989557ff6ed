// Events at every mip: a per-sample stamp evaluated on the samples of one mip tile.
//
// A mip-m sample *is* the mip-0 sample at 2^m spacing (samples past the world's edge repeat
// the nearest edge sample: World's decimation clamps). A per-sample stamp (every kind but the
// shockwave) changes a sample as a pure function of its position and old value, so running
// stamp_sample at the clamped mip-0 position of each mip-m sample gives exactly the
// decimation of the mip-0 result. The one input that is not per-sample, the footprint's
// contact height, is measured on the mip-0 terrain by whoever holds it (the server) and
// travels with the event; the volume-conserving crater's rim scale depends on the stamp's
// geometry alone and is baked identically everywhere. docs/stamps.md, "Every mip".
//
// Pure: no I/O. Safe on any stamp that passed check_quantized.
#pragma once

#include <cstdint>
#include <span>

#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/stamp_kernel.h"
#include "protocol/stamps/stamp_kinds.h"
#include "protocol/stamps/texture_registry.h"

namespace loam {

class World;

// True for kinds whose every sample depends only on its position and old value (all but the
// shockwave, a simulation on the grid that only mip 0 can run).
constexpr bool is_per_sample(StampKind kind) { return stamp_kind(kind).per_sample; }

// Measures a footprint's contact on `world` (the same integers as the kernel's pre-pass).
FootprintContact footprint_contact_of(const BakedStamp& b, const World& world);
// Sets a baked footprint's contact from a measured one.
void set_contact(BakedStamp& b, const FootprintContact& c);

// Applies a baked per-sample coarse stamp (contact set for a footprint) to the row-major
// kTileSamples of coarse tile `c` (any mip of the world), and returns the tile-local rect of
// the samples that changed (empty: none). Precondition: is_per_sample(b.q.kind), coarse layer.
RectI apply_to_coarse_tile(const BakedStamp& b, const WorldParams& world, const TileCoord& c,
                           std::span<uint16_t> tile);

}  // namespace loam
