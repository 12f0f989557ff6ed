// docs/protocol.md and docs/stamps.md are the contract others implement Loam from: these tests
// parse their tables out of the markdown and check every number, name, order and width
// against the code, so a change on either side that the other does not follow fails here.
// How each table is checked:
// - protocol.md: the version (title and table), the message ids and names (and every "Name (id)"
//   heading), the error codes, the Bye reasons, the caps, the byte layouts with offsets
//   (TileCoord, TileRect, WorldParams, QuantizedStamp) and every message table (type | field):
//   each sample message of tests/unit/wire_samples.h is decoded from every prefix of its
//   payload, and the field each truncated decode names gives the order, names and widths the
//   decoder really reads, which must be the table's rows (conditional rows, marked "only",
//   may be absent). That walk ends at a list's count; a second walk takes the encoder's layout
//   (wire::payload_layout, the same serialize function) through every list element, the rows
//   marked "per entry", "per image" or "per tile" repeating as many times as the count says.
//   The golden vector table's files must decode as the message named.
// - stamps.md: every constant (by name) against the code's constant or, for numbers that
//   live inside the kernel (the Q16 divisor, exp's halving limit and term count, the gaussian
//   exponent, the crater's bowl radius), against what the kernel computes; the kinds table
//   against StampKind, the event rule and check_quantized.
#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "protocol/replication/event_rule.h"
#include "protocol/stamps/stamp_kernel.h"
#include "protocol/stamps/stamp_profile.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/wire/constants.h"
#include "protocol/wire/fields.h"
#include "protocol/wire/framing.h"
#include "protocol/wire/messages.h"
#include "tests/unit/wire_samples.h"

namespace loam {
namespace {

namespace fs = std::filesystem;

std::string read_doc(const std::string& name) {
  std::ifstream f(fs::path(LOAM_SOURCE_DIR) / "docs" / name);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream s(text);
  for (std::string l; std::getline(s, l);) out.push_back(l);
  return out;
}

std::string trim(std::string s) {
  const auto a = s.find_first_not_of(" \t");
  if (a == std::string::npos) return "";
  const auto b = s.find_last_not_of(" \t");
  s = s.substr(a, b - a + 1);
  // Code spans are for the human reader; the value is what is inside.
  if (s.size() >= 2 && s.front() == '`' && s.back() == '`') s = s.substr(1, s.size() - 2);
  return s;
}

struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  size_t line = 0;  // where it starts, for messages
};

std::vector<std::string> cells_of(const std::string& line) {
  std::vector<std::string> cells;
  std::string cur;
  // A pipe inside a code span is text, not a column break.
  bool code = false;
  for (size_t i = 1; i < line.size(); ++i) {
    const char c = line[i];
    if (c == '`') code = !code;
    if (c == '|' && !code) {
      cells.push_back(trim(cur));
      cur.clear();
    } else {
      cur += c;
    }
  }
  return cells;
}

// Every markdown table in `lines` [from, to).
std::vector<Table> tables_in(const std::vector<std::string>& lines, size_t from = 0,
                             size_t to = std::string::npos) {
  std::vector<Table> out;
  to = std::min(to, lines.size());
  for (size_t i = from; i < to; ++i) {
    if (lines[i].rfind("|", 0) != 0) continue;
    Table t;
    t.line = i + 1;
    t.header = cells_of(lines[i]);
    size_t j = i + 1;
    if (j < to && lines[j].rfind("|---", 0) == 0) ++j;
    for (; j < to && lines[j].rfind("|", 0) == 0; ++j) t.rows.push_back(cells_of(lines[j]));
    out.push_back(std::move(t));
    i = j;
  }
  return out;
}

std::optional<Table> table_with_header(const std::vector<Table>& ts, const std::vector<std::string>& header) {
  for (const Table& t : ts)
    if (t.header == header) return t;
  return std::nullopt;
}

// The first table after the line that starts with `marker`.
std::optional<Table> table_after(const std::vector<std::string>& lines, const std::string& marker) {
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].rfind(marker, 0) != 0) continue;
    const auto ts = tables_in(lines, i);
    if (!ts.empty()) return ts.front();
  }
  return std::nullopt;
}

uint64_t to_u64(const std::string& s) { return std::stoull(s, nullptr, 0); }

// Every run of decimal digits in s, as numbers, in order. (No <regex>: GCC 12 warns inside
// it, and warnings are errors.)
std::vector<uint64_t> numbers_in(const std::string& s) {
  std::vector<uint64_t> out;
  for (size_t i = 0; i < s.size();) {
    if (!std::isdigit(static_cast<unsigned char>(s[i]))) {
      ++i;
      continue;
    }
    size_t j = i;
    while (j < s.size() && std::isdigit(static_cast<unsigned char>(s[j]))) ++j;
    out.push_back(std::stoull(s.substr(i, j - i)));
    i = j;
  }
  return out;
}

