// Wire messages and framing: round trips, and every way a hostile or broken peer can lie.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include "protocol/byte_order.h"
#include "protocol/wire/byte_stream.h"
#include "protocol/wire/fields.h"
#include "protocol/wire/framing.h"
#include "protocol/wire/messages.h"
#include "tests/unit/wire_samples.h"

namespace loam::wire {
namespace {

using test::sample_messages;

std::vector<uint8_t> payload_of(const Message& m) {
  Result<std::vector<uint8_t>> p = encode_payload(m);
  EXPECT_TRUE(p.ok()) << (p.ok() ? "" : p.error().describe());
  return p.ok() ? *p : std::vector<uint8_t>{};
}

uint16_t type_of(const Message& m) { return static_cast<uint16_t>(message_type(m)); }

template <typename T>
void put(std::vector<uint8_t>& bytes, size_t offset, T v) {
  ASSERT_LE(offset + sizeof(T), bytes.size());
  store_le<T>(bytes.data() + offset, v);
}

void expect_error(const Result<Message>& r, ErrorCode code, const std::string& field) {
  ASSERT_FALSE(r.ok()) << "decoded a payload that should have failed (" << field << ")";
  EXPECT_EQ(r.error().code, code) << r.error().describe();
  EXPECT_EQ(r.error().field, field) << r.error().describe();
}

TEST(WireMessages, EveryMessageTypeHasASampleInTypeOrder) {
  // Guards the sample list itself: the round-trip tests below only cover what it holds.
  std::vector<bool> seen(kLastMessageType + 1, false);
  for (const auto& [name, m] : sample_messages()) seen[type_of(m)] = true;
  for (uint16_t t = kFirstMessageType; t <= kLastMessageType; ++t) EXPECT_TRUE(seen[t]) << "type " << t;
}

TEST(WireMessages, EncodeThenDecodeIsTheIdentityForEveryMessage) {
  for (const auto& [name, m] : sample_messages()) {
    const std::vector<uint8_t> payload = payload_of(m);
    Result<size_t> measured = measure_payload(m);
    ASSERT_TRUE(measured.ok()) << name;
    EXPECT_EQ(*measured, payload.size()) << name << ": measure and write disagree";
    Result<Message> back = decode_payload(type_of(m), payload);
    ASSERT_TRUE(back.ok()) << name << ": " << back.error().describe();
    EXPECT_TRUE(*back == m) << name;
  }
}

TEST(WireMessages, FrameEncodeThenDecodeIsTheIdentityForEveryMessage) {
  for (const auto& [name, m] : sample_messages()) {
    Result<std::vector<uint8_t>> frame = encode_frame(m);
    ASSERT_TRUE(frame.ok()) << name;
    Result<Message> back = decode_frame(*frame);
    ASSERT_TRUE(back.ok()) << name << ": " << back.error().describe();
    EXPECT_TRUE(*back == m) << name;
  }
}

TEST(WireMessages, PayloadLayoutCoversEveryByteInOrderWithTheDecodersNames) {
  for (const auto& [name, m] : test::sample_messages()) {
    SCOPED_TRACE(name);
    const auto payload = encode_payload(m);
    const auto layout = payload_layout(m);
    ASSERT_TRUE(payload.ok() && layout.ok());
    size_t at = 0;
    for (const FieldSpan& f : *layout) {
      EXPECT_EQ(f.offset, at) << f.field;
      at += f.width;
      // The decoder, cut inside the field, names it: the layout is what it reads.
      if (f.width == 0) continue;
      const std::vector<uint8_t> cut(payload->begin(), payload->begin() + ptrdiff_t(f.offset + f.width - 1));
      const auto r = decode_payload(uint16_t(message_type(m)), cut);
      ASSERT_FALSE(r.ok());
      // Inside a list the count's check fails first (the elements cannot fit).
      const bool in_list = r.error().field.find("count") != std::string::npos;
      EXPECT_TRUE(r.error().field == f.field || in_list) << r.error().field << " vs " << f.field;
    }
    EXPECT_EQ(at, payload->size());
  }
}

TEST(WireMessages, EmptyAndMaximalCollectionsRoundTrip) {
  // Caps are inclusive: a message exactly at its cap must pass both ways.
  Subscribe sub;
  sub.entries.resize(kMaxSubscribeEntries, SubscribeEntry{TileCoord{Layer::kCoarse, 3, -5, 9}, true, 77});
  TileHashes hashes;
  Hello named;
  named.client_name = std::string(kMaxClientNameBytes, 'n');
  for (const Message& m : {Message(sub), Message(Subscribe{}), Message(hashes), Message(named)}) {
    Result<Message> back = decode_payload(type_of(m), payload_of(m));
    ASSERT_TRUE(back.ok()) << back.error().describe();
    EXPECT_TRUE(*back == m);
  }
}

TEST(WireMessages, CompoundFieldSizesMatchTheDocumentedConstants) {
  // docs/protocol.md's offset tables are computed from these sizes.
  MeasureStream s;
  TileCoord t;
  RectI r{0, 0, 1, 1};
  WorldParams w;
  QuantizedStamp q;
  ASSERT_TRUE(serialize_tile(s, t).ok());
  EXPECT_EQ(s.offset(), kTileCoordBytes);
  ASSERT_TRUE(serialize_tile_rect(s, r).ok());
  EXPECT_EQ(s.offset(), kTileCoordBytes + kTileRectBytes);
  ASSERT_TRUE(serialize_world_params(s, w).ok());
  EXPECT_EQ(s.offset(), kTileCoordBytes + kTileRectBytes + kWorldParamsBytes);
  ASSERT_TRUE(serialize_stamp(s, q).ok());
  EXPECT_EQ(s.offset(), kTileCoordBytes + kTileRectBytes + kWorldParamsBytes + kStampBytes);
}

TEST(WireDecode, TruncationAtEveryByteOffsetIsAnErrorNeverACrash) {
  for (const auto& [name, m] : sample_messages()) {
    const std::vector<uint8_t> payload = payload_of(m);
    for (size_t n = 0; n < payload.size(); ++n) {
      // A copy of exactly n bytes, so AddressSanitizer sees any read past the prefix.
      const std::vector<uint8_t> prefix(payload.begin(), payload.begin() + static_cast<ptrdiff_t>(n));
      Result<Message> r = decode_payload(type_of(m), prefix);
      ASSERT_FALSE(r.ok()) << name << " decoded from " << n << " of " << payload.size() << " bytes";
      EXPECT_EQ(r.error().code, ErrorCode::kTruncated) << name << " @" << n << ": " << r.error().describe();
      EXPECT_FALSE(r.error().field.empty()) << name << " @" << n;
    }
  }
}

TEST(WireDecode, TrailingBytesAfterAMessageAreRejected) {
  for (const auto& [name, m] : sample_messages()) {
    std::vector<uint8_t> payload = payload_of(m);
    payload.push_back(0);
    Result<Message> r = decode_payload(type_of(m), payload);
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_EQ(r.error().code, ErrorCode::kCorrupt) << name;
  }
}

TEST(WireDecode, CountOfTwoToThe32MinusOneIsRejectedBeforeAllocating) {
  // Each of these would ask for gigabytes if the count were trusted.
  struct Case {
    Message m;
    size_t count_offset;
    const char* field;
  };
  const Case cases[] = {
      {Subscribe{}, 0, "subscribe.count"},
      {Unsubscribe{}, 0, "unsubscribe.count"},
      {TileHashes{}, 0, "tile_hashes.count"},
  };
  for (const Case& c : cases) {
    std::vector<uint8_t> payload = payload_of(c.m);
    put<uint32_t>(payload, c.count_offset, 0xFFFFFFFFu);
    expect_error(decode_payload(type_of(c.m), payload), ErrorCode::kOversize, c.field);
  }
}

TEST(WireDecode, CountWithinCapButBeyondTheBytesPresentIsTruncated) {
  std::vector<uint8_t> payload = payload_of(Subscribe{});
  put<uint32_t>(payload, 0, kMaxSubscribeEntries);
  expect_error(decode_payload(type_of(Subscribe{}), payload), ErrorCode::kTruncated, "subscribe.count");
}

TEST(WireDecode, StringLengthBeyondItsCapIsOversize) {
  std::vector<uint8_t> payload = payload_of(Hello{});
  put<uint16_t>(payload, 8, 0xFFFF);  // client_name length
  expect_error(decode_payload(type_of(Hello{}), payload), ErrorCode::kOversize, "hello.client_name");
}

TEST(WireDecode, BlobLengthBeyondItsCapIsOversize) {
  const auto samples = sample_messages();
  const Message& reg = samples[12].second;
  ASSERT_EQ(message_type(reg), MessageType::kRegionUpdate);
  std::vector<uint8_t> payload = payload_of(reg);
  // chunk length sits after tile(10) rect(8) patch(1) base(8) new(8) encoding(1) total(4) offset(4).
  put<uint32_t>(payload, 44, 0xFFFFFFFFu);
  expect_error(decode_payload(type_of(reg), payload), ErrorCode::kOversize, "region.chunk");
}

// Welcome's WorldParams follow version_major(2) version_minor(2) client_id(4) granted_role(1).
constexpr size_t kWelcomeWorldOffset = 9;

TEST(WireDecode, NaNAndInfinityInWorldParametersAreRejectedByName) {
  const auto samples = sample_messages();
  const Message& welcome = samples[1].second;
  for (double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity()}) {
    std::vector<uint8_t> payload = payload_of(welcome);
    put<uint64_t>(payload, kWelcomeWorldOffset, std::bit_cast<uint64_t>(bad));  // world.meters_per_sample
    expect_error(decode_payload(type_of(welcome), payload), ErrorCode::kNotFinite, "world.meters_per_sample");
    put<uint64_t>(payload, kWelcomeWorldOffset, std::bit_cast<uint64_t>(2.0));
    put<uint64_t>(payload, kWelcomeWorldOffset + 8, std::bit_cast<uint64_t>(bad));  // world.height_offset
    expect_error(decode_payload(type_of(welcome), payload), ErrorCode::kNotFinite, "world.height_offset");
  }
}

TEST(WireDecode, WorldParametersOutOfRangeAreRejectedWithTheWorldPrefix) {
  Welcome w;
  std::vector<uint8_t> payload = payload_of(w);
  put<int32_t>(payload, kWelcomeWorldOffset + 44, 0);  // world.tiles_x
  expect_error(decode_payload(type_of(w), payload), ErrorCode::kInvalidArgument, "world.tiles_x");
}

TEST(WireDecode, EncoderRefusesNonFiniteAndOversizeFieldsLikeTheDecoder) {
  Welcome w;
  w.world.meters_per_sample = std::nan("");
  Result<std::vector<uint8_t>> r = encode_payload(w);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kNotFinite);
  Hello h;
  h.client_name = std::string(kMaxClientNameBytes + 1, 'x');
  r = encode_payload(h);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "hello.client_name");
  Subscribe s;
  s.entries.resize(kMaxSubscribeEntries + 1);
  r = encode_payload(s);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kOversize);
}

