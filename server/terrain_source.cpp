#include "server/terrain_source.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string_view>

#include "dem/default_terrain.h"
#include "dem/dem_import.h"
#include "dem/refined_default.h"
#include "protocol/base/tile_pack.h"
#include "protocol/snapshot/snapshot.h"

namespace loam::server {

namespace {
constexpr const char* kDefaultParams = "embedded default terrain";
constexpr const char* kRefinedParams = "embedded default terrain refined";
constexpr const char* kLegacyDemParams = "default import options";
constexpr const char* kLegacyBandPrefix = "default import options, band ";
constexpr const char* kDemPrefix = "dem import: ";
constexpr const char* kPackParams = kPackImportParams;

bool is_pack_path(const std::string& path) {
  const std::string ext = kPackExtension;
  return path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0;
}

Result<World> load_pack_world(const std::string& path) {
  auto pack = open_tile_pack(path);
  if (!pack) return pack.error();
  return World((*pack)->params(), *pack);
}

// A band number of 1 to 5 digits.
std::optional<int> parse_band(std::string_view digits) {
  if (digits.empty() || digits.size() > 5) return std::nullopt;
  int band = 0;
  for (const char c : digits) {
    if (c < '0' || c > '9') return std::nullopt;
    band = band * 10 + (c - '0');
  }
  if (band < 1 || band > 65535) return std::nullopt;
  return band;
}
Result<World> load_refined_world() {
  auto base = refined_default_base();
  if (!base) return base.error();
  return World(refined_default_params(), *base);
}
}  // namespace

std::string dem_import_params(const DemChoice& choice) {
  std::string s = kDemPrefix;
  if (choice.band > 0) s += "band " + std::to_string(choice.band) + ", ";
  if (choice.project != LocalProjection::kNone)
    s += std::string("project ") + to_string(choice.project) + ", ";
  return s + "nodata " + choice.nodata_fill.to_string();
}

Result<DemChoice> parse_dem_import_params(const std::string& params) {
  auto unknown = [&] {
    return make_error(ErrorCode::kUnsupported, "log.initial",
                      "unknown DEM import parameters '" + params + "'");
  };
  const NodataFill legacy_fill{NodataFill::Mode::kMin, 0};
  if (params == kLegacyDemParams) return DemChoice{0, legacy_fill};
  std::string_view s = params;
  if (const std::string_view prefix = kLegacyBandPrefix; s.substr(0, prefix.size()) == prefix) {
    const auto band = parse_band(s.substr(prefix.size()));
    if (!band) return unknown();
    return DemChoice{*band, legacy_fill};
  }
  if (const std::string_view prefix = kDemPrefix; s.substr(0, prefix.size()) != prefix) return unknown();
  s.remove_prefix(std::string_view(kDemPrefix).size());
  DemChoice c;
  if (constexpr std::string_view band = "band "; s.substr(0, band.size()) == band) {
    const size_t comma = s.find(", ");
    if (comma == std::string_view::npos) return unknown();
    const auto b = parse_band(s.substr(band.size(), comma - band.size()));
    if (!b) return unknown();
    c.band = *b;
    s.remove_prefix(comma + 2);
  }
  if (constexpr std::string_view project = "project "; s.substr(0, project.size()) == project) {
    const size_t comma = s.find(", ");
    if (comma == std::string_view::npos) return unknown();
    const auto p = parse_local_projection(s.substr(project.size(), comma - project.size()));
    if (!p || *p == LocalProjection::kNone) return unknown();
    c.project = *p;
    s.remove_prefix(comma + 2);
  }
  if (constexpr std::string_view nodata = "nodata "; s.substr(0, nodata.size()) != nodata) return unknown();
  auto fill = NodataFill::parse(s.substr(std::string_view("nodata ").size()));
  if (!fill) return unknown();
  c.nodata_fill = *fill;
  return c;
}

Result<World> load_initial_terrain(const std::string& dem_path, log::InitialTerrain* described,
                                   const DemChoice& dem_choice, const std::string& terrain) {
  if (dem_path.empty() && terrain == kTerrainRefined) {
    auto world = load_refined_world();
    if (!world) return world.error();
    if (described) {
      *described = {};
      described->world_hash = world->world_hash();
      described->source = log::InitialSource::kGenerated;
      described->import_params = kRefinedParams;
    }
    return world;
  }
  if (is_pack_path(dem_path)) {
    // A pack is already a world's tiles: nothing is imported, and memory follows the tiles read.
    auto world = load_pack_world(dem_path);
    if (!world) return world.error();
    world->set_initial_is_base(true);
    if (described) {
      *described = {};
      described->world_hash = world->world_hash();
      described->source = log::InitialSource::kDem;
      std::error_code ec;
      const auto abs = std::filesystem::absolute(dem_path, ec);
      described->dem_path = ec ? dem_path : abs.string();
      described->import_params = kPackParams;
    }
    return world;
  }
  if (dem_path.empty() && terrain != kTerrainCrop)
    return make_error(ErrorCode::kInvalidArgument, "terrain",
                      "unknown embedded terrain '" + terrain + "' (crop or refined)");
  Result<ImportedWorld> imported = [&]() -> Result<ImportedWorld> {
    if (dem_path.empty()) return load_default_terrain();
    DemScaleOptions options;
    if (dem_choice.band > 0) options.band = dem_choice.band;
    options.project = dem_choice.project;
    auto dem = read_dem_file(dem_path, options);
    if (!dem) return dem.error();
    ImportOptions import;
    import.nodata_fill = dem_choice.nodata_fill;
    return import_dem(*dem, import);
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
      described->import_params = dem_import_params(dem_choice);
    }
  }
  return std::move(imported->world);
}

