// What the patch renderers (error_clipmap_renderer.h here; the `lod` suite's geomipmap and
// quadtree renderers in bench/lod/) share: the frame block and its fill, the instanced
// per-patch attributes, their vertex array, the index buffer that holds each patch
// triangulation once (built on first use, in one growing GL buffer), and the upload of a
// frame's instances. Needs the GL 4.5 context current.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <string_view>
#include <vector>

#include "client/lod/geomipmap.h"
#include "client/scene/camera.h"
#include "gpu/gl_handle.h"
#include "gpu/uniform_block.h"
#include "protocol/result.h"

namespace loam::terrain {
class HeightSource;
}  // namespace loam::terrain

namespace loam::render {

// The frame block of every patch renderer's vertex stage (shaders/geomipmap_blocks.glsl).
struct GeomipmapFrameBlock {
  float view_proj[16];
  int32_t grid[4];  // patch size, levels, world width, world height
  float scale[4];   // meters per sample, meters per unit, height offset minus the camera's z, -
  float sun[4];
  float height_range[4];
};
static_assert(offsetof(GeomipmapFrameBlock, grid) == 64);
static_assert(sizeof(GeomipmapFrameBlock) == 128);

// shaders/geomipmap_blocks.glsl's GeomipmapFrame, member by member (also the quadtree's).
inline constexpr std::array kGeomipmapFrameMembers = {
    LOAM_UNIFORM_MEMBER(GeomipmapFrameBlock, view_proj, "g_view_proj"),
    LOAM_UNIFORM_MEMBER(GeomipmapFrameBlock, grid, "g_grid"),
    LOAM_UNIFORM_MEMBER(GeomipmapFrameBlock, scale, "g_scale"),
    LOAM_UNIFORM_MEMBER(GeomipmapFrameBlock, sun, "g_sun"),
    LOAM_UNIFORM_MEMBER(GeomipmapFrameBlock, height_range, "g_height_range"),
};

// Milliseconds since t0: the renderers' CPU timings.
inline double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The fragment stage of the `lod` suite's patch renderers: patch_shading.glsl's colour bands
// with the triangles' own normals.
inline constexpr std::array<std::string_view, 3> kPatchFragment = {
    "geomipmap_blocks.glsl", "patch_shading.glsl", "geomipmap.frag.glsl"};

// The program of a patch vertex stage (after geomipmap_blocks.glsl) and `fragment_files`, its
// GeomipmapFrame block checked member by member and nothing loose (a renderer with blocks of
// its own verifies them first: `extra_blocks`).
Result<gpu::GlProgram> build_patch_program(std::span<const std::string_view> vertex_files,
                                           std::span<const std::string_view> fragment_files = kPatchFragment,
                                           const std::function<Status(GLuint)>& extra_blocks = {});

// The whole mip-0 world as the full-resolution schemes keep it on the CPU, and its height range.
struct WorldHeights {
  RectI rect;  // the source's mip-0 samples (global grid)
  std::vector<uint16_t> samples;
  double min_height_m = 0, max_height_m = 0;
  static WorldHeights read(const terrain::HeightSource& source);
  lod::HeightGrid grid() const { return {samples, rect.width(), rect.height()}; }
  // Re-reads `r` (inside rect) from the source; returns the fresh samples, row-major.
  std::vector<uint16_t> refresh(const terrain::HeightSource& source, const RectI& r);
};

// The instanced attributes of shaders/geomipmap.vert.glsl and error_clipmap.vert.glsl.
struct PatchInstance {
  int32_t patch[4];  // origin (the patch's grid), level, -
  int32_t edge_level[4];
  float edge_morph[4];
  float misc[4];  // morph, origin relative to the camera (render frame x, y), spacing (m)
};
static_assert(sizeof(PatchInstance) == 64);

// A vertex array reading PatchInstance attributes 0-3 per instance from binding 0, and no
// per-vertex attribute (the stages derive the local vertex from gl_VertexID).
gpu::GlVertexArray make_patch_vertex_array();

// Patch triangulations by key, each uploaded once into one element buffer bound to `vao`.
class PatchIndexBuffer {
 public:
  using Triangles = std::vector<std::array<uint16_t, 3>>;
  struct Range {
    uint32_t first = 0, count = 0;  // in indices
  };
  explicit PatchIndexBuffer(GLuint vao) : vao_(vao) {}
  Range get(const std::array<int8_t, 5>& key, const std::function<Triangles()>& build);
  size_t bytes() const { return capacity_; }

 private:
  GLuint vao_ = 0;
  gpu::GlBuffer buffer_;
  size_t capacity_ = 0;
  std::vector<uint16_t> data_;
  std::map<std::array<int8_t, 5>, Range> ranges_;
};

// A growing instance buffer bound to binding 0 of `vao`.
class PatchInstanceBuffer {
 public:
  explicit PatchInstanceBuffer(GLuint vao) : vao_(vao) {}
  void upload(const std::vector<PatchInstance>& instances);
  size_t bytes() const { return capacity_; }

 private:
  GLuint vao_ = 0;
  gpu::GlBuffer buffer_;
  size_t capacity_ = 0;
};

// The frame block every patch stage reads: the camera's view-projection, the patch grid
// (vertices per side, levels, world width and height), the height scale relative to the
// camera's height, the sun and the material range.
GeomipmapFrameBlock patch_frame(const glm::mat4& view_proj, std::array<int32_t, 4> grid,
                                double meters_per_sample, double meters_per_unit, double height_offset,
                                const scene::Camera& camera, double min_height_m, double max_height_m);

}  // namespace loam::render