TEST(WireDecode, UnknownMessageTypesAreRejectedByName) {
  for (uint16_t t : {uint16_t(0), uint16_t(kLastMessageType + 1), uint16_t(0xFFFF)}) {
    expect_error(decode_payload(t, {}), ErrorCode::kUnknownType, "frame.type");
  }
}

TEST(WireDecode, EnumerationsOutsideTheirKnownValuesAreBadEnum) {
  struct Case {
    Message m;
    size_t offset;
    uint8_t value;
    const char* field;
  };
  const Case cases[] = {
      {Hello{}, 10, 4, "hello.requested_role"},
      {Hello{}, 11, 2, "hello.has_access_token"},
      {Deform{1, test::sample_stamp()}, 4, kStampKindCount, "stamp.kind"},
      {Deform{1, test::sample_stamp()}, 5, 2, "stamp.layer"},
      {Deform{1, test::sample_stamp()}, 6, kBlendModeCount, "stamp.blend"},
      {Deform{1, test::sample_stamp()}, 7, 0x80, "stamp.flags"},
      {Bye{}, 0, kByeReasonCount, "bye.reason"},
      {Subscribe{{SubscribeEntry{}}, {}}, 4, 7, "tile.layer"},
  };
  for (const Case& c : cases) {
    std::vector<uint8_t> payload = payload_of(c.m);
    put<uint8_t>(payload, c.offset, c.value);
    expect_error(decode_payload(type_of(c.m), payload), ErrorCode::kBadEnum, c.field);
  }
  ErrorMsg e{WireErrorCode::kInternal, "", ""};
  std::vector<uint8_t> payload = payload_of(e);
  put<uint16_t>(payload, 0, 999);
  expect_error(decode_payload(type_of(e), payload), ErrorCode::kBadEnum, "error.code");
}

