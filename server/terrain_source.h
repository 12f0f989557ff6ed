// Where a session's initial terrain comes from, and how replay finds it again: the embedded
// default (the ETOPO5 crop at 2 m, or the same crop refined to a 131 km world), a DEM file, or
// a snapshot. The description is stored in the log's header
// (log::InitialTerrain) so `loam-server replay` can rebuild the world from the log alone.
#pragma once

#include <string>

#include "dem/refined_default.h"
#include "protocol/log/log_format.h"
#include "protocol/result.h"
#include "protocol/world.h"

namespace loam::server {

// The embedded terrains `--terrain` names when no DEM is given.
inline constexpr const char* kTerrainCrop = "crop";        // the ETOPO5 crop at 2 m (2 x 1.5 km)
inline constexpr const char* kTerrainRefined = "refined";  // the crop refined 128x (131 x 98 km at 1 m)

// Loads a DEM file, or without one the embedded terrain `terrain` names, and describes it.
// `band` names the DEM's height band (0: its only band); the description records it.
Result<World> load_initial_terrain(const std::string& dem_path, log::InitialTerrain* described, int band = 0,
                                   const std::string& terrain = kTerrainCrop);

// known_base (dem/refined_default.h) rebuilds the base a snapshot names.

// Rebuilds the initial terrain a log header describes and checks it against the log: its
// parameters must equal `logged` (the header's world: a DEM whose sidecar changed since would
// import at another scale, and is refused naming the parameter) and its hash the logged one.
// Snapshot sources are looked up under <data_dir>/snapshots.
Result<World> load_described_terrain(const log::InitialTerrain& initial, const WorldParams& logged,
                                     const std::string& data_dir);

// "" when a and b are equal, else the first parameter that differs, with both values.
std::string world_params_difference(const WorldParams& a, const WorldParams& b);

}  // namespace loam::server
