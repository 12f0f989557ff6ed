#include "dem/gdal_source.h"

#include <cpl_string.h>
#include <cpl_vsi.h>
#include <gdal.h>
#include <gdal_utils.h>
#include <ogr_srs_api.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string_view>

#include "dem/ascii_grid_check.h"
#include "dem/gdal_errors.h"

namespace loam {
namespace {

struct DriverRow {
  const char* ext;
  const char* driver;
};
constexpr DriverRow kDrivers[] = {
    {"tif", "GTiff"},   {"tiff", "GTiff"},  {"png", "PNG"},
    {"hgt", "SRTMHGT"}, {"asc", "AAIGrid"}, {"vrt", "VRT"},
};

std::string type_name(GDALDataType t) {
  switch (t) {
    case GDT_Byte: return "uint8";
    case GDT_UInt16: return "uint16";
    case GDT_Int16: return "int16";
    case GDT_UInt32: return "uint32";
    case GDT_Int32: return "int32";
    case GDT_Float32: return "float32";
    case GDT_Float64: return "float64";
    default: return GDALGetDataTypeName(t) ? GDALGetDataTypeName(t) : "unknown";
  }
}

Georef::Crs crs_kind(OGRSpatialReferenceH srs) {
  if (!srs) return Georef::Crs::kNone;
  if (OSRIsProjected(srs)) return Georef::Crs::kProjected;
  if (OSRIsGeographic(srs)) return Georef::Crs::kGeographic;
  if (OSRIsLocal(srs)) return Georef::Crs::kLocal;
  return Georef::Crs::kOther;
}

class GdalSource final : public RasterSource {
 public:
  // `under`: the source a warped dataset reads, kept open until this one closes.
  GdalSource(GDALDatasetH ds, std::string name, std::string vsimem_path,
             std::unique_ptr<RasterSource> under = {})
      : ds_(ds), name_(std::move(name)), vsimem_path_(std::move(vsimem_path)), under_(std::move(under)) {}
  ~GdalSource() override {
    GdalErrorCapture quiet;
    GDALClose(ds_);
    if (!vsimem_path_.empty()) VSIUnlink(vsimem_path_.c_str());
  }
  GDALDatasetH dataset() const { return ds_; }
  GdalSource(const GdalSource&) = delete;
  GdalSource& operator=(const GdalSource&) = delete;

  int64_t width() const override { return GDALGetRasterXSize(ds_); }
  int64_t height() const override { return GDALGetRasterYSize(ds_); }
  int band_count() const override { return GDALGetRasterCount(ds_); }
  std::string format() const override {
    GDALDriverH d = GDALGetDatasetDriver(ds_);
    return d ? GDALGetDriverShortName(d) : "GDAL";
  }

  int64_t block_rows() const override {
    GDALRasterBandH b = GDALGetRasterBand(ds_, 1);
    int bx = 0, by = 0;
    if (b) GDALGetBlockSize(b, &bx, &by);
    return std::max(1, by);
  }

  RasterBandInfo band(int index) const override {
    GdalErrorCapture quiet;
    RasterBandInfo info;
    GDALRasterBandH b = GDALGetRasterBand(ds_, index);
    if (!b) return info;
    const GDALDataType t = GDALGetRasterDataType(b);
    info.sample_type = type_name(t);
    info.integer = t == GDT_Byte || t == GDT_UInt16 || t == GDT_Int16 || t == GDT_UInt32 || t == GDT_Int32;
    info.supported = info.integer || t == GDT_Float32 || t == GDT_Float64;
    const char* color = GDALGetColorInterpretationName(GDALGetRasterColorInterpretation(b));
    info.color = color ? color : "Undefined";
    int has = 0;
    const double nodata = GDALGetRasterNoDataValue(b, &has);
    if (has) info.nodata = nodata;
    has = 0;
    const double scale = GDALGetRasterScale(b, &has);
    if (has) info.scale = scale;
    has = 0;
    const double offset = GDALGetRasterOffset(b, &has);
    if (has) info.offset = offset;
    const char* unit = GDALGetRasterUnitType(b);
    info.unit = unit ? unit : "";
    if (const char* nbits = GDALGetMetadataItem(b, "NBITS", "IMAGE_STRUCTURE")) info.bits = std::atoi(nbits);
    return info;
  }

