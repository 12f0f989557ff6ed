// Golden byte vectors: the committed files under tests/golden/ are the wire and log formats.
// A failure here means the encoding changed: that needs a protocol (or log format) version
// bump, then `LOAM_UPDATE_GOLDEN=1 loam_unit_tests --gtest_filter='WireGolden*'` to rewrite
// the files (and the fuzz seed corpora), reviewed like any other change to the format.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "protocol/log/log_file.h"
#include "protocol/log/log_format.h"
#include "protocol/wire/framing.h"
#include "tests/unit/wire_samples.h"

namespace loam::wire {
namespace {

namespace fs = std::filesystem;

bool updating() {
  const char* v = std::getenv("LOAM_UPDATE_GOLDEN");
  return v != nullptr && std::string(v) == "1";
}

fs::path source_dir() { return fs::path(LOAM_SOURCE_DIR); }

void write_file(const fs::path& p, const std::vector<uint8_t>& bytes) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

std::vector<uint8_t> golden_log_segment(size_t records, uint16_t format_version = log::kLogFormatVersion) {
  std::vector<uint8_t> bytes;
  log::SegmentHeader h = test::sample_segment_header();
  if (format_version == 1) {  // format 1 recorded neither limits nor a base tick
    h.format_version = 1;
    h.has_limits = false;
    h.limits = {};
    h.base_tick = 0;
  }
  EXPECT_TRUE(log::append_segment_header(bytes, h).ok());
  for (uint64_t s = 1; s <= records; ++s)
    EXPECT_TRUE(log::append_record(bytes, test::sample_record(s, s)).ok());
  return bytes;
}

TEST(WireGolden, EveryMessageEncodesToItsCommittedBytesAndDecodesBack) {
  std::vector<uint8_t> stream;
  for (const auto& [name, m] : test::sample_messages()) {
    Result<std::vector<uint8_t>> frame = encode_frame(m);
    ASSERT_TRUE(frame.ok()) << name;
    stream.insert(stream.end(), frame->begin(), frame->end());
    const fs::path golden = source_dir() / "tests/golden/wire" / (name + ".bin");
    if (updating()) {
      write_file(golden, *frame);
      write_file(source_dir() / "fuzz/corpus/wire_fuzz" / (name + ".bin"), *frame);
      continue;
    }
    Result<std::vector<uint8_t>> committed = log::read_file(golden.string());
    ASSERT_TRUE(committed.ok()) << golden << ": " << committed.error().describe();
    EXPECT_EQ(*committed, *frame) << name << ": the wire format changed; see this file's header comment";
    Result<Message> back = decode_frame(*committed);
    ASSERT_TRUE(back.ok()) << name << ": " << back.error().describe();
    EXPECT_TRUE(*back == m) << name;
  }
  if (updating()) write_file(source_dir() / "fuzz/corpus/wire_fuzz/all_messages_stream.bin", stream);
}

TEST(WireGolden, FormatOneLogSegmentStillEncodesToItsCommittedBytesAndReads) {
  // Logs are long-lived: a format 1 segment (before limits and base ticks) still reads.
  const std::vector<uint8_t> bytes = golden_log_segment(3, 1);
  Result<std::vector<uint8_t>> committed =
      log::read_file((source_dir() / "tests/golden/log/segment-3-records.bin").string());
  ASSERT_TRUE(committed.ok()) << committed.error().describe();
  EXPECT_EQ(*committed, bytes);
  Result<log::SegmentScan> scan = log::scan_segment(*committed);
  ASSERT_TRUE(scan.ok()) << scan.error().describe();
  EXPECT_EQ(scan->header.header.format_version, 1);
  EXPECT_FALSE(scan->header.header.has_limits);
  EXPECT_FALSE(scan->header.header.hashes_cover_params());
  EXPECT_EQ(scan->records.size(), 3u);
}

TEST(WireGolden, LogSegmentEncodesToItsCommittedBytes) {
  const std::vector<uint8_t> bytes = golden_log_segment(3);
  const fs::path golden = source_dir() / "tests/golden/log/segment-3-records-v2.bin";
  if (updating()) {
    write_file(golden, bytes);
    write_file(source_dir() / "fuzz/corpus/log_fuzz/segment-3-records-v2.bin", bytes);
    write_file(source_dir() / "fuzz/corpus/log_fuzz/segment-empty.bin", golden_log_segment(0));
    std::vector<uint8_t> torn = golden_log_segment(2);
    torn.resize(torn.size() - 5);
    write_file(source_dir() / "fuzz/corpus/log_fuzz/segment-torn.bin", torn);
    return;
  }
  Result<std::vector<uint8_t>> committed = log::read_file(golden.string());
  ASSERT_TRUE(committed.ok()) << committed.error().describe();
  EXPECT_EQ(*committed, bytes) << "the log format changed; see this file's header comment";
  Result<log::SegmentScan> scan = log::scan_segment(*committed);
  ASSERT_TRUE(scan.ok()) << scan.error().describe();
  EXPECT_EQ(scan->records.size(), 3u);
}

}  // namespace
}  // namespace loam::wire
