// Surface queries in world meters: height and normal at any point, as double.
//
// Height is bilinear over the coarse grid plus bilinear over the detail grid, exact at
// sample positions (a query at x = i * meters_per_sample returns sample i, with no
// floor/round off-by-one) and continuous across tile borders and corners. Normals come from
// 4th-order central differences (FD4) of the samples, with 4th-order one-sided stencils at
// the world's edges, interpolated bilinearly between samples; there is no slope limit (an
// 80 degree cliff gives an 80 degree normal). World meters: x = global sample x *
// meters_per_sample, y likewise (y grows with the sample row, i.e. southward in a DEM).
#pragma once

#include <cstdint>
#include <functional>

#include "protocol/world.h"

namespace loam {

struct Vec3d {
  double x = 0, y = 0, z = 0;
};

// Height in meters at world position (x, y); positions outside the world clamp to its edge.
double height_at(const World& world, double x, double y);

// Unit surface normal (z up) at world position (x, y).
Vec3d normal_at(const World& world, double x, double y);

// Height gradient (dh/dx, dh/dy) in meters per meter at an integer coarse sample, FD4.
Vec3d coarse_gradient_at_sample(const World& world, int64_t gx, int64_t gy);
Vec3d detail_gradient_at_sample(const World& world, int64_t dx, int64_t dy);

// FD4 first derivative of f at index i on [lo, hi) with spacing h: central
// (f[i-2] - 8 f[i-1] + 8 f[i+1] - f[i+2]) / 12h inside, 4th-order one-sided stencils at
// the two samples nearest each end. Needs hi - lo >= 5.
double fd4_derivative(const std::function<double(int64_t)>& f, int64_t i, int64_t lo, int64_t hi, double h);

// Splits a world coordinate into a sample index and a fraction in [0, 1), snapping to the
// sample when within a few ulps so sample positions are exact.
void split_coordinate(double u, int64_t& index, double& frac);

}  // namespace loam