TEST(WireDecode, DetailTilesAboveMipZeroAreRejected) {
  Unsubscribe u{{TileCoord{Layer::kDetail, 0, 0, 0}}};
  std::vector<uint8_t> payload = payload_of(u);
  put<uint8_t>(payload, 5, 1);  // mip
  expect_error(decode_payload(type_of(u), payload), ErrorCode::kInvalidArgument, "tile.mip");
  put<uint8_t>(payload, 5, kMaxMips);
  put<uint8_t>(payload, 4, 0);
  expect_error(decode_payload(type_of(u), payload), ErrorCode::kInvalidArgument, "tile.mip");
}

TEST(WireDecode, DeformEventBaseVersionAtOrAfterItsOwnSequenceIsRejected) {
  // The base version travels as its distance below the sequence (1 = the previous stamp).
  DeformEvent ev{10, 1, test::sample_stamp(), {TileVersion{TileCoord{}, 9}}, {}};
  std::vector<uint8_t> payload = payload_of(ev);
  ASSERT_EQ(payload.back(), 1);
  payload.back() = 0;  // distance 0: the event's own sequence
  expect_error(decode_payload(type_of(ev), payload), ErrorCode::kInvalidArgument,
               "deform_event.base_version");
  payload.back() = 11;  // below version 0
  expect_error(decode_payload(type_of(ev), payload), ErrorCode::kInvalidArgument,
               "deform_event.base_version");
}

