#include "client/render/terrain_look.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <vector>

#include "client/render/reversed_depth.h"
#include "client/scene/material_textures.h"
#include "gpu/egl_context.h"

namespace loam::render {

namespace {

constexpr int32_t kMaterialTextureSize = 256;
// Material texture scales (meters per repeat): two, at an irrational ratio and turned against
// each other, so neither's repetition lines up; and a slow variation that mixes them
// (shaders/terrain_shading.glsl divides by the same).
constexpr double kMaterialScaleA = 5.3, kMaterialScaleB = 37.0, kMaterialScaleMacro = 431.0;
constexpr double kMaterialTurnB = 0.6458;  // radians (37 degrees)

// (x, y) / scale, turned by `turn`, as a phase in [0, 1): the texture coordinate of an anchor
// (world meters), so a fragment's coordinate is phase + its offset from the anchor / scale,
// exact however far the anchor is.
std::array<float, 2> tile_phase(double x, double y, double scale, double turn) {
  const double c = std::cos(turn), s = std::sin(turn);
  const double u = (c * x - s * y) / scale, v = (s * x + c * y) / scale;
  return {float(u - std::floor(u)), float(v - std::floor(v))};
}

}  // namespace

Result<TerrainLook> TerrainLook::create(const TerrainLookConfig& config) {
  if (!(config.anisotropy == 0.0f || (config.anisotropy >= 1.0f && config.anisotropy <= 16.0f))) {
    return make_error(ErrorCode::kInvalidArgument, "clipmap.anisotropy", "must be 0 (auto) or 1..16");
  }
  if (config.shadows && (config.shadow_size < 64 || config.shadow_size > 8192)) {
    return make_error(ErrorCode::kInvalidArgument, "clipmap.shadow_size", "must be 64..8192");
  }
  TerrainLook look;
  look.config_ = config;
  look.set_sun(config.sun_azimuth_degrees, config.sun_elevation_degrees);
  if (config.materials) {
    const int32_t size = kMaterialTextureSize;
    const int32_t mips = std::bit_width(uint32_t(size));
    look.materials_ = gpu::make_texture(GL_TEXTURE_2D_ARRAY);
    const GLuint m = look.materials_.get();
    glTextureStorage3D(m, mips, GL_RGBA8, size, size, scene::kMaterialCount);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    for (int32_t k = 0; k < scene::kMaterialCount; ++k) {
      const std::vector<uint8_t> texels = scene::material_texture(scene::Material(k), size);
      glTextureSubImage3D(m, 0, 0, 0, k, size, size, 1, GL_RGBA, GL_UNSIGNED_BYTE, texels.data());
    }
    glGenerateTextureMipmap(m);
    glTextureParameteri(m, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(m, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(m, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(m, GL_TEXTURE_WRAP_T, GL_REPEAT);
    // Anisotropic filtering keeps grazing views sharp without shimmer where the driver has it.
    look.anisotropy_ = config.anisotropy;
    if (look.anisotropy_ == 0.0f) {
      const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
      look.anisotropy_ = renderer != nullptr && gpu::is_software_renderer(renderer) ? 1.0f : 8.0f;
    }
    if (!epoxy_has_gl_extension("GL_EXT_texture_filter_anisotropic") &&
        !epoxy_has_gl_extension("GL_ARB_texture_filter_anisotropic")) {
      look.anisotropy_ = 1.0f;
    }
    if (look.anisotropy_ > 1.0f) glTextureParameterf(m, GL_TEXTURE_MAX_ANISOTROPY_EXT, look.anisotropy_);
  }
  if (config.shadows) {
    look.shadow_map_ = gpu::make_texture(GL_TEXTURE_2D);
    const GLuint s = look.shadow_map_.get();
    glTextureStorage2D(s, 1, GL_DEPTH_COMPONENT32F, config.shadow_size, config.shadow_size);
    glTextureParameteri(s, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(s, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(s, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(s, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    // Reversed depth: lit where the fragment is at least as near the sun as the stored depth.
    glTextureParameteri(s, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    glTextureParameteri(s, GL_TEXTURE_COMPARE_FUNC, GL_GEQUAL);
    GLuint fbo = 0;
    glCreateFramebuffers(1, &fbo);
    look.shadow_fbo_ = gpu::GlFramebuffer(fbo);
    glNamedFramebufferTexture(fbo, GL_DEPTH_ATTACHMENT, s, 0);
    glNamedFramebufferDrawBuffer(fbo, GL_NONE);
    if (glCheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      return make_error(ErrorCode::kUnsupported, "clipmap.shadows", "the shadow framebuffer is incomplete");
    }
  }
  look.block_.emplace(1);
  return look;
}

Status TerrainLook::verify(GLuint program) {
  return gpu::verify_uniform_block(program, "TerrainShading", sizeof(TerrainShadingBlock),
                                   kTerrainShadingMembers);
}

glm::vec3 TerrainLook::sun_dir() const {
  const float az = glm::radians(config_.sun_azimuth_degrees),
              el = glm::radians(config_.sun_elevation_degrees);
  // Azimuth clockwise from north, in the render frame (x east, y north).
  return {std::sin(az) * std::cos(el), std::cos(az) * std::cos(el), std::sin(el)};
}

void TerrainLook::set_sun(float azimuth_degrees, float elevation_degrees) {
  config_.sun_azimuth_degrees = azimuth_degrees;
  config_.sun_elevation_degrees = std::clamp(elevation_degrees, -10.0f, 90.0f);
}

TerrainShadingBlock TerrainLook::frame(const WorldParams& p, int64_t anchor_x, int64_t anchor_y,
                                       double min_height_m, double max_height_m,
                                       double view_distance_m) const {
  TerrainShadingBlock b{};
  const glm::vec3 sun = sun_dir();
  b.sun_dir[0] = sun.x, b.sun_dir[1] = sun.y, b.sun_dir[2] = sun.z;
  b.sea_level = float(-p.height_offset);
  b.fog_color[0] = 0.50f, b.fog_color[1] = 0.60f, b.fog_color[2] = 0.75f;
  b.fog_density = float(1.0 / (view_distance_m * 1.5));
  b.height_range[0] = float(min_height_m), b.height_range[1] = float(max_height_m);
  b.meters_per_sample = float(p.meters_per_sample);
  if (config_.materials) {
    // Texture phases of the anchor, so texture coordinates stay exact far out.
    const double axm = double(anchor_x) * p.meters_per_sample, aym = double(anchor_y) * p.meters_per_sample;
    const auto pa = tile_phase(axm, aym, kMaterialScaleA, 0.0),
               pb = tile_phase(axm, aym, kMaterialScaleB, kMaterialTurnB);
    const auto pm = tile_phase(axm, aym, kMaterialScaleMacro, 0.0);
    b.tex_phase[0] = pa[0], b.tex_phase[1] = pa[1], b.tex_phase[2] = pb[0], b.tex_phase[3] = pb[1];
    b.macro_phase[0] = pm[0], b.macro_phase[1] = pm[1];
    b.materials_on = 1;
  }
  return b;
}

std::optional<scene::SunShadowFrame> TerrainLook::shadow_frame(const scene::Camera& camera,
                                                               const WorldParams& p, double min_height_m,
                                                               double max_height_m,
                                                               double view_distance_m) const {
  if (!config_.shadows || config_.sun_elevation_degrees <= 0.5f) return std::nullopt;
  const double radius =
      config_.shadow_distance_m > 0 ? config_.shadow_distance_m : std::min(view_distance_m, 3000.0);
  return scene::sun_shadow_frame(camera, glm::dvec3(sun_dir()), radius, p.height_offset + min_height_m,
                                 p.height_offset + max_height_m, config_.shadow_size);
}

void TerrainLook::render_shadow(const scene::SunShadowFrame& shadow, TerrainShadingBlock& block,
                                const std::function<void()>& draw_depth) const {
  GLint target_fbo = 0;
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &target_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo_.get());
  glViewport(0, 0, config_.shadow_size, config_.shadow_size);
  clear_depth_reversed();
  glClear(GL_DEPTH_BUFFER_BIT);
  {
    const ReversedDepthTest depth_test;
    // Slope-scaled offset away from the sun (reversed depth: toward 0) against acne.
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(-1.5f, -2.0f);
    draw_depth();
    glDisable(GL_POLYGON_OFFSET_FILL);
  }
  glBindFramebuffer(GL_FRAMEBUFFER, GLuint(target_fbo));
  std::copy_n(&shadow.light_view_proj[0][0], 16, block.light_view_proj);
  block.shadows_on = 1;
  block.shadow_texel = float(1.0 / config_.shadow_size);
}

void TerrainLook::bind(const TerrainShadingBlock& block) {
  block_->write(0, block);
  block_->bind(kTerrainShadingBinding);
  if (materials_) glBindTextureUnit(kMaterialsUnit, materials_.get());
  if (shadow_map_) glBindTextureUnit(kShadowUnit, shadow_map_.get());
}

size_t TerrainLook::gpu_bytes() const {
  size_t bytes = 0;
  // RGBA8 layers with their mip chains (a third more).
  if (config_.materials)
    bytes += size_t(scene::kMaterialCount) * kMaterialTextureSize * kMaterialTextureSize * 4 * 4 / 3;
  if (config_.shadows) bytes += size_t(config_.shadow_size) * size_t(config_.shadow_size) * 4;
  return bytes;
}

}  // namespace loam::render
