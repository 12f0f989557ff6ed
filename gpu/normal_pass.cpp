#include "gpu/normal_pass.h"

#include "gpu/gl_debug.h"
#include "gpu/shader_library.h"

namespace loam::gpu {

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
  const std::string_view files[] = {"fd4_normal.glsl", "normals.comp.glsl"};
  auto program = build_compute_program_from(files);
  if (!program) return program.error();
  n->program_ = std::move(*program);
  n->normals_ = make_texture(GL_TEXTURE_2D);
  glTextureStorage2D(n->normals_.get(), 1, GL_R32UI, GLsizei(n->world_.width()), GLsizei(n->world_.height()));
  return n;
}

void NormalPass::update(GLuint heights, const RectI& rect) {
  const RectI r = rect.intersect(world_);
  if (r.empty()) return;
  const GLuint p = program_.get();
  glUseProgram(p);
  glProgramUniform2i(p, glGetUniformLocation(p, "world_size"), GLint(world_.width()), GLint(world_.height()));
  glProgramUniform4i(p, glGetUniformLocation(p, "rect"), GLint(r.x0 - world_.x0), GLint(r.y0 - world_.y0),
                     GLint(r.x1 - world_.x0), GLint(r.y1 - world_.y0));
  glProgramUniform1d(p, glGetUniformLocation(p, "height_offset"), params_.height_offset);
  glProgramUniform1d(p, glGetUniformLocation(p, "meters_per_unit"), params_.meters_per_unit);
  glProgramUniform1d(p, glGetUniformLocation(p, "spacing"), params_.meters_per_sample);
  // Heights written by image stores must be visible to texelFetch.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);
  glBindTextureUnit(0, heights);
  glBindImageTexture(1, normals_.get(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_R32UI);
  glDispatchCompute(GLuint((r.width() + 7) / 8), GLuint((r.height() + 7) / 8), 1);
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

Result<LevelNormalPass> LevelNormalPass::create() {
  const std::string_view files[] = {"fd4_normal.glsl", "level_normals.comp.glsl"};
  auto program = build_compute_program_from(files);
  if (!program) return program.error();
  LevelNormalPass pass;
  pass.program_ = std::move(*program);
  return pass;
}

void LevelNormalPass::update(GLuint heights, GLuint normals, int32_t tex_size, const RectI& region,
                             const RectI& rect, const RectI& world, const WorldParams& params,
                             double spacing_m) const {
  if (rect.empty() || world.empty()) return;
  const GLuint p = program_.get();
  glUseProgram(p);
  glProgramUniform1i(p, glGetUniformLocation(p, "tex_size"), tex_size);
  glProgramUniform2i(p, glGetUniformLocation(p, "region_lo"), GLint(region.x0), GLint(region.y0));
  glProgramUniform2i(p, glGetUniformLocation(p, "region_base"), GLint(floor_mod(region.x0, tex_size)),
                     GLint(floor_mod(region.y0, tex_size)));
  glProgramUniform4i(p, glGetUniformLocation(p, "rect"), GLint(rect.x0), GLint(rect.y0), GLint(rect.x1),
                     GLint(rect.y1));
  glProgramUniform2i(p, glGetUniformLocation(p, "world_lo"), GLint(world.x0), GLint(world.y0));
  glProgramUniform2i(p, glGetUniformLocation(p, "world_size"), GLint(world.width()), GLint(world.height()));
  glProgramUniform1d(p, glGetUniformLocation(p, "height_offset"), params.height_offset);
  glProgramUniform1d(p, glGetUniformLocation(p, "meters_per_unit"), params.meters_per_unit);
  glProgramUniform1d(p, glGetUniformLocation(p, "spacing"), spacing_m);
  glBindTextureUnit(0, heights);
  glBindImageTexture(1, normals, 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RG16_SNORM);
  glDispatchCompute(GLuint((rect.width() + 7) / 8), GLuint((rect.height() + 7) / 8), 1);
}

}  // namespace loam::gpu
