// Deformation log: encode/scan identity, durable writer, torn-tail recovery, corruption
// detection with offsets, sequence order, segment chaining, and the JSON views.
#include <gtest/gtest.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "protocol/byte_order.h"
#include "protocol/log/log_file.h"
#include "protocol/log/log_format.h"
#include "protocol/log/log_json.h"
#include "tests/unit/wire_samples.h"

namespace loam::log {
namespace {

namespace fs = std::filesystem;
using test::sample_record;
using test::sample_segment_header;

constexpr size_t kRecordBytes = kRecordOverheadBytes + kStampRecordBodyBytes;

std::vector<uint8_t> make_segment(const SegmentHeader& h, uint64_t first_seq, int count,
                                  uint64_t* checksum = nullptr) {
  std::vector<uint8_t> bytes;
  Result<uint64_t> sum = append_segment_header(bytes, h);
  EXPECT_TRUE(sum.ok()) << sum.error().describe();
  if (checksum) *checksum = *sum;
  for (int i = 0; i < count; ++i) {
    EXPECT_TRUE(
        append_record(bytes, sample_record(first_seq + uint64_t(i), h.base_tick + 10 + uint64_t(i) / 3))
            .ok());
  }
  return bytes;
}

class LogFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("loam-log-test-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  static void write_bytes(const std::string& p, const std::vector<uint8_t>& b) {
    std::ofstream(p, std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
  }
  static std::vector<uint8_t> bytes_of(const std::string& p) { return *read_file(p); }

  fs::path dir_;
};

TEST(LogFormat, HeaderAndRecordsEncodeThenScanToTheSameValues) {
  const SegmentHeader h = sample_segment_header();
  const std::vector<uint8_t> bytes = make_segment(h, 1, 7);
  Result<SegmentScan> scan = scan_segment(bytes);
  ASSERT_TRUE(scan.ok()) << scan.error().describe();
  EXPECT_EQ(scan->header.header, h);
  ASSERT_EQ(scan->records.size(), 7u);
  for (uint64_t i = 0; i < 7; ++i) EXPECT_EQ(scan->records[i], sample_record(i + 1, 10 + i / 3));
  EXPECT_EQ(scan->tail, TailState::kClean);
  EXPECT_EQ(scan->good_bytes, bytes.size());
  EXPECT_EQ(scan->last_seq(), 7u);
}

TEST(LogFormat, TruncationAtEveryByteOffsetIsAHeaderErrorOrATornTail) {
  const std::vector<uint8_t> bytes = make_segment(sample_segment_header(), 1, 3);
  const size_t header_bytes = bytes.size() - 3 * kRecordBytes;
  for (size_t n = 0; n < bytes.size(); ++n) {
    const std::vector<uint8_t> prefix(bytes.begin(), bytes.begin() + static_cast<ptrdiff_t>(n));
    Result<SegmentScan> scan = scan_segment(prefix);
    if (n < header_bytes) {
      ASSERT_FALSE(scan.ok()) << n;
      continue;
    }
    ASSERT_TRUE(scan.ok()) << n << ": " << scan.error().describe();
    const size_t whole = (n - header_bytes) / kRecordBytes;
    EXPECT_EQ(scan->records.size(), whole) << n;
    EXPECT_EQ(scan->good_bytes, header_bytes + whole * kRecordBytes) << n;
    if (scan->good_bytes == n) {
      EXPECT_EQ(scan->tail, TailState::kClean) << n;
    } else {
      EXPECT_EQ(scan->tail, TailState::kTorn) << n;
      EXPECT_TRUE(scan->recoverable) << n;
    }
  }
}

TEST(LogFormat, AnyFlippedByteIsDetectedAndMidFileDamageIsNotCalledATornTail) {
  const std::vector<uint8_t> clean = make_segment(sample_segment_header(), 1, 4);
  const size_t header_bytes = clean.size() - 4 * kRecordBytes;
  for (size_t i = 0; i < clean.size(); ++i) {
    std::vector<uint8_t> bytes = clean;
    bytes[i] ^= 0x10;
    Result<SegmentScan> scan = scan_segment(bytes);
    if (i < header_bytes) {
      EXPECT_FALSE(scan.ok()) << "header byte " << i;
      continue;
    }
    ASSERT_TRUE(scan.ok()) << i << ": " << scan.error().describe();
    const size_t record = (i - header_bytes) / kRecordBytes;
    EXPECT_EQ(scan->tail, TailState::kCorrupt) << i;
    EXPECT_EQ(scan->records.size(), record) << i;
    EXPECT_EQ(scan->damage_offset, header_bytes + record * kRecordBytes) << i;
    // A complete record with damage is never cut away automatically, the final one included:
    // it may have been acknowledged (only a short, torn append is).
    EXPECT_FALSE(scan->recoverable) << i;
  }
}

TEST(LogFormat, SequenceGapAndDisorderAreErrorsNamingTheOffset) {
  for (const auto& [seqs, word] : {std::pair{std::vector<uint64_t>{1, 2, 4}, "gap"},
                                   std::pair{std::vector<uint64_t>{1, 2, 2}, "disorder"}}) {
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(append_segment_header(bytes, sample_segment_header()).ok());
    const size_t header_bytes = bytes.size();
    for (uint64_t s : seqs) ASSERT_TRUE(append_record(bytes, sample_record(s, 1)).ok());
    Result<SegmentScan> scan = scan_segment(bytes);
    ASSERT_FALSE(scan.ok());
    EXPECT_EQ(scan.error().field, "record.global_seq");
    EXPECT_NE(scan.error().message.find(word), std::string::npos) << scan.error().message;
    EXPECT_NE(scan.error().message.find(std::to_string(header_bytes + 2 * kRecordBytes)), std::string::npos)
        << scan.error().message;
  }
}

TEST(LogFormat, TicksGoingBackwardsAreAnError) {
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(append_segment_header(bytes, sample_segment_header()).ok());
  ASSERT_TRUE(append_record(bytes, sample_record(1, 5)).ok());
  ASSERT_TRUE(append_record(bytes, sample_record(2, 4)).ok());
  Result<SegmentScan> scan = scan_segment(bytes);
  ASSERT_FALSE(scan.ok());
  EXPECT_EQ(scan.error().field, "record.tick");
}

TEST(LogFormat, UnknownFormatVersionIsUnsupportedEvenWithAValidChecksum) {
  std::vector<uint8_t> bytes = make_segment(sample_segment_header(), 1, 0);
  store_le<uint16_t>(bytes.data() + 12,
                     kLogFormatVersion + 1);  // format_version, the body's first field
  const size_t body_end = bytes.size() - 8;
  store_le<uint64_t>(bytes.data() + body_end, XXH3_64bits(bytes.data(), body_end));
  Result<SegmentScan> scan = scan_segment(bytes);
  ASSERT_FALSE(scan.ok());
  EXPECT_EQ(scan.error().code, ErrorCode::kUnsupported);
  EXPECT_EQ(scan.error().field, "log.format_version");
}

TEST(LogFormat, HeaderLengthBeyondItsCapIsOversizeWithoutAllocating) {
  std::vector<uint8_t> bytes = make_segment(sample_segment_header(), 1, 0);
  store_le<uint32_t>(bytes.data() + 8, 0xFFFFFFFFu);
  Result<SegmentScan> scan = scan_segment(bytes);
  ASSERT_FALSE(scan.ok());
  EXPECT_EQ(scan.error().code, ErrorCode::kOversize);
  EXPECT_EQ(scan.error().field, "log.header_length");
}

TEST(LogFormat, FirstSegmentMustStartFromTheInitialTerrain) {
  SegmentHeader h = sample_segment_header();
  h.base_seq = 5;
  std::vector<uint8_t> bytes;
  Result<uint64_t> r = append_segment_header(bytes, h);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "log.base_seq");
  h = sample_segment_header();
  h.base_world_hash ^= 1;
  r = append_segment_header(bytes, h);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "log.base_world_hash");
}