std::string pack_file_name(uint64_t identity) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%016llx%s", (unsigned long long)identity, kPackExtension);
  return buf;
}

Result<std::shared_ptr<const TilePackBase>> find_session_pack(
    const log::InitialTerrain& initial, const std::string& data_dir,
    const std::function<bool(const std::shared_ptr<const TilePackBase>&)>& is_it) {
  if (initial.source != log::InitialSource::kDem || initial.import_params != kPackParams)
    return make_error(ErrorCode::kNotFound, "log.initial", "the session's base is not a tile pack");
  // The path the log recorded, then the session's copies under <data>/bases/.
  std::vector<std::string> candidates{initial.dem_path};
  std::error_code ec;
  if (!data_dir.empty()) {
    for (const auto& e : std::filesystem::directory_iterator(std::filesystem::path(data_dir) / "bases", ec)) {
      if (e.path().extension() == kPackExtension) candidates.push_back(e.path().string());
    }
  }
  std::string tried;
  for (const std::string& path : candidates) {
    tried += (tried.empty() ? "" : ", ") + path;
    auto pack = open_tile_pack(path);
    if (!pack) {
      if (pack.error().code == ErrorCode::kNotFound) continue;
      return pack.error();
    }
    if (is_it(*pack)) return *pack;
  }
  return make_error(
      ErrorCode::kNotFound, "base",
      "the session's tile pack is missing (looked in " + tried +
          "): restore it, or import the DEM again into a pack (the same samples give the same pack)");
}

Result<std::shared_ptr<const TileBase>> resolve_base(uint64_t identity, const log::InitialTerrain& initial,
                                                     const std::string& data_dir) {
  if (auto known = known_base(identity)) return known;
  if (initial.source != log::InitialSource::kDem || initial.import_params != kPackParams)
    return known_base(identity);
  auto pack = find_session_pack(initial, data_dir, [&](const std::shared_ptr<const TilePackBase>& p) {
    return p->identity() == identity;
  });
  if (!pack) return pack.error();
  return std::shared_ptr<const TileBase>(*pack);
}

Result<std::shared_ptr<const TileBase>> known_base_of_snapshot(const std::string& snapshot_path,
                                                               uint64_t identity) {
  if (auto known = known_base(identity)) return known;
  namespace fs = std::filesystem;
  const fs::path data_dir = fs::path(snapshot_path).lexically_normal().parent_path().parent_path();
  std::vector<fs::path> segments;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(data_dir / "log", ec))
    if (e.path().extension() == ".loamlog") segments.push_back(e.path());
  std::sort(segments.begin(), segments.end());
  if (segments.empty()) return known_base(identity);
  std::ifstream in(segments.back(), std::ios::binary);
  std::vector<uint8_t> bytes(12 + log::kMaxHeaderBodyBytes + 8);
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  bytes.resize(size_t(in.gcount()));
  auto h = log::decode_segment_header(bytes);
  if (!h) return h.error();
  return resolve_base(identity, h->header.initial, data_dir.string());
}