// The "Name (id)" pairs of a heading such as "### StatsRequest (16) / Stats (17) — since 1.1".
std::vector<std::pair<std::string, uint16_t>> named_ids(const std::string& line) {
  std::vector<std::pair<std::string, uint16_t>> out;
  for (size_t p = line.find(" ("); p != std::string::npos; p = line.find(" (", p + 1)) {
    size_t q = p + 2;
    while (q < line.size() && std::isdigit(static_cast<unsigned char>(line[q]))) ++q;
    if (q == p + 2 || q >= line.size() || line[q] != ')') continue;
    size_t b = p;
    while (b > 0 && std::isalpha(static_cast<unsigned char>(line[b - 1]))) --b;
    if (b == p) continue;
    out.emplace_back(line.substr(b, p - b), uint16_t(std::stoul(line.substr(p + 2, q - p - 2))));
  }
  return out;
}

// The name with everything but letters and digits removed, lower case: "invalid_argument" and
// "invalid argument" compare equal.
std::string squash(const std::string& s) {
  std::string out;
  for (const char c : s)
    if (std::isalnum(static_cast<unsigned char>(c))) out += char(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

const std::string& protocol_doc() {
  static const std::string doc = read_doc("protocol.md");
  return doc;
}
const std::vector<std::string>& protocol_lines() {
  static const std::vector<std::string> l = lines_of(protocol_doc());
  return l;
}

// --- protocol.md ---

TEST(DocsDrift, ProtocolVersionInTheTitleAndTableIsTheCodes) {
  const auto& lines = protocol_lines();
  ASSERT_FALSE(lines.empty()) << "docs/protocol.md not found under " << LOAM_SOURCE_DIR;
  const size_t at = lines[0].find("version ");
  ASSERT_NE(at, std::string::npos) << lines[0];
  const auto title = numbers_in(lines[0].substr(at));
  ASSERT_GE(title.size(), 2u) << lines[0];
  EXPECT_EQ(title[0], wire::kProtocolMajor) << lines[0];
  EXPECT_EQ(title[1], wire::kProtocolMinor) << lines[0];
  const auto t = table_with_header(tables_in(lines), {"constant", "value"});
  ASSERT_TRUE(t.has_value()) << "no | constant | value | version table";
  std::map<std::string, uint64_t> v;
  for (const auto& r : t->rows) v[r.at(0)] = to_u64(r.at(1));
  EXPECT_EQ(v.at("version_major"), wire::kProtocolMajor);
  EXPECT_EQ(v.at("version_minor"), wire::kProtocolMinor);
  EXPECT_EQ(v.at("hello magic"), wire::kHelloMagic);
  // The Hello and Welcome tables state the major a peer must have.
  for (const char* msg : {"### Hello (1)", "### Welcome (2)"}) {
    const auto mt = table_after(lines, msg);
    ASSERT_TRUE(mt.has_value()) << msg;
    bool found = false;
    for (const auto& r : mt->rows) {
      if (r.at(1) != "version_major") continue;
      const auto n = numbers_in(r.at(2));
      ASSERT_FALSE(n.empty()) << msg << ": " << r.at(2);
      EXPECT_EQ(n[0], wire::kProtocolMajor) << msg << ": " << r.at(2);
      found = true;
    }
    EXPECT_TRUE(found) << msg << " has no version_major row";
  }
}

TEST(DocsDrift, MessageTableListsEveryTypeIdWithItsNameAndEachHeadingAgrees) {
  const auto& lines = protocol_lines();
  const auto t = table_with_header(tables_in(lines), {"id", "message", "direction"});
  ASSERT_TRUE(t.has_value()) << "no | id | message | direction | table";
  std::set<uint16_t> ids;
  for (const auto& r : t->rows) {
    const uint16_t id = uint16_t(to_u64(r.at(0)));
    ASSERT_GE(id, wire::kFirstMessageType) << r.at(1);
    ASSERT_LE(id, wire::kLastMessageType) << r.at(1);
    EXPECT_EQ(r.at(1), wire::to_string(wire::MessageType(id))) << "id " << id;
    EXPECT_TRUE(ids.insert(id).second) << "id " << id << " listed twice";
  }
  for (uint16_t id = wire::kFirstMessageType; id <= wire::kLastMessageType; ++id)
    EXPECT_TRUE(ids.count(id)) << "message id " << id << " (" << wire::to_string(wire::MessageType(id))
                               << ") is missing from the table";
  // Section headings name messages as "Name (id)": each must be the code's.
  std::set<uint16_t> headed;
  for (const std::string& l : lines) {
    if (l.rfind("### ", 0) != 0) continue;
    for (const auto& [name, id] : named_ids(l)) {
      ASSERT_LE(id, wire::kLastMessageType) << l;
      EXPECT_EQ(name, wire::to_string(wire::MessageType(id))) << l;
      headed.insert(id);
    }
  }
  EXPECT_EQ(headed, ids) << "every message has a section";
}

TEST(DocsDrift, ErrorCodeTableIsExactlyTheCodesTheDecoderAccepts) {
  const auto t = table_with_header(tables_in(protocol_lines()), {"code", "name", "meaning"});
  ASSERT_TRUE(t.has_value()) << "no | code | name | meaning | table";
  std::set<uint32_t> documented;
  for (const auto& r : t->rows) {
    const uint32_t code = uint32_t(to_u64(r.at(0)));
    documented.insert(code);
    ASSERT_LE(code, 65535u);
    const auto wc = wire::WireErrorCode(uint16_t(code));
    EXPECT_TRUE(wire::is_known(wc)) << "code " << code << " (" << r.at(1) << ") is not a code";
    // The code's own name for it ("i/o error" for io) starts with the documented name.
    EXPECT_EQ(squash(wire::to_string(wc)).rfind(squash(r.at(1)), 0), 0u)
        << "code " << code << ": doc says " << r.at(1) << ", code says " << wire::to_string(wc);
  }
  for (uint32_t v = 0; v <= 65535; ++v) {
    if (wire::is_known(wire::WireErrorCode(uint16_t(v)))) {
      EXPECT_TRUE(documented.count(v)) << "code " << v;
    }
  }
}

// The reasons as the code names them. A switch without default: a new ByeReason does not
// compile (-Werror=switch) until it is named here, and then this test asks the doc for it.
const char* bye_reason_name(wire::ByeReason r) {
  switch (r) {
    case wire::ByeReason::kNormal: return "normal";
    case wire::ByeReason::kShutdown: return "shutdown";
    case wire::ByeReason::kTimeout: return "timeout";
    case wire::ByeReason::kProtocolError: return "protocol_error";
    case wire::ByeReason::kKicked: return "kicked";
    case wire::ByeReason::kVersionMismatch: return "version_mismatch";
  }
  return "?";
}

TEST(DocsDrift, ByeReasonTableIsEveryReasonTheDecoderAccepts) {
  const auto t = table_after(protocol_lines(), "The sender closes after it.");
  ASSERT_TRUE(t.has_value());
  ASSERT_EQ(t->header.at(0), "reason");
  ASSERT_EQ(t->rows.size(), size_t(wire::kByeReasonCount));
  for (size_t i = 0; i < t->rows.size(); ++i) {
    const auto& r = t->rows[i];
    EXPECT_EQ(to_u64(r.at(0)), i);
    EXPECT_EQ(r.at(1), bye_reason_name(wire::ByeReason(i)));
  }
  // The table's end is the decoder's: one past the last reason is refused.
  std::vector<uint8_t> payload = {uint8_t(wire::kByeReasonCount - 1), 0, 0};
  EXPECT_TRUE(wire::decode_payload(uint16_t(wire::MessageType::kBye), payload).ok());
  payload[0] = uint8_t(wire::kByeReasonCount);
  const auto bad = wire::decode_payload(uint16_t(wire::MessageType::kBye), payload);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kBadEnum);
}

// "1 MiB / 16 MiB", "512 px / 512 KiB", "64 bytes", "1024" -> the numbers.
std::vector<uint64_t> cap_values(const std::string& cell) {
  std::vector<uint64_t> out;
  std::stringstream parts(cell);
  for (std::string part; std::getline(parts, part, '/');) {
    std::stringstream words(part);
    uint64_t v = 0;
    std::string unit;
    if (!(words >> v)) continue;
    words >> unit;
    if (unit == "KiB") v <<= 10;
    if (unit == "MiB") v <<= 20;
    out.push_back(v);
  }
  return out;
}

TEST(DocsDrift, CapsTableMatchesConstants) {
  const auto t = table_with_header(tables_in(protocol_lines()), {"cap", "value"});
  ASSERT_TRUE(t.has_value());
  using namespace wire;
  const std::map<std::string, std::vector<uint64_t>> code = {
      {"default / absolute max frame payload", {kDefaultMaxFrameBytes, kAbsoluteMaxFrameBytes}},
      {"client name", {kMaxClientNameBytes}},
      {"access token", {kAccessTokenBytes}},
      {"error / bye text", {kMaxErrorTextBytes}},
      {"field name (Error, DeformAck)", {kMaxFieldNameBytes}},
      {"Subscribe / Unsubscribe entries per message", {kMaxSubscribeEntries}},
      {"DeformEvent tiles", {kMaxEventTiles}},
      {"RegionUpdate chunk / whole payload", {kMaxRegionChunkBytes, kMaxRegionPayloadBytes}},
      {"TileHashes entries per message", {kMaxTileHashEntries}},
      {"stamp image side / bytes", {kMaxStampImageSide, kMaxStampImageBytes}},
      {"StampImageList entries", {kMaxStampImageListEntries}},
  };
  std::set<std::string> seen;
  for (const auto& r : t->rows) {
    const auto it = code.find(r.at(0));
    if (it == code.end()) {
      ADD_FAILURE() << "cap '" << r.at(0) << "' is not known to this test: add its constant";
      continue;
    }
    seen.insert(r.at(0));
    EXPECT_EQ(cap_values(r.at(1)), it->second) << r.at(0);
  }
  EXPECT_EQ(seen.size(), code.size()) << "a cap is missing from the table";
}

size_t type_width(const std::string& type) {
  static const std::map<std::string, size_t> w = {{"u8", 1},
                                                  {"bool", 1},
                                                  {"u16", 2},
                                                  {"u32", 4},
                                                  {"i32", 4},
                                                  {"u64", 8},
                                                  {"i64", 8},
                                                  {"f64", 8},
                                                  {"TileCoord", wire::kTileCoordBytes},
                                                  {"TileRect", wire::kTileRectBytes},
                                                  {"WorldParams", wire::kWorldParamsBytes},
                                                  {"QuantizedStamp", wire::kStampBytes}};
  if (const auto it = w.find(type); it != w.end()) return it->second;
  // bytes[N] with N a number (bytes[length] is variable).
  if (type.rfind("bytes[", 0) == 0 && type.back() == ']') {
    const std::string n = type.substr(6, type.size() - 7);
    if (!n.empty() && n.find_first_not_of("0123456789") == std::string::npos) return std::stoul(n);
  }
  return 0;  // variable: string, blob, varint, zigzag, CompactStamp, lists
}

// The field a decode of the first n bytes of `payload` names (what it was reading when the
// input ended), or "" when those bytes decode.
std::string field_at(wire::MessageType type, const std::vector<uint8_t>& payload, size_t n) {
  // Its own allocation, so a read past the prefix is an ASan error rather than a silent read.
  const std::vector<uint8_t> prefix(payload.begin(), payload.begin() + ptrdiff_t(n));
  const auto r = wire::decode_payload(uint16_t(type), prefix);
  return r.ok() ? std::string() : r.error().field;
}

std::vector<uint8_t> payload_of(const wire::Message& m) {
  auto p = wire::encode_payload(m);
  EXPECT_TRUE(p.ok());
  return p.ok() ? *p : std::vector<uint8_t>{};
}

const wire::Message& sample(const std::string& name) {
  static const auto samples = test::sample_messages();
  for (const auto& [n, m] : samples)
    if (n == name) return m;
  ADD_FAILURE() << "no sample " << name;
  return samples.front().second;
}

// A fixed layout table (offset | type | field | ...): offsets follow from the widths, the
// total is the code's, and the decoder, cut inside each field, names that field.
void check_layout(const std::string& marker, const std::string& prefix, size_t total,
                  const std::string& sample_name, size_t at) {
  SCOPED_TRACE(marker);
  const auto t = table_after(protocol_lines(), marker);
  ASSERT_TRUE(t.has_value());
  ASSERT_EQ(t->header.at(0), "offset");
  const wire::Message& m = sample(sample_name);
  const auto payload = payload_of(m);
  size_t offset = 0;
  for (const auto& r : t->rows) {
    EXPECT_EQ(to_u64(r.at(0)), offset) << r.at(2);
    const size_t w = type_width(r.at(1));
    ASSERT_GT(w, 0u) << r.at(1);
    // The field column may add a range or unit after the name: "meters_per_sample (> 0)".
    const std::string name = r.at(2).substr(0, r.at(2).find(' '));
    for (size_t k = 0; k < w; ++k)
      EXPECT_EQ(field_at(wire::message_type(m), payload, at + offset + k), prefix + name)
          << "byte " << k << " of " << name;
    offset += w;
  }
  EXPECT_EQ(offset, total);
}

TEST(DocsDrift, FixedLayoutsHaveTheDecodersOffsetsWidthsAndNames) {
  check_layout("**TileCoord**", "tile.", wire::kTileCoordBytes, "region_update", 0);
  check_layout("**TileRect**", "rect.", wire::kTileRectBytes, "region_update", wire::kTileCoordBytes);
  check_layout("**WorldParams**", "world.", wire::kWorldParamsBytes, "welcome", 2 + 2 + 4 + 1);
  check_layout("**QuantizedStamp**", "stamp.", wire::kStampBytes, "deform", 4);
  // The frame header is the framing code's.
  const auto t = table_after(protocol_lines(), "A connection is a byte stream of frames");
  ASSERT_TRUE(t.has_value());
  size_t offset = 0;
  for (const auto& r : t->rows) {
    EXPECT_EQ(to_u64(r.at(0)), offset);
    offset += type_width(r.at(1));
  }
  EXPECT_EQ(offset, wire::kFrameHeaderBytes);
}

// What the decoder reads, in order: each field's name and where it starts. Fields of a
// compound (tile.*, rect.*, world.*, stamp.*) count as one. The walk ends at a list's count:
// past it, a truncated list fails on the count (not enough bytes for the elements), so the
// elements are walked on the encoder's layout instead (folded_layout, below).
struct Read {
  std::string name;
  size_t offset = 0, width = 0;
};

std::string compound_of(const std::string& field) {
  for (const char* p : {"tile.", "rect.", "world.", "stamp."})
    if (field.rfind(p, 0) == 0) return std::string(p) + "*";
  return field;
}

bool is_count(const std::string& name) {
  return name.size() >= 5 && name.compare(name.size() - 5, 5, "count") == 0;
}

std::vector<Read> reads_of(const wire::Message& m) {
  const auto payload = payload_of(m);
  std::vector<Read> out;
  for (size_t n = 0; n < payload.size(); ++n) {
    const std::string f = compound_of(field_at(wire::message_type(m), payload, n));
    if (!out.empty() && out.back().name == f) continue;
    if (!out.empty()) out.back().width = n - out.back().offset;
    if (!out.empty() && is_count(out.back().name)) {
      out.back().width = 0;  // ran into the elements: unknown
      return out;
    }
    out.push_back({f, n, 0});
  }
  if (!out.empty()) out.back().width = is_count(out.back().name) ? 0 : payload.size() - out.back().offset;
  return out;
}

std::string expected_read(const std::string& prefix, const std::string& type, const std::string& field) {
  if (type == "TileCoord") return "tile.*";
  if (type == "TileRect") return "rect.*";
  if (type == "WorldParams") return "world.*";
  if (type == "QuantizedStamp" || type == "CompactStamp") return "stamp.*";
  return prefix + "." + field;
}

// Each message's field table (type | field ...) with its message: sections "### A (x)" or
// "### A (x) / B (y)", whose table, when there is one, is the last message's (the response of
// a request/response pair).
std::vector<std::pair<wire::MessageType, Table>> message_tables() {
  const auto& lines = protocol_lines();
  std::vector<std::pair<wire::MessageType, Table>> out;
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].rfind("### ", 0) != 0) continue;
    const auto named = named_ids(lines[i]);
    if (named.empty()) continue;
    size_t end = i + 1;
    while (end < lines.size() && lines[end].rfind("### ", 0) != 0 && lines[end].rfind("## ", 0) != 0) ++end;
    for (const Table& t : tables_in(lines, i + 1, end))
      if (t.header.size() >= 2 && t.header[0] == "type" && t.header[1] == "field") {
        out.emplace_back(wire::MessageType(named.back().second), t);
        break;
      }
  }
  return out;
}