TEST(WireDecode, DeformEventTileCountBeyondItsCapOrItsBytesIsRejectedBeforeAllocating) {
  DeformEvent ev{1, 0, test::sample_stamp(), {}, {}};
  std::vector<uint8_t> payload = payload_of(ev);
  ASSERT_EQ(payload.back(), 0);  // the count, last
  payload.pop_back();
  const uint8_t all_ones[] = {0xFF, 0xFF, 0xFF, 0xFF, 0x0F};  // 2^32 - 1
  payload.insert(payload.end(), std::begin(all_ones), std::end(all_ones));
  expect_error(decode_payload(type_of(ev), payload), ErrorCode::kOversize, "deform_event.tile_count");
  payload.erase(payload.end() - 5, payload.end());
  payload.push_back(0x80);
  payload.push_back(0x20);  // 4096: within the cap, but no bytes follow
  expect_error(decode_payload(type_of(ev), payload), ErrorCode::kTruncated, "deform_event.tile_count");
}

TEST(WireDecode, DeformEventTilesOutOfOrderOrListedTwiceAreRejected) {
  const TileCoord center_tile{Layer::kCoarse, 0, 3, -8};  // holds the sample stamp's center
  DeformEvent ev{10, 1, test::sample_stamp(), {TileVersion{center_tile, 9}, TileVersion{center_tile, 8}}, {}};
  std::vector<uint8_t> payload;
  ASSERT_FALSE(encode_payload(ev).ok());  // the encoder refuses what the decoder would
  ev.base_versions.pop_back();
  payload = payload_of(ev);
  // Append the same tile again by hand (key, offset code, distance) and bump the count.
  const std::vector<uint8_t> tile(payload.end() - 3, payload.end());
  payload.insert(payload.end(), tile.begin(), tile.end());
  payload[payload.size() - 7] = 2;
  expect_error(decode_payload(type_of(ev), payload), ErrorCode::kInvalidArgument, "deform_event.tile");
}

TEST(WireDecode, VarintsMustBeShortestAndFitSixtyFourBits) {
  const auto read = [](std::vector<uint8_t> bytes) {
    ReadStream s(bytes);
    uint64_t v = 0;
    Status st = s.varint(v, "v");
    return st.ok() ? Result<uint64_t>(v) : Result<uint64_t>(st.error());
  };
  EXPECT_EQ(*read({0x00}), 0u);
  EXPECT_EQ(*read({0x7F}), 127u);
  EXPECT_EQ(*read({0x80, 0x01}), 128u);
  EXPECT_EQ(*read({0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x01}), UINT64_MAX);
  EXPECT_EQ(read({0x80, 0x00}).error().code, ErrorCode::kCorrupt);  // 0 in two bytes
  EXPECT_EQ(read({0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x02}).error().code,
            ErrorCode::kCorrupt);
  EXPECT_EQ(read({0x80, 0x80}).error().code, ErrorCode::kTruncated);
  for (uint64_t v : {uint64_t(0), uint64_t(1), uint64_t(127), uint64_t(128), uint64_t(1) << 35, UINT64_MAX}) {
    std::vector<uint8_t> out;
    WriteStream w(out);
    uint64_t x = v;
    ASSERT_TRUE(w.varint(x, "v").ok());
    MeasureStream m;
    ASSERT_TRUE(m.varint(x, "v").ok());
    EXPECT_EQ(m.offset(), out.size());
    EXPECT_EQ(*read(out), v);
  }
}

