// The per-pixel screen-space error evaluator every level-of-detail suite scores with (`clipmap`,
// `lod`): for every terrain pixel, the point under it (from the depth buffer) is moved to the
// full-resolution terrain's height and projected back; the distance in pixels is the
// screen-space error, beside the vertical error in meters. The full-resolution terrain is
// protocol/surface.h's bilinear surface, or a scheme's own finest triangulation of the same
// samples (so that a view from 2 m above the ground does not count the difference between
// bilinear patches and triangles, which no level of detail changes, as error).
#pragma once

#include <cstdint>
#include <vector>

#include "client/scene/camera.h"
#include "protocol/world.h"

namespace loam::bench {

struct ErrorStats {
  double mean_px = 0, p50_px = 0, p99_px = 0, max_px = 0, mean_m = 0, max_m = 0;
  int64_t pixels = 0;
};

enum class Truth {
  kBilinear,   // height_at(): coarse and detail layers, bilinear
  kTriangles,  // the coarse samples, every cell split along (x, y)-(x + 1, y + 1) (clipmaps)
  kUnionJack,  // the coarse samples, cells split in the union-jack pattern (geomipmapping)
};

// The full-resolution terrain's height (m) at world position (x, y) as `truth` defines it.
double truth_height(const World& world, double x, double y, Truth truth);

// Appends the screen error (px) and vertical error (m) of every terrain pixel (over the world,
// half a sample in from its edge) of a frame drawn
// from `cam` into a width x height viewport whose window depth (row 0 at the top) is `depth`.
void add_screen_errors(const World& world, const scene::Camera& cam, int32_t width, int32_t height,
                       const std::vector<float>& depth, std::vector<double>& px_errors,
                       std::vector<double>& m_errors, Truth truth = Truth::kBilinear);

// Mean, median, p99 and maximum (sorts `px`).
ErrorStats summarize_errors(std::vector<double>& px, const std::vector<double>& m);

}  // namespace loam::bench
