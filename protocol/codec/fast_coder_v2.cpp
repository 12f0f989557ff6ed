#include "protocol/codec/fast_coder_v2.h"

#include <zstd.h>

#include <memory>
#include <string>
#include <vector>

#include "protocol/byte_order.h"
#include "protocol/codec/predictor.h"

namespace loam::codec {
namespace {

struct DctxDeleter {
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};
// Reused per thread: creating a context costs more than decompressing a tile.
ZSTD_DCtx* dctx() {
  thread_local const std::unique_ptr<ZSTD_DCtx, DctxDeleter> d(ZSTD_createDCtx());
  return d.get();
}
std::vector<uint8_t>& planes_scratch() {
  thread_local std::vector<uint8_t> p;
  return p;
}

template <typename T>
Status decode(const FastBodyV2& fb, uint32_t width, uint32_t height, std::span<T> out) {
  const size_t n = out.size();
  ZSTD_DCtx* dc = dctx();
  if (dc == nullptr) return make_error(ErrorCode::kCorrupt, "region.fast", "no zstd context");
  std::vector<uint8_t>& scratch = planes_scratch();
  if (scratch.size() < sizeof(T) * n) scratch.resize(sizeof(T) * n);
  uint8_t* planes = scratch.data();
  for (size_t p = 0; p < sizeof(T); ++p) {
    const size_t got = ZSTD_decompressDCtx(dc, planes + p * n, n, fb.frames[p].data(), fb.frames[p].size());
    if (ZSTD_isError(got) || got != n) {
      return make_error(ErrorCode::kCorrupt, p == 0 ? "region.fast.frame0" : "region.fast.frame1",
                        ZSTD_isError(got) ? ZSTD_getErrorName(got) : "zstd frame shorter than the plane");
    }
  }
  if constexpr (sizeof(T) == 2) {
    med_inverse_u16({planes, n}, {planes + n, n}, width, height, out);
    if (fb.shift > 0)
      for (uint16_t& v : out) v = uint16_t((uint32_t(v) << fb.shift) | fb.low);
  } else {
    med_inverse_i8({planes, n}, width, height, out);
  }
  return {};
}

}  // namespace

Result<FastBodyV2> parse_fast_body_v2(std::span<const uint8_t> body, size_t planes, size_t n) {
  if (body.empty()) return make_error(ErrorCode::kTruncated, "region.fast", "body too short");
  FastBodyV2 fb;
  fb.shift = body[0];
  if (fb.shift > (planes == 2 ? 15u : 0u))
    return make_error(ErrorCode::kCorrupt, "region.fast", "shift out of range");
  size_t at = 1;
  if (fb.shift > 0) {
    if (body.size() < 3)
      return make_error(ErrorCode::kTruncated, "region.fast", "body too short for the low bits");
    fb.low = load_le<uint16_t>(body.data() + 1);
    if (fb.low >= (1u << fb.shift))
      return make_error(ErrorCode::kCorrupt, "region.fast", "low bits out of range");
    at = 3;
  }
  std::span<const uint8_t> rest = body.subspan(at);
  for (size_t p = 0; p < planes; ++p) {
    const char* field = p == 0 ? "region.fast.frame0" : "region.fast.frame1";
    size_t len = rest.size();
    if (p + 1 < planes) {
      len = ZSTD_findFrameCompressedSize(rest.data(), rest.size());
      if (ZSTD_isError(len) || len > rest.size())
        return make_error(ErrorCode::kCorrupt, field, "no complete zstd frame");
    }
    fb.frames[p] = rest.first(len);
    if (ZSTD_getFrameContentSize(fb.frames[p].data(), fb.frames[p].size()) != n) {
      return make_error(ErrorCode::kCorrupt, field, "zstd frame size does not match the rect");
    }
    rest = rest.subspan(len);
  }
  return fb;
}

Status decode_fast_body_v2(const FastBodyV2& body, uint32_t width, uint32_t height, std::span<uint16_t> out) {
  return decode(body, width, height, out);
}
Status decode_fast_body_v2(const FastBodyV2& body, uint32_t width, uint32_t height, std::span<int8_t> out) {
  return decode(body, width, height, out);
}

}  // namespace loam::codec