TEST(WireMessages, CompactStampKeepsEveryFieldOfEveryKind) {
  for (int k = 0; k < kStampKindCount; ++k) {
    QuantizedStamp q = test::sample_stamp(uint32_t(k));
    q.kind = StampKind(k);
    q.layer = k % 2 ? Layer::kDetail : Layer::kCoarse;
    q.blend = BlendMode(k % kBlendModeCount);
    q.target = -k * 1000;
    q.damping = uint16_t(k * 17);
    q.speed = uint16_t(k * 300);
    q.steps = uint16_t(k);
    q.texture_id = k == 0 ? 0xFEDCBA9876543210ull : 0;
    q.center_x = k == 3 ? INT64_MIN : q.center_x;
    q.radius = k == 4 ? UINT32_MAX : q.radius;
    DeformEvent ev{5, 1, q, {}, {}};
    Result<Message> back = decode_payload(type_of(ev), payload_of(ev));
    ASSERT_TRUE(back.ok()) << back.error().describe();
    EXPECT_TRUE(std::get<DeformEvent>(*back) == ev) << k;
  }
}

TEST(WireMessages, DeformEventOfATypicalStampOnAWideWorldFitsInSixtyFourBytes) {
  // A radius-24 crater on a 64 x 32-tile world (7 mips) that touches two mip-0 tiles and one
  // tile at each coarser mip, long after the initial terrain: the frame a client in sync pays.
  QuantizedStamp q;
  q.kind = StampKind::kCrater;
  q.center_x = (int64_t(9000) << 8) + 100;
  q.center_y = (int64_t(5000) << 8) + 3;
  q.radius = 24u << 8;
  q.intensity = 6 << 8;
  q.shape = 0x4000;
  DeformEvent ev{250000, 17, q, {}, {}};
  ev.base_versions.push_back({TileCoord{Layer::kCoarse, 0, 35, 19}, 249990});
  ev.base_versions.push_back({TileCoord{Layer::kCoarse, 0, 35, 20}, 0});
  for (uint8_t m = 1; m < 7; ++m) {
    ev.base_versions.push_back({TileCoord{Layer::kCoarse, m, 9000 >> (8 + m), 5000 >> (8 + m)}, 249000});
  }
  Result<std::vector<uint8_t>> frame = encode_frame(ev);
  ASSERT_TRUE(frame.ok());
  EXPECT_LE(frame->size(), 64u);
}

TEST(WireDecode, RegionChunkPastItsTotalOrRawSizeMismatchIsCorrupt) {
  const Message reg = sample_messages()[12].second;
  std::vector<uint8_t> payload = payload_of(reg);
  put<uint32_t>(payload, 40, 1);  // chunk_offset: 1 + 8 bytes > total 8
  expect_error(decode_payload(type_of(reg), payload), ErrorCode::kCorrupt, "region.chunk_offset");
  payload = payload_of(reg);
  put<uint32_t>(payload, 36, 10);  // total_bytes != 2x2 coarse samples
  expect_error(decode_payload(type_of(reg), payload), ErrorCode::kCorrupt, "region.total_bytes");
  payload = payload_of(reg);
  put<uint16_t>(payload, 10, 6);  // rect.x0 == x1
  expect_error(decode_payload(type_of(reg), payload), ErrorCode::kInvalidArgument, "rect.x0");
  payload = payload_of(reg);
  put<uint16_t>(payload, 14, kTileSize + 1);  // rect.x1 beyond the tile
  expect_error(decode_payload(type_of(reg), payload), ErrorCode::kInvalidArgument, "rect.x1");
}

TEST(WireDecode, StampImageWhosePixelCountDisagreesWithItsSizeIsCorrupt) {
  const Message img = sample_messages()[15].second;
  ASSERT_EQ(message_type(img), MessageType::kStampImageResponse);
  std::vector<uint8_t> payload = payload_of(img);
  put<uint16_t>(payload, 9, 3);  // width 3 while pixels hold 2x2x2 bytes
  expect_error(decode_payload(type_of(img), payload), ErrorCode::kCorrupt, "stamp_image.pixels");
  put<uint16_t>(payload, 9, 0);
  expect_error(decode_payload(type_of(img), payload), ErrorCode::kInvalidArgument, "stamp_image.width");
}

