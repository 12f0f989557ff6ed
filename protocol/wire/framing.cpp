#include "protocol/wire/framing.h"

#include <algorithm>

#include "protocol/byte_order.h"
#include "protocol/wire/byte_stream.h"

namespace loam::wire {

Result<FrameHeader> parse_frame_header(std::span<const uint8_t> header, uint32_t max_frame_bytes) {
  if (header.size() < kFrameHeaderBytes) {
    return truncated_error("frame.header", kFrameHeaderBytes, 0, header.size());
  }
  FrameHeader h;
  h.length = load_le<uint32_t>(header.data());
  h.type = load_le<uint16_t>(header.data() + 4);
  if (h.length > max_frame_bytes) return oversize_error("frame.length", h.length, max_frame_bytes);
  return h;
}

Status append_frame(std::vector<uint8_t>& out, const Message& m, uint32_t max_frame_bytes) {
  // Measure first so an oversize message is refused before anything is appended.
  Result<size_t> size = measure_payload(m);
  if (!size.ok()) return size.error();
  if (*size > max_frame_bytes) return oversize_error("frame.length", *size, max_frame_bytes);
  const size_t start = out.size();
  out.resize(start + kFrameHeaderBytes);
  store_le<uint32_t>(out.data() + start, static_cast<uint32_t>(*size));
  store_le<uint16_t>(out.data() + start + 4, static_cast<uint16_t>(message_type(m)));
  Result<std::vector<uint8_t>> payload = encode_payload(m);
  if (!payload.ok()) {
    out.resize(start);
    return payload.error();
  }
  out.insert(out.end(), payload->begin(), payload->end());
  return {};
}

Result<std::vector<uint8_t>> encode_frame(const Message& m, uint32_t max_frame_bytes) {
  std::vector<uint8_t> out;
  LOAM_TRY(append_frame(out, m, max_frame_bytes));
  return out;
}

Result<Message> decode_frame(std::span<const uint8_t> frame, uint32_t max_frame_bytes) {
  Result<FrameHeader> h = parse_frame_header(frame, max_frame_bytes);
  if (!h.ok()) return h.error();
  const size_t have = frame.size() - kFrameHeaderBytes;
  if (have < h->length) return truncated_error("frame.payload", h->length, kFrameHeaderBytes, have);
  if (have > h->length) {
    return make_error(ErrorCode::kCorrupt, "frame.payload",
                      std::to_string(have - h->length) + " bytes after the frame");
  }
  return decode_payload(h->type, frame.subspan(kFrameHeaderBytes));
}

FrameAssembler::FrameAssembler(uint32_t max_frame_bytes)
    : max_frame_bytes_(std::min(max_frame_bytes, kAbsoluteMaxFrameBytes)) {}

void FrameAssembler::feed(std::span<const uint8_t> bytes) {
  if (error_) return;  // the stream is out of sync; keep nothing more
  // Drop the consumed prefix once it dominates, so memory stays bounded by what is unread.
  if (read_ > 0 && read_ >= buffer_.size() / 2) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<ptrdiff_t>(read_));
    read_ = 0;
  }
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
}

Result<std::optional<Frame>> FrameAssembler::next() {
  if (error_) return *error_;
  const size_t avail = buffer_.size() - read_;
  if (avail < kFrameHeaderBytes) return std::optional<Frame>();
  Result<FrameHeader> h = parse_frame_header(
      std::span<const uint8_t>(buffer_).subspan(read_, kFrameHeaderBytes), max_frame_bytes_);
  if (h.ok() && (h->type < kFirstMessageType || h->type > kLastMessageType)) {
    // Refuse an unknown type at the header too, so no payload is buffered for it.
    h = make_error(ErrorCode::kUnknownType, "frame.type", "unknown message type " + std::to_string(h->type));
  }
  if (!h.ok()) {
    error_ = h.error();
    buffer_.clear();
    buffer_.shrink_to_fit();
    read_ = 0;
    return *error_;
  }
  if (avail - kFrameHeaderBytes < h->length) return std::optional<Frame>();
  Frame f;
  f.type = h->type;
  const auto begin = buffer_.begin() + static_cast<ptrdiff_t>(read_ + kFrameHeaderBytes);
  f.payload.assign(begin, begin + static_cast<ptrdiff_t>(h->length));
  read_ += kFrameHeaderBytes + h->length;
  if (read_ == buffer_.size()) {
    buffer_.clear();
    read_ = 0;
  }
  return std::optional<Frame>(std::move(f));
}

Result<std::optional<Message>> FrameAssembler::next_message() {
  Result<std::optional<Frame>> f = next();
  if (!f.ok()) return f.error();
  if (!f->has_value()) return std::optional<Message>();
  Result<Message> m = decode_payload((*f)->type, (*f)->payload);
  if (!m.ok()) {
    // A payload that does not decode leaves framing intact, but the peer is broken or
    // hostile: make it sticky so the caller closes the connection.
    error_ = m.error();
    return m.error();
  }
  return std::optional<Message>(std::move(*m));
}

}  // namespace loam::wire
