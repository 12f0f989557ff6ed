#include "dem/dem_raster.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>

#include "dem/ascii_grid_check.h"
#include "dem/dem_georef.h"
#include "dem/dem_sidecar.h"
#include "dem/exr_source.h"
#include "dem/gdal_source.h"
#include "dem/raster_source.h"

namespace loam {
namespace {

// Samples per read: 1 Mi doubles (8 MiB) per strip, whatever the raster claims.
constexpr int64_t kStripSamples = int64_t(1) << 20;
// Sidecars are small; a bigger one is not a sidecar.
constexpr std::uintmax_t kMaxSidecarBytes = 1 << 20;

Error fail(ErrorCode code, const std::string& name, const std::string& why) {
  return make_error(code, name, why);
}

Status check_extension(const std::string& ext, const std::string& name) {
  if (ext.empty()) return fail(ErrorCode::kUnsupported, name, "no file extension to tell the format");
  if (ext != "exr" && !gdal_driver_for_extension(ext)) {
    return fail(ErrorCode::kUnsupported, name,
                "unsupported format '" + ext +
                    "' (use GeoTIFF .tif, PNG, SRTM .hgt, ESRI ASCII grid .asc, "
                    "VRT or OpenEXR)");
  }
  return {};
}

std::string sidecar_path(const std::string& path) {
  const std::filesystem::path p(path);
  return (p.parent_path() / (p.stem().string() + ".json")).string();
}

// Metres per unit of a band's unit type (GDAL's names), 1 for metres or none.
double band_unit_meters(const std::string& unit) {
  std::string u;
  for (char c : unit) u.push_back(char(std::tolower(static_cast<unsigned char>(c))));
  if (u == "ft" || u == "foot" || u == "feet" || u == "international foot") return 0.3048;
  if (u == "us-ft" || u == "us survey foot" || u == "ftus") return 1200.0 / 3937.0;
  if (u == "cm" || u == "centimetre" || u == "centimeter") return 0.01;
  return 1.0;
}

// Which band holds the heights: the named one, or the only one when it is not a colour.
Result<int> choose_band(const RasterSource& src, std::optional<int> named, const std::string& name) {
  const int count = src.band_count();
  if (count < 1) return fail(ErrorCode::kCorrupt, name, "the raster has no bands");
  if (named) {
    if (*named < 1 || *named > count) {
      return fail(ErrorCode::kInvalidArgument, name,
                  "--band " + std::to_string(*named) + " but the raster has " + std::to_string(count) +
                      (count == 1 ? " band" : " bands"));
    }
    return *named;
  }
  std::string colors;
  bool alpha = false;
  for (int i = 1; i <= count; ++i) {
    const std::string c = src.band(i).color;
    alpha = alpha || c == "Alpha";
    colors += (i > 1 ? ", " : "") + c;
  }
  if (count == 1) {
    if (src.band(1).color == "Palette") {
      return fail(ErrorCode::kInvalidArgument, name,
                  "a palette (indexed colour) image is not a DEM; name the band with --band 1 to read its "
                  "indices as heights");
    }
    return 1;
  }
  std::string kind = std::to_string(count) + "-band";
  if (count == 2 && alpha) kind = "gray+alpha";
  if (count == 3 && colors == "Red, Green, Blue") kind = "RGB";
  if (count == 4 && colors == "Red, Green, Blue, Alpha") kind = "RGBA";
  const std::string article = kind[0] == 'R' ? "an " : "a ";
  return fail(ErrorCode::kInvalidArgument, name,
              article + kind + " image (bands: " + colors +
                  ") is not a DEM; name the height band with --band N (1.." + std::to_string(count) + ")");
}

// Rows per read: whole storage blocks when they fit the strip budget.
int64_t strip_rows(const RasterSource& src) {
  const int64_t w = std::max<int64_t>(1, src.width());
  const int64_t budget = std::max<int64_t>(1, kStripSamples / w);
  const int64_t block = std::max<int64_t>(1, src.block_rows());
  if (block <= budget) return budget / block * block;
  return src.format() == "OpenEXR" ? block : budget;  // OpenEXR tiles are read whole
}

}  // namespace

struct DemStripsOpener {
  // Row 0 north, column 0 west: flips for a south-up or east-left geotransform; refuses a
  // rotated or sheared one (resampling it is gdalwarp's job, and the message says how).
  static Status orient(const Georef& g, int64_t w, int64_t h, const std::string& name, DemStrips& out) {
    if (!g.has_transform) return {};
    const double* t = g.transform;
    for (int i = 0; i < 6; ++i) {
      if (!std::isfinite(t[i])) return fail(ErrorCode::kCorrupt, name, "geotransform is not finite");
    }
    // Rotation terms that move the raster's far edge by under a hundredth of a sample are
    // rounding in the file, not a rotation.
    const bool rotated = std::fabs(t[2]) * double(h) > 0.01 * std::fabs(t[1]) ||
                         std::fabs(t[4]) * double(w) > 0.01 * std::fabs(t[5]);
    if (rotated) {
      char steps[160];
      std::snprintf(steps, sizeof steps, "column step %.6g, %.6g; row step %.6g, %.6g", t[1], t[4], t[2],
                    t[5]);
      return fail(ErrorCode::kUnsupported, name,
                  std::string("the geotransform is rotated or sheared (") + steps +
                      "): Loam reads north-up rasters; make it north-up first, e.g. gdalwarp " + name +
                      " north_up.tif");
    }
    out.flip_rows_ = t[5] > 0;
    out.flip_columns_ = t[1] < 0;
    DemInfo& dem = out.info_;
    if (out.flip_rows_ && out.flip_columns_) {
      dem.orientation = "south-up and east-left (rows and columns flipped)";
    } else if (out.flip_rows_) {
      dem.orientation = "south-up (rows flipped)";
    } else if (out.flip_columns_) {
      dem.orientation = "east-left (columns flipped)";
    }
    return {};
  }

