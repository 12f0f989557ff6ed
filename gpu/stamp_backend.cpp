#include "gpu/stamp_backend.h"

#include <cstdio>
#include <utility>

#include "gpu/egl_context.h"
#include "gpu/gpu_stamper.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/world.h"

namespace loam::gpu {

namespace {

class CpuBackend final : public StampBackend {
 public:
  CpuBackend(const TextureRegistry* textures, const StampLimits& limits)
      : textures_(textures), limits_(limits) {}
  const char* name() const override { return "cpu"; }
  std::string renderer() const override { return "CPU reference"; }
  Result<RectI> apply(World& world, const QuantizedStamp& q) override {
    return apply_stamp(world, q, textures_, limits_);
  }
  void world_changed(World&, Layer, const RectI&) override {}  // it reads the World itself

 private:
  const TextureRegistry* textures_;
  StampLimits limits_;
};

// The GL context is current only while a call runs, so whichever thread calls next (the
// server's apply worker, replay's main thread) may use it; calls must not overlap.
class GpuBackend final : public StampBackend {
 public:
  GpuBackend(EglContext context, std::unique_ptr<GpuStamper> stamper)
      : context_(std::move(context)), stamper_(std::move(stamper)) {
    context_.release_current();
  }
  ~GpuBackend() override {
    // GL objects go while their context is current; then the context itself.
    if (context_.make_current().ok()) stamper_.reset();
  }
  const char* name() const override { return "gpu"; }
  std::string renderer() const override { return context_.renderer(); }
  Result<RectI> apply(World& world, const QuantizedStamp& q) override {
    const Current current(context_);
    LOAM_TRY(current.status);
    return stamper_->apply(world, q);
  }
  void world_changed(World& world, Layer layer, const RectI& rect) override {
    const Current current(context_);
    if (current.status.ok()) stamper_->upload(world, layer, rect);
  }

 private:
  struct Current {
    explicit Current(const EglContext& c) : context(c), status(c.make_current()) {}
    ~Current() { context.release_current(); }
    const EglContext& context;
    Status status;
  };
  EglContext context_;
  std::unique_ptr<GpuStamper> stamper_;
};

}  // namespace

Result<std::unique_ptr<StampBackend>> make_stamp_backend(BackendKind kind, const World& world,
                                                         const TextureRegistry* textures,
                                                         const StampLimits& limits) {
  EglProbe probe;
  std::optional<EglContext> context;
  std::string egl_error;
  if (kind != BackendKind::kCpu) {
    // auto asks for hardware only: llvmpipe loses to the CPU reference here.
    auto created =
        EglContext::create(kind == BackendKind::kGpu ? EglPreference::kAny : EglPreference::kHardware);
    if (created) {
      probe.opened = true;
      probe.software = created->is_software();
      context.emplace(std::move(*created));
    } else {
      egl_error = created.error().describe();
    }
  }
  switch (decide_backend(kind, probe)) {
    case BackendDecision::kError:
      return make_error(
          ErrorCode::kUnsupported, "backend",
          "the gpu backend was asked for but no EGL display gives an OpenGL 4.5 core context: " + egl_error);
    case BackendDecision::kCpu:
      std::fprintf(stderr, "stamp backend: cpu (asked for %s%s%s)\n", to_string(kind),
                   egl_error.empty() ? "" : "; EGL: ", egl_error.c_str());
      return std::unique_ptr<StampBackend>(new CpuBackend(textures, limits));
    case BackendDecision::kGpu: break;
  }
  auto stamper = GpuStamper::create(world, textures, limits);
  if (!stamper) {
    // auto falls back where the GPU cannot hold the world (a layer over GL_MAX_TEXTURE_SIZE).
    if (kind != BackendKind::kAuto) return stamper.error();
    std::fprintf(stderr, "stamp backend: cpu (asked for auto; the gpu cannot hold this world: %s)\n",
                 stamper.error().describe().c_str());
    return std::unique_ptr<StampBackend>(new CpuBackend(textures, limits));
  }
  std::fprintf(stderr, "stamp backend: gpu (asked for %s): %s via EGL %s platform, %s\n", to_string(kind),
               context->renderer().c_str(), context->platform().c_str(), context->version().c_str());
  return std::unique_ptr<StampBackend>(new GpuBackend(std::move(*context), std::move(*stamper)));
}

}  // namespace loam::gpu