TEST(LogFormat, ZeroFilledTailIsATornAppend) {
  std::vector<uint8_t> bytes = make_segment(sample_segment_header(), 1, 2);
  const size_t good = bytes.size();
  bytes.resize(bytes.size() + 4096, 0);
  Result<SegmentScan> scan = scan_segment(bytes);
  ASSERT_TRUE(scan.ok());
  EXPECT_EQ(scan->tail, TailState::kTorn);
  EXPECT_TRUE(scan->recoverable);
  EXPECT_EQ(scan->good_bytes, good);
}

TEST_F(LogFile, WriterAppendsSyncsAndReaderSeesEveryRecord) {
  const std::string p = path(segment_file_name(0));
  EXPECT_EQ(segment_file_name(3), "segment-00000003.loamlog");
  Result<LogWriter> w = LogWriter::create(p, sample_segment_header());
  ASSERT_TRUE(w.ok()) << w.error().describe();
  for (uint64_t s = 1; s <= 10; ++s) {
    ASSERT_TRUE(w->append(sample_record(s, s)).ok());
    if (s % 4 == 0) {
      ASSERT_TRUE(w->sync().ok());  // group commit every few records
    }
  }
  ASSERT_TRUE(w->sync().ok());
  EXPECT_EQ(w->pending_bytes(), 0u);
  Result<SegmentScan> scan = read_segment(p);
  ASSERT_TRUE(scan.ok()) << scan.error().describe();
  ASSERT_EQ(scan->records.size(), 10u);
  EXPECT_EQ(scan->records[9], sample_record(10, 10));
  EXPECT_EQ(scan->tail, TailState::kClean);
  EXPECT_EQ(uint64_t(fs::file_size(p)), w->file_bytes());
}

