#include "protocol/snapshot/snapshot.h"

#include <fcntl.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "protocol/byte_order.h"
#include "protocol/codec/region_codec.h"
#include "protocol/file_io.h"
#include "protocol/layer.h"
#include "protocol/snapshot/snapshot_io.h"
#include "protocol/snapshot/snapshot_store.h"
#include "protocol/tile_hash.h"

namespace loam {
namespace fs = std::filesystem;

namespace {

constexpr char kMagic[8] = {'L', 'O', 'A', 'M', 'S', 'N', 'A', 'P'};
constexpr uint32_t kFormat = 2;  // 2: texture-stamp images after the tile sections

// Writing a layer's decoded tile into a world.
template <class R>
struct LayerWrite;
template <>
struct LayerWrite<CoarseLayer> {
  static void write(World& w, const RectI& r, std::span<const uint16_t> s) { w.write_coarse(r, s); }
};
template <>
struct LayerWrite<DetailLayer> {
  static void write(World& w, const RectI& r, std::span<const int8_t> s) { w.write_detail(r, s); }
};

}  // namespace

namespace {

struct Reader {
  std::span<const uint8_t> bytes;
  size_t at = 0;
  std::string path;
  template <typename T>
  Result<T> get(const char* field) {
    if (bytes.size() - at < sizeof(T))
      return make_error(ErrorCode::kTruncated, path, std::string("truncated at ") + field);
    const T v = load_le<T>(bytes.data() + at);
    at += sizeof v;
    return v;
  }
};

}  // namespace

namespace snapshot_io {

Status write_file_synced(const std::string& path, std::span<const uint8_t> bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return file_error(path, "cannot create");
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const Error e = file_error(path, "write failed");
      ::close(fd);
      return e;
    }
    done += size_t(n);
  }
  if (::fsync(fd) != 0) {
    const Error e = file_error(path, "fsync failed");
    ::close(fd);
    return e;
  }
  if (::close(fd) != 0) return file_error(path, "close failed");
  return {};
}

nlohmann::json world_json(const WorldParams& p) {
  return {{"meters_per_sample", p.meters_per_sample},
          {"height_offset", p.height_offset},
          {"meters_per_unit", p.meters_per_unit},
          {"detail_factor", p.detail_factor},
          {"detail_meters_per_unit", p.detail_meters_per_unit},
          {"origin_tile_x", p.origin_tile_x},
          {"origin_tile_y", p.origin_tile_y},
          {"tiles_x", p.tiles_x},
          {"tiles_y", p.tiles_y}};
}

Result<WorldParams> world_from_json(const nlohmann::json& j, const std::string& path) {
  WorldParams p;
  try {
    p.meters_per_sample = j.at("meters_per_sample").get<double>();
    p.height_offset = j.at("height_offset").get<double>();
    p.meters_per_unit = j.at("meters_per_unit").get<double>();
    p.detail_factor = j.at("detail_factor").get<int32_t>();
    p.detail_meters_per_unit = j.at("detail_meters_per_unit").get<double>();
    p.origin_tile_x = j.at("origin_tile_x").get<int32_t>();
    p.origin_tile_y = j.at("origin_tile_y").get<int32_t>();
    p.tiles_x = j.at("tiles_x").get<int32_t>();
    p.tiles_y = j.at("tiles_y").get<int32_t>();
  } catch (const nlohmann::json::exception& e) {
    return make_error(ErrorCode::kCorrupt, path, std::string("manifest world: ") + e.what());
  }
  if (const Status st = p.validate(); !st.ok()) {
    return make_error(ErrorCode::kCorrupt, path, "manifest world: " + st.error().describe());
  }
  return p;
}

}  // namespace snapshot_io

using snapshot_io::world_from_json;
using snapshot_io::world_json;
using snapshot_io::write_file_synced;

Status fsync_path(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return file_error(path, "cannot open to fsync");
  const int rc = ::fsync(fd);
  ::close(fd);
  if (rc != 0) return file_error(path, "fsync failed");
  return {};
}

std::string snapshot_dir_name(uint64_t snapshot_id) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "snapshot-%020llu", (unsigned long long)snapshot_id);
  return buf;
}