TEST(DocsDrift, EveryMessageTableIsTheOrderNamesAndWidthsTheDecoderReads) {
  size_t tables_checked = 0;
  for (const auto& [type, table] : message_tables()) {
    SCOPED_TRACE(std::string(wire::to_string(type)) + " (docs/protocol.md line " +
                 std::to_string(table.line) + ")");
    size_t samples = 0;
    for (const auto& [sample_name, m] : test::sample_messages()) {
      if (wire::message_type(m) != type) continue;
      SCOPED_TRACE("sample " + sample_name);
      ++samples;
      const std::vector<Read> reads = reads_of(m);
      ASSERT_FALSE(reads.empty());
      std::string prefix;
      for (const Read& r : reads)
        if (r.name.back() != '*') {
          prefix = r.name.substr(0, r.name.find('.'));
          break;
        }
      size_t k = 0;
      bool ended = false;
      for (const auto& row : table.rows) {
        if (ended) break;
        const std::string want = expected_read(prefix, row.at(0), row.at(1));
        if (k < reads.size() && reads[k].name == want) {
          const size_t w = type_width(row.at(0));
          if (w != 0 && reads[k].width != 0) {
            EXPECT_EQ(reads[k].width, w) << row.at(1);
          }
          ended = is_count(want);
          ++k;
          continue;
        }
        // Absent here: only a conditional field may be.
        EXPECT_NE(row.size() > 2 ? row.at(2).find("only") : std::string::npos, std::string::npos)
            << "the table has " << row.at(1) << " (" << want << ") where the decoder reads "
            << (k < reads.size() ? reads[k].name : std::string("nothing more"));
      }
      EXPECT_EQ(k, reads.size()) << "the decoder reads " << (k < reads.size() ? reads[k].name : "")
                                 << ", which the table does not list there";
    }
    EXPECT_GT(samples, 0u) << "no sample message to check the table with";
    ++tables_checked;
  }
  EXPECT_GE(tables_checked, 10u);
}