TEST_F(LogFile, WriterRefusesAnExistingFileAndOutOfOrderRecords) {
  const std::string p = path("a.loamlog");
  Result<LogWriter> w = LogWriter::create(p, sample_segment_header());
  ASSERT_TRUE(w.ok());
  EXPECT_FALSE(LogWriter::create(p, sample_segment_header()).ok());
  Status st = w->append(sample_record(2, 1));
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().field, "record.global_seq");
  ASSERT_TRUE(w->append(sample_record(1, 5)).ok());
  st = w->append(sample_record(2, 4));
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().field, "record.tick");
}

TEST_F(LogFile, TornLastRecordIsRecoveredAndAppendingContinues) {
  const std::string p = path("torn.loamlog");
  {
    Result<LogWriter> w = LogWriter::create(p, sample_segment_header());
    ASSERT_TRUE(w.ok());
    for (uint64_t s = 1; s <= 5; ++s) ASSERT_TRUE(w->append(sample_record(s, s)).ok());
    ASSERT_TRUE(w->sync().ok());
  }
  const uint64_t full = fs::file_size(p);
  fs::resize_file(p, full - 7);  // a crash in the middle of writing record 5
  EXPECT_FALSE(LogWriter::open_append(p).ok()) << "appending after a torn tail would bury it";
  Result<Recovery> rec = recover_segment(p);
  ASSERT_TRUE(rec.ok()) << rec.error().describe();
  EXPECT_EQ(rec->scan.records.size(), 4u);
  EXPECT_EQ(rec->truncated_at, full - kRecordBytes);
  EXPECT_EQ(rec->removed_bytes, kRecordBytes - 7);
  EXPECT_EQ(fs::file_size(p), full - kRecordBytes);
  Result<LogWriter> w = LogWriter::open_append(p);
  ASSERT_TRUE(w.ok()) << w.error().describe();
  EXPECT_EQ(w->next_seq(), 5u);
  ASSERT_TRUE(w->append(sample_record(5, 6)).ok());
  ASSERT_TRUE(w->sync().ok());
  Result<SegmentScan> scan = read_segment(p);
  ASSERT_TRUE(scan.ok());
  EXPECT_EQ(scan->records.size(), 5u);
  EXPECT_EQ(scan->tail, TailState::kClean);
}

TEST_F(LogFile, FlippedByteMidFileIsDetectedWithItsOffsetAndNotTruncated) {
  const std::string p = path("flip.loamlog");
  std::vector<uint8_t> bytes = make_segment(sample_segment_header(), 1, 10);
  const size_t header_bytes = bytes.size() - 10 * kRecordBytes;
  const size_t bad_record_offset = header_bytes + 4 * kRecordBytes;
  bytes[bad_record_offset + 30] ^= 0x01;
  write_bytes(p, bytes);
  Result<SegmentScan> scan = read_segment(p);
  ASSERT_TRUE(scan.ok());
  EXPECT_EQ(scan->tail, TailState::kCorrupt);
  EXPECT_EQ(scan->damage_offset, bad_record_offset);
  EXPECT_EQ(scan->records.size(), 4u);
  EXPECT_FALSE(scan->recoverable);
  ASSERT_TRUE(scan->tail_error.has_value());
  EXPECT_NE(scan->tail_error->message.find(std::to_string(bad_record_offset)), std::string::npos);
  Result<Recovery> rec = recover_segment(p);
  ASSERT_FALSE(rec.ok());
  EXPECT_EQ(rec.error().code, ErrorCode::kCorrupt);
  EXPECT_NE(rec.error().message.find(std::to_string(bad_record_offset)), std::string::npos);
  EXPECT_EQ(bytes_of(p), bytes) << "a mid-file corruption must leave the file for an operator";
}

