// Checked uniform blocks (gpu/uniform_block.h): a C++ struct that does not mirror its block,
// by a name, an offset or a member, is an error at creation that says which; a program with a
// uniform outside any block is named.
#include "gpu/uniform_block.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "client/render/clipmap_blocks.h"
#include "client/render/error_clipmap_renderer.h"
#include "client/render/terrain_look.h"
#include "gl_test_context.h"
#include "gpu/normal_pass.h"
#include "gpu/shader_library.h"

namespace loam::gpu {
namespace {

GlProgram clipmap_program() {
  const std::string_view vertex[] = {"clipmap_blocks.glsl", "terrain_shading_block.glsl",
                                     "clipmap.vert.glsl"};
  const std::string_view fragment[] = {"clipmap_blocks.glsl", "terrain_shading_block.glsl",
                                       "terrain_shading.glsl", "clipmap.frag.glsl"};
  auto p = build_graphics_program_from(vertex, fragment);
  EXPECT_TRUE(p.ok()) << p.error().describe();
  return p.ok() ? std::move(*p) : GlProgram();
}

TEST(UniformBlock, TheClipmapBlocksMirrorTheirShaders) {
  LOAM_REQUIRE_GL();
  const GlProgram p = clipmap_program();
  EXPECT_TRUE(verify_uniform_block(p.get(), "ClipmapFrame", sizeof(render::ClipmapFrameBlock),
                                   render::kClipmapFrameMembers)
                  .ok());
  EXPECT_TRUE(verify_uniform_block(p.get(), "ClipmapLevel", sizeof(render::ClipmapLevelBlock),
                                   render::kClipmapLevelMembers)
                  .ok());
  EXPECT_TRUE(verify_uniform_block(p.get(), "TerrainShading", sizeof(render::TerrainShadingBlock),
                                   render::kTerrainShadingMembers)
                  .ok());
  EXPECT_TRUE(verify_no_loose_uniforms(p.get()).ok());
}

TEST(UniformBlock, TheErrorClipmapsBlocksMirrorTheirShaders) {
  LOAM_REQUIRE_GL();
  const std::string_view vertex[] = {"geomipmap_blocks.glsl", "error_clipmap_frame.glsl", "patch_morph.glsl",
                                     "error_clipmap.vert.glsl"};
  const std::string_view fragment[] = {"terrain_shading_block.glsl", "terrain_shading.glsl",
                                       "error_clipmap.frag.glsl"};
  auto p = build_graphics_program_from(vertex, fragment);
  ASSERT_TRUE(p.ok()) << p.error().describe();
  EXPECT_TRUE(verify_uniform_block(p->get(), "ErrorClipmapFrame", sizeof(render::ErrorClipmapFrameBlock),
                                   render::kErrorClipmapFrameMembers)
                  .ok());
  EXPECT_TRUE(verify_uniform_block(p->get(), "TerrainShading", sizeof(render::TerrainShadingBlock),
                                   render::kTerrainShadingMembers)
                  .ok());
  EXPECT_TRUE(verify_no_loose_uniforms(p->get()).ok());
}

TEST(UniformBlock, AMisspeltMemberAWrongOffsetOrAMissingMemberIsNamed) {
  LOAM_REQUIRE_GL();
  const GlProgram p = clipmap_program();
  std::vector<UniformBlockMember> members(render::kClipmapLevelMembers.begin(),
                                          render::kClipmapLevelMembers.end());
  const size_t size = sizeof(render::ClipmapLevelBlock);

  auto misspelt = members;
  misspelt[5].name = "u_spaceing";
  Status st = verify_uniform_block(p.get(), "ClipmapLevel", size, misspelt);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().describe().find("u_spaceing"), std::string::npos) << st.error().describe();

  auto shifted = members;
  shifted[4].offset += 4;
  st = verify_uniform_block(p.get(), "ClipmapLevel", size, shifted);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().describe().find("u_viewer"), std::string::npos) << st.error().describe();

  auto short_list = members;
  short_list.erase(short_list.begin() + 6);  // u_has_coarse
  st = verify_uniform_block(p.get(), "ClipmapLevel", size, short_list);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().describe().find("u_has_coarse"), std::string::npos) << st.error().describe();

  st = verify_uniform_block(p.get(), "ClipmapLevel", size + 16, members);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().describe().find("bytes"), std::string::npos) << st.error().describe();

  st = verify_uniform_block(p.get(), "ClipmapLevle", size, members);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().describe().find("ClipmapLevle"), std::string::npos) << st.error().describe();
}

TEST(UniformBlock, AUniformOutsideABlockIsNamed) {
  LOAM_REQUIRE_GL();
  // The stamp helpers' test shader sets `count` by name; the product's passes read blocks.
  const std::string_view files[] = {"stamp_common.glsl", "stamp_helpers_test.comp.glsl"};
  const ShaderDefine defines[] = {{"KIND", "1"}, {"MODE", "0"}};
  auto p = build_compute_program_from(files, defines);
  ASSERT_TRUE(p.ok()) << p.error().describe();
  const Status st = verify_no_loose_uniforms(p->get());
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().describe().find("outside a uniform block"), std::string::npos)
      << st.error().describe();
  EXPECT_NE(st.error().describe().find("count"), std::string::npos) << st.error().describe();
  // Both normal passes and the shockwave passes have none: they build (the builds check it).
  EXPECT_TRUE(LevelNormalPass::create().ok());
}

TEST(UniformBlock, EachCopyOfABufferBindsAtAnAllowedOffset) {
  LOAM_REQUIRE_GL();
  UniformBuffer<render::ClipmapLevelBlock> levels(5);
  EXPECT_GE(levels.bytes(), 5 * sizeof(render::ClipmapLevelBlock));
  EXPECT_EQ(levels.bytes() % uniform_buffer_alignment(), 0u);
  render::ClipmapLevelBlock b{};
  for (int32_t i = 0; i < 5; ++i) {
    b.spacing = 1 << i;
    levels.write(i, b);
    levels.bind(1, i);
  }
  EXPECT_EQ(glGetError(), GLenum(GL_NO_ERROR));
}

}  // namespace
}  // namespace loam::gpu
