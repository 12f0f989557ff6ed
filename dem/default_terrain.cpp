#include "dem/default_terrain.h"

#include <cstdint>
#include <span>
#include <string>

extern "C" {
extern const uint8_t loam_default_terrain_png_data[];
extern const uint64_t loam_default_terrain_png_size;
extern const uint8_t loam_default_terrain_json_data[];
extern const uint64_t loam_default_terrain_json_size;
}

namespace loam {

Result<DemRaster> read_default_terrain_raster() {
  const std::span<const uint8_t> png(loam_default_terrain_png_data, size_t(loam_default_terrain_png_size));
  const std::string json(reinterpret_cast<const char*>(loam_default_terrain_json_data),
                         size_t(loam_default_terrain_json_size));
  return read_dem_memory(png, "default_terrain.png", json);
}

Result<ImportedWorld> load_default_terrain(const ImportOptions& options) {
  auto dem = read_default_terrain_raster();
  if (!dem) return dem.error();
  return import_dem(*dem, options);
}

}  // namespace loam