TEST_F(LogFile, SegmentsThatChainAreReadInOrder) {
  uint64_t sum0 = 0;
  const SegmentHeader h0 = sample_segment_header();
  write_bytes(path("s0"), make_segment(h0, 1, 5, &sum0));
  SegmentHeader h1 = h0;
  h1.segment_index = 1;
  h1.base_seq = 5;
  h1.base_snapshot_id = 77;
  h1.base_world_hash = 0xABCDEF;
  h1.prev_header_checksum = sum0;
  h1.base_tick = 11;  // segment 0's last tick
  write_bytes(path("s1"), make_segment(h1, 6, 3));
  Result<std::vector<SegmentScan>> log = read_log({path("s0"), path("s1")});
  ASSERT_TRUE(log.ok()) << log.error().describe();
  ASSERT_EQ(log->size(), 2u);
  EXPECT_EQ((*log)[1].last_seq(), 8u);
  const LogSummary s = summarize(*log);
  EXPECT_EQ(s.records, 8u);
  EXPECT_EQ(s.first_seq, 1u);
  EXPECT_EQ(s.last_seq, 8u);
  EXPECT_EQ(s.segments, 2u);
}

TEST_F(LogFile, SegmentThatDoesNotChainIsRejectedNamingTheField) {
  uint64_t sum0 = 0;
  const SegmentHeader h0 = sample_segment_header();
  write_bytes(path("s0"), make_segment(h0, 1, 5, &sum0));
  SegmentHeader good = h0;
  good.segment_index = 1;
  good.base_seq = 5;
  good.base_snapshot_id = 77;
  good.prev_header_checksum = sum0;
  good.base_tick = 11;
  struct Case {
    SegmentHeader h;
    const char* field;
  };
  std::vector<Case> cases;
  SegmentHeader h = good;
  h.base_seq = 4;
  cases.push_back({h, "log.base_seq"});
  h = good;
  h.prev_header_checksum ^= 1;
  cases.push_back({h, "log.prev_header_checksum"});
  h = good;
  h.segment_index = 2;
  cases.push_back({h, "log.segment_index"});
  h = good;
  h.world.tiles_x += 1;
  cases.push_back({h, "log.world"});
  h = good;
  h.initial.dem_path = "other.tif";
  cases.push_back({h, "log.initial"});
  h = good;
  h.base_tick = 3;
  cases.push_back({h, "log.base_tick"});
  for (const Case& c : cases) {
    write_bytes(path("s1"), make_segment(c.h, c.h.base_seq + 1, 2));
    Result<std::vector<SegmentScan>> log = read_log({path("s0"), path("s1")});
    ASSERT_FALSE(log.ok()) << c.field;
    EXPECT_EQ(log.error().field, c.field) << log.error().describe();
  }
}

TEST_F(LogFile, DamagedSegmentFollowedByAnotherDoesNotChain) {
  uint64_t sum0 = 0;
  std::vector<uint8_t> s0 = make_segment(sample_segment_header(), 1, 5, &sum0);
  s0.resize(s0.size() - 3);
  write_bytes(path("s0"), s0);
  SegmentHeader h1 = sample_segment_header();
  h1.segment_index = 1;
  h1.base_seq = 4;
  h1.base_snapshot_id = 1;
  h1.prev_header_checksum = sum0;
  write_bytes(path("s1"), make_segment(h1, 5, 1));
  Result<std::vector<SegmentScan>> log = read_log({path("s0"), path("s1")});
  ASSERT_FALSE(log.ok());
  EXPECT_EQ(log.error().field, "log.tail");
}

TEST(LogJson, DumpHasOneLinePerRecordAndMarksADamagedTail) {
  std::vector<uint8_t> bytes = make_segment(sample_segment_header(), 1, 3);
  Result<SegmentScan> scan = scan_segment(bytes);
  ASSERT_TRUE(scan.ok());
  std::string dump = dump_jsonl(*scan);
  EXPECT_EQ(std::count(dump.begin(), dump.end(), '\n'), 4);
  EXPECT_NE(dump.find("\"type\":\"segment\""), std::string::npos);
  EXPECT_NE(dump.find("\"seq\":3"), std::string::npos);
  EXPECT_NE(dump.find("\"dem_path\":\"data/terrain/alps.tif\""), std::string::npos);
  EXPECT_NE(dump.find("\"import_params\":\"{\\\"headroom\\\":0.25}\""), std::string::npos) << dump;
  bytes.resize(bytes.size() - 1);
  scan = scan_segment(bytes);
  ASSERT_TRUE(scan.ok());
  dump = dump_jsonl(*scan);
  EXPECT_NE(dump.find("\"type\":\"tail\",\"state\":\"torn\""), std::string::npos) << dump;
}

