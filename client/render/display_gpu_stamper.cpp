#include "client/render/display_gpu_stamper.h"

namespace loam::render {

namespace {

class GpuDisplayStamper final : public terrain::DisplayStamper {
 public:
  explicit GpuDisplayStamper(std::unique_ptr<gpu::GpuStamper> s) : s_(std::move(s)) {}
  Result<uint64_t> submit(const QuantizedStamp& q) override { return s_->submit(q); }
  std::vector<gpu::StampReadback> collect(World& world) override { return s_->collect(world); }
  void upload(World& world, Layer layer, const RectI& rect) override { s_->upload(world, layer, rect); }
  void forget(World& world, Layer layer, int32_t tx, int32_t ty) override {
    s_->forget(world, layer, tx, ty);
  }
  gpu::GpuStamperMemory memory() const override { return s_->memory(); }

 private:
  std::unique_ptr<gpu::GpuStamper> s_;
};

}  // namespace

terrain::DisplayStamperFactory gpu_display_stamper(gpu::GpuStamperOptions options) {
  return [options](const World& mirror,
                   const TextureRegistry* textures) -> Result<std::unique_ptr<terrain::DisplayStamper>> {
    auto s = gpu::GpuStamper::create(mirror, textures, {}, options);
    if (!s) return s.error();
    return std::unique_ptr<terrain::DisplayStamper>(new GpuDisplayStamper(std::move(*s)));
  };
}

}  // namespace loam::render