  Georef georef() const override {
    GdalErrorCapture quiet;
    Georef g;
    g.has_transform = GDALGetGeoTransform(ds_, g.transform) == CE_None;
    OGRSpatialReferenceH srs = GDALGetSpatialRef(ds_);
    g.crs = crs_kind(srs);
    if (!srs) return g;
    const char* name = OSRGetName(srs);
    g.crs_name = name ? name : "unnamed";
    if (g.crs == Georef::Crs::kGeographic) {
      g.angular_unit_deg = OSRGetAngularUnits(srs, nullptr) * 180.0 / M_PI;
      OGRErr err = OGRERR_NONE;
      g.semi_major_m = OSRGetSemiMajor(srs, &err);
      if (err != OGRERR_NONE) g.semi_major_m = 0;
      g.inverse_flattening = OSRGetInvFlattening(srs, &err);
      if (err != OGRERR_NONE) g.inverse_flattening = 0;
    } else if (g.crs == Georef::Crs::kProjected || g.crs == Georef::Crs::kLocal) {
      char* unit = nullptr;
      g.linear_unit_m = OSRGetLinearUnits(srs, &unit);
      g.linear_unit_name = unit ? unit : "";
    }
    return g;
  }

  Status read_rows(int index, int64_t y0, int64_t rows, std::span<double> out) override {
    const int64_t w = width();
    if (y0 < 0 || rows < 1 || y0 + rows > height() || out.size() != size_t(rows * w)) {
      return make_error(ErrorCode::kInvalidArgument, name_, "read outside the raster");
    }
    GdalErrorCapture errors;
    GDALRasterBandH b = GDALGetRasterBand(ds_, index);
    if (!b) return make_error(ErrorCode::kInvalidArgument, name_, "no band " + std::to_string(index));
    const CPLErr e = GDALRasterIO(b, GF_Read, 0, int(y0), int(w), int(rows), out.data(), int(w), int(rows),
                                  GDT_Float64, 0, 0);
    if (e != CE_None || errors.failed()) {
      return make_error(ErrorCode::kCorrupt, name_,
                        "cannot read rows " + std::to_string(y0) + ".." + std::to_string(y0 + rows - 1) +
                            " (truncated or corrupt data): " + errors.text("decoder error"));
    }
    return {};
  }

