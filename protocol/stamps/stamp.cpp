#include "protocol/stamps/stamp.h"

#include "protocol/stamps/stamp_kinds.h"

namespace loam {

const char* to_string(StampKind kind) {
  // The names are string literals, so the views are terminated.
  return size_t(kind) < kStampKinds.size() ? stamp_kind(kind).name.data() : "?";
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
