#include "protocol/stamps/stamp.h"

namespace loam {

const char* to_string(StampKind kind) {
  switch (kind) {
    case StampKind::kTexture: return "texture";
    case StampKind::kGaussian: return "gaussian";
    case StampKind::kCrater: return "crater";
    case StampKind::kFootprint: return "footprint";
    case StampKind::kFlatten: return "flatten";
    case StampKind::kShockwave: return "shockwave";
  }
  return "?";
}

const char* to_string(BlendMode mode) {
  switch (mode) {
    case BlendMode::kAdd: return "add";
    case BlendMode::kSubtract: return "subtract";
    case BlendMode::kMin: return "min";
    case BlendMode::kMax: return "max";
  }
  return "?";
}

}  // namespace loam
