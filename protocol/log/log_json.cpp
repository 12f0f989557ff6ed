#include "protocol/log/log_json.h"

#include <cinttypes>
#include <cstdio>
#include <set>

#include "protocol/hex64.h"

namespace loam::log {

namespace {

// JSON numbers lose bits above 2^53: hashes and ids are quoted hex strings.
std::string json_hex64(uint64_t v) { return "\"" + loam::hex64(v) + "\""; }

// JSON string with every control character and non-ASCII byte escaped, so paths from an
// untrusted header cannot break the line format.
std::string quote(const std::string& s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += char(c);
    } else if (c < 0x20 || c >= 0x7F) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\u%04x", unsigned(c));
      out += buf;
    } else {
      out += char(c);
    }
  }
  return out + "\"";
}

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

const char* source_name(InitialSource s) {
  switch (s) {
    case InitialSource::kSnapshot: return "snapshot";
    case InitialSource::kDem: return "dem";
    case InitialSource::kGenerated: return "generated";
  }
  return "unknown";
}

std::string stamp_to_json(const QuantizedStamp& q) {
  std::string o = "{\"kind\":\"" + std::string(to_string(q.kind)) + "\"";
  o += ",\"layer\":\"" + std::string(to_string(q.layer)) + "\"";
  o += ",\"blend\":\"" + std::string(to_string(q.blend)) + "\"";
  o += ",\"flags\":" + std::to_string(q.flags);
  o += ",\"center_x\":" + std::to_string(q.center_x);
  o += ",\"center_y\":" + std::to_string(q.center_y);
  o += ",\"radius\":" + std::to_string(q.radius);
  o += ",\"rotation\":" + std::to_string(q.rotation);
  o += ",\"intensity\":" + std::to_string(q.intensity);
  o += ",\"target\":" + std::to_string(q.target);
  o += ",\"shape\":" + std::to_string(q.shape);
  o += ",\"damping\":" + std::to_string(q.damping);
  o += ",\"speed\":" + std::to_string(q.speed);
  o += ",\"steps\":" + std::to_string(q.steps);
  o += ",\"seed\":" + std::to_string(q.seed);
  o += ",\"texture_id\":" + json_hex64(q.texture_id);
  return o + "}";
}

}  // namespace

std::string header_to_json(const DecodedHeader& d) {
  const SegmentHeader& h = d.header;
  const WorldParams& w = h.world;
  std::string o = "{\"type\":\"segment\",\"format_version\":" + std::to_string(h.format_version);
  o += ",\"segment_index\":" + std::to_string(h.segment_index);
  o += ",\"created_unix_us\":" + std::to_string(h.created_unix_us);
  o += ",\"world\":{\"meters_per_sample\":" + num(w.meters_per_sample) +
       ",\"height_offset\":" + num(w.height_offset) + ",\"meters_per_unit\":" + num(w.meters_per_unit) +
       ",\"detail_factor\":" + std::to_string(w.detail_factor) +
       ",\"detail_meters_per_unit\":" + num(w.detail_meters_per_unit) +
       ",\"origin_tile_x\":" + std::to_string(w.origin_tile_x) +
       ",\"origin_tile_y\":" + std::to_string(w.origin_tile_y) + ",\"tiles_x\":" + std::to_string(w.tiles_x) +
       ",\"tiles_y\":" + std::to_string(w.tiles_y) + "}";
  o += ",\"initial\":{\"world_hash\":" + json_hex64(h.initial.world_hash) + ",\"source\":\"" +
       source_name(h.initial.source) + "\",\"snapshot_id\":" + json_hex64(h.initial.snapshot_id) +
       ",\"dem_path\":" + quote(h.initial.dem_path) + ",\"import_params\":" + quote(h.initial.import_params) +
       "}";
  o += ",\"base_seq\":" + std::to_string(h.base_seq);
  o += ",\"base_snapshot_id\":" + json_hex64(h.base_snapshot_id);
  o += ",\"base_world_hash\":" + json_hex64(h.base_world_hash);
  o += ",\"prev_header_checksum\":" + json_hex64(h.prev_header_checksum);
  o += ",\"header_checksum\":" + json_hex64(d.checksum);
  return o + "}";
}

std::string record_to_json(const LogRecord& r) {
  return "{\"type\":\"stamp\",\"seq\":" + std::to_string(r.global_seq) +
         ",\"tick\":" + std::to_string(r.tick) + ",\"client\":" + std::to_string(r.client_id) +
         ",\"stamp\":" + stamp_to_json(r.stamp) + "}";
}

