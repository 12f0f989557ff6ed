// Where a session's initial terrain comes from, and how replay finds it again: the embedded
// default (the ETOPO5 crop at 2 m, or the same crop refined to a 131 km world), a DEM file, or
// a snapshot. The description is stored in the log's header
// (log::InitialTerrain) so `loam-server replay` can rebuild the world from the log alone.
#pragma once

#include <string>

#include "dem/dem_georef.h"
#include "dem/nodata_fill.h"
#include "dem/refined_default.h"
#include "protocol/log/log_format.h"
#include "protocol/result.h"
#include "protocol/world.h"

namespace loam::server {

// The embedded terrains `--terrain` names when no DEM is given.
inline constexpr const char* kTerrainCrop = "crop";        // the ETOPO5 crop at 2 m (2 x 1.5 km)
inline constexpr const char* kTerrainRefined = "refined";  // the crop refined 128x (131 x 98 km at 1 m)

// What a log records as the import parameters of a session on a tile pack.
inline constexpr const char* kPackImportParams = "tile pack";

// How a DEM file is read into a session: its height band (0: its only band), the local
// projection a geographic DEM is warped to, and what its NoData samples become. The log
// records them, so replay imports the DEM the same way.
struct DemChoice {
  int band = 0;
  NodataFill nodata_fill;
  LocalProjection project = LocalProjection::kNone;
};

// The import parameters a log records for a DEM read with `choice`, and back. Logs written
// before the NoData fill was a choice ("default import options[, band N]") filled NoData with
// the data minimum, and read back so.
std::string dem_import_params(const DemChoice& choice);
Result<DemChoice> parse_dem_import_params(const std::string& params);

// Loads a DEM file (a tile pack, .loampack, is opened as the world's base: nothing imported),
// or without one the embedded terrain `terrain` names, and describes it (with `dem`).
Result<World> load_initial_terrain(const std::string& dem_path, log::InitialTerrain* described,
                                   const DemChoice& dem = {}, const std::string& terrain = kTerrainCrop);

// known_base (dem/refined_default.h) rebuilds the base a snapshot names.

// Rebuilds the initial terrain a log header describes and checks it against the log: its
// parameters must equal `logged` (the header's world: a DEM whose sidecar changed since would
// import at another scale, and is refused naming the parameter) and its hash the logged one.
// Snapshot sources are looked up under <data_dir>/snapshots.
Result<World> load_described_terrain(const log::InitialTerrain& initial, const WorldParams& logged,
                                     const std::string& data_dir);

// The base a snapshot names: one this program generates (known_base), else the session's tile
// pack (the log's initial terrain names it): its copy under <data_dir>/bases/ or the path the
// log recorded, with that identity. kNotFound says where it looked.
Result<std::shared_ptr<const TileBase>> resolve_base(uint64_t identity, const log::InitialTerrain& initial,
                                                     const std::string& data_dir);
// The base of the snapshot at `snapshot_path` (<data>/snapshots/snapshot-<seq>) with this
// identity: resolve_base with the initial terrain of the log beside it.
Result<std::shared_ptr<const TileBase>> known_base_of_snapshot(const std::string& snapshot_path,
                                                               uint64_t identity);
// A fresh session on a tile pack keeps it under <data_dir>/bases/<identity>.loampack (a hard
// link where the file system allows), so the session still finds its base if the original moves.
Status keep_pack_in_session(const std::string& pack_path, const std::string& data_dir);
// "<identity, 16 hex digits>.loampack"
std::string pack_file_name(uint64_t identity);

// "" when a and b are equal, else the first parameter that differs, with both values.
std::string world_params_difference(const WorldParams& a, const WorldParams& b);

}  // namespace loam::server