TEST(WireHandshake, UnknownMajorVersionIsAnErrorNamingBothVersions) {
  Hello h;
  h.version_major = kProtocolMajor + 1;
  h.version_minor = 5;
  const std::string theirs = std::to_string(kProtocolMajor + 1) + ".5";
  Result<Message> r = decode_payload(type_of(h), payload_of(h));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kUnsupported);
  EXPECT_EQ(r.error().field, "hello.version_major");
  EXPECT_NE(r.error().message.find(theirs), std::string::npos) << r.error().message;
  const std::string ours = std::to_string(kProtocolMajor) + "." + std::to_string(kProtocolMinor);
  EXPECT_NE(r.error().message.find(ours), std::string::npos) << r.error().message;
  const ErrorMsg reply = to_error_message(r.error());
  EXPECT_EQ(reply.code, WireErrorCode::kUnsupported);
  EXPECT_NE(reply.text.find(theirs), std::string::npos);
  EXPECT_EQ(version_mismatch(kProtocolMajor + 1, 5).code, WireErrorCode::kUnsupported);
  // A 1.x peer (before patches and codec format 3) is refused the same way.
  h.version_major = 1;
  EXPECT_EQ(decode_payload(type_of(h), payload_of(h)).error().field, "hello.version_major");
}

TEST(WireHandshake, HelloWithWrongMagicIsRejected) {
  std::vector<uint8_t> payload = payload_of(Hello{});
  payload[0] ^= 0xFF;
  expect_error(decode_payload(type_of(Hello{}), payload), ErrorCode::kCorrupt, "hello.magic");
}

TEST(WireHandshake, NewerMinorVersionIsAccepted) {
  Hello h;
  h.version_minor = kProtocolMinor + 3;
  Result<Message> r = decode_payload(type_of(h), payload_of(h));
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(std::get<Hello>(*r).version_minor, kProtocolMinor + 3);
}

TEST(WireHandshake, ErrorTextLongerThanTheCapIsCutWhenTurnedIntoAMessage) {
  const ErrorMsg m =
      to_error_message(make_error(ErrorCode::kIo, std::string(200, 'f'), std::string(5000, 'x')));
  EXPECT_LE(m.field.size(), kMaxFieldNameBytes);
  EXPECT_LE(m.text.size(), kMaxErrorTextBytes);
  EXPECT_TRUE(encode_payload(m).ok());
}

TEST(FrameDecoder, RejectsLengthBeyondMaximumWithoutAllocating) {
  FrameAssembler fa(1024);
  std::vector<uint8_t> header(kFrameHeaderBytes);
  store_le<uint32_t>(header.data(), 0xFFFFFFFFu);
  store_le<uint16_t>(header.data() + 4, uint16_t(MessageType::kPing));
  fa.feed(header);
  // The error comes as soon as the header is complete, not after 4 GiB of payload.
  Result<std::optional<Frame>> r = fa.next();
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kOversize);
  EXPECT_EQ(r.error().field, "frame.length");
  EXPECT_EQ(fa.buffered(), 0u);
  EXPECT_TRUE(fa.failed());
}

TEST(FrameDecoder, ErrorsAreStickySoAnOutOfSyncStreamIsNeverReinterpreted) {
  FrameAssembler fa(64);
  std::vector<uint8_t> bytes(kFrameHeaderBytes);
  store_le<uint32_t>(bytes.data(), 65);
  fa.feed(bytes);
  EXPECT_FALSE(fa.next().ok());
  Result<std::vector<uint8_t>> ping = encode_frame(Ping{1});
  fa.feed(*ping);
  EXPECT_FALSE(fa.next().ok());
}

TEST(FrameDecoder, ByteByByteFeedYieldsTheSameMessagesAsOneFeed) {
  std::vector<uint8_t> stream;
  for (const auto& [name, m] : sample_messages()) ASSERT_TRUE(append_frame(stream, m).ok()) << name;
  FrameAssembler fa;
  std::vector<Message> got;
  for (uint8_t b : stream) {
    fa.feed(std::span<const uint8_t>(&b, 1));
    for (;;) {
      Result<std::optional<Message>> r = fa.next_message();
      ASSERT_TRUE(r.ok()) << r.error().describe();
      if (!r->has_value()) break;
      got.push_back(std::move(**r));
    }
  }
  const auto samples = sample_messages();
  ASSERT_EQ(got.size(), samples.size());
  for (size_t i = 0; i < got.size(); ++i) EXPECT_TRUE(got[i] == samples[i].second) << samples[i].first;
  EXPECT_EQ(fa.buffered(), 0u);
}

