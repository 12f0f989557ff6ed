#include "protocol/codec/predictor.h"

// The forward transform has no loop-carried dependency; GCC vectorizes it only above -O2's
// very-cheap cost model. (clang vectorizes it at -O2 already.)
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("O3")
#endif

namespace loam::codec {

// The row loops are split into the first row, the first column and the interior so the
// interior runs without edge branches: decode is a serial chain through W, and branches
// there cost more than the arithmetic.

void med_forward_u16(std::span<const uint16_t> in, uint32_t width, uint32_t height, std::span<uint8_t> out) {
  const size_t n = size_t(width) * height;
  uint8_t* lo = out.data();
  uint8_t* hi = out.data() + n;
  const uint16_t* s = in.data();
  uint16_t prev = 0;
  for (uint32_t x = 0; x < width; ++x) {
    const uint16_t z = zigzag16(int16_t(uint16_t(s[x] - prev)));
    lo[x] = uint8_t(z);
    hi[x] = uint8_t(z >> 8);
    prev = s[x];
  }
  for (uint32_t y = 1; y < height; ++y) {
    const size_t r = size_t(y) * width;
    const uint16_t* cur = s + r;
    const uint16_t* up = cur - width;
    {
      const uint16_t z = zigzag16(int16_t(uint16_t(cur[0] - up[0])));
      lo[r] = uint8_t(z);
      hi[r] = uint8_t(z >> 8);
    }
    for (uint32_t x = 1; x < width; ++x) {
      const int32_t p = med(cur[x - 1], up[x], up[x - 1]);
      const uint16_t z = zigzag16(int16_t(uint16_t(cur[x] - p)));
      lo[r + x] = uint8_t(z);
      hi[r + x] = uint8_t(z >> 8);
    }
  }
}

void med_inverse_u16(std::span<const uint8_t> planes, uint32_t width, uint32_t height,
                     std::span<uint16_t> out) {
  const size_t n = size_t(width) * height;
  const uint8_t* lo = planes.data();
  const uint8_t* hi = planes.data() + n;
  uint16_t* s = out.data();
  auto res = [&](size_t i) { return unzigzag16(uint16_t(lo[i] | (hi[i] << 8))); };
  uint16_t prev = 0;
  for (uint32_t x = 0; x < width; ++x) {
    prev = uint16_t(prev + res(x));
    s[x] = prev;
  }
  for (uint32_t y = 1; y < height; ++y) {
    const size_t r = size_t(y) * width;
    uint16_t* cur = s + r;
    const uint16_t* up = cur - width;
    int32_t w = uint16_t(up[0] + res(r));
    cur[0] = uint16_t(w);
    for (uint32_t x = 1; x < width; ++x) {
      const int32_t p = med(w, up[x], up[x - 1]);
      w = uint16_t(p + res(r + x));
      cur[x] = uint16_t(w);
    }
  }
}

void med_forward_i8(std::span<const int8_t> in, uint32_t width, uint32_t height, std::span<uint8_t> out) {
  const int8_t* s = in.data();
  int8_t prev = 0;
  for (uint32_t x = 0; x < width; ++x) {
    out[x] = zigzag8(int8_t(s[x] - prev));
    prev = s[x];
  }
  for (uint32_t y = 1; y < height; ++y) {
    const size_t r = size_t(y) * width;
    const int8_t* cur = s + r;
    const int8_t* up = cur - width;
    out[r] = zigzag8(int8_t(cur[0] - up[0]));
    for (uint32_t x = 1; x < width; ++x) {
      const int32_t p = med(cur[x - 1], up[x], up[x - 1]);
      out[r + x] = zigzag8(int8_t(cur[x] - p));
    }
  }
}

void med_inverse_i8(std::span<const uint8_t> plane, uint32_t width, uint32_t height, std::span<int8_t> out) {
  int8_t* s = out.data();
  int8_t prev = 0;
  for (uint32_t x = 0; x < width; ++x) {
    prev = int8_t(prev + unzigzag8(plane[x]));
    s[x] = prev;
  }
  for (uint32_t y = 1; y < height; ++y) {
    const size_t r = size_t(y) * width;
    int8_t* cur = s + r;
    const int8_t* up = cur - width;
    cur[0] = int8_t(up[0] + unzigzag8(plane[r]));
    for (uint32_t x = 1; x < width; ++x) {
      const int32_t p = med(cur[x - 1], up[x], up[x - 1]);
      cur[x] = int8_t(p + unzigzag8(plane[r + x]));
    }
  }
}

}  // namespace loam::codec
