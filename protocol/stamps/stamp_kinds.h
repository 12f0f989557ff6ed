// The stamp kinds as one table: a row per StampKind saying what the kind is and what it needs.
// Validation (which optional fields a kind uses), the event rule (per-sample kinds apply at every
// mip), the GPU stamper (which programs to build, the contact pre-pass) and the shaders (whose
// kind constants are generated from the rows) all read it, so a kind is added in one row here
// plus its kernel. docs/stamps.md's kinds table is held to it by the drift test.
#pragma once

#include <array>
#include <cstddef>
#include <string_view>

#include "protocol/stamps/stamp.h"

namespace loam {

struct StampKindRow {
  StampKind kind;
  std::string_view name;      // to_string, the logs' JSON, docs/stamps.md
  std::string_view constant;  // the shaders' constant for it: KIND_<constant>
  bool per_sample;            // a sample's new value depends on its position and old value alone
  bool needs_contact;         // a pre-pass finds the first point of contact (over every sample)
  bool uses_texture;          // texture_id names a registered image
  bool uses_shape;            // shape (rim, sole, edge softness)
  bool uses_wave;             // damping, speed, steps
  bool own_combination;       // combines old and new itself: the blend must be add
  bool uses_target;           // target, whatever the blend
};

inline constexpr std::array<StampKindRow, kStampKindCount> kStampKinds{{
    // kind, name, constant, per-sample, needs contact, uses texture, shape, wave, own combination, target
    {StampKind::kTexture, "texture", "TEXTURE", true, false, true, false, false, false, false},
    {StampKind::kGaussian, "gaussian", "GAUSSIAN", true, false, false, false, false, false, false},
    {StampKind::kCrater, "crater", "CRATER", true, false, false, true, false, false, false},
    {StampKind::kFootprint, "footprint", "FOOTPRINT", true, true, false, true, false, true, false},
    {StampKind::kFlatten, "flatten", "FLATTEN", true, false, false, true, false, true, true},
    {StampKind::kShockwave, "shockwave", "SHOCKWAVE", false, false, false, false, true, true, false},
}};

constexpr bool stamp_kinds_in_id_order() {
  for (size_t i = 0; i < kStampKinds.size(); ++i) {
    if (size_t(kStampKinds[i].kind) != i) return false;
  }
  return true;
}
static_assert(stamp_kinds_in_id_order(), "kStampKinds is indexed by StampKind");

// The row of a kind that passed check_quantized (an id below kStampKindCount).
constexpr const StampKindRow& stamp_kind(StampKind kind) { return kStampKinds[size_t(kind)]; }

}  // namespace loam
