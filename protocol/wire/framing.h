// Framing: every message on a stream is [u32 payload length][u16 message type][payload],
// little-endian. FrameAssembler turns arbitrary stream reads into whole frames.
//
// Safe on untrusted input: a frame header whose length exceeds the connection's maximum, or
// whose type is unknown, is an error as soon as its 6 header bytes are present; nothing is
// ever allocated for a claimed length. Errors are sticky: after one, the connection must be closed (send
// Error, then Bye) because the byte stream can no longer be trusted to be in sync.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "protocol/result.h"
#include "protocol/wire/constants.h"
#include "protocol/wire/messages.h"

namespace loam::wire {

struct FrameHeader {
  uint32_t length = 0;  // payload bytes, not counting the header
  uint16_t type = 0;    // MessageType, unchecked until decode
};

// Parses a header from exactly kFrameHeaderBytes; rejects length > max_frame_bytes.
Result<FrameHeader> parse_frame_header(std::span<const uint8_t> header, uint32_t max_frame_bytes);

// Appends header + payload of m. Fails if m does not encode or its payload exceeds
// max_frame_bytes (the peer's limit, from Welcome), leaving `out` unchanged.
Status append_frame(std::vector<uint8_t>& out, const Message& m,
                    uint32_t max_frame_bytes = kDefaultMaxFrameBytes);
Result<std::vector<uint8_t>> encode_frame(const Message& m, uint32_t max_frame_bytes = kDefaultMaxFrameBytes);

// Decodes exactly one whole frame (header + payload, nothing after it).
Result<Message> decode_frame(std::span<const uint8_t> frame,
                             uint32_t max_frame_bytes = kDefaultMaxFrameBytes);

struct Frame {
  uint16_t type = 0;
  std::vector<uint8_t> payload;
};

class FrameAssembler {
 public:
  // max_frame_bytes is clamped to kAbsoluteMaxFrameBytes.
  explicit FrameAssembler(uint32_t max_frame_bytes = kDefaultMaxFrameBytes);

  // Appends bytes read from the stream. Call next() until it yields nothing after each feed:
  // then the buffer never holds more than one partial frame plus one read.
  void feed(std::span<const uint8_t> bytes);
  // The next whole frame, std::nullopt when more bytes are needed, or the (sticky) error.
  Result<std::optional<Frame>> next();
  // next() followed by decode_payload().
  Result<std::optional<Message>> next_message();

  // Bytes buffered but not yet returned (for tests and back-pressure accounting).
  size_t buffered() const { return buffer_.size() - read_; }
  bool failed() const { return error_.has_value(); }

 private:
  uint32_t max_frame_bytes_;
  std::vector<uint8_t> buffer_;
  size_t read_ = 0;  // consumed prefix of buffer_, dropped lazily to keep feed() amortized O(n)
  std::optional<Error> error_;
};

}  // namespace loam::wire
