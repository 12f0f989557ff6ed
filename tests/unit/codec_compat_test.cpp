// Region codec across format versions and the fuzz seed corpus: version 2 payloads (what
// server snapshots written before version 3 hold) still decode; version 2 refinement is
// refused; the seed corpus of fuzz/codec_fuzz.cpp holds valid current payloads of every
// mode. `LOAM_UPDATE_GOLDEN=1 loam_unit_tests --gtest_filter='CodecCorpus*'` rewrites the
// corpus (review the diff like any format change).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "protocol/byte_order.h"
#include "protocol/codec/region_codec.h"
#include "protocol/tile_hash.h"

namespace loam {
namespace {

namespace fs = std::filesystem;

fs::path golden_dir() { return fs::path(LOAM_SOURCE_DIR) / "tests" / "golden" / "codec"; }

std::vector<uint8_t> read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  EXPECT_TRUE(in.good()) << p;
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}
template <typename T>
std::vector<T> read_samples(const fs::path& p) {
  const std::vector<uint8_t> b = read_bytes(p);
  std::vector<T> s(b.size() / sizeof(T));
  for (size_t i = 0; i < s.size(); ++i) {
    if constexpr (sizeof(T) == 2) {
      s[i] = load_le<uint16_t>(b.data() + 2 * i);
    } else {
      s[i] = int8_t(b[i]);
    }
  }
  return s;
}

// tests/golden/codec/README.md says how these were made (the version 2 encoder, frozen).
TEST(CodecCompat, Version2FastPayloadsOfSnapshotsStillDecode) {
  for (const char* name : {"fast_v2_coarse_64x48", "fast_v2_coarse_shift3_64x48"}) {
    const std::vector<uint8_t> p = read_bytes(golden_dir() / (std::string(name) + ".region"));
    const std::vector<uint16_t> want =
        read_samples<uint16_t>(golden_dir() / (std::string(name) + ".samples"));
    ASSERT_EQ(p[2], 2) << "format version";
    ASSERT_EQ(read_region_header(p)->encoding, RegionEncoding::kFast);
    auto got = decode_region(p, 64, 48, {}, hash_coarse_tile(want));
    ASSERT_TRUE(got.ok()) << name << ": " << got.error().describe();
    EXPECT_EQ(*got, want) << name;
  }
  const std::vector<uint8_t> p = read_bytes(golden_dir() / "fast_v2_detail_40x24.region");
  const std::vector<int8_t> want = read_samples<int8_t>(golden_dir() / "fast_v2_detail_40x24.samples");
  auto got = decode_detail_region(p, 40, 24, {}, hash_detail_tile(want));
  ASSERT_TRUE(got.ok()) << got.error().describe();
  EXPECT_EQ(*got, want);
}

// Best and delta bodies did not change in version 3 (the field coder codes them as before).
TEST(CodecCompat, Version2BestAndDeltaPayloadsStillDecode) {
  const std::vector<uint8_t> best = read_bytes(golden_dir() / "best_v2_coarse_64x48.region");
  ASSERT_EQ(read_region_header(best)->encoding, RegionEncoding::kBest);
  auto b = decode_region(best, 64, 48);
  ASSERT_TRUE(b.ok()) << b.error().describe();
  EXPECT_EQ(*b, read_samples<uint16_t>(golden_dir() / "best_v2_coarse_64x48.samples"));

  const std::vector<uint8_t> delta = read_bytes(golden_dir() / "delta_v2_coarse_64x48.region");
  const std::vector<uint16_t> base = read_samples<uint16_t>(golden_dir() / "fast_v2_coarse_64x48.samples");
  ASSERT_EQ(read_region_header(delta)->encoding, RegionEncoding::kDelta);
  auto d = decode_region(delta, 64, 48, RegionRefs<uint16_t>{.base = base, .coarser = {}});
  ASSERT_TRUE(d.ok()) << d.error().describe();
  EXPECT_EQ(*d, read_samples<uint16_t>(golden_dir() / "delta_v2_coarse_64x48.samples"));
}

// Version 3 predicts refinement differently: a version 2 refinement payload must not be
// misread as version 3.
TEST(CodecCompat, Version2RefinementPayloadsAreRefusedAsUnsupported) {
  std::vector<uint16_t> s(16 * 16);
  for (size_t i = 0; i < s.size(); ++i) s[i] = uint16_t(3000 + i * 3);
  std::vector<uint16_t> coarser;
  for (uint32_t y = 0; y < 16; y += 2)
    for (uint32_t x = 0; x < 16; x += 2) coarser.push_back(s[y * 16 + x]);
  const RegionRefs<uint16_t> refs{.base = {}, .coarser = coarser};
  std::vector<uint8_t> p =
      *encode_region(RegionEncoding::kRefine, std::span<const uint16_t>(s), 16, 16, refs);
  ASSERT_EQ(read_region_header(p)->encoding, RegionEncoding::kRefine);
  p[2] = 2;
  const uint32_t c = region_checksum(p);
  for (int k = 0; k < 4; ++k) p[14 + size_t(k)] = uint8_t(c >> (8 * k));
  auto r = decode_region(p, 16, 16, refs);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kUnsupported);
  EXPECT_EQ(r.error().field, "region.version");
}

