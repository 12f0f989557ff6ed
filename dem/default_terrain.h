// The embedded default terrain (data/default_terrain.png + .json, compiled into the binary
// so no runtime path lookup is needed). See data/README.md for its provenance and scale.
#pragma once

#include "dem/dem_import.h"

namespace loam {

// Loads and imports the embedded default terrain.
Result<ImportedWorld> load_default_terrain(const ImportOptions& options = {});

// Reads the embedded crop as a raster (metres at the sidecar's game scale), unimported.
Result<DemRaster> read_default_terrain_raster();

}  // namespace loam
