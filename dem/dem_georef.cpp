#include "dem/dem_georef.h"

#include <cmath>
#include <cstdio>

namespace loam {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kWgs84SemiMajor = 6378137.0;
constexpr double kWgs84InverseFlattening = 298.257223563;

std::string fmt(const char* f, double a) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, a);
  return buf;
}

}  // namespace

Result<std::optional<GeoSpacing>> spacing_from_georef(const Georef& g, int64_t width, int64_t height,
                                                      const std::string& name) {
  if (!g.has_transform) return std::optional<GeoSpacing>{};
  const double* t = g.transform;
  for (int i = 0; i < 6; ++i) {
    if (!std::isfinite(t[i])) return make_error(ErrorCode::kCorrupt, name, "geotransform is not finite");
  }
  const double px = std::hypot(t[1], t[4]);  // one column step
  const double py = std::hypot(t[2], t[5]);  // one row step
  if (!(px > 0) || !(py > 0))
    return make_error(ErrorCode::kCorrupt, name, "geotransform has a zero pixel size");
  const std::string crs = "'" + g.crs_name + "'";
  GeoSpacing s;
  switch (g.crs) {
    case Georef::Crs::kGeographic: {
      const double deg = g.angular_unit_deg;
      if (!(deg > 0) || !std::isfinite(deg))
        return make_error(ErrorCode::kUnsupported, name, "geographic CRS " + crs + " has no angular unit");
      const double lat = (t[3] + t[4] * double(width) / 2 + t[5] * double(height) / 2) * deg;
      if (!std::isfinite(lat) || std::fabs(lat) >= 90.0) {
        return make_error(ErrorCode::kInvalidArgument, name,
                          "CRS " + crs + " is geographic but the raster's centre latitude is " +
                              fmt("%.6g", lat) +
                              " degrees, outside -90..90 (is its transform in degrees?); give "
                              "--meters-per-sample or a sidecar");
      }
      const double a = g.semi_major_m > 0 ? g.semi_major_m : kWgs84SemiMajor;
      const double inv_f = g.semi_major_m > 0 ? g.inverse_flattening : kWgs84InverseFlattening;
      const double f = inv_f > 0 ? 1.0 / inv_f : 0.0;
      const double e2 = f * (2.0 - f);
      const double phi = lat * kPi / 180.0;
      const double sin_phi = std::sin(phi);
      const double w = 1.0 - e2 * sin_phi * sin_phi;
      const double n = a / std::sqrt(w);                     // prime vertical radius
      const double m = a * (1.0 - e2) / (w * std::sqrt(w));  // meridional radius
      s.x_m = n * std::cos(phi) * px * deg * kPi / 180.0;
      s.y_m = m * py * deg * kPi / 180.0;
      if (!(s.x_m > 1e-6)) {
        return make_error(ErrorCode::kInvalidArgument, name,
                          "CRS " + crs + " is geographic and the raster is centred at the pole (latitude " +
                              fmt("%.6g", lat) + "): no metres per sample along a row");
      }
      s.note = "geographic CRS " + crs + ": metres per sample at centre latitude " + fmt("%.4f", lat);
      break;
    }
    case Georef::Crs::kProjected:
    case Georef::Crs::kLocal: {
      const double unit = g.linear_unit_m;
      if (!(unit > 0) || !std::isfinite(unit))
        return make_error(ErrorCode::kUnsupported, name, "CRS " + crs + " has no linear unit");
      s.x_m = px * unit;
      s.y_m = py * unit;
      s.note = std::string(g.crs == Georef::Crs::kProjected ? "projected" : "local") + " CRS " + crs +
               " in " + (g.linear_unit_name.empty() ? std::string("its units") : g.linear_unit_name) +
               (unit != 1.0 ? fmt(" (%.10g m)", unit) : "");
      break;
    }
    case Georef::Crs::kNone:
      s.x_m = px;
      s.y_m = py;
      s.note = "geotransform without a CRS: units taken as metres";
      break;
    case Georef::Crs::kOther:
      return make_error(ErrorCode::kUnsupported, name,
                        "CRS " + crs +
                            " is neither geographic nor projected: cannot derive metres per sample; give "
                            "--meters-per-sample or a sidecar");
  }
  return std::optional<GeoSpacing>(s);
}

}  // namespace loam
