#include "dem/exr_source.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfTileDescriptionAttribute.h>

#include <algorithm>
#include <climits>
#include <cstring>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace loam {
namespace {

// An OpenEXR input stream over bytes in memory (read-only; the bytes outlive it).
class MemoryStream final : public Imf::IStream {
 public:
  MemoryStream(std::span<const uint8_t> bytes, const std::string& name)
      : Imf::IStream(name.c_str()), bytes_(bytes) {}

  bool read(char c[], int n) override {
    if (n < 0 || size_t(n) > bytes_.size() - pos_) throw std::runtime_error("unexpected end of file");
    std::memcpy(c, bytes_.data() + pos_, size_t(n));
    pos_ += size_t(n);
    return pos_ < bytes_.size();
  }
  uint64_t tellg() override { return pos_; }
  void seekg(uint64_t pos) override {
    if (pos > bytes_.size()) throw std::runtime_error("seek past the end of file");
    pos_ = size_t(pos);
  }
  void clear() override {}

 private:
  std::span<const uint8_t> bytes_;
  size_t pos_ = 0;
};

// Channels in the order other tools present them: colour (R, G, B), luminance (Y), alpha (A),
// then any others by name (OpenEXR stores them sorted by name).
std::vector<std::pair<std::string, Imf::PixelType>> ordered_channels(const Imf::ChannelList& list) {
  std::vector<std::pair<std::string, Imf::PixelType>> out;
  for (const char* known : {"R", "G", "B", "Y", "A"}) {
    if (const Imf::Channel* c = list.findChannel(known)) out.emplace_back(known, c->type);
  }
  for (auto it = list.begin(); it != list.end(); ++it) {
    const std::string n = it.name();
    if (std::none_of(out.begin(), out.end(), [&](const auto& e) { return e.first == n; }))
      out.emplace_back(n, it.channel().type);
  }
  return out;
}

class ExrSource final : public RasterSource {
 public:
  ExrSource(std::unique_ptr<MemoryStream> stream, std::unique_ptr<Imf::InputFile> in, std::string name)
      : stream_(std::move(stream)), in_(std::move(in)), name_(std::move(name)) {
    window_ = in_->header().dataWindow();
    channels_ = ordered_channels(in_->header().channels());
    if (in_->header().hasTileDescription()) tile_rows_ = int64_t(in_->header().tileDescription().ySize);
  }
  ExrSource(const ExrSource&) = delete;
  ExrSource& operator=(const ExrSource&) = delete;

  int64_t width() const override { return int64_t(window_.max.x) - window_.min.x + 1; }
  int64_t height() const override { return int64_t(window_.max.y) - window_.min.y + 1; }
  int band_count() const override { return int(channels_.size()); }
  std::string format() const override { return "OpenEXR"; }
  Georef georef() const override { return {}; }

  RasterBandInfo band(int index) const override {
    RasterBandInfo info;
    if (index < 1 || index > band_count()) return info;
    const auto& [ch, type] = channels_[size_t(index - 1)];
    info.sample_type = type == Imf::HALF ? "float16" : type == Imf::FLOAT ? "float32" : "uint32";
    info.integer = type == Imf::UINT;
    info.supported = true;
    info.color = ch == "R" ? "Red" : ch == "G" ? "Green" : ch == "B" ? "Blue" : ch == "A" ? "Alpha" : "Gray";
    return info;
  }

  Status read_rows(int index, int64_t y0, int64_t rows, std::span<double> out) override {
    const int64_t w = width();
    if (y0 < 0 || rows < 1 || y0 + rows > height() || out.size() != size_t(rows * w) || index < 1 ||
        index > band_count()) {
      return make_error(ErrorCode::kInvalidArgument, name_, "read outside the raster");
    }
    const auto& [ch, type] = channels_[size_t(index - 1)];
    const int yb = window_.min.y + int(y0), ye = yb + int(rows) - 1;
    const Imath::Box2i strip(Imath::V2i(window_.min.x, yb), Imath::V2i(window_.max.x, ye));
    try {
      // Integers are read as integers (exact above 2^24); half and float as float.
      Imf::FrameBuffer fb;
      if (type == Imf::UINT) {
        std::vector<uint32_t> buf(out.size());
        fb.insert(ch, Imf::Slice::Make(Imf::UINT, buf.data(), strip));
        in_->setFrameBuffer(fb);
        in_->readPixels(yb, ye);
        std::copy(buf.begin(), buf.end(), out.begin());
      } else {
        std::vector<float> buf(out.size());
        fb.insert(ch, Imf::Slice::Make(Imf::FLOAT, buf.data(), strip));
        in_->setFrameBuffer(fb);
        in_->readPixels(yb, ye);
        std::copy(buf.begin(), buf.end(), out.begin());
      }
    } catch (const std::exception& e) {
      return make_error(ErrorCode::kCorrupt, name_,
                        "cannot read rows " + std::to_string(y0) + ".." + std::to_string(y0 + rows - 1) +
                            " (truncated or corrupt data): " + e.what());
    }
    return {};
  }

  int64_t block_rows() const override { return std::max<int64_t>(1, tile_rows_); }

 private:
  std::unique_ptr<MemoryStream> stream_;  // null for a file (the InputFile owns its stream)
  std::unique_ptr<Imf::InputFile> in_;
  std::string name_;
  Imath::Box2i window_;
  std::vector<std::pair<std::string, Imf::PixelType>> channels_;
  int64_t tile_rows_ = 1;
};

// Opens the header; a data window too large to index is refused here, before any read.
Result<std::unique_ptr<RasterSource>> open_with(const std::string& name, std::unique_ptr<MemoryStream> stream,
                                                const std::string& path) {
  // A header may claim any size, and OpenEXR sizes its tables by the claim: sides beyond a
  // million samples (and tiles beyond 64 Ki) are refused while the header is read.
  static std::once_flag limits;
  std::call_once(limits, [] {
    Imf::Header::setMaxImageSize(1 << 20, 1 << 20);
    Imf::Header::setMaxTileSize(1 << 16, 1 << 16);
  });
  std::unique_ptr<Imf::InputFile> in;
  try {
    in = stream ? std::make_unique<Imf::InputFile>(*stream) : std::make_unique<Imf::InputFile>(path.c_str());
  } catch (const std::exception& e) {
    return make_error(ErrorCode::kCorrupt, name, std::string("cannot decode: ") + e.what());
  }
  const Imath::Box2i dw = in->header().dataWindow();
  const int64_t w = int64_t(dw.max.x) - dw.min.x + 1, h = int64_t(dw.max.y) - dw.min.y + 1;
  if (w < 1 || h < 1 || w > INT32_MAX || h > INT32_MAX) {
    return make_error(ErrorCode::kCorrupt, name, "cannot decode: the data window is empty or too large");
  }
  if (in->header().channels().begin() == in->header().channels().end()) {
    return make_error(ErrorCode::kCorrupt, name, "cannot decode: the file has no channels");
  }
  return std::unique_ptr<RasterSource>(new ExrSource(std::move(stream), std::move(in), name));
}

}  // namespace

Result<std::unique_ptr<RasterSource>> open_exr_file(const std::string& path) {
  return open_with(path, nullptr, path);
}

Result<std::unique_ptr<RasterSource>> open_exr_memory(std::span<const uint8_t> bytes,
                                                      const std::string& name) {
  return open_with(name, std::make_unique<MemoryStream>(bytes, name), "");
}

}  // namespace loam