 private:
  GDALDatasetH ds_;
  std::string name_;
  std::string vsimem_path_;
  std::unique_ptr<RasterSource> under_;
};

// A VRT may window, mosaic and scale raster files; it may not read any file as raw samples
// (VRTRawRasterBand: /etc/passwd, /dev/zero) nor nest other VRTs (which would escape this
// check). GDAL's own serialization of the opened VRT is what is inspected.
Status check_vrt(GDALDatasetH ds, const std::string& name) {
  GdalErrorCapture quiet;
  char** xml = GDALGetMetadata(ds, "xml:VRT");
  const std::string text = xml && xml[0] ? xml[0] : "";
  if (text.find("VRTRawRasterBand") != std::string::npos) {
    return make_error(ErrorCode::kUnsupported, name,
                      "a VRT raw band (VRTRawRasterBand) reads any file as samples: not accepted for a DEM");
  }
  std::string lower = text;
  for (char& c : lower) c = char(std::tolower(static_cast<unsigned char>(c)));
  for (size_t at = lower.find("<sourcefilename"); at != std::string::npos;
       at = lower.find("<sourcefilename", at + 1)) {
    const size_t close = lower.find("</sourcefilename>", at);
    if (close == std::string::npos) break;
    const std::string_view entry(lower.data() + at, close - at);
    if (entry.size() >= 4 && entry.substr(entry.size() - 4) == ".vrt") {
      return make_error(ErrorCode::kUnsupported, name,
                        "a VRT whose sources are VRTs is not accepted (one level of VRT only)");
    }
  }
  // An ESRI ASCII grid is checked as text before GDAL reads it (ascii_grid_check.h), through a
  // VRT as when it is opened itself.
  char** files = GDALGetFileList(ds);
  Status checked;
  for (char** f = files; f && *f && checked.ok(); ++f) {
    if (lower_extension(*f) != "asc") continue;
    checked = check_ascii_grid_file(*f);
    if (!checked.ok()) {
      checked = make_error(
          checked.error().code, name,
          "its source " + std::filesystem::path(*f).filename().string() + ": " + checked.error().describe());
    }
  }
  CSLDestroy(files);
  return checked;
}

Result<std::unique_ptr<RasterSource>> open_path(const std::string& gdal_path, const std::string& name,
                                                const std::string& ext, std::string vsimem_path) {
  const char* driver = gdal_driver_for_extension(ext);
  if (!driver) {
    if (!vsimem_path.empty()) VSIUnlink(vsimem_path.c_str());
    return make_error(ErrorCode::kUnsupported, name, "no GDAL driver for '" + ext + "'");
  }
  ensure_gdal_ready();
  const char* const allowed[] = {driver, nullptr};
  GDALDatasetH ds = nullptr;
  std::string why;
  {
    GdalErrorCapture errors;
    ds = GDALOpenEx(gdal_path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR, allowed,
                    nullptr, nullptr);
    if (!ds) why = errors.text("not a readable " + std::string(driver) + " file");
  }
  if (!ds) {
    if (!vsimem_path.empty()) VSIUnlink(vsimem_path.c_str());
    return make_error(ErrorCode::kCorrupt, name, "cannot decode: " + why);
  }
  auto source = std::unique_ptr<RasterSource>(new GdalSource(ds, name, std::move(vsimem_path)));
  if (std::string(driver) == "VRT") LOAM_TRY(check_vrt(ds, name));
  return source;
}

}  // namespace

const char* gdal_driver_for_extension(const std::string& ext) {
  for (const DriverRow& row : kDrivers) {
    if (ext == row.ext) return row.driver;
  }
  return nullptr;
}

Result<std::unique_ptr<RasterSource>> open_gdal_file(const std::string& path, const std::string& ext) {
  return open_path(path, path, ext, "");
}

Result<std::unique_ptr<RasterSource>> open_gdal_memory(std::span<const uint8_t> bytes,
                                                       const std::string& name, const std::string& ext) {
  static std::atomic<uint64_t> counter{0};
  ensure_gdal_ready();
  // A folder per opening keeps the file's own name (drivers such as SRTM HGT read it).
  const std::string leaf = std::filesystem::path(name).filename().string();
  const std::string path = "/vsimem/loam_dem_" + std::to_string(counter.fetch_add(1)) + "/" + leaf;
  VSILFILE* f =
      VSIFileFromMemBuffer(path.c_str(), const_cast<GByte*>(bytes.data()), vsi_l_offset(bytes.size()),
                           /*bTakeOwnership=*/FALSE);
  if (!f) return make_error(ErrorCode::kIo, name, "cannot map the bytes into GDAL's memory files");
  VSIFCloseL(f);
  return open_path(path, name, ext, path);
}

Result<std::unique_ptr<RasterSource>> project_gdal_source(std::unique_ptr<RasterSource> source,
                                                          LocalProjection projection,
                                                          const std::string& name) {
  auto* gdal = dynamic_cast<GdalSource*>(source.get());
  if (!gdal)
    return make_error(ErrorCode::kUnsupported, name, "only rasters read through GDAL can be projected");
  const Georef g = source->georef();
  const auto centre = geographic_centre(g, source->width(), source->height());
  if (g.crs != Georef::Crs::kGeographic || !centre) {
    return make_error(ErrorCode::kInvalidArgument, name,
                      "--project warps a geographic DEM (degrees) to metres; this one's CRS is '" +
                          (g.crs_name.empty() ? std::string("none") : g.crs_name) + "'");
  }
  GdalErrorCapture errors;
  // The target: the source's datum, projected about the raster's centre.
  OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
  OSRCopyGeogCSFrom(srs, GDALGetSpatialRef(gdal->dataset()));
  OGRErr err = OGRERR_NONE;
  if (projection == LocalProjection::kUtm) {
    err = OSRSetUTM(srs, utm_zone(centre->lon), centre->lat >= 0 ? TRUE : FALSE);
  } else {
    OSRSetProjCS(srs, "Loam local azimuthal equidistant");
    err = OSRSetAE(srs, centre->lat, centre->lon, 0.0, 0.0);
  }
  char* wkt = nullptr;
  if (err == OGRERR_NONE) err = OSRExportToWkt(srs, &wkt);
  OSRDestroySpatialReference(srs);
  if (err != OGRERR_NONE || !wkt) {
    CPLFree(wkt);
    return make_error(ErrorCode::kUnsupported, name,
                      "cannot build the local projection: " + errors.text("OSR error"));
  }
  const std::string target = wkt;
  CPLFree(wkt);
  const char* argv[] = {"-of",     "VRT",        "-t_srs", target.c_str(), "-r",   "bilinear", "-ot",
                        "Float64", "-dstnodata", "nan",    "-et",          "0.05", nullptr};
  GDALWarpAppOptions* options = GDALWarpAppOptionsNew(const_cast<char**>(argv), nullptr);
  if (!options)
    return make_error(ErrorCode::kUnsupported, name, "cannot set up the warp: " + errors.text("options"));
  static std::atomic<uint64_t> counter{0};
  const std::string path = "/vsimem/loam_warp_" + std::to_string(counter.fetch_add(1)) + ".vrt";
  GDALDatasetH in = gdal->dataset();
  int usage_error = 0;
  GDALDatasetH out = GDALWarp(path.c_str(), nullptr, 1, &in, options, &usage_error);
  GDALWarpAppOptionsFree(options);
  if (!out || errors.failed()) {
    if (out) GDALClose(out);
    VSIUnlink(path.c_str());
    return make_error(
        ErrorCode::kUnsupported, name,
        "cannot warp to " + std::string(to_string(projection)) + ": " + errors.text("GDALWarp failed"));
  }
  return std::unique_ptr<RasterSource>(new GdalSource(out, name, path, std::move(source)));
}

}  // namespace loam