TEST(FrameDecoder, PartialFrameWaitsForMoreBytes) {
  Result<std::vector<uint8_t>> frame = encode_frame(Ping{5});
  FrameAssembler fa;
  fa.feed(std::span<const uint8_t>(*frame).first(frame->size() - 1));
  Result<std::optional<Frame>> r = fa.next();
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r->has_value());
  fa.feed(std::span<const uint8_t>(*frame).last(1));
  r = fa.next();
  ASSERT_TRUE(r.ok());
  ASSERT_TRUE(r->has_value());
  EXPECT_EQ((*r)->type, uint16_t(MessageType::kPing));
}

TEST(FrameDecoder, UnknownTypeIsRejectedAtTheHeaderBeforeItsPayloadIsBuffered) {
  std::vector<uint8_t> bytes(kFrameHeaderBytes);
  store_le<uint32_t>(bytes.data(), 100000);
  store_le<uint16_t>(bytes.data() + 4, 0x7777);
  FrameAssembler fa;
  fa.feed(bytes);
  Result<std::optional<Frame>> r = fa.next();
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kUnknownType);
  EXPECT_EQ(r.error().field, "frame.type");
  EXPECT_EQ(fa.buffered(), 0u);
}

TEST(FrameDecoder, UndecodablePayloadInAWellFormedFrameIsAStickyTypedError) {
  std::vector<uint8_t> bytes(kFrameHeaderBytes + 1);
  store_le<uint32_t>(bytes.data(), 1);
  store_le<uint16_t>(bytes.data() + 4, uint16_t(MessageType::kBye));
  bytes[kFrameHeaderBytes] = 0x99;  // bye.reason, then the text length is missing
  FrameAssembler fa;
  fa.feed(bytes);
  Result<std::optional<Message>> r = fa.next_message();
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "bye.reason");
  EXPECT_TRUE(fa.failed());
  EXPECT_FALSE(fa.next_message().ok());
}

TEST(FrameEncoder, RefusesAMessageLargerThanThePeersMaximumAndLeavesTheBufferUnchanged) {
  RegionUpdate reg = std::get<RegionUpdate>(sample_messages()[12].second);
  std::vector<uint8_t> out = {9, 9};
  Status st = append_frame(out, reg, 16);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().field, "frame.length");
  EXPECT_EQ(out, (std::vector<uint8_t>{9, 9}));
}

TEST(FrameDecoder, WholeFrameDecodeRejectsBytesAfterTheFrame) {
  Result<std::vector<uint8_t>> frame = encode_frame(Ping{5});
  frame->push_back(0);
  Result<Message> r = decode_frame(*frame);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "frame.payload");
}

// Protocol 2: a region either replaces the whole tile (no base version) or patches a rect over
// the version the client holds; anything in between is refused, naming the field.
TEST(WireDecode, ReplacementOfLessThanTheWholeTileOrWithABaseVersionIsRejected) {
  RegionUpdate reg = std::get<RegionUpdate>(sample_messages()[12].second);
  ASSERT_TRUE(reg.patch);
  reg.patch = false;  // a 2x2 rect is not the whole tile
  EXPECT_EQ(encode_payload(reg).error().field, "region.base_version");
  reg.base_version = 0;
  EXPECT_EQ(encode_payload(reg).error().field, "region.rect");
  reg.rect = RectI{0, 0, kTileSize, kTileSize};
  reg.encoding = RegionEncoding::kCodec;
  EXPECT_TRUE(encode_payload(reg).ok());
  reg.patch = true;
  reg.base_version = reg.new_version;
  EXPECT_EQ(encode_payload(reg).error().field, "region.new_version");
}

TEST(WireDecode, SubscribeHeldVersionOfATileNotHeldIsRejected) {
  Subscribe sub;
  sub.entries.push_back({TileCoord{Layer::kCoarse, 0, 0, 0}, false, 5});
  EXPECT_EQ(encode_payload(sub).error().field, "subscribe.held_version");
  sub.entries[0].held = true;
  EXPECT_TRUE(encode_payload(sub).ok());
  sub.entries[0].held_version = 0;  // held at the initial terrain: claimable since protocol 2
  EXPECT_TRUE(encode_payload(sub).ok());
}

