// Which GPU program a stamp pass runs: a typed key (pass, kind, layer, stage) instead of a
// string, so the stamper's program cache, its start-up build and its passes name programs the
// same way and the compiler checks them.
#pragma once

#include <array>
#include <compare>
#include <cstddef>
#include <cstdint>

#include "protocol/layer.h"
#include "protocol/stamps/stamp.h"

namespace loam::gpu {

// The passes of a stamp: the per-sample stamp and the footprint's contact pre-pass; the
// shockwave's initial pulse, its steps and the final field applied to the pages.
enum class StampPass : uint8_t { kStamp, kContact, kWaveInit, kWaveStep, kWaveApply };
inline constexpr size_t kStampPassCount = 5;

// Where a pass runs: a compute dispatch, or points drawn through the vertex stage (the path a
// CPU rasterizer runs faster).
enum class ShaderStage : uint8_t { kCompute, kVertex };

struct ProgramKey {
  StampPass pass = StampPass::kStamp;
  StampKind kind = StampKind::kGaussian;
  Layer layer = Layer::kCoarse;
  ShaderStage stage = ShaderStage::kCompute;
  auto operator<=>(const ProgramKey&) const = default;
};

// The shockwave step and apply passes' parameters: mirrors the WaveParams block of
// shaders/shockwave.comp.glsl (std140), checked member by member when those programs are built.
struct WaveBlock {
  int32_t active_rect[4];   // interior cells [x0, y0, x1, y1)
  int32_t texel_origin[2];  // apply: the page texel of interior cell (0, 0)
  int32_t stride;           // width + 2
  int32_t nu2_q16, damping_q16;
  int32_t pad[3];
};
static_assert(sizeof(WaveBlock) == 48);

// One value per pass, indexed by StampPass.
template <class T>
struct PerStampPass {
  std::array<T, kStampPassCount> v;
  constexpr const T& operator[](StampPass p) const { return v[size_t(p)]; }
};

}  // namespace loam::gpu
