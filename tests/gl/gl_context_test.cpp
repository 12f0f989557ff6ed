#include <gtest/gtest.h>

#include <vector>

#include "gl_test_context.h"
#include "gpu/gl_handle.h"
#include "gpu/shader_library.h"

namespace loam::gpu {
namespace {

TEST(GlContext, HeadlessContextIsOpenGl45CoreWithComputeShaders) {
  LOAM_REQUIRE_GL();
  GLint major = 0, minor = 0, mask = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  glGetIntegerv(GL_CONTEXT_PROFILE_MASK, &mask);
  EXPECT_GE(major * 10 + minor, 45);
  EXPECT_TRUE(mask & GL_CONTEXT_CORE_PROFILE_BIT);
  GLint invocations = 0;
  glGetIntegerv(GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS, &invocations);
  EXPECT_GE(invocations, 64);
}

TEST(GlContext, ComputeShaderWithPrependedDefineReturnsExactIntegers) {
  LOAM_REQUIRE_GL();
  const ShaderDefine defines[] = {{"SELFTEST_MULTIPLIER", "37"}};
  auto program = build_compute_program("selftest.comp.glsl", defines);
  ASSERT_TRUE(program.ok()) << program.error().describe();
  std::vector<int32_t> values(1000);
  for (size_t i = 0; i < values.size(); ++i) values[i] = int32_t(i * 7919 % 100000) - 50000;
  GlBuffer buffer = make_buffer();
  glNamedBufferData(buffer.get(), GLsizeiptr(values.size() * 4), values.data(), GL_DYNAMIC_COPY);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, buffer.get());
  glUseProgram(program->get());
  glDispatchCompute(GLuint((values.size() + 63) / 64), 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  std::vector<int32_t> out(values.size());
  glGetNamedBufferSubData(buffer.get(), 0, GLsizeiptr(out.size() * 4), out.data());
  ASSERT_EQ(glGetError(), GLenum(GL_NO_ERROR));
  for (size_t i = 0; i < values.size(); ++i) {
    ASSERT_EQ(out[i], ((values[i] * 37) >> 3) - int32_t(i)) << "index " << i;  // arithmetic shift both sides
  }
}

TEST(GlContext, ShaderCompileErrorNamesTheFileAndLine) {
  LOAM_REQUIRE_GL();
  // Without its define the self-test shader does not compile: the error must point at the
  // file and the line that uses SELFTEST_MULTIPLIER.
  auto program = build_compute_program("selftest.comp.glsl");
  ASSERT_FALSE(program.ok());
  const std::string text = program.error().describe();
  EXPECT_NE(text.find("selftest.comp.glsl:14"), std::string::npos) << text;
}

TEST(GlContext, UnknownShaderIsAnErrorNotACrash) {
  auto program = build_compute_program("no_such_shader.glsl");
  ASSERT_FALSE(program.ok());
  EXPECT_EQ(program.error().code, ErrorCode::kNotFound);
}

TEST(GlContext, EveryEmbeddedShaderIsNonEmpty) {
  const auto names = embedded_shader_names();
  ASSERT_FALSE(names.empty());
  for (auto n : names) {
    const auto src = embedded_shader(n);
    ASSERT_TRUE(src.has_value()) << n;
    EXPECT_GT(src->size(), 10u) << n;
  }
}

TEST(ShaderLog, DriverLineNumbersBecomeFileAndLine) {
  EXPECT_EQ(annotate_shader_log("0:12(5): error: x undeclared", "a.glsl"),
            "a.glsl:12:5: error: x undeclared");
  EXPECT_EQ(annotate_shader_log("0(7) : error C1008", "b.glsl"), "b.glsl:7 : error C1008");
}

}  // namespace
}  // namespace loam::gpu
