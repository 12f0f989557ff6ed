#include "dem/dem_georef.h"

#include <algorithm>
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

double rad(double deg) { return deg * kPi / 180.0; }

// Great-circle angle between two points, radians.
double central_angle(const GeoCentre& a, const GeoCentre& b) {
  const double dlat = rad(b.lat - a.lat), dlon = rad(b.lon - a.lon);
  const double h = std::sin(dlat / 2) * std::sin(dlat / 2) +
                   std::cos(rad(a.lat)) * std::cos(rad(b.lat)) * std::sin(dlon / 2) * std::sin(dlon / 2);
  return 2.0 * std::asin(std::min(1.0, std::sqrt(h)));
}

}  // namespace

Result<LocalProjection> parse_local_projection(std::string_view text) {
  if (text == "none") return LocalProjection::kNone;
  if (text == "aeqd") return LocalProjection::kAzimuthalEquidistant;
  if (text == "utm") return LocalProjection::kUtm;
  return make_error(ErrorCode::kInvalidArgument, "project",
                    "'" + std::string(text) + "' is not none, aeqd or utm");
}

const char* to_string(LocalProjection p) {
  switch (p) {
    case LocalProjection::kNone: return "none";
    case LocalProjection::kAzimuthalEquidistant: return "aeqd";
    case LocalProjection::kUtm: return "utm";
  }
  return "none";
}

std::optional<GeoCentre> geographic_centre(const Georef& g, int64_t width, int64_t height) {
  if (!g.has_transform || g.crs != Georef::Crs::kGeographic) return std::nullopt;
  const double* t = g.transform;
  const double x = double(width) / 2, y = double(height) / 2, deg = g.angular_unit_deg;
  const GeoCentre c{(t[0] + t[1] * x + t[2] * y) * deg, (t[3] + t[4] * x + t[5] * y) * deg};
  if (!std::isfinite(c.lon) || !std::isfinite(c.lat) || std::fabs(c.lat) >= 90.0) return std::nullopt;
  return c;
}

int utm_zone(double lon) {
  const double wrapped = lon - 360.0 * std::floor((lon + 180.0) / 360.0);
  return std::clamp(int(std::floor((wrapped + 180.0) / 6.0)) + 1, 1, 60);
}

std::string geographic_distortion(const Georef& g, int64_t width, int64_t height, LocalProjection p) {
  const auto centre = geographic_centre(g, width, height);
  if (!centre) return "";
  const double* t = g.transform;
  const double deg = g.angular_unit_deg;
  auto at = [&](double x, double y) {
    return GeoCentre{(t[0] + t[1] * x + t[2] * y) * deg, (t[3] + t[4] * x + t[5] * y) * deg};
  };
  const double w = double(width), h = double(height);
  const GeoCentre probes[8] = {at(0, 0),     at(w, 0),     at(0, h),     at(w, h),
                               at(w / 2, 0), at(w / 2, h), at(0, h / 2), at(w, h / 2)};
  char buf[320];
  switch (p) {
    case LocalProjection::kNone: {
      // East-west spacing goes with cos(latitude); Loam's square samples take the centre's.
      const double c = std::cos(rad(centre->lat));
      double worst = 0;
      for (const GeoCentre& q : probes)
        worst = std::max(worst, std::fabs(std::cos(rad(std::clamp(q.lat, -90.0, 90.0))) / c - 1.0));
      const double x_m = c * std::hypot(t[1], t[4]), y_m = std::hypot(t[2], t[5]);
      const double square = std::sqrt(x_m * y_m);
      std::snprintf(buf, sizeof buf,
                    "geographic samples: east-west distances off by up to %.2f%% at the northern or southern "
                    "edge; squaring the samples stretches east-west by %+.2f%% and north-south by %+.2f%% "
                    "(--project aeqd or utm warps to square metres)",
                    100.0 * worst, 100.0 * (square / x_m - 1.0), 100.0 * (square / y_m - 1.0));
      return buf;
    }
    case LocalProjection::kAzimuthalEquidistant: {
      // Exact along lines from the centre; across them the scale is c / sin(c).
      double worst = 0;
      for (const GeoCentre& q : probes) {
        const double a = central_angle(*centre, q);
        if (a > 1e-12) worst = std::max(worst, a / std::sin(a) - 1.0);
      }
      std::snprintf(buf, sizeof buf,
                    "warped to an azimuthal equidistant projection at %.4f, %.4f: distances from the centre "
                    "exact, across them off by up to %.3f%% at the corners",
                    centre->lat, centre->lon, 100.0 * worst);
      return buf;
    }
    case LocalProjection::kUtm: {
      // Transverse Mercator's scale: k0 / sqrt(1 - B^2), B = cos(lat) sin(lon - lon0).
      const int zone = utm_zone(centre->lon);
      const double lon0 = -183.0 + 6.0 * zone;
      double worst = std::fabs(0.9996 - 1.0);
      for (const GeoCentre& q : probes) {
        const double b = std::cos(rad(q.lat)) * std::sin(rad(q.lon - lon0));
        if (std::fabs(b) < 1.0) worst = std::max(worst, std::fabs(0.9996 / std::sqrt(1.0 - b * b) - 1.0));
      }
      std::snprintf(
          buf, sizeof buf,
          "warped to UTM zone %d%s: distances off by up to %.3f%% (scale %.4f on the central meridian)", zone,
          centre->lat >= 0 ? "N" : "S", 100.0 * worst, 0.9996);
      return buf;
    }
  }
  return "";
}

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