std::string dump_jsonl(const SegmentScan& scan) {
  std::string out = header_to_json(scan.header) + "\n";
  for (const LogRecord& r : scan.records) out += record_to_json(r) + "\n";
  if (scan.tail != TailState::kClean) {
    out += "{\"type\":\"tail\",\"state\":\"" + std::string(to_string(scan.tail)) +
           "\",\"offset\":" + std::to_string(scan.damage_offset) +
           ",\"good_bytes\":" + std::to_string(scan.good_bytes) +
           ",\"recoverable\":" + (scan.recoverable ? "true" : "false") +
           ",\"error\":" + quote(scan.tail_error ? scan.tail_error->describe() : "") + "}\n";
  }
  return out;
}

LogSummary summarize(std::span<const SegmentScan> scans) {
  LogSummary s;
  std::set<uint32_t> clients;
  for (const SegmentScan& scan : scans) {
    if (s.segments == 0) s.created_unix_us = scan.header.header.created_unix_us;
    ++s.segments;
    if (scan.tail != TailState::kClean) ++s.damaged_segments;
    for (const LogRecord& r : scan.records) {
      if (s.records == 0) {
        s.first_seq = r.global_seq;
        s.first_tick = r.tick;
      }
      ++s.records;
      s.last_seq = r.global_seq;
      s.last_tick = r.tick;
      const auto kind = size_t(r.stamp.kind);
      if (kind < s.per_kind.size()) ++s.per_kind[kind];
      ++s.per_layer[r.stamp.layer];
      clients.insert(r.client_id);
    }
  }
  s.distinct_clients = clients.size();
  return s;
}

std::string summary_to_json(const LogSummary& s) {
  std::string o =
      "{\"segments\":" + std::to_string(s.segments) + ",\"records\":" + std::to_string(s.records) +
      ",\"first_seq\":" + std::to_string(s.first_seq) + ",\"last_seq\":" + std::to_string(s.last_seq) +
      ",\"first_tick\":" + std::to_string(s.first_tick) + ",\"last_tick\":" + std::to_string(s.last_tick) +
      ",\"kinds\":{";
  for (size_t k = 0; k < s.per_kind.size(); ++k) {
    if (k) o += ",";
    // Appended piecewise: GCC 12 at -O3 reports a bogus -Wrestrict for "lit" + std::string.
    o += '"';
    o += to_string(StampKind(k));
    o += "\":";
    o += std::to_string(s.per_kind[k]);
  }
  o += "},\"layers\":{";
  s.per_layer.for_each([&](Layer l, uint64_t n) {
    if (l != kLayers.front()) o += ',';
    o += "\"" + std::string(layer_info(l).name) + "\":" + std::to_string(n);
  });
  o += '}';
  o += ",\"clients\":" + std::to_string(s.distinct_clients);
  o += ",\"created_unix_us\":" + std::to_string(s.created_unix_us);
  o += ",\"damaged_segments\":" + std::to_string(s.damaged_segments) + "}";
  return o;
}

std::string summary_to_text(const LogSummary& s) {
  std::string o =
      "segments: " + std::to_string(s.segments) + "\nrecords: " + std::to_string(s.records) + "\n";
  if (s.records > 0) {
    o += "sequence: " + std::to_string(s.first_seq) + ".." + std::to_string(s.last_seq) + "\n";
    o += "ticks: " + std::to_string(s.first_tick) + ".." + std::to_string(s.last_tick) + "\n";
  }
  o += "kinds:";
  for (size_t k = 0; k < s.per_kind.size(); ++k) {
    if (!s.per_kind[k]) continue;
    o += ' ';
    o += to_string(StampKind(k));
    o += '=';
    o += std::to_string(s.per_kind[k]);
  }
  o += "\nlayers:";
  s.per_layer.for_each(
      [&](Layer l, uint64_t n) { o += " " + std::string(layer_info(l).name) + "=" + std::to_string(n); });
  o += '\n';
  o += "clients: " + std::to_string(s.distinct_clients) + "\n";
  o += "created_unix_us: " + std::to_string(s.created_unix_us) + "\n";
  if (s.damaged_segments) o += "damaged segments: " + std::to_string(s.damaged_segments) + "\n";
  return o;
}

}  // namespace loam::log