// The encoder's layout of m (payload_layout: the one serialize function the decoder runs too),
// with each compound (a TileCoord's tile.*, ...) folded into one field. Unlike the truncation
// walk above, it goes on past a list's count: every element, every field.
std::vector<wire::FieldSpan> folded_layout(const wire::Message& m) {
  const auto layout = wire::payload_layout(m);
  EXPECT_TRUE(layout.ok());
  std::vector<wire::FieldSpan> out;
  std::set<std::string> in_compound;  // the compound's fields so far: a repeat starts the next one
  for (const wire::FieldSpan& f : layout.ok() ? *layout : std::vector<wire::FieldSpan>{}) {
    const std::string name = compound_of(f.field);
    if (!out.empty() && out.back().field == name && name.back() == '*' && !in_compound.count(f.field)) {
      out.back().width += f.width;
      in_compound.insert(f.field);
      continue;
    }
    in_compound = {f.field};
    out.push_back({name, f.offset, f.width, f.value});
  }
  return out;
}

// A row describing a list's elements: its rule starts "per entry", "per image", "per tile".
bool per_element(const std::vector<std::string>& row) {
  return row.size() > 2 && row[2].rfind("per ", 0) == 0;
}
bool conditional(const std::vector<std::string>& row) {
  return row.size() > 2 && row[2].find("only") != std::string::npos;
}

