// Which stamp backend to run: the user's choice (auto | gpu | cpu) and what EGL offered.
// Header-only and free of GL so the rule is unit-tested without a context
// (tests/unit/backend_choice_test.cpp); gpu/stamp_backend.cpp applies it.
//   auto: a hardware GPU when EGL offers one, otherwise the CPU reference (llvmpipe is slower
//         than the CPU reference here, so auto never picks it);
//   gpu:  EGL whatever renderer it gives, llvmpipe included (the GL tests rely on this); no
//         EGL display is an error, never a silent fallback;
//   cpu:  the CPU reference, without touching EGL.
#pragma once

#include <string_view>

#include "protocol/result.h"

namespace loam::gpu {

enum class BackendKind { kAuto, kGpu, kCpu };

inline const char* to_string(BackendKind k) {
  switch (k) {
    case BackendKind::kAuto: return "auto";
    case BackendKind::kGpu: return "gpu";
    case BackendKind::kCpu: return "cpu";
  }
  return "?";
}

inline Result<BackendKind> parse_backend_kind(std::string_view s) {
  if (s == "auto") return BackendKind::kAuto;
  if (s == "gpu") return BackendKind::kGpu;
  if (s == "cpu") return BackendKind::kCpu;
  return make_error(ErrorCode::kBadEnum, "backend",
                    "expected auto, gpu or cpu, got \"" + std::string(s) + "\"");
}

// What EGL gave when asked (nothing asked for kCpu).
struct EglProbe {
  bool opened = false;    // an OpenGL 4.5 core context was created
  bool software = false;  // ... and its renderer is a CPU rasterizer (llvmpipe)
};

enum class BackendDecision { kCpu, kGpu, kError };

inline BackendDecision decide_backend(BackendKind requested, const EglProbe& egl) {
  switch (requested) {
    case BackendKind::kCpu: return BackendDecision::kCpu;
    case BackendKind::kGpu: return egl.opened ? BackendDecision::kGpu : BackendDecision::kError;
    case BackendKind::kAuto:
      return egl.opened && !egl.software ? BackendDecision::kGpu : BackendDecision::kCpu;
  }
  return BackendDecision::kError;
}

}  // namespace loam::gpu