TEST(WireRegion, ChunkedPayloadReassemblesToTheOriginal) {
  RegionUpdate header;
  header.tile = TileCoord{Layer::kCoarse, 0, 1, 1};
  header.rect = RectI{0, 0, kTileSize, kTileSize};
  header.new_version = 9;
  header.encoding = RegionEncoding::kRaw;
  std::vector<uint8_t> payload(size_t(kTileSamples) * 2);
  for (size_t i = 0; i < payload.size(); ++i) payload[i] = uint8_t(i * 31 + 7);
  Result<std::vector<RegionUpdate>> chunks = chunk_region(header, payload, 50000);
  ASSERT_TRUE(chunks.ok());
  EXPECT_EQ(chunks->size(), 3u);
  RegionAssembler ra;
  std::optional<std::vector<uint8_t>> done;
  for (const RegionUpdate& c : *chunks) {
    // Through the wire, so the decoder's checks run on every chunk.
    Result<Message> m = decode_frame(*encode_frame(c));
    ASSERT_TRUE(m.ok()) << m.error().describe();
    Result<std::optional<std::vector<uint8_t>>> r = ra.add(std::get<RegionUpdate>(*m));
    ASSERT_TRUE(r.ok()) << r.error().describe();
    if (r->has_value()) done = std::move(**r);
  }
  ASSERT_TRUE(done.has_value());
  EXPECT_EQ(*done, payload);
  EXPECT_FALSE(ra.in_progress());
}

TEST(WireRegion, ChunkOutOfOrderDropsThePartialRegion) {
  RegionUpdate header;
  header.rect = RectI{0, 0, 16, 16};
  header.encoding = RegionEncoding::kRaw;
  std::vector<uint8_t> payload(16 * 16 * 2, 1);
  Result<std::vector<RegionUpdate>> chunks = chunk_region(header, payload, 100);
  ASSERT_TRUE(chunks.ok());
  RegionAssembler ra;
  ASSERT_TRUE(ra.add((*chunks)[0]).ok());
  Result<std::optional<std::vector<uint8_t>>> r = ra.add((*chunks)[2]);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "region.chunk_offset");
  EXPECT_FALSE(ra.in_progress());
}

// A full server or a rate limit is not an authorization failure: a client may retry it later,
// an unauthorized one must not (both used to read as unauthorized).
TEST(WireErrors, FromWireKeepsCapacityRefusalsApartFromAuthorization) {
  for (WireErrorCode c :
       {WireErrorCode::kServerFull, WireErrorCode::kRateLimited, WireErrorCode::kTooManyPending})
    EXPECT_EQ(from_wire(c), ErrorCode::kBusy) << to_string(c);
  EXPECT_EQ(from_wire(WireErrorCode::kUnauthorized), ErrorCode::kUnauthorized);
  EXPECT_TRUE(is_known(to_wire(ErrorCode::kBusy)));
  EXPECT_EQ(from_wire(to_wire(ErrorCode::kBusy)), ErrorCode::kBusy);
}

}  // namespace
}  // namespace loam::wire

namespace loam::wire {
namespace {

// Found by wire_fuzz (fuzz/corpus/wire_fuzz/deform_event_tile_offset_overflow.bin): a DeformEvent
// whose long-form tile offset is near INT64_MIN overflowed when added to the stamp's tile.
TEST(WireMessages, ATileOffsetNearTheInt64LimitIsAnErrorNotAnOverflow) {
  const uint8_t bytes[] = {0x32, 0x00, 0x00, 0x00, 0x0b, 0x00, 0xc1, 0xa8, 0xa5, 0x04, 0xac, 0x02,
                           0x00, 0x00, 0x05, 0x00, 0x08, 0x07, 0x06, 0x05, 0x04, 0x8b, 0x01, 0x80,
                           0xff, 0xff, 0xff, 0xff, 0x01, 0x00, 0x01, 0x00, 0xff, 0xff, 0xff, 0xff,
                           0x06, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x01, 0x00,
                           0x60, 0x30, 0x02, 0xf0, 0x35, 0x1c, 0x83, 0x06};
  const auto m = decode_frame(std::span<const uint8_t>(bytes, sizeof bytes));
  ASSERT_FALSE(m.ok());
  EXPECT_FALSE(m.error().field.empty());
}

}  // namespace
}  // namespace loam::wire
