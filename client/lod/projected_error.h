// How far a vertical error can move a terrain point's image: the bound the error-driven
// clipmap splits blocks by. A point P (relative to the eye) seen along the unit axes forward w,
// right r and up u has screen position f (P.r, P.u) / (P.w), f the pixels per radian. Moving P
// up by e moves its image by (f e / z) |(Z.r - s_x Z.w, Z.u - s_y Z.w)|, z = P.w its depth,
// (s_x, s_y) = (P.r, P.u) / z its screen position as tangents and Z the world's up. Dividing
// e by the distance alone (f e / |P|) misses |P| / z, up to 1.55 at a 1920 x 1080, 60 degree
// view's corner, and the term in Z.w, which grows with the pitch: blocks near the screen's
// edges would be drawn with more error than the budget.
#pragma once

#include <array>

#include "client/lod/geomipmap.h"

namespace loam::lod {

// Sets the view's axes from a perspective camera's forward and up hint (world frame, any
// length; the up hint not parallel to forward) and its screen: fov_y and width / height.
void set_view_axes(LodView& view, const std::array<double, 3>& forward, const std::array<double, 3>& up_hint,
                   double fov_y_degrees, double aspect);

// The most pixels a vertical error of 1 m can move the image of any point of the box (world
// meters) that is on screen: 0 when the box is wholly off screen, infinite when the eye is in
// it. Without the view's axes (half_tan_x 0): pixels_per_radian / the box's distance.
double pixels_per_vertical_meter(const LodView& view, const std::array<double, 3>& lo,
                                 const std::array<double, 3>& hi);

}  // namespace loam::lod