namespace snapshot_io {

nlohmann::json manifest_json(const SnapshotManifest& m, uint32_t format) {
  return {{"format", format},
          {"snapshot_id", m.snapshot_id},
          {"last_seq", m.last_seq},
          {"world_hash", m.world_hash},
          {"created_unix_us", m.created_unix_us},
          {"next_segment_index", m.next_segment_index},
          {"coarse_tiles", m.coarse_tiles},
          {"detail_tiles", m.detail_tiles},
          {"tiles_bytes", m.tiles_bytes},
          {"world", world_json(m.world)},
          {"world_hash_covers_params", true},
          {"base_identity", m.base_identity},
          {"base", m.base_description},
          {"initial_is_base", m.initial_is_base},
          {"tick", m.tick},
          {"limits",
           {{"max_radius_samples", m.limits.max_radius_samples},
            {"max_shockwave_steps", m.limits.max_shockwave_steps},
            {"max_shockwave_cells", m.limits.max_shockwave_cells}}}};
}

Result<std::string> publish(const std::string& data_dir, uint64_t snapshot_id,
                            const std::vector<std::pair<std::string, std::span<const uint8_t>>>& files) {
  std::error_code ec;
  const fs::path root = fs::path(data_dir) / "snapshots";
  fs::create_directories(root, ec);
  if (ec) return make_error(ErrorCode::kIo, root.string(), "cannot create: " + ec.message());
  const fs::path final_dir = root / snapshot_dir_name(snapshot_id);
  const fs::path tmp = root / (".tmp-" + snapshot_dir_name(snapshot_id));
  fs::remove_all(tmp, ec);
  const Status written = [&]() -> Status {
    fs::create_directories(tmp, ec);
    if (ec) return make_error(ErrorCode::kIo, tmp.string(), "cannot create: " + ec.message());
    for (const auto& [name, bytes] : files) LOAM_TRY(write_file_synced((tmp / name).string(), bytes));
    LOAM_TRY(fsync_path(tmp.string()));
    if (fs::exists(final_dir)) fs::remove_all(final_dir, ec);  // same id rewritten (e.g. shutdown twice)
    fs::rename(tmp, final_dir, ec);
    if (ec) return make_error(ErrorCode::kIo, final_dir.string(), "rename failed: " + ec.message());
    return {};
  }();
  if (!written.ok()) {
    // A partial snapshot would hold the disk space a full disk needs back.
    std::error_code ignored;
    fs::remove_all(tmp, ignored);
    return written.error();
  }
  LOAM_TRY(fsync_path(root.string()));
  return final_dir.string();
}

}  // namespace snapshot_io

Result<std::string> write_snapshot(const std::string& data_dir, World& world, uint64_t last_seq,
                                   uint32_t next_segment_index, const TextureRegistry& textures,
                                   const SnapshotSession& session) {
  auto written = SnapshotStore::open(data_dir)->write(world, last_seq, next_segment_index, textures, session);
  if (!written) return written.error();
  return written->path;
}

size_t remove_partial_snapshots(const std::string& data_dir) {
  std::error_code ec;
  const fs::path root = fs::path(data_dir) / "snapshots";
  if (!fs::is_directory(root, ec)) return 0;
  std::vector<fs::path> partial;
  for (const auto& e : fs::directory_iterator(root, ec)) {
    if (e.path().filename().string().rfind(".tmp-", 0) == 0) partial.push_back(e.path());
  }
  size_t removed = 0;
  for (const fs::path& p : partial) {
    if (fs::remove_all(p, ec) > 0 && !ec) ++removed;
  }
  return removed;
}