// --- Fuzz seed corpus ------------------------------------------------------------------

// What fuzz/codec_fuzz.cpp passes as references: base[i] = i * 37 + 11, coarser[i] = i * 5.
template <typename T>
struct FuzzRefs {
  std::vector<T> base, coarser;
  FuzzRefs(uint32_t w, uint32_t h) : base(size_t(w) * h), coarser(size_t((w + 1) / 2) * ((h + 1) / 2)) {
    for (size_t i = 0; i < base.size(); ++i) base[i] = T(i * 37 + 11);
    for (size_t i = 0; i < coarser.size(); ++i) coarser[i] = T(i * 5);
  }
};

// Samples for mode `m` consistent with those references: a delta is a small bump on the
// base, a refinement has the coarser samples at its even positions.
template <typename T>
std::vector<T> corpus_samples(RegionEncoding m, uint32_t w, uint32_t h, const FuzzRefs<T>& refs) {
  std::vector<T> s(size_t(w) * h);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const size_t i = size_t(y) * w + x;
      const int bump = int((x * 7 + y * 3) % 11) - 5;
      if (m == RegionEncoding::kDelta) {
        s[i] = T(refs.base[i] + (x > 3 && y > 3 ? bump : 0));
      } else if (m == RegionEncoding::kRefine && x % 2 == 0 && y % 2 == 0) {
        s[i] = refs.coarser[size_t(y / 2) * ((w + 1) / 2) + x / 2];
      } else if (m == RegionEncoding::kRefine) {
        const size_t j = size_t(y / 2) * ((w + 1) / 2) + x / 2;
        s[i] = T(refs.coarser[j] + bump);
      } else {
        s[i] = T(100 + x * 5 + y * 9 + bump);
      }
    }
  return s;
}

struct CorpusEntry {
  std::string name;
  std::vector<uint8_t> bytes;  // control byte, then the payload
};

template <typename T>
void add_entries(std::vector<CorpusEntry>& out, const char* prefix, uint32_t w, uint32_t h, uint8_t control) {
  const FuzzRefs<T> refs(w, h);
  for (RegionEncoding m : {RegionEncoding::kRaw, RegionEncoding::kFast, RegionEncoding::kBest,
                           RegionEncoding::kDelta, RegionEncoding::kRefine}) {
    const std::vector<T> s = corpus_samples(m, w, h, refs);
    RegionRefs<T> r;
    if (m == RegionEncoding::kDelta) r.base = refs.base;
    if (m == RegionEncoding::kRefine) r.coarser = refs.coarser;
    auto p = encode_region(m, std::span<const T>(s), w, h, r);
    ASSERT_TRUE(p.ok());
    CorpusEntry e{
        std::string(prefix) + "_" + std::to_string(w) + "x" + std::to_string(h) + "_" + to_string(m),
        {control}};
    e.bytes.insert(e.bytes.end(), p->begin(), p->end());
    out.push_back(std::move(e));
  }
}

std::vector<CorpusEntry> corpus() {
  std::vector<CorpusEntry> c;
  // Control bits (fuzz/codec_fuzz.cpp): 1 repair the checksum, 2 detail layer, 4 use the
  // header's dimensions (else 16x16).
  add_entries<uint16_t>(c, "u16", 16, 16, 0x01);
  add_entries<uint16_t>(c, "u16", 24, 20, 0x05);
  add_entries<uint16_t>(c, "u16", 64, 8, 0x05);  // 64 wide: the AVX2 row kernels
  add_entries<int8_t>(c, "i8", 16, 16, 0x07);
  add_entries<int8_t>(c, "i8", 64, 16, 0x07);  // big enough for fast to beat raw
  return c;
}

bool update_golden() {
  const char* v = std::getenv("LOAM_UPDATE_GOLDEN");
  return v != nullptr && std::string(v) == "1";
}

TEST(CodecCorpus, SeedCorpusHoldsTheCurrentPayloadOfEveryMode) {
  const fs::path dir = fs::path(LOAM_SOURCE_DIR) / "fuzz" / "corpus" / "codec_fuzz";
  const std::vector<CorpusEntry> entries = corpus();
  if (update_golden()) {
    for (const auto& e : fs::directory_iterator(dir)) fs::remove(e.path());
    for (const CorpusEntry& e : entries)
      std::ofstream(dir / e.name, std::ios::binary)
          .write(reinterpret_cast<const char*>(e.bytes.data()), std::streamsize(e.bytes.size()));
  }
  size_t files = 0;
  for (const auto& f : fs::directory_iterator(dir)) {
    (void)f;
    ++files;
  }
  EXPECT_EQ(files, entries.size()) << "stale seeds: rerun with LOAM_UPDATE_GOLDEN=1";
  for (const CorpusEntry& e : entries) {
    EXPECT_EQ(read_bytes(dir / e.name), e.bytes) << e.name << ": rerun with LOAM_UPDATE_GOLDEN=1";
  }
}

}  // namespace
}  // namespace loam
