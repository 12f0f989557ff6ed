// libFuzzer target for the frame assembler and every message decoder. The input is raw
// stream bytes, as a hostile peer would send them (the seed corpus holds real frames).
// Beyond "no crash, no sanitizer report" it checks two properties and aborts on violation:
//  - splitting the stream into reads of any size yields the same frames and errors;
//  - a payload that decodes re-encodes to exactly the same bytes (canonical encoding), and
//    measure_payload agrees with the encoder.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <vector>

#include "protocol/wire/framing.h"
#include "protocol/wire/messages.h"

namespace {

using namespace loam::wire;

// A small maximum so the fuzzer reaches the oversize path as well as whole frames.
constexpr uint32_t kFuzzMaxFrame = 64u << 10;

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "wire_fuzz property violated: %s\n", what);
  std::abort();
}

struct Outcome {
  std::vector<Frame> frames;
  bool failed = false;
};

Outcome assemble(std::span<const uint8_t> data, size_t read_size) {
  Outcome out;
  FrameAssembler fa(kFuzzMaxFrame);
  for (size_t at = 0; at < data.size() && !out.failed; at += read_size) {
    fa.feed(data.subspan(at, std::min(read_size, data.size() - at)));
    for (;;) {
      loam::Result<std::optional<Frame>> r = fa.next();
      if (!r.ok()) {
        out.failed = true;
        break;
      }
      if (!r->has_value()) break;
      out.frames.push_back(std::move(**r));
    }
  }
  return out;
}

void check_payload(uint16_t type, std::span<const uint8_t> payload) {
  loam::Result<Message> m = decode_payload(type, payload);
  if (!m.ok()) {
    if (m.error().field.empty()) fail("decode error without a field name");
    return;
  }
  loam::Result<std::vector<uint8_t>> again = encode_payload(*m);
  if (!again.ok()) fail("a decoded message does not encode");
  if (again->size() != payload.size() || !std::equal(again->begin(), again->end(), payload.begin())) {
    fail("decode then encode is not the identity");
  }
  loam::Result<size_t> measured = measure_payload(*m);
  if (!measured.ok() || *measured != payload.size()) fail("measure disagrees with encode");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> input(data, size);
  const Outcome whole = assemble(input, size == 0 ? 1 : size);
  const Outcome pieces = assemble(input, 1 + size % 7);
  if (whole.failed != pieces.failed || whole.frames.size() != pieces.frames.size()) {
    fail("read size changed the frames");
  }
  for (size_t i = 0; i < whole.frames.size(); ++i) {
    if (whole.frames[i].type != pieces.frames[i].type ||
        whole.frames[i].payload != pieces.frames[i].payload) {
      fail("read size changed a frame");
    }
    check_payload(whole.frames[i].type, whole.frames[i].payload);
  }
  // Also the bare payload decoders, with the type taken from the first two bytes, so
  // mutations reach deep fields without first having to produce a valid frame header.
  if (size >= 2) check_payload(uint16_t(data[0] | (data[1] << 8)), input.subspan(2));
  return 0;
}
