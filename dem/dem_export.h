// Writing a world (or a region of it) out as an image (dem/image_file.h: GDAL for PNG, OpenEXR).
//
// PNG: 16-bit coarse height units exactly as stored, with a JSON sidecar (NAME.json) that
// gives the vertical mapping and the world's parameters, so importing it again reproduces
// the world bit for bit. EXR: 32-bit float heights in meters (coarse plus detail at each
// coarse sample), for other tools.
#pragma once

#include <string>

#include "protocol/world.h"

namespace loam {

// `region` is in global coarse samples and must lie inside the world.
Status export_png16(const World& world, const RectI& region, const std::string& path);
Status export_exr(const World& world, const RectI& region, const std::string& path);

// The sidecar JSON text written beside a PNG export.
std::string sidecar_json(const WorldParams& params, const RectI& region);

}  // namespace loam
