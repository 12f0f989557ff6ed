// Shared set-up of GL tests: one headless EGL context per test binary. Without an EGL
// display a GL test is skipped, visibly, unless CI=true, where it fails (CI must prove the
// GPU paths on llvmpipe).
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <memory>

#include "gpu/egl_context.h"

namespace loam::gpu::test {

inline EglContext* shared_context() {
  static std::unique_ptr<EglContext> ctx = [] {
    auto created = EglContext::create();
    if (!created) {
      std::fprintf(stderr, "GL tests: no context: %s\n", created.error().describe().c_str());
      return std::unique_ptr<EglContext>();
    }
    std::fprintf(stderr, "GL tests: %s via EGL %s platform, %s\n", created->renderer().c_str(),
                 created->platform().c_str(), created->version().c_str());
    return std::make_unique<EglContext>(std::move(*created));
  }();
  return ctx.get();
}

inline bool running_in_ci() {
  const char* ci = std::getenv("CI");
  return ci && std::strcmp(ci, "true") == 0;
}

}  // namespace loam::gpu::test

// Makes the shared context current, or skips (fails under CI=true) when there is none.
#define LOAM_REQUIRE_GL()                                                                   \
  do {                                                                                      \
    ::loam::gpu::EglContext* loam_ctx_ = ::loam::gpu::test::shared_context();               \
    if (!loam_ctx_) {                                                                       \
      if (::loam::gpu::test::running_in_ci()) FAIL() << "no EGL display under CI=true";     \
      GTEST_SKIP() << "no EGL display";                                                     \
    }                                                                                       \
    ASSERT_TRUE(loam_ctx_->make_current().ok());                                            \
  } while (false)
