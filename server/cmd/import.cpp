// loam-server import DEM: read a DEM and report its quantization; --png writes the imported
// world as an image, --pack as a tile pack (.loampack) read in strips, in bounded memory.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>

#include "app/cli_checks.h"
#include "dem/dem_export.h"
#include "dem/dem_import.h"
#include "dem/pack_import.h"
#include "protocol/base/tile_pack.h"
#include "protocol/hex64.h"
#include "server/cmd/command.h"

namespace loam::server::cmd {

namespace {

struct ImportOptions {
  std::string dem, png, pack;
  std::optional<int> band;
  std::optional<double> mps, vscale, voffset;
  NodataFill nodata_fill;
  LocalProjection project = LocalProjection::kNone;
};

int import_to_pack(const ImportOptions& o, const DemScaleOptions& scale) {
  if (!o.png.empty()) throw std::runtime_error("--png and --pack are separate imports: choose one");
  if (o.pack.size() < 9 || o.pack.substr(o.pack.size() - 9) != kPackExtension)
    throw std::runtime_error("--pack: the file name must end in .loampack");
  loam::ImportOptions options;
  options.nodata_fill = o.nodata_fill;
  auto r = import_dem_to_pack(o.dem, o.pack, scale, options);
  if (!r) die(r.error());
  const PackSummary& p = r->pack;
  const double mib = double(r->import.width) * double(r->import.height) * 2.0 / double(1 << 20);
  std::printf(
      "%spack              %s\n"
      "identity          %016llx\n"
      "tiles             %llu (every mip), %.1f MiB (%.2f bytes a sample at mip 0)\n"
      "time              scan %.1f s, write %.1f s (%.0f MiB/s of 16-bit samples)\n",
      r->import.summary().c_str(), p.path.c_str(), (unsigned long long)p.identity,
      (unsigned long long)p.tiles, double(p.file_bytes) / double(1 << 20),
      double(p.file_bytes) / (double(r->import.width) * double(r->import.height)), r->scan_seconds,
      r->write_seconds, mib / std::max(1e-9, r->scan_seconds + r->write_seconds));
  return 0;
}

int import(const ImportOptions& o) {
  DemScaleOptions scale;
  scale.band = o.band;
  scale.meters_per_sample = o.mps;
  scale.vertical_scale = o.vscale;
  scale.vertical_offset = o.voffset;
  scale.project = o.project;
  if (!o.pack.empty()) return import_to_pack(o, scale);
  auto dem = read_dem_file(o.dem, scale);
  if (!dem) die(dem.error());
  loam::ImportOptions options;
  options.nodata_fill = o.nodata_fill;
  auto w = import_dem(*dem, options);
  if (!w) die(w.error());
  std::printf("%sworld hash        %s\n", w->report.summary().c_str(), hex64(w->world.world_hash()).c_str());
  if (!o.png.empty()) {
    const Status st = export_png16(w->world, w->world.params().sample_rect(), o.png);
    if (!st.ok()) die(st.error());
  }
  return 0;
}

}  // namespace

Command add_import(CLI::App& app) {
  auto o = std::make_shared<ImportOptions>();
  auto* import_cmd = app.add_subcommand("import", "Import a DEM and report its quantization");
  import_cmd->add_option("dem", o->dem, "DEM file: GeoTIFF/COG, PNG, SRTM .hgt, ESRI .asc, VRT or EXR")
      ->required();
  import_cmd->add_option("--band", o->band, "The height band, 1-based (required for multi-band images)")
      ->check(cli::IntRange(1, 65535));
  import_cmd->add_option("--meters-per-sample", o->mps, "Horizontal spacing (overrides sidecar and CRS)")
      ->check(cli::FiniteRange(0, 1e7, cli::Bound::kOpen));
  import_cmd->add_option("--vertical-scale", o->vscale, "Metres per source unit")
      ->check(cli::FiniteRange(0, 1e6, cli::Bound::kOpen));
  import_cmd->add_option("--vertical-offset", o->voffset, "Metres at source value 0")
      ->check(cli::FiniteRange(-1e7, 1e7));
  import_cmd
      ->add_option_function<std::string>(
          "--nodata-fill",
          [o](const std::string& v) {
            auto fill = NodataFill::parse(v);
            if (!fill) throw CLI::ValidationError("--nodata-fill", fill.error().message);
            o->nodata_fill = *fill;
          },
          "What NoData samples become: interpolate (from the data within 64 samples), min (the data "
          "minimum) or value:H (H metres)")
      ->default_str("interpolate");
  import_cmd
      ->add_option_function<std::string>(
          "--project",
          [o](const std::string& v) {
            auto p = parse_local_projection(v);
            if (!p) throw CLI::ValidationError("--project", p.error().message);
            o->project = *p;
          },
          "Warp a geographic DEM (degrees) to square metres first: aeqd (azimuthal equidistant at its "
          "centre) or utm (its centre's zone); none takes the centre's mean spacing")
      ->default_str("none");
  import_cmd->add_option("--png", o->png, "Also write the imported world as PNG + sidecar");
  import_cmd->add_option("--pack", o->pack,
                         "Write the world as a tile pack (.loampack) for serve --dem, reading the DEM in "
                         "strips: any size up to 2^17 samples a side, in bounded memory");
  return {import_cmd, [o] { return import(*o); }};
}

}  // namespace loam::server::cmd
