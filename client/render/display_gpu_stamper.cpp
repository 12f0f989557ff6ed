#include "client/render/display_gpu_stamper.h"

namespace loam::render {

namespace {

class GpuDisplayStamper final : public terrain::DisplayStamper {
 public:
  explicit GpuDisplayStamper(std::unique_ptr<gpu::GpuStamper> s) : s_(std::move(s)) {}
  Status submit(const QuantizedStamp& q) override {
    auto t = s_->submit(q);
    if (!t) return t.error();
    return {};
  }
  void end_batch() override { s_->end_batch(); }
  void upload(World& world, Layer layer, const RectI& rect) override { s_->upload(world, layer, rect); }
  void forget(World& world, Layer layer, int32_t tx, int32_t ty) override {
    s_->forget(world, layer, tx, ty);
  }
  bool resident(Layer layer, int32_t tx, int32_t ty) const override {
    return s_->pages(layer).find(tx, ty).has_value();
  }
  std::vector<int32_t> read(Layer layer, const RectI& rect) override { return s_->read_gpu(layer, rect); }
  gpu::GpuStamperMemory memory() const override { return s_->memory(); }
  gpu::GpuStamperTraffic traffic() const override { return s_->traffic(); }
  const gpu::GpuStamper& cache() const override { return *s_; }

 private:
  std::unique_ptr<gpu::GpuStamper> s_;
};

}  // namespace

terrain::DisplayStamperFactory gpu_display_stamper(gpu::GpuStamperOptions options) {
  options.read_back = false;  // the display copies the confirmed store instead
  return [options](const World& mirror,
                   const TextureRegistry* textures) -> Result<std::unique_ptr<terrain::DisplayStamper>> {
    auto s = gpu::GpuStamper::create(mirror, textures, {}, options);
    if (!s) return s.error();
    return std::unique_ptr<terrain::DisplayStamper>(new GpuDisplayStamper(std::move(*s)));
  };
}

}  // namespace loam::render