// Matches the table's rows against the layout, from k: each row is the next field, or absent
// when it is conditional. The rows of a list's elements repeat as a group, as many times as the
// count before them says. Returns the fields matched.
void match_rows(const Table& table, const std::vector<wire::FieldSpan>& layout, const std::string& prefix) {
  size_t k = 0;
  uint64_t last_count = 0;
  const auto match = [&](const std::vector<std::string>& row) {
    const std::string want = expected_read(prefix, row.at(0), row.at(1));
    if (k < layout.size() && layout[k].field == want) {
      const size_t w = type_width(row.at(0));
      if (w != 0) {
        EXPECT_EQ(layout[k].width, w) << row.at(1) << " at byte " << layout[k].offset;
      }
      if (is_count(want)) last_count = layout[k].value;
      ++k;
      return;
    }
    EXPECT_TRUE(conditional(row)) << "the table has " << row.at(1) << " (" << want
                                  << ") where the encoder writes "
                                  << (k < layout.size() ? layout[k].field : std::string("nothing more"))
                                  << " at byte " << (k < layout.size() ? layout[k].offset : 0);
  };
  for (size_t i = 0; i < table.rows.size();) {
    if (!per_element(table.rows[i])) {
      match(table.rows[i++]);
      continue;
    }
    size_t j = i;
    while (j < table.rows.size() && per_element(table.rows[j])) ++j;
    EXPECT_GT(last_count, 0u) << "the sample's list is empty: its element rows go unchecked";
    for (uint64_t e = 0; e < last_count; ++e) {
      SCOPED_TRACE("element " + std::to_string(e));
      for (size_t r = i; r < j; ++r) match(table.rows[r]);
    }
    i = j;
  }
  EXPECT_EQ(k, layout.size()) << "the encoder writes " << (k < layout.size() ? layout[k].field : "")
                              << " at byte " << (k < layout.size() ? layout[k].offset : 0)
                              << ", which the table does not list there";
}

