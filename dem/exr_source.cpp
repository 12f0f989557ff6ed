#include "dem/exr_source.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>

namespace loam {
namespace {

class ExrSource final : public RasterSource {
 public:
  ExrSource(std::unique_ptr<OIIO::ImageInput> in, std::unique_ptr<OIIO::Filesystem::IOMemReader> proxy,
            std::string name)
      : in_(std::move(in)), proxy_(std::move(proxy)), name_(std::move(name)), spec_(in_->spec()) {}
  ~ExrSource() override { in_->close(); }
  ExrSource(const ExrSource&) = delete;
  ExrSource& operator=(const ExrSource&) = delete;

  int64_t width() const override { return spec_.width; }
  int64_t height() const override { return spec_.height; }
  int band_count() const override { return spec_.nchannels; }
  std::string format() const override { return "OpenEXR"; }
  Georef georef() const override { return {}; }

  RasterBandInfo band(int index) const override {
    RasterBandInfo info;
    const OIIO::TypeDesc t = spec_.channelformat(index - 1);
    const auto base = OIIO::TypeDesc::BASETYPE(t.basetype);
    info.sample_type = base == OIIO::TypeDesc::HALF    ? "float16"
                       : base == OIIO::TypeDesc::FLOAT ? "float32"
                       : base == OIIO::TypeDesc::UINT  ? "uint32"
                                                       : t.c_str();
    info.integer = base == OIIO::TypeDesc::UINT;
    info.supported = true;
    const std::string ch =
        index - 1 < int(spec_.channelnames.size()) ? spec_.channelnames[size_t(index - 1)] : "";
    info.color = ch == "R" ? "Red" : ch == "G" ? "Green" : ch == "B" ? "Blue" : ch == "A" ? "Alpha" : "Gray";
    return info;
  }

  Status read_rows(int index, int64_t y0, int64_t rows, std::span<double> out) override {
    const int64_t w = width();
    if (y0 < 0 || rows < 1 || y0 + rows > height() || out.size() != size_t(rows * w) || index < 1 ||
        index > band_count()) {
      return make_error(ErrorCode::kInvalidArgument, name_, "read outside the raster");
    }
    const int yb = spec_.y + int(y0), ye = yb + int(rows);
    bool ok = false;
    if (spec_.tile_width > 0) {
      ok = in_->read_tiles(0, 0, spec_.x, spec_.x + spec_.width, yb, ye, spec_.z, spec_.z + 1, index - 1,
                           index, OIIO::TypeDesc::DOUBLE, out.data());
    } else {
      ok = in_->read_scanlines(0, 0, yb, ye, spec_.z, index - 1, index, OIIO::TypeDesc::DOUBLE, out.data());
    }
    if (!ok) {
      std::string why = in_->geterror();
      return make_error(ErrorCode::kCorrupt, name_,
                        "cannot read rows " + std::to_string(y0) + ".." + std::to_string(y0 + rows - 1) +
                            " (truncated or corrupt data): " + (why.empty() ? "decoder error" : why));
    }
    return {};
  }

  int64_t block_rows() const override { return spec_.tile_width > 0 ? std::max(1, spec_.tile_height) : 1; }

 private:
  std::unique_ptr<OIIO::ImageInput> in_;
  std::unique_ptr<OIIO::Filesystem::IOMemReader> proxy_;
  std::string name_;
  OIIO::ImageSpec spec_;
};

Result<std::unique_ptr<RasterSource>> open_with(const std::string& name,
                                                std::unique_ptr<OIIO::Filesystem::IOMemReader> proxy) {
  auto in = OIIO::ImageInput::create("exr");
  OIIO::ImageSpec spec;
  if (!in || (proxy && !in->set_ioproxy(proxy.get())) || !in->open(name, spec)) {
    std::string why = in ? in->geterror() : OIIO::geterror();
    if (why.empty()) why = "not a readable OpenEXR file";
    return make_error(ErrorCode::kCorrupt, name, "cannot decode: " + why);
  }
  return std::unique_ptr<RasterSource>(new ExrSource(std::move(in), std::move(proxy), name));
}

}  // namespace

Result<std::unique_ptr<RasterSource>> open_exr_file(const std::string& path) {
  return open_with(path, nullptr);
}

Result<std::unique_ptr<RasterSource>> open_exr_memory(std::span<const uint8_t> bytes,
                                                      const std::string& name) {
  auto proxy =
      std::make_unique<OIIO::Filesystem::IOMemReader>(const_cast<uint8_t*>(bytes.data()), bytes.size());
  return open_with(name, std::move(proxy));
}

}  // namespace loam
