// The refined default world: the embedded ETOPO5 crop (data/default_terrain.png) refined
// 128 times per axis into a 131072 x 98304 sample world at 1 m (512 x 384 tiles), with the
// parameters chosen in docs/world.md ("Refined worlds"). Server and clients both build it
// from the embedded crop, so untouched tiles are computed, never stored or sent.
#pragma once

#include <memory>
#include <string>

#include "protocol/base/refinement.h"
#include "protocol/base/tile_base.h"
#include "protocol/geometry.h"

namespace loam {

struct RefinedWorld {
  WorldParams params;  // 1 m spacing, 1/32 m per height unit, the whole refined extent
  RefinedBase base;
  std::string description;
};

// The refinement parameters of the default world (seed, per-level amplitudes, roughness).
RefinementParams default_refinement_params();

// Builds the refined default world from the embedded crop.
Result<RefinedWorld> load_refined_default();

// The refined default as a world's base (built once per process, then shared).
Result<std::shared_ptr<const RefinedTileBase>> refined_default_base();
const WorldParams& refined_default_params();

// The bases this program can generate from nothing but itself: a fill of 0 and the refined
// default. kNotFound for any other identity (a snapshot or server naming a base from another
// version or an imported pack).
Result<std::shared_ptr<const TileBase>> known_base(uint64_t identity);
// known_base as a client::BaseProvider-shaped function: null where the base is unknown.
std::shared_ptr<const TileBase> generate_known_base(uint64_t identity);

}  // namespace loam
