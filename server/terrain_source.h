// Where a session's initial terrain comes from, and how replay finds it again: the embedded
// default, a DEM file, or a snapshot. The description is stored in the log's header
// (log::InitialTerrain) so `loam-server replay` can rebuild the world from the log alone.
#pragma once

#include <string>

#include "protocol/log/log_format.h"
#include "protocol/result.h"
#include "protocol/world.h"

namespace loam::server {

// Loads the embedded default terrain (dem_path empty) or a DEM file, and describes it.
// `band` names the DEM's height band (0: its only band); the description records it.
Result<World> load_initial_terrain(const std::string& dem_path, log::InitialTerrain* described, int band = 0);

// Rebuilds the initial terrain a log header describes and checks it against the log: its
// parameters must equal `logged` (the header's world: a DEM whose sidecar changed since would
// import at another scale, and is refused naming the parameter) and its hash the logged one.
// Snapshot sources are looked up under <data_dir>/snapshots.
Result<World> load_described_terrain(const log::InitialTerrain& initial, const WorldParams& logged,
                                     const std::string& data_dir);

// "" when a and b are equal, else the first parameter that differs, with both values.
std::string world_params_difference(const WorldParams& a, const WorldParams& b);

}  // namespace loam::server
