#include "protocol/codec/rans.h"

#include <algorithm>

namespace loam::codec::rans {

void normalize_frequencies(std::span<const uint32_t> counts, std::span<uint16_t> freqs) {
  uint64_t total = 0;
  for (uint32_t c : counts) total += c;
  std::fill(freqs.begin(), freqs.end(), uint16_t(0));
  if (total == 0) return;
  int64_t sum = 0;
  size_t largest = 0;
  for (size_t i = 0; i < counts.size(); ++i) {
    if (counts[i] == 0) continue;
    const uint64_t f = (uint64_t(counts[i]) * kProbScale + total / 2) / total;
    freqs[i] = uint16_t(std::max<uint64_t>(f, 1));
    sum += freqs[i];
    if (counts[i] > counts[largest]) largest = i;
  }
  // Rounding (and the floor of 1) leaves the sum a few counts off: the difference goes to
  // or comes from the largest frequencies, where it costs the fewest bits.
  if (sum < int64_t(kProbScale)) {
    freqs[largest] = uint16_t(freqs[largest] + (int64_t(kProbScale) - sum));
    return;
  }
  while (sum > int64_t(kProbScale)) {
    size_t top = 0;
    for (size_t i = 1; i < freqs.size(); ++i)
      if (freqs[i] > freqs[top]) top = i;
    // Every present symbol has at least 1 and there are at most kProbScale of them, so the
    // largest exceeds 1 while the sum exceeds kProbScale.
    freqs[top] = uint16_t(freqs[top] - 1);
    --sum;
  }
}

EncSymbol make_enc_symbol(uint32_t start, uint32_t freq) {
  EncSymbol s;
  // Renormalized states stay below f * 2^22 (= 2^32 for f = kProbScale: never emit).
  s.x_limit = uint32_t((uint64_t(freq) << (32 - kProbBits)) - 1);
  s.start = uint16_t(start);
  s.complement = uint16_t(kProbScale - freq);
  s.reciprocal = ((uint64_t(1) << kReciprocalShift) + freq - 1) / freq;
  return s;
}

bool build_decode_table(std::span<const uint16_t> freqs, std::span<uint32_t> table) {
  uint32_t sum = 0;
  for (uint16_t f : freqs) sum += f;
  if (sum != kProbScale || table.size() != kProbScale) return false;
  uint32_t slot = 0;
  for (size_t s = 0; s < freqs.size(); ++s) {
    const uint32_t first = pack_slot(uint32_t(s), freqs[s], 0);
    uint32_t* run = table.data() + slot;
    for (uint32_t k = 0; k < freqs[s]; ++k) run[k] = first + (k << 8);  // the bias field counts up
    slot += freqs[s];
  }
  return true;
}

void fill_unused_decode_table(std::span<uint32_t> table) {
  for (uint32_t slot = 0; slot < table.size(); ++slot) table[slot] = pack_slot(0, kProbScale, slot);
}

}  // namespace loam::codec::rans