TEST(LogJson, SummaryCountsRecordsKindsClientsAndRange) {
  Result<SegmentScan> scan = scan_segment(make_segment(sample_segment_header(), 1, 6));
  ASSERT_TRUE(scan.ok());
  const LogSummary s = summarize(std::span<const SegmentScan>(&*scan, 1));
  EXPECT_EQ(s.records, 6u);
  EXPECT_EQ(s.first_seq, 1u);
  EXPECT_EQ(s.last_seq, 6u);
  EXPECT_EQ(s.per_kind[size_t(StampKind::kGaussian)], 3u);
  EXPECT_EQ(s.per_kind[size_t(StampKind::kCrater)], 3u);
  EXPECT_EQ(s.distinct_clients, 3u);
  EXPECT_NE(summary_to_json(s).find("\"records\":6"), std::string::npos);
  EXPECT_NE(summary_to_text(s).find("sequence: 1..6"), std::string::npos);
}

// A crash during the last append leaves a short record; a complete final record that fails
// its checksum was written whole (and possibly acknowledged after its fdatasync): media
// damage, which recovery refuses to drop by itself.
TEST_F(LogFile, CompleteFinalRecordWithABadChecksumIsRefusedNotDropped) {
  const std::string p = path("media.loamlog");
  std::vector<uint8_t> bytes = make_segment(sample_segment_header(), 1, 3);
  bytes[bytes.size() - kRecordBytes + 30] ^= 0x04;  // inside the final record's body
  write_bytes(p, bytes);
  Result<Recovery> rec = recover_segment(p);
  ASSERT_FALSE(rec.ok());
  EXPECT_EQ(rec.error().code, ErrorCode::kCorrupt);
  EXPECT_NE(rec.error().message.find("media damage"), std::string::npos) << rec.error().describe();
  EXPECT_EQ(bytes_of(p), bytes) << "a complete record must stay for an operator";
  // The operator's explicit repair cuts it.
  Result<SegmentScan> scan = read_segment(p);
  ASSERT_TRUE(scan.ok());
  ASSERT_TRUE(truncate_segment(p, scan->good_bytes).ok());
  EXPECT_EQ(fs::file_size(p), bytes.size() - kRecordBytes);
}

TEST_F(LogFile, ShortFinalRecordIsATornAppendAndIsTruncated) {
  const std::string p = path("short.loamlog");
  std::vector<uint8_t> bytes = make_segment(sample_segment_header(), 1, 3);
  bytes.resize(bytes.size() - 1);  // one byte short of complete
  write_bytes(p, bytes);
  Result<Recovery> rec = recover_segment(p);
  ASSERT_TRUE(rec.ok()) << rec.error().describe();
  EXPECT_EQ(rec->scan.records.size(), 2u);
  EXPECT_EQ(rec->removed_bytes, kRecordBytes - 1);
}

TEST(LogFormat, FormatTwoHeaderRecordsLimitsAndBaseTick) {
  SegmentHeader h = sample_segment_header();
  h.limits = {65536.0, 4000, int64_t(1) << 30};
  h.base_tick = 777;
  const std::vector<uint8_t> bytes = make_segment(h, 1, 0);
  Result<SegmentScan> scan = scan_segment(bytes);
  ASSERT_TRUE(scan.ok()) << scan.error().describe();
  EXPECT_EQ(scan->header.header.limits, h.limits);
  EXPECT_EQ(scan->header.header.base_tick, 777u);
  EXPECT_TRUE(scan->header.header.has_limits);
  EXPECT_TRUE(scan->header.header.hashes_cover_params());
  EXPECT_EQ(scan->last_tick, 777u);
}

TEST(LogFormat, RecordTickBeforeTheSegmentsBaseTickIsAnError) {
  SegmentHeader h = sample_segment_header();
  h.base_tick = 1000;
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(append_segment_header(bytes, h).ok());
  ASSERT_TRUE(append_record(bytes, sample_record(1, 999)).ok());
  Result<SegmentScan> scan = scan_segment(bytes);
  ASSERT_FALSE(scan.ok());
  EXPECT_EQ(scan.error().field, "record.tick");
}

