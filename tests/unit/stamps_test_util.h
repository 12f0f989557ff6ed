// Shared helpers of the stamp tests: a small world whose tile borders and four-tile corner
// sit at sample 0 (origin tile -1, -1), and a contiguous-array reference of the kernel.
#pragma once

#include <gtest/gtest.h>

#include <vector>

#include "protocol/stamps/stamp_kernel.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"

namespace loam::stamps_test {

inline WorldParams corner_world_params() {
  WorldParams p;
  p.meters_per_sample = 1.0;
  p.meters_per_unit = 1.0 / 64.0;
  p.height_offset = 0.0;
  p.detail_factor = 4;
  p.detail_meters_per_unit = 0.005;
  p.origin_tile_x = -1;
  p.origin_tile_y = -1;
  p.tiles_x = 2;
  p.tiles_y = 2;
  return p;
}

inline StampParams make_params(StampKind kind, double cx, double cy, double radius, double intensity) {
  StampParams s;
  s.kind = kind;
  s.center_x = cx;
  s.center_y = cy;
  s.radius = radius;
  s.intensity = intensity;
  return s;
}

inline QuantizedStamp must_validate(const StampParams& s, const WorldParams& w,
                                    const TextureRegistry* reg = nullptr, const StampLimits& lim = {}) {
  auto q = validate_stamp(s, w, lim, reg);
  EXPECT_TRUE(q.ok()) << (q.ok() ? "" : q.error().describe());
  return q.ok() ? q.value() : QuantizedStamp{};
}

// The whole layer of a world as one contiguous int32 array (row-major over the layer rect).
inline std::vector<int32_t> layer_array(const World& w, Layer layer) {
  const RectI r = layer_sample_rect(w.params(), layer);
  std::vector<int32_t> out(size_t(r.area()));
  if (layer == Layer::kCoarse) {
    std::vector<uint16_t> t(out.size());
    w.read_coarse(r, t);
    for (size_t i = 0; i < t.size(); ++i) out[i] = t[i];
  } else {
    std::vector<int8_t> t(out.size());
    w.read_detail(r, t);
    for (size_t i = 0; i < t.size(); ++i) out[i] = t[i];
  }
  return out;
}

// Reference: the kernel on one contiguous array, with no tiles anywhere (footprint contact
// computed on the array too).
inline std::vector<int32_t> contiguous_reference(const World& w, const QuantizedStamp& q,
                                                 const TextureRegistry* reg = nullptr) {
  const RectI r = layer_sample_rect(w.params(), q.layer);
  std::vector<int32_t> a = layer_array(w, q.layer);
  auto baked = bake_stamp(q, w.params(), reg);
  EXPECT_TRUE(baked.ok());
  BakedStamp b = baked.value();
  auto at = [&](int64_t x, int64_t y) -> int32_t& { return a[size_t((y - r.y0) * r.width() + (x - r.x0))]; };
  if (q.kind == StampKind::kFootprint) {
    b.has_contact = false;
    for (int64_t y = r.y0; y < r.y1; ++y) {
      for (int64_t x = r.x0; x < r.x1; ++x) {
        const int32_t u = radial_u_q16(b, x, y);
        if (u < 0) continue;
        const int32_t c = at(x, y) * 256 - table_lookup(b.table, u);
        if (!b.has_contact || c > b.contact_q8) b.contact_q8 = c;
        b.has_contact = true;
      }
    }
  }
  for (int64_t y = r.y0; y < r.y1; ++y) {
    for (int64_t x = r.x0; x < r.x1; ++x) at(x, y) = stamp_sample(b, x, y, at(x, y));
  }
  return a;
}

}  // namespace loam::stamps_test
