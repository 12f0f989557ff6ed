// loam: the command-line front door. For now it loads a terrain (the embedded default or a
// DEM file), prints its summary, and imports/exports DEMs; later issues grow it into the
// server, viewer and bots.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "dem/default_terrain.h"
#include "dem/dem_export.h"
#include "dem/dem_import.h"
#include "protocol/surface.h"

namespace {

// How a DEM file is read: the scale options and the import's NoData fill.
struct DemReading {
  loam::DemScaleOptions scale;
  loam::ImportOptions import;
};

loam::ImportedWorld load(const std::string& dem_path, const DemReading& reading) {
  const loam::DemScaleOptions& scale = reading.scale;
  loam::Result<loam::ImportedWorld> imported = [&]() -> loam::Result<loam::ImportedWorld> {
    if (dem_path.empty()) return loam::load_default_terrain();
    auto dem = loam::read_dem_file(dem_path, scale);
    if (!dem) return dem.error();
    return loam::import_dem(*dem, reading.import);
  }();
  if (!imported) throw std::runtime_error(imported.error().describe());
  return std::move(*imported);
}

void print_summary(const loam::ImportedWorld& w) {
  const loam::WorldParams& p = w.world.params();
  std::printf("%s", w.report.summary().c_str());
  const loam::RectI r = p.sample_rect();
  std::printf("world             %d x %d tiles, %d mips, %.1f x %.1f m, origin tile (%d, %d)\n", p.tiles_x,
              p.tiles_y, p.mip_count(), double(r.width()) * p.meters_per_sample,
              double(r.height()) * p.meters_per_sample, p.origin_tile_x, p.origin_tile_y);
  const double cx = double(r.x0 + r.width() / 2) * p.meters_per_sample;
  const double cy = double(r.y0 + r.height() / 2) * p.meters_per_sample;
  const loam::Vec3d n = loam::normal_at(w.world, cx, cy);
  std::printf("center            height %.3f m, normal (%.4f, %.4f, %.4f)\n",
              loam::height_at(w.world, cx, cy), n.x, n.y, n.z);
  std::printf("world hash        %016llx\n", (unsigned long long)w.world.world_hash());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Loam: networked deformable terrain"};
  app.require_subcommand(1);

  std::string dem_path;
  DemReading reading;
  // The options every command that reads a DEM takes alike.
  auto dem_options = [&reading](CLI::App* cmd) {
    cmd->add_option("--band", reading.scale.band,
                    "The DEM's height band, 1-based (required for multi-band images)")
        ->check(CLI::Range(1, 65535));
    cmd->add_option_function<std::string>(
           "--nodata-fill",
           [&reading](const std::string& v) {
             auto fill = loam::NodataFill::parse(v);
             if (!fill) throw CLI::ValidationError("--nodata-fill", fill.error().message);
             reading.import.nodata_fill = *fill;
           },
           "What NoData samples become: interpolate (from the data within 64 samples), min or value:H")
        ->default_str("interpolate");
    cmd->add_option_function<std::string>(
           "--project",
           [&reading](const std::string& v) {
             auto p = loam::parse_local_projection(v);
             if (!p) throw CLI::ValidationError("--project", p.error().message);
             reading.scale.project = *p;
           },
           "Warp a geographic DEM to square metres first: aeqd or utm (none: the centre's mean spacing)")
        ->default_str("none");
  };
  auto* summary =
      app.add_subcommand("summary", "Load a terrain (default: the embedded one) and print its summary");
  summary->add_option(
      "--dem", dem_path,
      "DEM file (GeoTIFF, PNG, SRTM .hgt, ESRI .asc, VRT, EXR) instead of the embedded default");
  dem_options(summary);
  summary->add_option("--meters-per-sample", reading.scale.meters_per_sample,
                      "Horizontal spacing (overrides sidecar/GeoTIFF)");
  summary->add_option("--vertical-scale", reading.scale.vertical_scale,
                      "Meters per source unit for integer DEMs");

  std::string out_path;
  auto* exp = app.add_subcommand("export", "Write a terrain as 16-bit PNG (+ sidecar) or float EXR");
  exp->add_option("--dem", dem_path, "DEM file instead of the embedded default");
  dem_options(exp);
  exp->add_option("output", out_path, "Output .png or .exr")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    const loam::ImportedWorld w = load(dem_path, reading);
    if (*summary) {
      print_summary(w);
    } else if (*exp) {
      const loam::RectI region = w.world.params().sample_rect();
      const bool exr = out_path.size() >= 4 && out_path.substr(out_path.size() - 4) == ".exr";
      const loam::Status st =
          exr ? loam::export_exr(w.world, region, out_path) : loam::export_png16(w.world, region, out_path);
      if (!st.ok()) throw std::runtime_error(st.error().describe());
      std::printf("wrote %s\n", out_path.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "loam: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
