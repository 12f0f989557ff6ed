#include "dem/tiff_tags.h"

#include <cstdlib>
#include <cstring>

namespace loam {
namespace {

constexpr uint16_t kTagModelPixelScale = 33550;
constexpr uint16_t kTagGdalNodata = 42113;

struct Reader {
  std::span<const uint8_t> bytes;
  bool little = true;

  bool has(uint64_t offset, uint64_t size) const {
    return offset <= bytes.size() && size <= bytes.size() - offset;
  }
  uint64_t get(uint64_t offset, int size) const {  // caller checked has()
    uint64_t v = 0;
    for (int i = 0; i < size; ++i) {
      const uint64_t b = bytes[offset + uint64_t(i)];
      v |= little ? (b << (8 * i)) : (b << (8 * (size - 1 - i)));
    }
    return v;
  }
};

Error corrupt(const std::string& what) { return make_error(ErrorCode::kCorrupt, "tiff", what); }

}  // namespace

Result<TiffGeoTags> read_tiff_geo_tags(std::span<const uint8_t> bytes) {
  TiffGeoTags tags;
  if (bytes.size() < 8) return tags;
  Reader r{bytes};
  if (bytes[0] == 'I' && bytes[1] == 'I') {
    r.little = true;
  } else if (bytes[0] == 'M' && bytes[1] == 'M') {
    r.little = false;
  } else {
    return tags;  // not a TIFF
  }
  const uint64_t magic = r.get(2, 2);
  const bool big = magic == 43;
  if (magic != 42 && !big) return tags;
  uint64_t ifd = 0;
  if (big) {
    if (!r.has(8, 8)) return corrupt("BigTIFF header truncated");
    ifd = r.get(8, 8);
  } else {
    ifd = r.get(4, 4);
  }
  const int count_size = big ? 8 : 2;
  const uint64_t entry_size = big ? 20 : 12;
  const int value_size = big ? 8 : 4;
  if (!r.has(ifd, uint64_t(count_size))) return corrupt("first directory offset beyond the end of the file");
  const uint64_t entries = r.get(ifd, count_size);
  if (entries > 4096) return corrupt("directory claims " + std::to_string(entries) + " entries");
  if (!r.has(ifd + uint64_t(count_size), entries * entry_size)) return corrupt("directory truncated");

  for (uint64_t e = 0; e < entries; ++e) {
    const uint64_t at = ifd + uint64_t(count_size) + e * entry_size;
    const uint64_t tag = r.get(at, 2);
    const uint64_t type = r.get(at + 2, 2);
    const uint64_t count = r.get(at + 4, big ? 8 : 4);
    const uint64_t value_at = at + (big ? 12 : 8);
    if (tag != kTagModelPixelScale && tag != kTagGdalNodata) continue;
    const uint64_t elem = type == 2 ? 1 : type == 12 ? 8 : 0;  // ASCII or DOUBLE
    if (elem == 0)
      return corrupt("tag " + std::to_string(tag) + " has unexpected type " + std::to_string(type));
    if (count > (uint64_t(1) << 20)) return corrupt("tag " + std::to_string(tag) + " count too large");
    const uint64_t size = count * elem;
    const uint64_t data_at = size <= uint64_t(value_size) ? value_at : r.get(value_at, value_size);
    if (!r.has(data_at, size))
      return corrupt("tag " + std::to_string(tag) + " data beyond the end of the file");
    if (tag == kTagGdalNodata) {
      std::string text(reinterpret_cast<const char*>(bytes.data() + data_at), size_t(size));
      text = text.c_str();  // stop at the terminating NUL
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      if (end != text.c_str()) tags.nodata = v;
    } else if (count >= 2) {
      const uint64_t x = r.get(data_at, 8), y = r.get(data_at + 8, 8);
      double dx, dy;
      std::memcpy(&dx, &x, 8);
      std::memcpy(&dy, &y, 8);
      tags.pixel_scale_x = dx;
      tags.pixel_scale_y = dy;
    }
  }
  return tags;
}

}  // namespace loam