TEST(LogFormat, HeaderWithNonFiniteOrOutOfRangeLimitsIsRefused) {
  for (const double r : {std::nan(""), -1.0, 0.0, 1e9}) {
    SegmentHeader h = sample_segment_header();
    h.limits.max_radius_samples = r;
    std::vector<uint8_t> bytes;
    // One serialize function reads and writes: such a header can be neither written nor read.
    Result<uint64_t> written = append_segment_header(bytes, h);
    ASSERT_FALSE(written.ok()) << r;
    EXPECT_EQ(written.error().field, "log.limits.max_radius_samples");
  }
}

TEST_F(LogFile, WriterCreatedAtABaseTickRefusesEarlierTicks) {
  SegmentHeader h = sample_segment_header();
  h.base_tick = 50;
  Result<LogWriter> w = LogWriter::create(path("tick.loamlog"), h);
  ASSERT_TRUE(w.ok()) << w.error().describe();
  EXPECT_EQ(w->last_tick(), 50u);
  EXPECT_FALSE(w->append(sample_record(1, 49)).ok());
  EXPECT_TRUE(w->append(sample_record(1, 50)).ok());
}

TEST_F(LogFile, ReopenedSegmentContinuesFromItsLastTick) {
  const std::string p = path("ticks.loamlog");
  {
    Result<LogWriter> w = LogWriter::create(p, sample_segment_header());
    ASSERT_TRUE(w.ok());
    ASSERT_TRUE(w->append(sample_record(1, 900)).ok());
    ASSERT_TRUE(w->sync().ok());
  }
  Result<LogWriter> w = LogWriter::open_append(p);
  ASSERT_TRUE(w.ok()) << w.error().describe();
  EXPECT_EQ(w->last_tick(), 900u) << "a restarted server continues the log's ticks";
}

TEST_F(LogFile, ReopenAfterFailureCutsAnUnsyncedBatchOff) {
  const std::string p = path("reopen.loamlog");
  uint64_t durable = 0;
  {
    Result<LogWriter> w = LogWriter::create(p, sample_segment_header());
    ASSERT_TRUE(w.ok());
    ASSERT_TRUE(w->append(sample_record(1, 1)).ok());
    ASSERT_TRUE(w->sync().ok());
    durable = w->durable_bytes();
  }
  // A failed sync may leave whole records of the batch behind the durable end.
  std::vector<uint8_t> bytes = bytes_of(p);
  ASSERT_TRUE(append_record(bytes, sample_record(2, 2)).ok());
  write_bytes(p, bytes);
  Result<LogWriter> w = LogWriter::reopen_after_failure(p, durable, 1);
  ASSERT_TRUE(w.ok()) << w.error().describe();
  EXPECT_EQ(fs::file_size(p), durable);
  EXPECT_EQ(w->next_seq(), 2u);
  EXPECT_FALSE(LogWriter::reopen_after_failure(p, durable + 100, 1).ok()) << "shorter than durable";
}

TEST_F(LogFile, ReplacingAnEmptySegmentKeepsOneValidFile) {
  const std::string p = path("segment-00000000.loamlog");
  ASSERT_TRUE(LogWriter::create(p, sample_segment_header()).ok());
  SegmentHeader h = sample_segment_header();
  h.limits.max_radius_samples = 65536;
  Result<LogWriter> w = LogWriter::create_replacing(p, h);
  ASSERT_TRUE(w.ok()) << w.error().describe();
  Result<SegmentScan> scan = read_segment(p);
  ASSERT_TRUE(scan.ok());
  EXPECT_EQ(scan->header.header.limits.max_radius_samples, 65536);
  EXPECT_FALSE(fs::exists(p + ".tmp"));
}

TEST_F(LogFile, SegmentStartingBeforeThePreviousLastTickDoesNotChain) {
  uint64_t sum0 = 0;
  const std::vector<uint8_t> seg0 = make_segment(sample_segment_header(), 1, 3, &sum0);  // ticks 10, 10, 10
  Result<SegmentScan> scan0 = scan_segment(seg0);
  ASSERT_TRUE(scan0.ok());
  SegmentHeader h1 = sample_segment_header();
  h1.segment_index = 1;
  h1.base_seq = 3;
  h1.base_snapshot_id = 3;
  h1.prev_header_checksum = sum0;
  h1.base_tick = 5;
  Status st = check_chain(*scan0, h1);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().field, "log.base_tick");
  h1.base_tick = 10;
  EXPECT_TRUE(check_chain(*scan0, h1).ok());
}

}  // namespace
}  // namespace loam::log
