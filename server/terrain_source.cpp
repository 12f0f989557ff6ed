#include "server/terrain_source.h"

#include <cstdio>
#include <filesystem>

#include "dem/default_terrain.h"
#include "dem/dem_import.h"
#include "protocol/snapshot/snapshot.h"

namespace loam::server {

namespace {
constexpr const char* kDefaultParams = "embedded default terrain";
}

Result<World> load_initial_terrain(const std::string& dem_path, log::InitialTerrain* described) {
  Result<ImportedWorld> imported = [&]() -> Result<ImportedWorld> {
    if (dem_path.empty()) return load_default_terrain();
    auto dem = read_dem_file(dem_path);
    if (!dem) return dem.error();
    return import_dem(*dem);
  }();
  if (!imported) return imported.error();
  if (described) {
    *described = {};
    described->world_hash = imported->world.world_hash();
    if (dem_path.empty()) {
      described->source = log::InitialSource::kGenerated;
      described->import_params = kDefaultParams;
    } else {
      described->source = log::InitialSource::kDem;
      std::error_code ec;
      const auto abs = std::filesystem::absolute(dem_path, ec);
      described->dem_path = ec ? dem_path : abs.string();
      described->import_params = "default import options";
    }
  }
  return std::move(imported->world);
}

Result<World> load_described_terrain(const log::InitialTerrain& initial, const std::string& data_dir) {
  Result<World> world = [&]() -> Result<World> {
    switch (initial.source) {
      case log::InitialSource::kGenerated:
        if (initial.import_params != kDefaultParams) {
          return make_error(ErrorCode::kUnsupported, "log.initial",
                            "unknown generated terrain '" + initial.import_params + "'");
        }
        return load_initial_terrain("", nullptr);
      case log::InitialSource::kDem: return load_initial_terrain(initial.dem_path, nullptr);
      case log::InitialSource::kSnapshot: {
        const auto path =
            std::filesystem::path(data_dir) / "snapshots" / snapshot_dir_name(initial.snapshot_id);
        auto snap = read_snapshot(path.string());
        if (!snap) return snap.error();
        return std::move(snap->world);
      }
    }
    return make_error(ErrorCode::kBadEnum, "log.initial.source", "unknown source");
  }();
  if (!world) return world.error();
  if (world->world_hash() != initial.world_hash) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "initial terrain hash %016llx differs from the log's %016llx",
                  (unsigned long long)world->world_hash(), (unsigned long long)initial.world_hash);
    return make_error(ErrorCode::kCorrupt, "log.initial", buf);
  }
  return world;
}

}  // namespace loam::server
