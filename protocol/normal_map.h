// Normal maps of the coarse layer for a sample rect, for clients' lighting after a stamp.
//
// Gradients are 4th-order central differences (FD4) of the coarse heights in meters, with
// the 4th-order one-sided stencils at the world's edges; they are bit-identical to
// coarse_gradient_at_sample (surface.h), so a normal-map texel and a normal query agree.
// There is no slope limit: an 80 degree cliff gives an 80 degree normal.
//
// Packed format (GL RG16_SNORM): one uint32 per sample, row-major over the rect; bits 0..15
// hold nx and bits 16..31 ny as signed Q15 (round(n * 32767), two's complement), where
// n = (-dh/dx, -dh/dy, 1) / |...| is the unit normal, z up, x east (+gx), y along +gy.
// nz = sqrt(max(0, 1 - nx^2 - ny^2)) is implied (always >= 0). Quantization of nx, ny costs at
// most 1.5e-5 per component; the angle error is below 0.01 degree for slopes up to 89 degrees.
// Pure: reads the world, any rect (samples outside the world are clamped to its edge).
#pragma once

#include <cstdint>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/world.h"

namespace loam {

// FD4 height gradient (dh/dx, dh/dy in meters per meter) of every coarse sample in `rect`,
// row-major; identical to coarse_gradient_at_sample.
void coarse_gradients(const World& world, const RectI& rect, std::vector<double>& dhdx,
                      std::vector<double>& dhdy);

// The same at a decimated spacing: the world seen through every 2^mip-th sample (a mip-`mip`
// grid, rect in it; spacing meters_per_sample * 2^mip), with the one-sided stencils at the
// world's edges in that grid. What a clipmap level's normal map holds (client/render).
void decimated_gradients(const World& world, int32_t mip, const RectI& rect, std::vector<double>& dhdx,
                         std::vector<double>& dhdy);

// Packs one gradient into the RG16_SNORM format above.
uint32_t pack_normal(double dhdx, double dhdy);
// Unpacks to a unit normal (nx, ny, nz).
void unpack_normal(uint32_t packed, double& nx, double& ny, double& nz);

// The packed normal map of `rect`.
std::vector<uint32_t> generate_normal_map(const World& world, const RectI& rect);
// The packed normal map of `rect` of the mip-`mip` grid (decimated_gradients).
std::vector<uint32_t> generate_decimated_normal_map(const World& world, int32_t mip, const RectI& rect);

}  // namespace loam