Status keep_pack_in_session(const std::string& pack_path, const std::string& data_dir) {
  auto pack = open_tile_pack(pack_path);
  if (!pack) return pack.error();
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path dir = fs::path(data_dir) / "bases";
  fs::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIo, dir.string(), "cannot create: " + ec.message());
  const fs::path link = dir / pack_file_name((*pack)->identity());
  if (fs::exists(link, ec)) return {};
  // A hard link costs nothing and survives the original's removal; across file systems the
  // session goes on referring to the pack by its path.
  fs::create_hard_link(pack_path, link, ec);
  return {};
}

std::string world_params_difference(const WorldParams& a, const WorldParams& b) {
  auto num = [](double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return std::string(buf);
  };
  struct ParamField {
    const char* name;
    double a, b;
  };
  const ParamField fields[] = {{"meters_per_sample", a.meters_per_sample, b.meters_per_sample},
                               {"height_offset", a.height_offset, b.height_offset},
                               {"meters_per_unit", a.meters_per_unit, b.meters_per_unit},
                               {"detail_factor", double(a.detail_factor), double(b.detail_factor)},
                               {"detail_meters_per_unit", a.detail_meters_per_unit, b.detail_meters_per_unit},
                               {"origin_tile_x", double(a.origin_tile_x), double(b.origin_tile_x)},
                               {"origin_tile_y", double(a.origin_tile_y), double(b.origin_tile_y)},
                               {"tiles_x", double(a.tiles_x), double(b.tiles_x)},
                               {"tiles_y", double(a.tiles_y), double(b.tiles_y)}};
  for (const ParamField& f : fields) {
    if (!(f.a == f.b)) return std::string(f.name) + " " + num(f.a) + " against " + num(f.b);
  }
  return "";
}

Result<World> load_described_terrain(const log::InitialTerrain& initial, const WorldParams& logged,
                                     const std::string& data_dir) {
  Result<World> world = [&]() -> Result<World> {
    switch (initial.source) {
      case log::InitialSource::kGenerated:
        if (initial.import_params == kRefinedParams) return load_refined_world();
        if (initial.import_params != kDefaultParams) {
          return make_error(ErrorCode::kUnsupported, "log.initial",
                            "unknown generated terrain '" + initial.import_params + "'");
        }
        return load_initial_terrain("", nullptr);
      case log::InitialSource::kDem: {
        if (initial.import_params == kPackParams) {
          auto pack = find_session_pack(initial, data_dir, [&](const std::shared_ptr<const TilePackBase>& p) {
            return World(p->params(), p).matches_recorded_hash(initial.world_hash);
          });
          if (!pack) return pack.error();
          World w((*pack)->params(), *pack);
          w.set_initial_is_base(true);
          return w;
        }
        auto choice = parse_dem_import_params(initial.import_params);
        if (!choice) return choice.error();
        return load_initial_terrain(initial.dem_path, nullptr, *choice);
      }
      case log::InitialSource::kSnapshot: {
        const auto path =
            std::filesystem::path(data_dir) / "snapshots" / snapshot_dir_name(initial.snapshot_id);
        auto manifest = read_snapshot_manifest(path.string());
        if (!manifest) return manifest.error();
        auto base = resolve_base(manifest->base_identity, initial, data_dir);
        if (!base) return base.error();
        auto snap = read_snapshot(path.string(), *base);
        if (!snap) return snap.error();
        return std::move(snap->world);
      }
    }
    return make_error(ErrorCode::kBadEnum, "log.initial.source", "unknown source");
  }();
  if (!world) return world.error();
  if (const std::string diff = world_params_difference(world->params(), logged); !diff.empty()) {
    return make_error(
        ErrorCode::kCorrupt, "log.world",
        "the initial terrain now loads with other parameters than the log recorded (" + diff +
            "): was the DEM or its sidecar changed? Replay needs the terrain the session began on");
  }
  // Version 1 logs recorded the content hash, and logs before tiled bases the legacy hash;
  // with the parameters equal, any of them identifies the terrain.
  if (!world->matches_recorded_hash(initial.world_hash)) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "initial terrain hash %016llx differs from the log's %016llx",
                  (unsigned long long)world->world_hash(), (unsigned long long)initial.world_hash);
    return make_error(ErrorCode::kCorrupt, "log.initial", buf);
  }
  return world;
}

}  // namespace loam::server