  // Checks the header, picks the band and resolves the scale. `whole`: the raster is to be
  // read whole (read_dem_*), so the whole-raster cap applies; else the streamed side cap.
  static Result<DemStrips> open(std::unique_ptr<RasterSource> owned, const std::string& name,
                                const std::string& sidecar_json, const DemScaleOptions& options, bool whole) {
    // A geographic DEM warped to square metres first: everything below sees the warped raster.
    std::string distortion;
    if (options.project != LocalProjection::kNone) {
      if (options.meters_per_sample || !sidecar_json.empty()) {
        return fail(ErrorCode::kInvalidArgument, name,
                    std::string("--project warps by the DEM's georeferencing, but ") +
                        (options.meters_per_sample ? "--meters-per-sample" : "its sidecar") +
                        " states the spacing: use one or the other");
      }
      const Georef g = owned->georef();
      const int64_t w0 = owned->width(), h0 = owned->height();
      auto projected = project_gdal_source(std::move(owned), options.project, name);
      if (!projected) return projected.error();
      owned = std::move(*projected);
      distortion = geographic_distortion(g, w0, h0, options.project);
    }
    RasterSource& src = *owned;
    const int64_t w = src.width(), h = src.height();
    if (w <= 0 || h <= 0) return fail(ErrorCode::kCorrupt, name, "image has no samples");
    if (w < 2 || h < 2) {
      return fail(
          ErrorCode::kInvalidArgument, name,
          "image is " + std::to_string(w) + "x" + std::to_string(h) + "; a DEM needs at least 2x2 samples");
    }
    if (whole && (w > kMaxDemSide || h > kMaxDemSide || w * h > kMaxDemSamples)) {
      return fail(ErrorCode::kOversize, name,
                  "image claims " + std::to_string(w) + "x" + std::to_string(h) +
                      " samples; a whole-raster import is capped at 2^28 samples and 2^20 a side "
                      "(import it into a tile pack: loam-server import --pack)");
    }
    if (!whole && (w > kMaxStreamedDemSide || h > kMaxStreamedDemSide)) {
      return fail(
          ErrorCode::kOversize, name,
          "image claims " + std::to_string(w) + "x" + std::to_string(h) +
              " samples; a tile pack import is capped at 2^17 samples a side (crop or tile it first)");
    }
    auto band_index = choose_band(src, options.band, name);
    if (!band_index) return band_index.error();
    const RasterBandInfo band = src.band(*band_index);
    if (!band.supported) {
      return fail(ErrorCode::kUnsupported, name,
                  "unsupported sample type " + band.sample_type + " (use 8/16/32-bit integers or floats)");
    }

    DemStrips out;
    LOAM_TRY(orient(src.georef(), w, h, name, out));
    DemInfo& dem = out.info_;
    dem.name = name;
    dem.width = w;
    dem.height = h;
    dem.integer_source = band.integer;
    dem.format = src.format();
    dem.sample_type = band.sample_type;
    dem.band = *band_index;

    // Scale: explicit > sidecar > georeferencing > defaults.
    Sidecar side;
    if (!sidecar_json.empty()) {
      auto parsed = parse_sidecar(sidecar_json, name + " sidecar");
      if (!parsed) return parsed.error();
      side = *parsed;
      LOAM_TRY(check_sidecar_matches(side, w, h, band.sample_type, name + " sidecar"));
    }
    dem.scale_source = "default";
    if (options.meters_per_sample) {
      dem.meters_per_sample = *options.meters_per_sample;
      dem.scale_source = "explicit";
    } else if (side.meters_per_sample) {
      dem.meters_per_sample = *side.meters_per_sample;
      dem.anisotropy = side.anisotropy;
      dem.scale_source = "sidecar";
    } else {
      auto geo = spacing_from_georef(src.georef(), w, h, name);
      if (!geo) return geo.error();
      if (*geo) {
        dem.meters_per_sample = std::sqrt((*geo)->x_m * (*geo)->y_m);
        dem.anisotropy = (*geo)->y_m / (*geo)->x_m;
        dem.scale_source = "georeferencing";
        dem.scale_note = (*geo)->note;
        if (distortion.empty())
          distortion = geographic_distortion(src.georef(), w, h, LocalProjection::kNone);
      }
    }
    if (!std::isfinite(dem.meters_per_sample) || dem.meters_per_sample <= 0 || dem.meters_per_sample > 1e5) {
      return fail(ErrorCode::kInvalidArgument, name, "meters per sample must be in (0, 1e5]");
    }
    double scale = 1.0, offset = 0.0;
    if (band.scale || band.offset) {
      scale = band.scale.value_or(1.0);
      offset = band.offset.value_or(0.0);
    }
    const double unit = band_unit_meters(band.unit);
    scale *= unit;
    offset *= unit;
    if (side.vertical_scale) scale = *side.vertical_scale;
    if (side.vertical_offset) offset = *side.vertical_offset;
    if (options.vertical_scale) scale = *options.vertical_scale;
    if (options.vertical_offset) offset = *options.vertical_offset;
    if (!std::isfinite(scale) || scale <= 0 || !std::isfinite(offset)) {
      return fail(ErrorCode::kInvalidArgument, name, "vertical scale must be finite and > 0");
    }
    if (dem.integer_source) dem.vertical_step = scale;
    dem.loam_world = side.loam_world;
    dem.distortion = distortion;
    out.nodata_ = band.nodata;
    out.scale_ = scale;
    out.offset_ = offset;
    out.src_ = std::move(owned);
    return out;
  }
};

DemStrips::DemStrips(DemStrips&&) noexcept = default;
DemStrips& DemStrips::operator=(DemStrips&&) noexcept = default;
DemStrips::~DemStrips() = default;

int64_t DemStrips::strip_rows() const { return loam::strip_rows(*src_); }

Result<int64_t> DemStrips::read_rows(int64_t y0, int64_t rows, std::span<double> out) {
  if (y0 < 0 || rows <= 0 || y0 + rows > info_.height || out.size() != size_t(rows * info_.width)) {
    return fail(ErrorCode::kInvalidArgument, info_.name, "strip outside the raster");
  }
  const int64_t w = info_.width;
  LOAM_TRY(src_->read_rows(info_.band, flip_rows_ ? info_.height - y0 - rows : y0, rows, out));
  if (flip_rows_) {
    for (int64_t a = 0, b = rows - 1; a < b; ++a, --b) {
      std::swap_ranges(out.begin() + a * w, out.begin() + (a + 1) * w, out.begin() + b * w);
    }
  }
  if (flip_columns_) {
    for (int64_t r = 0; r < rows; ++r) std::reverse(out.begin() + r * w, out.begin() + (r + 1) * w);
  }
  const bool nodata_nan = nodata_ && std::isnan(*nodata_);
  int64_t missing_count = 0;
  for (double& v : out) {
    const bool missing = !std::isfinite(v) || (nodata_ && !nodata_nan && v == *nodata_);
    if (missing) {
      v = std::numeric_limits<double>::quiet_NaN();
      ++missing_count;
    } else {
      v = offset_ + scale_ * v;
    }
  }
  return missing_count;
}

namespace {

// Reads every row in strips: the resident output grows with what was decoded, never with
// the header's claim.
Result<DemRaster> read_whole(DemStrips strips) {
  DemRaster dem;
  static_cast<DemInfo&>(dem) = strips.info();
  const int64_t w = dem.width, h = dem.height;
  const int64_t rows_per_strip = strips.strip_rows();
  for (int64_t y = 0; y < h; y += rows_per_strip) {
    const int64_t rows = std::min(rows_per_strip, h - y);
    const size_t at = dem.meters.size();
    dem.meters.resize(at + size_t(rows * w));
    auto missing = strips.read_rows(y, rows, std::span<double>(dem.meters.data() + at, size_t(rows * w)));
    if (!missing) return missing.error();
    dem.nodata_count += *missing;
    // Once the first strip decoded, reserve the whole raster: address space only (pages become
    // resident as strips are written), and no reallocation copies on the way.
    if (y == 0) dem.meters.reserve(size_t(w * h));
  }
  if (dem.nodata_count == w * h)
    return fail(ErrorCode::kInvalidArgument, dem.name, "every sample is NaN or NoData");
  return dem;
}

Result<std::string> read_sidecar_beside(const std::string& path) {
  const std::string side = sidecar_path(path);
  std::error_code ec;
  if (side == path || !std::filesystem::is_regular_file(side, ec)) return std::string();
  const std::uintmax_t size = std::filesystem::file_size(side, ec);
  if (ec) return fail(ErrorCode::kIo, side, "cannot read the sidecar");
  if (size > kMaxSidecarBytes) return fail(ErrorCode::kOversize, side, "sidecar larger than 1 MiB");
  std::ifstream in(side);
  std::ostringstream text;
  text << in.rdbuf();
  if (!in) return fail(ErrorCode::kIo, side, "cannot read the sidecar");
  return text.str();
}

}  // namespace

Result<DemRaster> read_dem_file(const std::string& path, const DemScaleOptions& options) {
  const std::string ext = lower_extension(path);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return fail(ErrorCode::kNotFound, path, "cannot open the file");
  if (!std::filesystem::is_regular_file(path, ec))
    return fail(ErrorCode::kInvalidArgument, path, "not a regular file");
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return fail(ErrorCode::kIo, path, "cannot determine the file size");
  if (size == 0) return fail(ErrorCode::kInvalidArgument, path, "the file is empty");
  LOAM_TRY(check_extension(ext, path));
  auto sidecar = read_sidecar_beside(path);
  if (!sidecar) return sidecar.error();
  if (ext == "asc") LOAM_TRY(check_ascii_grid_file(path));
  auto src = ext == "exr" ? open_exr_file(path) : open_gdal_file(path, ext);
  if (!src) return src.error();
  auto strips = DemStripsOpener::open(std::move(*src), path, *sidecar, options, true);
  if (!strips) return strips.error();
  return read_whole(std::move(*strips));
}

Result<DemStrips> open_dem_strips(const std::string& path, const DemScaleOptions& options) {
  const std::string ext = lower_extension(path);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return fail(ErrorCode::kNotFound, path, "cannot open the file");
  if (!std::filesystem::is_regular_file(path, ec))
    return fail(ErrorCode::kInvalidArgument, path, "not a regular file");
  LOAM_TRY(check_extension(ext, path));
  auto sidecar = read_sidecar_beside(path);
  if (!sidecar) return sidecar.error();
  if (ext == "asc") LOAM_TRY(check_ascii_grid_file(path));
  auto src = ext == "exr" ? open_exr_file(path) : open_gdal_file(path, ext);
  if (!src) return src.error();
  return DemStripsOpener::open(std::move(*src), path, *sidecar, options, false);
}

Result<DemRaster> read_dem_memory(std::span<const uint8_t> bytes, const std::string& name,
                                  const std::string& sidecar_json, const DemScaleOptions& options) {
  if (bytes.empty()) return fail(ErrorCode::kInvalidArgument, name, "the image is empty");
  const std::string ext = lower_extension(name);
  LOAM_TRY(check_extension(ext, name));
  if (ext == "asc") LOAM_TRY(check_ascii_grid(bytes, name));
  auto src = ext == "exr" ? open_exr_memory(bytes, name) : open_gdal_memory(bytes, name, ext);
  if (!src) return src.error();
  auto strips = DemStripsOpener::open(std::move(*src), name, sidecar_json, options, true);
  if (!strips) return strips.error();
  return read_whole(std::move(*strips));
}

}  // namespace loam
