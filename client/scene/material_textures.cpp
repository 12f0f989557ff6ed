#include "client/scene/material_textures.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace loam::scene {

const char* to_string(Material m) {
  switch (m) {
    case Material::kRock: return "rock";
    case Material::kGrass: return "grass";
    case Material::kSand: return "sand";
    case Material::kSnow: return "snow";
    case Material::kEarth: return "earth";
  }
  return "?";
}

namespace {

uint32_t hash(uint32_t x, uint32_t y, uint32_t seed) {
  uint32_t h = x * 0x8DA6B343u ^ y * 0xD8163841u ^ seed * 0xCB1AB31Fu;
  h ^= h >> 15;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12;
  h *= 0x297A2D39u;
  h ^= h >> 15;
  return h;
}

double lattice(int64_t x, int64_t y, int64_t period, uint32_t seed) {
  const auto wrap = [&](int64_t v) { return uint32_t(((v % period) + period) % period); };
  return double(hash(wrap(x), wrap(y), seed) & 0xFFFFFF) / double(0xFFFFFF);
}

// Value noise of `period` cells across the texture (u, v in [0, 1)): periodic, so the texture
// tiles without a seam. Smoothstep-interpolated, in [0, 1].
double value_noise(double u, double v, int64_t period, uint32_t seed) {
  const double x = u * double(period), y = v * double(period);
  const int64_t x0 = int64_t(std::floor(x)), y0 = int64_t(std::floor(y));
  const double fx = x - double(x0), fy = y - double(y0);
  const double sx = fx * fx * (3 - 2 * fx), sy = fy * fy * (3 - 2 * fy);
  const double a = lattice(x0, y0, period, seed), b = lattice(x0 + 1, y0, period, seed);
  const double c = lattice(x0, y0 + 1, period, seed), d = lattice(x0 + 1, y0 + 1, period, seed);
  return (a * (1 - sx) + b * sx) * (1 - sy) + (c * (1 - sx) + d * sx) * sy;
}

// Fractal sum of octaves from `period` cells, each twice as fine and half as strong; [0, 1].
double fbm(double u, double v, int64_t period, int octaves, uint32_t seed) {
  double sum = 0, weight = 0, amp = 1;
  for (int o = 0; o < octaves; ++o, period *= 2, amp *= 0.5) {
    sum += amp * value_noise(u, v, period, seed + uint32_t(o) * 101u);
    weight += amp;
  }
  return sum / weight;
}

struct Rgb {
  double r, g, b;
};

// One texel of a material: a brightness pattern and a slight tint around (1, 1, 1).
Rgb texel(Material m, double u, double v) {
  switch (m) {
    case Material::kRock: {
      // Strata: ridged noise stretched along u, broken by a coarser fbm; cracks darker.
      const double warp = fbm(u, v, 4, 3, 11);
      const double strata =
          1.0 - std::abs(2.0 * value_noise(u * 0.25 + 0.1 * warp, v + 0.35 * warp, 16, 12) - 1.0);
      const double grain = fbm(u, v, 32, 3, 13);
      const double crack = std::pow(1.0 - std::abs(2.0 * fbm(u, v, 8, 2, 14) - 1.0), 12.0);
      const double l = 0.55 * warp + 0.25 * strata + 0.35 * grain - 0.45 * crack + 0.05;
      return {l * 1.02, l, l * 0.96};
    }
    case Material::kGrass: {
      // Clumps and blades: mid fbm, fine high-contrast speckle, some straw-coloured patches.
      const double clump = fbm(u, v, 8, 3, 21), blade = value_noise(u, v, 128, 22),
                   straw = fbm(u, v, 16, 2, 23);
      const double l = 0.35 + 0.35 * clump + 0.3 * blade;
      const double s = std::clamp((straw - 0.55) * 4.0, 0.0, 1.0);
      return {l * (0.95 + 0.25 * s), l * (1.05 - 0.05 * s), l * (0.90 - 0.10 * s)};
    }
    case Material::kSand: {
      // Ripples across v, bent by a low fbm, over fine grain.
      const double bend = fbm(u, v, 4, 2, 31);
      const double ripple = 0.5 + 0.5 * std::sin(2.0 * std::numbers::pi * (24.0 * v + 3.0 * bend));
      const double grain = value_noise(u, v, 128, 32);
      const double l = 0.62 + 0.12 * ripple + 0.18 * (grain - 0.5) + 0.2 * (bend - 0.5);
      return {l, l * 0.98, l * 0.94};
    }
    case Material::kSnow: {
      // Soft drifts, little contrast.
      const double drift = fbm(u, v, 4, 4, 41), sparkle = value_noise(u, v, 128, 42);
      const double l = 0.78 + 0.25 * (drift - 0.5) + 0.06 * (sparkle - 0.5);
      return {l * 0.98, l * 0.99, l * 1.02};
    }
    case Material::kEarth: {
      // Freshly turned soil: clods (cells of varied brightness), pebbles, fine crumbs.
      const double clods = value_noise(u, v, 24, 51), lumps = fbm(u, v, 8, 3, 52),
                   crumb = value_noise(u, v, 128, 53);
      const double pebble = std::pow(std::max(0.0, value_noise(u, v, 48, 54) - 0.72) / 0.28, 2.0);
      const double l = 0.28 + 0.25 * clods + 0.25 * lumps + 0.12 * crumb + 0.35 * pebble;
      return {l * 1.05, l, l * 0.92};
    }
  }
  return {0.5, 0.5, 0.5};
}

}  // namespace

std::vector<uint8_t> material_texture(Material m, int32_t size) {
  std::vector<double> lum(size_t(size) * size_t(size) * 3);
  for (int32_t y = 0; y < size; ++y) {
    for (int32_t x = 0; x < size; ++x) {
      const Rgb c = texel(m, (x + 0.5) / size, (y + 0.5) / size);
      const size_t i = (size_t(y) * size_t(size) + size_t(x)) * 3;
      lum[i] = c.r, lum[i + 1] = c.g, lum[i + 2] = c.b;
    }
  }
  // Mean brightness to one half: the shader's 2 x texel then keeps the material's colour.
  double mean = 0;
  for (double v : lum) mean += v;
  mean /= double(lum.size());
  std::vector<uint8_t> out(size_t(size) * size_t(size) * 4);
  for (size_t p = 0; p < out.size() / 4; ++p) {
    for (int k = 0; k < 3; ++k)
      out[4 * p + size_t(k)] =
          uint8_t(std::clamp(lum[3 * p + size_t(k)] * (0.5 / mean) * 255.0 + 0.5, 0.0, 255.0));
    out[4 * p + 3] = 255;
  }
  return out;
}

}  // namespace loam::scene