Result<SnapshotManifest> read_snapshot_manifest(const std::string& path) {
  const std::string mpath = (fs::path(path) / "manifest.json").string();
  std::ifstream in(mpath);
  if (!in) return make_error(ErrorCode::kNotFound, mpath, "cannot open");
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object())
    return make_error(ErrorCode::kCorrupt, mpath, "manifest does not parse");
  SnapshotManifest m;
  try {
    m.format = j.at("format").get<uint32_t>();
    if (m.format != kFormat && m.format != kSnapshotFormatIncremental) {
      return make_error(
          ErrorCode::kUnsupported, mpath,
          "unknown snapshot format " + j.at("format").dump() + " (this build reads formats 2 and 3)");
    }
    if (m.format == kSnapshotFormatIncremental) {
      m.index_bytes = j.at("index_bytes").get<uint64_t>();
      m.tile_files = j.at("tile_files").get<std::vector<uint64_t>>();
    }
    m.snapshot_id = j.at("snapshot_id").get<uint64_t>();
    m.last_seq = j.at("last_seq").get<uint64_t>();
    m.world_hash = j.at("world_hash").get<uint64_t>();
    m.created_unix_us = j.at("created_unix_us").get<uint64_t>();
    m.next_segment_index = j.at("next_segment_index").get<uint32_t>();
    m.coarse_tiles = j.at("coarse_tiles").get<size_t>();
    m.detail_tiles = j.at("detail_tiles").get<size_t>();
    m.tiles_bytes = j.at("tiles_bytes").get<uint64_t>();
    m.hash_covers_params = j.value("world_hash_covers_params", false);
    m.base_identity = j.value("base_identity", FillBase(0).identity());
    m.base_description = j.value("base", std::string("fill 0"));
    m.initial_is_base = j.value("initial_is_base", false);
    if (j.contains("limits")) {
      const nlohmann::json& l = j.at("limits");
      m.has_session = true;
      m.limits.max_radius_samples = l.at("max_radius_samples").get<double>();
      m.limits.max_shockwave_steps = l.at("max_shockwave_steps").get<uint32_t>();
      m.limits.max_shockwave_cells = l.at("max_shockwave_cells").get<int64_t>();
      m.tick = j.at("tick").get<uint64_t>();
      if (Status st = validate_limits(m.limits); !st.ok())
        return make_error(ErrorCode::kCorrupt, mpath, "manifest: " + st.error().describe());
    }
  } catch (const nlohmann::json::exception& e) {
    return make_error(ErrorCode::kCorrupt, mpath, std::string("manifest: ") + e.what());
  }
  auto world = world_from_json(j.contains("world") ? j["world"] : nlohmann::json(), mpath);
  if (!world) return world.error();
  m.world = *world;
  return m;
}

