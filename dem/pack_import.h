// Importing a DEM of any size into a tile pack (protocol/base/tile_pack.h) in bounded memory:
// the raster is read twice in strips of rows, never whole. The first pass gathers what the
// quantization needs (range, NoData, the border's mean: dem_import.h); the second quantizes
// each row and feeds a TileRowPyramid, whose tiles of every mip go to the pack as they are
// complete. Peak memory is about 2 x 256 world rows plus one strip of source rows (8 MiB of
// doubles) and GDAL's block cache, whatever the raster's height; a raster with NoData to
// interpolate adds the fill's 96 rows in flight (24 bytes a sample: dem/nodata_fill.h).
//
// The pack's samples equal import_dem()'s world for the same raster and options, tile for
// tile at every mip (the tests pin it), so a session on the pack plays exactly as one on
// the DEM; only the world hash differs, since it names the pack as its base.
#pragma once

#include <cstdint>
#include <string>

#include "dem/dem_import.h"
#include "dem/dem_raster.h"
#include "protocol/base/tile_pack.h"

namespace loam {

struct PackImportReport {
  ImportReport import;
  PackSummary pack;
  double scan_seconds = 0;   // the first pass
  double write_seconds = 0;  // the second pass: quantize, build mips, encode, write
  size_t pyramid_bytes = 0;  // rows held for tile rows in progress
};

// Imports `dem_path` into a new pack at `pack_path` (replacing nothing: an existing file is an
// error). The scale options and import options are those of import_dem.
Result<PackImportReport> import_dem_to_pack(const std::string& dem_path, const std::string& pack_path,
                                            const DemScaleOptions& scale = {},
                                            const ImportOptions& options = {},
                                            RegionEncoding encoding = RegionEncoding::kFast);

}  // namespace loam