// Every sample message, and an event with a tile far from its stamp's (the long offset form).
std::vector<std::pair<std::string, wire::Message>> layout_samples() {
  auto v = test::sample_messages();
  for (const auto& [name, m] : test::sample_messages()) {
    if (name != "deform_event") continue;
    wire::DeformEvent far = std::get<wire::DeformEvent>(m);
    far.base_versions.push_back({TileCoord{Layer::kCoarse, 1, 60, 40}, 5});
    v.emplace_back("deform_event_far_tile", far);
  }
  return v;
}

TEST(DocsDrift, EveryMessageTableListsEveryFieldTheEncoderWritesListElementsIncluded) {
  const auto samples = layout_samples();
  size_t tables = 0, element_groups = 0;
  std::set<std::string> long_offset_seen;
  for (const auto& [type, table] : message_tables()) {
    SCOPED_TRACE(std::string(wire::to_string(type)) + " (docs/protocol.md line " +
                 std::to_string(table.line) + ")");
    ++tables;
    for (const auto& row : table.rows) element_groups += per_element(row) ? 1 : 0;
    size_t checked = 0;
    for (const auto& [name, m] : samples) {
      if (wire::message_type(m) != type) continue;
      SCOPED_TRACE("sample " + name);
      const auto layout = folded_layout(m);
      ASSERT_FALSE(layout.empty());
      std::string prefix;
      for (const auto& f : layout)
        if (f.field.back() != '*') {
          prefix = f.field.substr(0, f.field.find('.'));
          break;
        }
      match_rows(table, layout, prefix);
      for (const auto& f : layout)
        if (f.field == "deform_event.tile_dx") long_offset_seen.insert(name);
      ++checked;
    }
    EXPECT_GT(checked, 0u) << "no sample message to check the table with";
  }
  EXPECT_GE(tables, 15u);
  // Subscribe, Unsubscribe, DeformEvent, TileHashes and StampImageList have element rows.
  EXPECT_GE(element_groups, 14u);
  EXPECT_TRUE(long_offset_seen.count("deform_event_far_tile")) << "the far tile must take the long form";
}

TEST(DocsDrift, AListsElementRowsFailWhenTheyDisagreeWithTheEncoder) {
  // The check itself: a table that swaps two element fields, or drops one, is caught.
  const wire::Message& m = sample("tile_hashes");
  const auto layout = folded_layout(m);
  Table swapped;
  swapped.rows = {{"u32", "count", ""},
                  {"TileCoord", "tile", "per entry"},
                  {"u64", "hash", "per entry"},
                  {"u64", "version", "per entry"}};
  Table short_one = swapped;
  short_one.rows = {
      {"u32", "count", ""}, {"TileCoord", "tile", "per entry"}, {"u64", "version", "per entry"}};
  for (const Table* t : {&swapped, &short_one}) {
    ::testing::TestPartResultArray failures;
    {
      ::testing::ScopedFakeTestPartResultReporter reporter(
          ::testing::ScopedFakeTestPartResultReporter::INTERCEPT_ONLY_CURRENT_THREAD, &failures);
      match_rows(*t, layout, "tile_hashes");
    }
    EXPECT_GT(failures.size(), 0) << "a wrong element table passed";
  }
}

TEST(DocsDrift, GoldenVectorTableNamesFilesThatDecodeAsItsMessages) {
  const auto t = table_with_header(tables_in(protocol_lines()), {"file", "message", "decoded fields"});
  ASSERT_TRUE(t.has_value());
  std::set<std::string> listed;
  for (const auto& r : t->rows) {
    const fs::path file = fs::path(LOAM_SOURCE_DIR) / "tests/golden/wire" / r.at(0);
    std::ifstream f(file, std::ios::binary);
    ASSERT_TRUE(f.good()) << file;
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    const auto frame = wire::decode_frame(bytes);
    ASSERT_TRUE(frame.ok()) << r.at(0) << ": " << frame.error().describe();
    EXPECT_EQ(wire::to_string(wire::message_type(*frame)), r.at(1)) << r.at(0);
    listed.insert(r.at(0));
  }
  for (const auto& e : fs::directory_iterator(fs::path(LOAM_SOURCE_DIR) / "tests/golden/wire"))
    if (e.path().extension() == ".bin") {
      EXPECT_TRUE(listed.count(e.path().filename().string())) << e.path();
    }
}