Result<LoadedSnapshot> read_snapshot(const std::string& path, std::shared_ptr<const TileBase> base,
                                     bool verify_tiles) {
  auto manifest = read_snapshot_manifest(path);
  if (!manifest) return manifest.error();
  if (manifest->format == kSnapshotFormatIncremental) {
    // <data>/snapshots/snapshot-<seq>: the store is the data folder's.
    const std::string data_dir = fs::path(path).lexically_normal().parent_path().parent_path().string();
    return SnapshotStore::open(data_dir)->load(path, std::move(base), verify_tiles);
  }
  const std::string tpath = (fs::path(path) / "tiles.bin").string();
  std::ifstream in(tpath, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, tpath, "cannot open");
  const std::vector<uint8_t> bytes{std::istreambuf_iterator<char>(in), {}};
  if (bytes.size() != manifest->tiles_bytes || bytes.size() < 20) {
    return make_error(ErrorCode::kCorrupt, tpath,
                      "size " + std::to_string(bytes.size()) + " does not match the manifest");
  }
  uint64_t stored_sum;
  std::memcpy(&stored_sum, bytes.data() + bytes.size() - 8, 8);
  if (XXH3_64bits(bytes.data(), bytes.size() - 8) != stored_sum)
    return make_error(ErrorCode::kCorrupt, tpath, "checksum mismatch");
  Reader r{std::span(bytes).first(bytes.size() - 8), 0, tpath};
  if (bytes.size() < 12 || std::memcmp(bytes.data(), kMagic, 8) != 0)
    return make_error(ErrorCode::kCorrupt, tpath, "bad magic");
  r.at = 8;
  auto fmt = r.get<uint32_t>("format");
  if (!fmt) return fmt.error();
  if (*fmt != kFormat) return make_error(ErrorCode::kUnsupported, tpath, "unknown tiles format");

  if (!base) base = std::make_shared<FillBase>(0);
  if (base->identity() != manifest->base_identity)
    return make_error(ErrorCode::kUnsupported, (fs::path(path) / "manifest.json").string(),
                      "the snapshot edits the base '" + manifest->base_description +
                          "', not the session's base '" + base->describe() + "'");
  World world(manifest->world, std::move(base));
  struct Versioned {
    TileCoord c;
    uint64_t version, hash;
  };
  std::vector<Versioned> versions;
  for (int section = 0; section < 3; ++section) {
    auto count = r.get<uint32_t>("section count");
    if (!count) return count.error();
    if (*count > (1u << 24)) return make_error(ErrorCode::kCorrupt, tpath, "section count too large");
    for (uint32_t i = 0; i < *count; ++i) {
      auto layer = r.get<uint8_t>("layer");
      auto mip = r.get<uint8_t>("mip");
      auto tx = r.get<int32_t>("tx");
      auto ty = r.get<int32_t>("ty");
      auto version = r.get<uint64_t>("version");
      auto hash = r.get<uint64_t>("hash");
      auto size = r.get<uint32_t>("payload size");
      if (!layer || !mip || !tx || !ty || !version || !hash || !size)
        return make_error(ErrorCode::kTruncated, tpath, "tile record truncated");
      if (*size > r.bytes.size() - r.at)
        return make_error(ErrorCode::kTruncated, tpath, "tile payload truncated");
      const auto payload = r.bytes.subspan(r.at, *size);
      r.at += *size;
      const TileCoord c{Layer(*layer), *mip, *tx, *ty};
      if (*layer > 1) return make_error(ErrorCode::kCorrupt, tpath, "bad layer");
      const RectI rect = tile_rect(*tx, *ty);
      if (section <= 1) {
        // Sections 0 and 1: the mip-0 tiles of the coarse and of the detail layer.
        const Layer want = Layer(section);
        if (c.layer != want || c.mip != 0 || !layer_tile_range(manifest->world, want, 0).contains(*tx, *ty)) {
          return make_error(
              ErrorCode::kCorrupt, tpath,
              std::string(layer_info(want).name) + " tile " + to_string(c) + " outside the world");
        }
        const Status read = visit_layer(want, [&](auto row) -> Status {
          using R = decltype(row);
          auto samples = decode_samples<typename R::Sample>(payload, kTileSize, kTileSize, {}, *hash);
          if (!samples)
            return make_error(ErrorCode::kCorrupt, tpath,
                              "tile " + to_string(c) + ": " + samples.error().describe());
          LayerWrite<R>::write(world, rect, *samples);
          return {};
        });
        LOAM_TRY(read);
      }
      versions.push_back({c, *version, *hash});
    }
  }
  auto image_count = r.get<uint32_t>("texture count");
  if (!image_count) return image_count.error();
  if (*image_count > 4096) return make_error(ErrorCode::kCorrupt, tpath, "texture count too large");
  std::vector<StampTexture> images;
  for (uint32_t i = 0; i < *image_count; ++i) {
    auto id = r.get<uint64_t>("texture id");
    auto w = r.get<int32_t>("texture width");
    auto h = r.get<int32_t>("texture height");
    if (!id || !w || !h) return make_error(ErrorCode::kTruncated, tpath, "texture record truncated");
    if (*w <= 0 || *h <= 0 || *w > kMaxTextureSide || *h > kMaxTextureSide) {
      return make_error(ErrorCode::kCorrupt, tpath, "texture size out of range");
    }
    const size_t bytes_needed = size_t(*w) * size_t(*h) * sizeof(uint16_t);
    if (bytes_needed > r.bytes.size() - r.at)
      return make_error(ErrorCode::kTruncated, tpath, "texture samples truncated");
    StampTexture t;
    t.width = *w;
    t.height = *h;
    t.samples.resize(size_t(*w) * size_t(*h));
    std::memcpy(t.samples.data(), r.bytes.data() + r.at, bytes_needed);
    r.at += bytes_needed;
    t.id = texture_content_id(t.width, t.height, t.samples);
    if (t.id != *id) return make_error(ErrorCode::kCorrupt, tpath, "texture content does not match its id");
    images.push_back(std::move(t));
  }
  if (r.at != r.bytes.size()) return make_error(ErrorCode::kCorrupt, tpath, "trailing bytes");
  world.commit(0);
  for (const Versioned& v : versions) {
    if (!world.restore_version(v.c, v.version))
      return make_error(ErrorCode::kCorrupt, tpath, "tile " + to_string(v.c) + " outside the world");
    if (world.tile_state(v.c).hash != v.hash)
      return make_error(ErrorCode::kCorrupt, tpath, "tile " + to_string(v.c) + " hash mismatch");
  }
  world.set_initial_is_base(manifest->initial_is_base);
  if (!world.matches_recorded_hash(manifest->world_hash))
    return make_error(ErrorCode::kCorrupt, tpath, "world hash mismatch");
  return LoadedSnapshot{*manifest, std::move(world), path, std::move(images)};
}

std::vector<std::string> list_snapshots(const std::string& data_dir) {
  std::vector<std::string> out;
  std::error_code ec;
  const fs::path root = fs::path(data_dir) / "snapshots";
  if (!fs::is_directory(root, ec)) return out;
  for (const auto& e : fs::directory_iterator(root, ec)) {
    const std::string name = e.path().filename().string();
    if (e.is_directory() && name.rfind("snapshot-", 0) == 0) out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end(), std::greater<>());  // zero-padded ids sort numerically
  return out;
}

}  // namespace loam
