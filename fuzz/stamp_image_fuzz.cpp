// libFuzzer target for stored texture-stamp images (files in a data folder: untrusted):
// decode_stamp_image() on arbitrary bytes. Properties checked (abort on violation):
//  - it returns an image or an error, never crashes, reads out of bounds or allocates more
//    than the buffer justifies;
//  - an accepted image re-encodes to exactly the input bytes, and its id is its content id.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>

#include "protocol/snapshot/stamp_image_file.h"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "stamp_image_fuzz property violated: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  auto image = loam::decode_stamp_image(bytes, "fuzz");
  if (!image.ok()) return 0;
  const std::vector<uint8_t> again = loam::encode_stamp_image(*image);
  if (again.size() != size || !std::equal(again.begin(), again.end(), data)) fail("re-encoding differs");
  if (image->id != loam::texture_content_id(image->width, image->height, image->samples)) fail("id");
  return 0;
}
