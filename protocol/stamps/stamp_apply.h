// The CPU reference: applies a quantized stamp to a World, tile by tile.
//
// apply_stamp evaluates the kernel (stamp_kernel.h) on every sample of the stamp's rect,
// writes the samples that change through World::coarse_tile_mut / detail_tile_mut, and marks
// each tile's exact changed rect dirty; the caller then calls World::commit(seq), which
// updates mips, hashes and versions. Samples are visited in a fixed order but every result
// depends only on the sample, so tile borders and corners give exactly what one contiguous
// array would. Detail tiles are created only where a sample actually changes.
//
// apply_stamp runs the fast kernel (stamp_fast.h), which computes exactly stamp_sample's
// integers; apply_stamp_reference runs stamp_sample itself on every sample and is the
// definition the fast kernel is tested against. Both change the world, mark it dirty and
// return the changed rect identically.
#pragma once

#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/stamp_at_mip.h"
#include "protocol/stamps/stamp_fast.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/stamps/texture_registry.h"

namespace loam {

class World;

// Re-checks q (check_quantized, since it may come from the wire or the log), applies it and
// returns the bounding rect of the samples that changed, in the stamp layer's global sample
// grid (empty: nothing changed). On error the world is unchanged.
Result<RectI> apply_stamp(World& world, const QuantizedStamp& q, const TextureRegistry* textures = nullptr,
                          const StampLimits& limits = {});

// The scalar reference: stamp_sample on every sample of the rect (footprint_contact for the
// pre-pass). Same contract as apply_stamp.
Result<RectI> apply_stamp_reference(World& world, const QuantizedStamp& q,
                                    const TextureRegistry* textures = nullptr,
                                    const StampLimits& limits = {});

// The samples a stamp may change (its layer's global grid, clipped to the world), without
// applying it: the baked rect, or a shockwave's final box. Errors as check_quantized.
Result<RectI> stamp_reach(const QuantizedStamp& q, const WorldParams& world,
                          const TextureRegistry* textures = nullptr, const StampLimits& limits = {});

// The work of applying a stamp, in sample updates: the samples of its reach, times its
// (sub-)steps for a shockwave (a bound: early steps touch less). Admission budgets count it
// (a radius-1000 shockwave of 1024 steps is 4 * 10^9; a crater of radius 40 samples, 6561).
// Errors as check_quantized.
Result<uint64_t> stamp_cost(const QuantizedStamp& q, const WorldParams& world,
                            const TextureRegistry* textures = nullptr, const StampLimits& limits = {});

// apply_stamp with a footprint's contact given (a DeformEvent carries the server's) instead
// of measured on `world`, which then need not hold every sample under the foot. Other kinds
// ignore `contact`.
Result<RectI> apply_stamp_with_contact(World& world, const QuantizedStamp& q, const FootprintContact& contact,
                                       const TextureRegistry* textures = nullptr,
                                       const StampLimits& limits = {});

// apply_stamp with the fast kernel's instruction set forced (tests compare every choice).
// An `isa` this CPU lacks falls back to the portable kernel.
Result<RectI> apply_stamp_with(World& world, const QuantizedStamp& q, FastIsa isa,
                               const TextureRegistry* textures = nullptr, const StampLimits& limits = {});

}  // namespace loam
