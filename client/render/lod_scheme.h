// Which level-of-detail scheme draws a viewer's terrain: the error-driven clipmap (blocks
// chosen for a screen-space error budget, error_clipmap_renderer.h) or the classic geometry
// clipmap (rings at fixed distances, clipmap_renderer.h). `loam-client view --lod` chooses.
#pragma once

namespace loam::render {

enum class LodScheme { kError, kClassic };

inline const char* to_string(LodScheme scheme) { return scheme == LodScheme::kError ? "error" : "classic"; }

}  // namespace loam::render
