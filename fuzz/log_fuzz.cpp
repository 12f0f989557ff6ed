// libFuzzer target for the deformation-log reader: scan_segment() on arbitrary bytes, then
// the JSON views of whatever it accepted. Properties checked (abort on violation):
//  - the accepted prefix re-encodes to exactly the input's bytes up to good_bytes;
//  - good_bytes never exceeds the input and damage is reported with an offset inside it.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <vector>

#include "protocol/log/log_format.h"
#include "protocol/log/log_json.h"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "log_fuzz property violated: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace loam::log;
  const std::span<const uint8_t> input(data, size);
  loam::Result<SegmentScan> scan = scan_segment(input);
  if (!scan.ok()) {
    if (scan.error().field.empty()) fail("scan error without a field name");
    return 0;
  }
  if (scan->good_bytes > size) fail("good_bytes beyond the input");
  if (scan->tail != TailState::kClean && (scan->damage_offset != scan->good_bytes || !scan->tail_error)) {
    fail("damage reported without its offset");
  }
  if (scan->tail == TailState::kClean && scan->good_bytes != size) fail("clean tail that is not the end");

  std::vector<uint8_t> again;
  if (!append_segment_header(again, scan->header.header).ok()) fail("accepted header does not encode");
  for (const LogRecord& r : scan->records) {
    if (!append_record(again, r).ok()) fail("accepted record does not encode");
  }
  if (again.size() != scan->good_bytes || !std::equal(again.begin(), again.end(), data)) {
    fail("scan then encode is not the identity");
  }

  const std::string dump = dump_jsonl(*scan);
  const LogSummary summary = summarize(std::span<const SegmentScan>(&*scan, 1));
  if (summary.records != scan->records.size()) fail("summary miscounts records");
  (void)summary_to_json(summary);
  (void)dump;
  return 0;
}