// --- stamps.md ---

const std::vector<std::string>& stamps_lines() {
  static const std::vector<std::string> l = lines_of(read_doc("stamps.md"));
  return l;
}

std::map<std::string, double> stamp_constants() {
  std::map<std::string, double> out;
  const auto t = table_with_header(tables_in(stamps_lines()), {"constant", "value", "where / meaning"});
  EXPECT_TRUE(t.has_value()) << "docs/stamps.md has no constants table";
  if (t)
    for (const auto& r : t->rows) out[r.at(0)] = std::stod(r.at(1));
  return out;
}

// exp(-x) exactly as docs/stamps.md spells it out, with its parameters.
double documented_exp_neg(double x, double halving_limit, int terms) {
  if (!(x > 0.0)) return 1.0;
  if (x > 700.0) return 0.0;
  int k = 0;
  double y = x;
  while (y > halving_limit) {
    y = y / 2.0;
    ++k;
  }
  double term = 1.0, sum = 1.0;
  for (int n = 1; n <= terms; ++n) {
    term = term * (-y) / double(n);
    sum = sum + term;
  }
  for (int i = 0; i < k; ++i) sum = sum * sum;
  return sum;
}

WorldParams drift_world() {
  WorldParams w;
  w.meters_per_sample = 1.0;
  w.height_offset = 0.0;
  w.meters_per_unit = 1.0 / 64.0;
  w.tiles_x = 2;
  w.tiles_y = 2;
  return w;
}

QuantizedStamp drift_stamp(StampKind kind) {
  QuantizedStamp q;
  q.kind = kind;
  q.center_x = (200 << 8) + 77;
  q.center_y = (180 << 8) + 5;
  q.radius = 40 << 8;
  q.intensity = kind == StampKind::kFlatten ? 40000 : 300 << 8;
  return q;
}

TEST(DocsDrift, StampConstantsAreTheCodesConstants) {
  const auto c = stamp_constants();
  const std::map<std::string, double> code = {
      {"position_frac_bits", double(kPositionFracBits)},
      {"intensity_frac_bits", double(kIntensityFracBits)},
      {"rotation_units_per_turn", double(kRotationUnitsPerTurn)},
      {"q16_divisor", double(kUnitFracOne)},
      {"reduced_bits", double(kReducedBits)},
      {"profile_entries", double(kProfileEntries)},
      {"profile_frac_bits", double(kProfileFracBits)},
      {"wave_nu2_cap_q16", double(kWaveNu2CapQ16)},
      {"hard_max_radius_samples", kHardMaxRadiusSamples},
      {"default_max_radius_samples", StampLimits{}.max_radius_samples},
      {"default_max_shockwave_steps", double(StampLimits{}.max_shockwave_steps)},
      {"hard_max_shockwave_steps", double(kHardMaxShockwaveSteps)},
      {"default_max_shockwave_cells", double(StampLimits{}.max_shockwave_cells)},
  };
  // Checked by what the kernel computes (the tests below), not by a named constant.
  const std::set<std::string> computed = {"shape_max", "exp_halving_limit", "exp_taylor_terms",
                                          "gaussian_exponent", "crater_bowl_radius"};
  for (const auto& [name, value] : c) {
    if (computed.count(name)) continue;
    const auto it = code.find(name);
    if (it == code.end()) {
      ADD_FAILURE() << "stamps.md constant '" << name << "' is not known to this test";
      continue;
    }
    EXPECT_EQ(value, it->second) << name;
  }
  for (const auto& [name, value] : code) EXPECT_TRUE(c.count(name)) << name << " is missing from stamps.md";
  for (const auto& name : computed) EXPECT_TRUE(c.count(name)) << name << " is missing from stamps.md";
}

// Past about nine terms a term is below half an ulp of the sum (y <= 1/16), so a longer series
// gives the same bits: this pins the documented recipe's results, and a wrong halving limit,
// order or too short a series fails it.
TEST(DocsDrift, ExpIsTheDocumentedSeriesBitForBit) {
  const auto c = stamp_constants();
  const double limit = c.at("exp_halving_limit");
  const int terms = int(c.at("exp_taylor_terms"));
  // Across the range the tables use (12u^2 up to 12), at and around the halving limit, and tiny.
  for (int i = 0; i <= 4000; ++i) {
    const double x = double(i) * 0.003 + 1e-9 * double(i % 7);
    ASSERT_EQ(exact_exp_neg(x), documented_exp_neg(x, limit, terms)) << "x = " << x;
  }
  for (const double x : {0.0625, 0.125, 1.0, 0.0625 * 1.0000001, 12.0, 699.0})
    EXPECT_EQ(exact_exp_neg(x), documented_exp_neg(x, limit, terms)) << "x = " << x;
}

