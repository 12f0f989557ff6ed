#include "gpu/normal_pass.h"

#include "gpu/gl_debug.h"
#include "gpu/shader_library.h"

namespace loam::gpu {

namespace {

constexpr GLuint kNormalBinding = 3;  // NormalParams' binding in fd4_normal.glsl

const UniformBlockMember kNormalMembers[] = {
    LOAM_UNIFORM_MEMBER(NormalBlock, rect, "n_rect"),
    LOAM_UNIFORM_MEMBER(NormalBlock, world_lo, "n_world_lo"),
    LOAM_UNIFORM_MEMBER(NormalBlock, world_size, "n_world_size"),
    LOAM_UNIFORM_MEMBER(NormalBlock, region_lo, "n_region_lo"),
    LOAM_UNIFORM_MEMBER(NormalBlock, region_base, "n_region_base"),
    LOAM_UNIFORM_MEMBER(NormalBlock, tex_size, "n_tex_size"),
    LOAM_UNIFORM_MEMBER(NormalBlock, pad0, "n_pad0"),
    LOAM_UNIFORM_MEMBER(NormalBlock, height_offset, "n_height_offset"),
    LOAM_UNIFORM_MEMBER(NormalBlock, meters_per_unit, "n_meters_per_unit"),
    LOAM_UNIFORM_MEMBER(NormalBlock, spacing, "n_spacing"),
};

// A normal pass's program: its parameters in the checked block, nothing looked up by name.
Result<GlProgram> build_normal_program(std::span<const std::string_view> files,
                                       std::span<const ShaderDefine> defines = {}) {
  auto program = build_compute_program_from(files, defines);
  if (!program) return program.error();
  LOAM_TRY(verify_uniform_block(program->get(), "NormalParams", sizeof(NormalBlock), kNormalMembers));
  LOAM_TRY(verify_no_loose_uniforms(program->get()));
  return program;
}

Result<GlProgram> build_normal_program(std::string_view file) {
  const std::string_view files[] = {"fd4_normal.glsl", file};
  return build_normal_program(files);
}

void dispatch(GLuint program, const UniformBuffer<NormalBlock>& block, const RectI& rect) {
  glUseProgram(program);
  block.bind(kNormalBinding);
  glDispatchCompute(GLuint((rect.width() + 7) / 8), GLuint((rect.height() + 7) / 8), 1);
}

}  // namespace

RectI normals_rect_for(const WorldParams& params, const RectI& changed) {
  if (changed.empty()) return {};
  return RectI{changed.x0 - 4, changed.y0 - 4, changed.x1 + 4, changed.y1 + 4}.intersect(
      params.sample_rect());
}

Result<std::unique_ptr<NormalPass>> NormalPass::create(const WorldParams& params) {
  install_gl_debug_output();
  std::unique_ptr<NormalPass> n(new NormalPass());
  n->params_ = params;
  n->world_ = params.sample_rect();
  auto program = build_normal_program("normals.comp.glsl");
  if (!program) return program.error();
  n->program_ = std::move(*program);
  n->normals_ = make_texture(GL_TEXTURE_2D);
  glTextureStorage2D(n->normals_.get(), 1, GL_R32UI, GLsizei(n->world_.width()), GLsizei(n->world_.height()));
  return n;
}

void NormalPass::update(GLuint heights, const RectI& rect) {
  const RectI r = rect.intersect(world_);
  if (r.empty()) return;
  NormalBlock b{};
  const RectI local = r.translated(-world_.x0, -world_.y0);
  b.rect[0] = int32_t(local.x0), b.rect[1] = int32_t(local.y0), b.rect[2] = int32_t(local.x1),
  b.rect[3] = int32_t(local.y1);
  b.world_size[0] = int32_t(world_.width()), b.world_size[1] = int32_t(world_.height());
  b.height_offset = params_.height_offset;
  b.meters_per_unit = params_.meters_per_unit;
  b.spacing = params_.meters_per_sample;
  block_.write(0, b);
  // Heights written by image stores must be visible to texelFetch.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);
  glBindTextureUnit(0, heights);
  glBindImageTexture(1, normals_.get(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_R32UI);
  dispatch(program_.get(), block_, r);
}

std::vector<uint32_t> NormalPass::read(const RectI& rect) {
  const RectI r = rect.intersect(world_);
  std::vector<uint32_t> out(size_t(r.area()));
  if (r.empty()) return out;
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glGetTextureSubImage(normals_.get(), 0, GLint(r.x0 - world_.x0), GLint(r.y0 - world_.y0), 0,
                       GLsizei(r.width()), GLsizei(r.height()), 1, GL_RED_INTEGER, GL_UNSIGNED_INT,
                       GLsizei(out.size() * 4), out.data());
  return out;
}

Result<GlProgram> build_event_level_normal_program() {
  // Every level's parameters come from an array (gpu/level_fill.h), not NormalParams.
  const std::string_view files[] = {"fd4_normal.glsl", "level_event.glsl", "level_normals.comp.glsl"};
  const ShaderDefine defines[] = {{"FROM_EVENT", "1"}, {"NORMAL_PARAMS_PER_LEVEL", "1"}};
  auto program = build_compute_program_from(files, defines);
  if (!program) return program.error();
  LOAM_TRY(verify_no_loose_uniforms(program->get()));
  return program;
}

Result<LevelNormalPass> LevelNormalPass::create() {
  auto program = build_normal_program("level_normals.comp.glsl");
  if (!program) return program.error();
  LevelNormalPass pass;
  pass.program_ = std::move(*program);
  return pass;
}

NormalBlock level_normal_block(int32_t tex_size, const RectI& region, const RectI& rect, const RectI& world,
                               const WorldParams& params, double spacing_m) {
  NormalBlock b{};
  b.rect[0] = int32_t(rect.x0), b.rect[1] = int32_t(rect.y0), b.rect[2] = int32_t(rect.x1),
  b.rect[3] = int32_t(rect.y1);
  b.world_lo[0] = int32_t(world.x0), b.world_lo[1] = int32_t(world.y0);
  b.world_size[0] = int32_t(world.width()), b.world_size[1] = int32_t(world.height());
  b.region_lo[0] = int32_t(region.x0), b.region_lo[1] = int32_t(region.y0);
  b.region_base[0] = int32_t(floor_mod(region.x0, tex_size)),
  b.region_base[1] = int32_t(floor_mod(region.y0, tex_size));
  b.tex_size = tex_size;
  b.height_offset = params.height_offset;
  b.meters_per_unit = params.meters_per_unit;
  b.spacing = spacing_m;
  return b;
}

void LevelNormalPass::update(GLuint heights, GLuint normals, int32_t tex_size, const RectI& region,
                             const RectI& rect, const RectI& world, const WorldParams& params,
                             double spacing_m) {
  if (rect.empty() || world.empty()) return;
  block_.write(0, level_normal_block(tex_size, region, rect, world, params, spacing_m));
  glBindTextureUnit(0, heights);
  glBindImageTexture(1, normals, 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RG16_SNORM);
  dispatch(program_.get(), block_, rect);
}

}  // namespace loam::gpu
