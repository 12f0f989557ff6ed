// Binary adaptive range coder for the region codec's best, delta and refinement modes.
//
// A carry-propagating range coder over 32-bit ranges with 12-bit probabilities, and an
// adaptive bit model that averages a fast and a slow estimate (so it follows local changes
// and still converges tightly on skewed bits). Encoder and decoder share the model code
// through the Coder interface: bit(model, b) encodes b and returns it, or decodes and returns
// the decoded bit; modelling code is written once and cannot drift between the two.
//
// Safety on untrusted input: the decoder never reads outside its span. Reading past the end
// feeds zero bytes and counts them; overran() reports it so the caller rejects the payload
// as truncated. Every decoded bit is valid for any input, so a corrupt stream only yields
// wrong samples, which the caller's checks (checksum, hash) catch.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace loam::codec {

inline constexpr uint32_t kProbBits = 12;
inline constexpr uint32_t kProbOne = 1u << kProbBits;
inline constexpr uint32_t kRangeTop = 1u << 24;

// Probability that the next bit is 0, as two 16-bit estimates adapting at different rates.
struct BitModel {
  uint16_t fast = 1u << 15;
  uint16_t slow = 1u << 15;

  uint32_t p0() const {
    const uint32_t p = (uint32_t(fast) + uint32_t(slow)) >> (17 - kProbBits);
    return p < 1 ? 1 : (p > kProbOne - 1 ? kProbOne - 1 : p);
  }
  void update(int bit) {
    if (bit) {
      fast = uint16_t(fast - (fast >> 4));
      slow = uint16_t(slow - (slow >> 7));
    } else {
      fast = uint16_t(fast + ((65535u - fast) >> 4));
      slow = uint16_t(slow + ((65535u - slow) >> 7));
    }
  }
};

class RangeEncoder {
 public:
  static constexpr bool kDecoding = false;
  explicit RangeEncoder(std::vector<uint8_t>& out) : out_(out) {}

  int bit(BitModel& m, int b) {
    encode(m.p0(), b);
    m.update(b);
    return b;
  }
  // A bit with probability 1/2 (no model).
  int raw_bit(int b) {
    encode(kProbOne / 2, b);
    return b;
  }
  // Writes the final bytes; call once at the end.
  void finish() {
    for (int i = 0; i < 5; ++i) shift_low();
  }

 private:
  void encode(uint32_t p0, int b) {
    const uint32_t bound = (range_ >> kProbBits) * p0;
    if (b) {
      low_ += bound;
      range_ -= bound;
    } else {
      range_ = bound;
    }
    while (range_ < kRangeTop) {
      range_ <<= 8;
      shift_low();
    }
  }
  void shift_low() {
    // A byte can only be emitted once no later carry can reach it; bytes of 0xFF are held
    // back (counted in pending_) until the carry is known.
    if (uint32_t(low_) < 0xFF000000u || (low_ >> 32) != 0) {
      const uint8_t carry = uint8_t(low_ >> 32);
      uint8_t byte = cache_;
      do {
        out_.push_back(uint8_t(byte + carry));
        byte = 0xFF;
      } while (--pending_ != 0);
      cache_ = uint8_t(low_ >> 24);
    }
    ++pending_;
    low_ = (low_ & 0x00FFFFFFu) << 8;
  }

  std::vector<uint8_t>& out_;
  uint64_t low_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
  uint8_t cache_ = 0;
  uint64_t pending_ = 1;
};

class RangeDecoder {
 public:
  static constexpr bool kDecoding = true;
  explicit RangeDecoder(std::span<const uint8_t> in) : in_(in) {
    // The encoder's first byte is always 0 (its initial cache); the next four prime code_.
    first_byte_ok_ = next() == 0;
    for (int i = 0; i < 4; ++i) code_ = (code_ << 8) | next();
  }

  int bit(BitModel& m, int /*unused*/) {
    const int b = decode(m.p0());
    m.update(b);
    return b;
  }
  int raw_bit(int /*unused*/) { return decode(kProbOne / 2); }

  // True when the stream was read past its end or did not start like an encoder's stream.
  bool overran() const { return overrun_ > 0 || !first_byte_ok_; }
  // Bytes of the span not consumed (a valid stream is consumed exactly).
  size_t remaining() const { return in_.size() - pos_; }

 private:
  int decode(uint32_t p0) {
    const uint32_t bound = (range_ >> kProbBits) * p0;
    int b;
    if (code_ < bound) {
      range_ = bound;
      b = 0;
    } else {
      code_ -= bound;
      range_ -= bound;
      b = 1;
    }
    while (range_ < kRangeTop) {
      range_ <<= 8;
      code_ = (code_ << 8) | next();
    }
    return b;
  }
  uint32_t next() {
    if (pos_ < in_.size()) return in_[pos_++];
    ++overrun_;
    return 0;
  }

  std::span<const uint8_t> in_;
  size_t pos_ = 0;
  uint64_t overrun_ = 0;
  uint32_t code_ = 0;
  uint32_t range_ = 0xFFFFFFFFu;
  bool first_byte_ok_ = true;
};

}  // namespace loam::codec