TEST(DocsDrift, ShapeIsQuantizedToAtMostShapeMaxAndDividedByTheDocumentedDivisor) {
  const auto c = stamp_constants();
  const double divisor = c.at("q16_divisor"), a = c.at("crater_bowl_radius");
  const WorldParams w = drift_world();
  // Shape 1 quantizes to shape_max.
  StampParams p;
  p.kind = StampKind::kCrater;
  p.center_x = 100.0;
  p.center_y = 100.0;
  p.radius = 20.0;
  p.intensity = 2.0;
  p.shape = 1.0;
  auto q = validate_stamp(p, w);
  ASSERT_TRUE(q.ok()) << q.error().describe();
  EXPECT_EQ(double(q->shape), c.at("shape_max"));
  // The crater, footprint and flatten tables with the documented divisor are the kernel's.
  for (const uint16_t shape : {uint16_t(65535), uint16_t(40000), uint16_t(1)}) {
    QuantizedStamp crater = drift_stamp(StampKind::kCrater);
    crater.shape = shape;
    auto b = bake_stamp(crater, w);
    ASSERT_TRUE(b.ok());
    const double s = double(shape) / divisor;
    const auto bowl = [&](double u) {
      if (u >= a) return 0.0;
      const double r = u / a;
      return -(1.0 - r * r);
    };
    const auto rim = [&](double u) {
      if (u < a) {
        const double r = u / a;
        return r * r * r * r;
      }
      const double t = (u - a) / (1.0 - a);
      return (1.0 - t) * (1.0 - t) * (1.0 + 2.0 * t);
    };
    EXPECT_EQ(b->table, bake_table(double(crater.intensity), [&](double u) { return bowl(u) + s * rim(u); }))
        << "crater, shape " << shape;
    QuantizedStamp foot = drift_stamp(StampKind::kFootprint);
    foot.shape = shape;
    b = bake_stamp(foot, w);
    ASSERT_TRUE(b.ok());
    EXPECT_EQ(b->table, bake_table(double(foot.intensity), [&](double u) { return s * u * u; }))
        << "footprint, shape " << shape;
    QuantizedStamp flat = drift_stamp(StampKind::kFlatten);
    flat.shape = shape;
    b = bake_stamp(flat, w);
    ASSERT_TRUE(b.ok());
    const double strength = double(flat.intensity) / divisor;
    EXPECT_EQ(b->table, bake_table(16384.0 * strength,
                                   [&](double u) {
                                     if (s <= 0.0) return u < 1.0 ? 1.0 : 0.0;
                                     const double inner = 1.0 - s;
                                     if (u <= inner) return 1.0;
                                     const double t = (u - inner) / s;
                                     return 1.0 - t * t * (3.0 - 2.0 * t);
                                   }))
        << "flatten, shape " << shape;
  }
}

TEST(DocsDrift, GaussianTableUsesTheDocumentedExponent) {
  const double k = stamp_constants().at("gaussian_exponent");
  const QuantizedStamp g = drift_stamp(StampKind::kGaussian);
  auto b = bake_stamp(g, drift_world());
  ASSERT_TRUE(b.ok());
  EXPECT_EQ(b->table, bake_table(double(g.intensity), [&](double u) { return exact_exp_neg(k * u * u); }));
}

TEST(DocsDrift, KindsTableIsStampKindTheEventRuleAndCheckQuantized) {
  const auto t = table_with_header(
      tables_in(stamps_lines()), {"id", "kind", "per-sample", "shape", "texture_id", "damping/speed/steps"});
  ASSERT_TRUE(t.has_value()) << "docs/stamps.md has no kinds table";
  ASSERT_EQ(t->rows.size(), size_t(kStampKindCount));
  const WorldParams w = drift_world();
  const auto yes = [](const std::string& s) { return s == "yes"; };
  // Whether check_quantized refuses the field as unused by the kind (not for another reason).
  const auto refused = [&](QuantizedStamp q, const char* field) {
    const Status st = check_quantized(q, w);
    return !st.ok() && st.error().field == field && st.error().code == ErrorCode::kInvalidArgument;
  };
  for (size_t i = 0; i < t->rows.size(); ++i) {
    const auto& r = t->rows[i];
    ASSERT_EQ(to_u64(r.at(0)), i);
    const auto kind = StampKind(i);
    SCOPED_TRACE(r.at(1));
    EXPECT_EQ(r.at(1), to_string(kind));
    const QuantizedStamp base = drift_stamp(kind);
    EXPECT_EQ(yes(r.at(2)), replication::event_reproduces_tile(base, TileCoord{Layer::kCoarse, 1, 0, 0}));
    QuantizedStamp q = base;
    q.shape = 100;
    EXPECT_EQ(yes(r.at(3)), !refused(q, "stamp.shape"));
    q = base;
    q.texture_id = 5;
    EXPECT_EQ(yes(r.at(4)), !refused(q, "stamp.texture_id"));
    q = base;
    q.damping = 100;
    EXPECT_EQ(yes(r.at(5)), !refused(q, "stamp.damping"));
  }
}

}  // namespace
}  // namespace loam
