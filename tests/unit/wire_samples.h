// Deterministic sample messages and log records shared by the wire/log tests, the golden
// vectors and the fuzz seed corpus generator. Changing a sample changes the golden files:
// regenerate them with LOAM_UPDATE_GOLDEN=1 (tests/golden/wire/README.md).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "protocol/log/log_format.h"
#include "protocol/wire/messages.h"

namespace loam::test {

inline QuantizedStamp sample_stamp(uint32_t salt = 0) {
  QuantizedStamp q;
  q.kind = StampKind::kCrater;
  q.layer = Layer::kCoarse;
  q.blend = BlendMode::kSubtract;
  q.flags = kStampFlagVolumeConserving;
  q.center_x = (int64_t(1000) << 8) + 17 + salt;
  q.center_y = -(int64_t(2000) << 8) - 3;
  q.radius = 12u << 8;
  q.rotation = 0x4000;
  q.intensity = -(300 << 8);
  q.target = 0;
  q.shape = 0x8000;
  q.damping = 0;
  q.speed = 0;
  q.steps = 0;
  q.seed = 0xC0FFEEu + salt;
  q.texture_id = 0;
  return q;
}

inline WorldParams sample_world() {
  WorldParams w;
  w.meters_per_sample = 2.0;
  w.height_offset = -100.0;
  w.meters_per_unit = 1.0 / 64.0;
  w.detail_factor = 4;
  w.detail_meters_per_unit = 0.005;
  w.origin_tile_x = -2;
  w.origin_tile_y = -1;
  w.tiles_x = 4;
  w.tiles_y = 2;
  return w;
}

// One named sample per message type, in MessageType order.
inline std::vector<std::pair<std::string, wire::Message>> sample_messages() {
  using namespace wire;
  std::vector<std::pair<std::string, Message>> v;
  Hello hello;
  hello.client_name = "viewer-1";
  hello.requested_role = Role::kPlayer;
  hello.access_token = AccessToken{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16};
  hello.resume_key = 0x0123456789ABCDEFull;
  v.emplace_back("hello", hello);
  Welcome welcome;
  welcome.client_id = 7;
  welcome.granted_role = Role::kPlayer;
  welcome.world = sample_world();
  welcome.global_sequence = 123456;
  welcome.tick_rate_hz = 30;
  v.emplace_back("welcome", welcome);
  v.emplace_back("error", ErrorMsg{WireErrorCode::kOversize, "subscribe.count", "too many entries"});
  v.emplace_back("ping", Ping{0x0102030405060708ull});
  v.emplace_back("pong", Pong{0x0102030405060708ull, 99});
  v.emplace_back("bye", Bye{ByeReason::kShutdown, "server restarting"});
  Subscribe sub;
  sub.entries.push_back({TileCoord{Layer::kCoarse, 0, -2, -1}, false, 0});
  sub.entries.push_back({TileCoord{Layer::kCoarse, 2, 0, 0}, true, 41});
  sub.entries.push_back({TileCoord{Layer::kDetail, 0, 1, 0}, true, 0});  // held at the initial version
  sub.focus = Focus{-1234.5, 88.25};                                     // the camera above this point
  v.emplace_back("subscribe", sub);
  Unsubscribe unsub;
  unsub.tiles.push_back(TileCoord{Layer::kCoarse, 1, -1, 0});
  v.emplace_back("unsubscribe", unsub);
  v.emplace_back("deform", Deform{42, sample_stamp()});
  DeformAck ok;
  ok.client_seq = 42;
  ok.accepted = true;
  ok.global_seq = 123457;
  v.emplace_back("deform_ack_accepted", ok);
  DeformAck rejected;
  rejected.client_seq = 43;
  rejected.accepted = false;
  rejected.reject_code = WireErrorCode::kInvalidArgument;
  rejected.field = "stamp.radius";
  v.emplace_back("deform_ack_rejected", rejected);
  DeformEvent ev;
  ev.global_seq = 123457;
  ev.origin_client_id = 7;
  ev.stamp = sample_stamp();
  ev.base_versions.push_back({TileCoord{Layer::kCoarse, 0, 3, -8}, 120000});
  ev.base_versions.push_back({TileCoord{Layer::kCoarse, 1, 1, -4}, 0});
  v.emplace_back("deform_event", ev);
  RegionUpdate reg;
  reg.tile = TileCoord{Layer::kCoarse, 0, -1, 0};
  reg.rect = RectI{4, 8, 6, 10};
  reg.patch = true;
  reg.base_version = 100;
  reg.new_version = 123457;
  reg.encoding = wire::RegionEncoding::kRaw;
  reg.total_bytes = 8;
  reg.chunk_offset = 0;
  reg.chunk = {1, 0, 2, 0, 3, 0, 0xFF, 0xFF};
  v.emplace_back("region_update", reg);
  TileHashes th;
  th.entries.push_back({TileCoord{Layer::kCoarse, 0, 0, 0}, 5, 0x1122334455667788ull});
  th.entries.push_back({TileCoord{Layer::kDetail, 0, 0, 0}, 0, 0x8877665544332211ull});
  v.emplace_back("tile_hashes", th);
  v.emplace_back("stamp_image_request", StampImageRequest{0xDEADBEEFCAFEF00Dull});
  StampImageResponse img;
  img.image_id = 0xDEADBEEFCAFEF00Dull;
  img.found = true;
  img.width = 2;
  img.height = 2;
  img.format = StampImageFormat::kGray16;
  img.pixels = {0, 0, 0xFF, 0x7F, 0x00, 0x80, 0xFF, 0xFF};
  v.emplace_back("stamp_image_response", img);
  StampImageResponse missing;
  missing.image_id = 17;
  missing.found = false;
  v.emplace_back("stamp_image_missing", missing);
  v.emplace_back("stats_request", StatsRequest{7});
  v.emplace_back("stamp_image_list_request", StampImageListRequest{3});
  StampImageList list;
  list.request_id = 3;
  list.images = {{0x0123456789ABCDEFull, 64, 64}, {0xDEADBEEFCAFEF00Dull, 4096, 1}};
  v.emplace_back("stamp_image_list", list);
  Stats st;
  st.request_id = 7;
  st.clients = 3;
  st.global_sequence = 123456;
  st.deforms_accepted = 123456;
  st.deforms_rejected = 12;
  st.violations = 4;
  st.bytes_in = 1u << 20;
  st.bytes_out = 1ull << 33;
  st.tick_overruns = 2;
  st.tick_p50_us = 850;
  st.tick_p99_us = 4100;
  st.uptime_ms = 3600000;
  st.region_encodes = 5000;
  st.region_cache_hits = 310000;
  st.events_sent = 123456 * 3;
  st.regions_sent = 315000;
  st.client_bytes_per_second = 131072;
  v.emplace_back("stats", st);
  DeformEvent foot;  // a footprint carries its contact; its tiles one to the side of the center
  foot.global_seq = 9000001;
  foot.origin_client_id = 300;
  foot.stamp = sample_stamp();
  foot.stamp.kind = StampKind::kFootprint;
  foot.stamp.blend = BlendMode::kAdd;
  foot.stamp.flags = 0;
  foot.stamp.intensity = 40 << 8;
  foot.contact = {true, -(1234 << 8) - 77};
  foot.base_versions.push_back({TileCoord{Layer::kCoarse, 0, 3, -8}, 9000000});
  foot.base_versions.push_back({TileCoord{Layer::kCoarse, 0, 4, -8}, 1});
  foot.base_versions.push_back({TileCoord{Layer::kCoarse, 2, 0, -2}, 77});
  v.emplace_back("deform_event_footprint", foot);  // last: tests index the samples above
  return v;
}

inline log::SegmentHeader sample_segment_header() {
  log::SegmentHeader h;
  h.world = sample_world();
  h.initial.world_hash = 0x0123456789ABCDEFull;
  h.initial.source = log::InitialSource::kDem;
  h.initial.dem_path = "data/terrain/alps.tif";
  h.initial.import_params = "{\"headroom\":0.25}";
  h.created_unix_us = 1700000000000000ull;
  h.segment_index = 0;
  h.base_seq = 0;
  h.base_world_hash = h.initial.world_hash;
  h.limits = {1000.0, 512, int64_t(1) << 20};
  h.base_tick = 0;
  return h;
}

inline log::LogRecord sample_record(uint64_t seq, uint64_t tick) {
  log::LogRecord r;
  r.global_seq = seq;
  r.tick = tick;
  r.client_id = uint32_t(seq % 3);
  r.stamp = sample_stamp(uint32_t(seq));
  if (seq % 2 == 0) r.stamp.kind = StampKind::kGaussian, r.stamp.flags = 0;
  return r;
}

}  // namespace loam::test
