#include "protocol/snapshot/snapshot_store.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>

#include "protocol/byte_order.h"
#include "protocol/codec/region_codec.h"
#include "protocol/file_io.h"
#include "protocol/snapshot/snapshot_io.h"
#include "protocol/tile_hash.h"

namespace loam {
namespace fs = std::filesystem;

namespace {

constexpr char kTilesMagic[8] = {'L', 'O', 'A', 'M', 'T', 'I', 'L', 'E'};
constexpr char kIndexMagic[8] = {'L', 'O', 'A', 'M', 'S', 'I', 'D', 'X'};
constexpr uint32_t kTilesFormat = 1;
constexpr size_t kTilesHeaderSize = 16;
constexpr size_t kRecordHeaderSize = 30;  // kind, mip, tx, ty, version, hash, size
constexpr size_t kTilesTrailerSize = 16;  // record count, checksum
constexpr size_t kIndexHeaderSize = 24;   // magic, format, entry count, image count
constexpr size_t kIndexEntrySize = 54;
constexpr size_t kIndexImageSize = 36;
constexpr uint8_t kKindCoarse = 0, kKindDetail = 1, kKindImage = 2;
// A tile's payload is at most its raw samples plus the codec's header and some slack (an
// image's is exactly its samples: checked against its size).
constexpr uint32_t kMaxTilePayload = uint32_t(kRegionHeaderSize + kTileSamples * 2 + 64);

void put_record_header(std::vector<uint8_t>& out, uint8_t kind, uint8_t mip, int32_t tx, int32_t ty,
                       uint64_t version, uint64_t hash, uint32_t size) {
  append_le<uint8_t>(out, kind);
  append_le<uint8_t>(out, mip);
  append_le<int32_t>(out, tx);
  append_le<int32_t>(out, ty);
  append_le<uint64_t>(out, version);
  append_le<uint64_t>(out, hash);
  append_le<uint32_t>(out, size);
}

std::string describe_entry(const StoredTile& e) {
  if (e.kind == kKindImage) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "stamp image %016llx", (unsigned long long)e.hash);
    return buf;
  }
  return to_string(TileCoord{Layer(e.kind), e.mip, e.tx, e.ty});
}

}  // namespace

Result<SnapshotIndex> parse_snapshot_index(std::span<const uint8_t> bytes, const WorldParams& world,
                                           const std::string& path) {
  if (bytes.size() < kIndexHeaderSize + 8)
    return make_error(ErrorCode::kTruncated, path, "shorter than an index");
  if (std::memcmp(bytes.data(), kIndexMagic, 8) != 0)
    return make_error(ErrorCode::kCorrupt, path, "not a snapshot index (bad magic)");
  if (XXH3_64bits(bytes.data(), bytes.size() - 8) != load_le<uint64_t>(bytes.data() + bytes.size() - 8))
    return make_error(ErrorCode::kCorrupt, path, "index checksum mismatch");
  const uint32_t format = load_le<uint32_t>(bytes.data() + 8);
  if (format != kSnapshotFormatIncremental)
    return make_error(ErrorCode::kUnsupported, path, "index format " + std::to_string(format));
  const uint64_t entries = load_le<uint64_t>(bytes.data() + 12);
  const uint32_t images = load_le<uint32_t>(bytes.data() + 20);
  const uint64_t body = bytes.size() - kIndexHeaderSize - 8;
  if (entries > body / kIndexEntrySize || images > 4096 ||
      entries * kIndexEntrySize + uint64_t(images) * kIndexImageSize != body)
    return make_error(ErrorCode::kCorrupt, path, "entry counts do not match the index's size");
  SnapshotIndex out;
  out.tiles.reserve(size_t(entries));
  const RectI detail_tiles = tiles_overlapping(world.detail_sample_rect());
  const uint8_t* p = bytes.data() + kIndexHeaderSize;
  std::set<TileCoord> seen;
  for (uint64_t i = 0; i < entries; ++i, p += kIndexEntrySize) {
    StoredTile e;
    e.kind = p[0];
    e.mip = p[1];
    e.tx = load_le<int32_t>(p + 2);
    e.ty = load_le<int32_t>(p + 6);
    e.version = load_le<uint64_t>(p + 10);
    e.hash = load_le<uint64_t>(p + 18);
    e.base_hash = load_le<uint64_t>(p + 26);
    e.file = load_le<uint64_t>(p + 34);
    e.offset = load_le<uint64_t>(p + 42);
    e.size = load_le<uint32_t>(p + 50);
    const std::string what = "index entry " + std::to_string(i);
    if (e.kind == kKindCoarse) {
      if (e.mip >= world.mip_count() || !world.tile_range(e.mip).contains(e.tx, e.ty))
        return make_error(ErrorCode::kCorrupt, path, what + ": coarse tile outside the world");
      if (e.size < kRegionHeaderSize || e.size > kMaxTilePayload)
        return make_error(ErrorCode::kCorrupt, path, what + ": payload size out of range");
    } else if (e.kind == kKindDetail) {
      if (e.mip != 0 || !detail_tiles.contains(e.tx, e.ty))
        return make_error(ErrorCode::kCorrupt, path, what + ": detail tile outside the world");
      if ((e.size != 0 && e.size < kRegionHeaderSize) || e.size > kMaxTilePayload)
        return make_error(ErrorCode::kCorrupt, path, what + ": payload size out of range");
      if (e.size == 0 && e.hash != zero_detail_tile_hash())
        return make_error(ErrorCode::kCorrupt, path, what + ": a tile without samples must hash as zeros");
    } else {
      return make_error(ErrorCode::kCorrupt, path, what + ": unknown kind " + std::to_string(e.kind));
    }
    if (!seen.insert(TileCoord{Layer(e.kind), e.mip, e.tx, e.ty}).second)
      return make_error(ErrorCode::kCorrupt, path, what + ": tile listed twice");
    out.tiles.push_back(e);
  }
  for (uint32_t i = 0; i < images; ++i, p += kIndexImageSize) {
    StoredTile e;
    e.kind = kKindImage;
    e.hash = load_le<uint64_t>(p);
    e.tx = load_le<int32_t>(p + 8);
    e.ty = load_le<int32_t>(p + 12);
    e.file = load_le<uint64_t>(p + 16);
    e.offset = load_le<uint64_t>(p + 24);
    e.size = load_le<uint32_t>(p + 32);
    if (e.tx <= 0 || e.ty <= 0 || e.tx > kMaxTextureSide || e.ty > kMaxTextureSide ||
        uint64_t(e.size) != uint64_t(e.tx) * uint64_t(e.ty) * 2)
      return make_error(ErrorCode::kCorrupt, path,
                        "index image " + std::to_string(i) + ": size out of range");
    out.images.push_back(e);
  }
  return out;
}

namespace {

std::vector<uint8_t> serialize_index(const std::vector<StoredTile>& tiles,
                                     const std::vector<StoredTile>& images) {
  std::vector<uint8_t> b;
  b.reserve(kIndexHeaderSize + tiles.size() * kIndexEntrySize + images.size() * kIndexImageSize + 8);
  b.resize(8);
  std::memcpy(b.data(), kIndexMagic, 8);
  append_le<uint32_t>(b, kSnapshotFormatIncremental);
  append_le<uint64_t>(b, uint64_t(tiles.size()));
  append_le<uint32_t>(b, uint32_t(images.size()));
  for (const StoredTile& e : tiles) {
    append_le<uint8_t>(b, e.kind);
    append_le<uint8_t>(b, e.mip);
    append_le<int32_t>(b, e.tx);
    append_le<int32_t>(b, e.ty);
    append_le<uint64_t>(b, e.version);
    append_le<uint64_t>(b, e.hash);
    append_le<uint64_t>(b, e.base_hash);
    append_le<uint64_t>(b, e.file);
    append_le<uint64_t>(b, e.offset);
    append_le<uint32_t>(b, e.size);
  }
  for (const StoredTile& e : images) {
    append_le<uint64_t>(b, e.hash);
    append_le<int32_t>(b, e.tx);
    append_le<int32_t>(b, e.ty);
    append_le<uint64_t>(b, e.file);
    append_le<uint64_t>(b, e.offset);
    append_le<uint32_t>(b, e.size);
  }
  append_le<uint64_t>(b, XXH3_64bits(b.data(), b.size()));
  return b;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

uint64_t now_unix_us() {
  return uint64_t(std::chrono::duration_cast<std::chrono::microseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count());
}

// Tiles files in the folder, by number.
std::map<uint64_t, uint64_t> list_tiles_files(const std::string& dir) {
  std::map<uint64_t, uint64_t> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    unsigned long long n = 0;
    char tail[16] = {};
    if (std::sscanf(name.c_str(), "tiles-%20llu.%15s", &n, tail) == 2 && std::string(tail) == "loamtiles") {
      std::error_code sec;
      out[n] = fs::file_size(e.path(), sec);
    }
  }
  return out;
}

}  // namespace

std::string snapshot_tiles_file_name(uint64_t n) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "tiles-%020llu.loamtiles", (unsigned long long)n);
  return buf;
}

std::string snapshot_tiles_dir(const std::string& data_dir) {
  return (fs::path(data_dir) / "snapshots" / "tiles").string();
}

std::shared_ptr<SnapshotStore> SnapshotStore::open(const std::string& data_dir) {
  std::shared_ptr<SnapshotStore> s(new SnapshotStore(data_dir));
  const auto existing = list_tiles_files(snapshot_tiles_dir(data_dir));
  if (!existing.empty()) s->next_file_ = existing.rbegin()->first + 1;
  return s;
}

SnapshotStore::~SnapshotStore() {
  for (const auto& [n, fd] : fds_) ::close(fd);
}

std::string SnapshotStore::tiles_path(uint64_t file) const {
  return (fs::path(snapshot_tiles_dir(data_dir_)) / snapshot_tiles_file_name(file)).string();
}

int SnapshotStore::fd_of(uint64_t file) const {
  if (const auto it = fds_.find(file); it != fds_.end()) return it->second;
  const int fd = ::open(tiles_path(file).c_str(), O_RDONLY | O_CLOEXEC);
  if (fd >= 0) fds_[file] = fd;
  return fd;
}

Result<std::vector<uint8_t>> SnapshotStore::read_payload(const StoredTile& e) const {
  const std::string path = tiles_path(e.file);
  const int fd = fd_of(e.file);
  if (fd < 0) return file_error(path, "cannot open");
  std::vector<uint8_t> rec(kRecordHeaderSize + e.size);
  LOAM_TRY(pread_exact(fd, e.offset, rec, path));
  const uint8_t* h = rec.data();
  if (h[0] != e.kind || h[1] != e.mip || load_le<int32_t>(h + 2) != e.tx || load_le<int32_t>(h + 6) != e.ty ||
      load_le<uint64_t>(h + 10) != e.version || load_le<uint64_t>(h + 18) != e.hash ||
      load_le<uint32_t>(h + 26) != e.size)
    return make_error(ErrorCode::kCorrupt, path,
                      "the record at offset " + std::to_string(e.offset) + " is not " + describe_entry(e));
  rec.erase(rec.begin(), rec.begin() + ptrdiff_t(kRecordHeaderSize));
  return rec;
}

void SnapshotStore::damaged(const StoredTile& e, const Error& error) const {
  std::fprintf(
      stderr,
      "loam: the snapshot store is damaged: %s: %s (check it with loam-server snapshot info --verify)\n",
      describe_entry(e).c_str(), error.describe().c_str());
  std::abort();
}

void SnapshotStore::read_coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const {
  const auto it = index_.find(TileCoord{Layer::kCoarse, uint8_t(mip), tx, ty});
  if (it == index_.end()) {
    damaged(StoredTile{kKindCoarse, uint8_t(mip), tx, ty},
            make_error(ErrorCode::kNotFound, "index", "the store does not hold this tile"));
  }
  const StoredTile& e = it->second;
  auto payload = read_payload(e);
  if (!payload) damaged(e, payload.error());
  auto samples = decode_region(*payload, kTileSize, kTileSize, {}, e.hash);
  if (!samples) damaged(e, samples.error());
  std::copy(samples->begin(), samples->end(), out.begin());
}

void SnapshotStore::read_detail_tile(int32_t tx, int32_t ty, std::span<int8_t> out) const {
  const auto it = index_.find(TileCoord{Layer::kDetail, 0, tx, ty});
  if (it == index_.end()) {
    damaged(StoredTile{kKindDetail, 0, tx, ty},
            make_error(ErrorCode::kNotFound, "index", "the store does not hold this tile"));
  }
  const StoredTile& e = it->second;
  if (e.size == 0) {
    std::fill(out.begin(), out.end(), int8_t{0});
    return;
  }
  auto payload = read_payload(e);
  if (!payload) damaged(e, payload.error());
  auto samples = decode_detail_region(*payload, kTileSize, kTileSize, {}, e.hash);
  if (!samples) damaged(e, samples.error());
  std::copy(samples->begin(), samples->end(), out.begin());
}

void SnapshotStore::recount_live() {
  for (auto& [n, f] : files_) f.live = 0;
  const auto add = [&](const StoredTile& e) { files_[e.file].live += kRecordHeaderSize + e.size; };
  for (const auto& [c, e] : index_)
    if (!(e.kind == kKindDetail && e.size == 0)) add(e);
  for (const auto& [id, e] : images_) add(e);
}

uint64_t SnapshotStore::file_bytes() const {
  uint64_t n = 0;
  for (const auto& [k, f] : files_) n += f.bytes;
  return n;
}

uint64_t SnapshotStore::live_bytes() const {
  uint64_t n = 0;
  for (const auto& [k, f] : files_) n += f.live;
  return n;
}

Result<LoadedSnapshot> SnapshotStore::load(const std::string& path, std::shared_ptr<const TileBase> base,
                                           bool verify_tiles) {
  auto manifest = read_snapshot_manifest(path);
  if (!manifest) return manifest.error();
  const std::string mpath = (fs::path(path) / "manifest.json").string();
  if (manifest->format != kSnapshotFormatIncremental)
    return make_error(ErrorCode::kUnsupported, mpath, "not an incremental snapshot");
  const std::string ipath = (fs::path(path) / "index.bin").string();
  std::ifstream in(ipath, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, ipath, "cannot open");
  const std::vector<uint8_t> bytes{std::istreambuf_iterator<char>(in), {}};
  if (bytes.size() != manifest->index_bytes)
    return make_error(ErrorCode::kCorrupt, ipath,
                      "size " + std::to_string(bytes.size()) + " does not match the manifest");
  auto parsed = parse_snapshot_index(bytes, manifest->world, ipath);
  if (!parsed) return parsed.error();

  // Every file the entries name must be one the manifest lists, present and long enough.
  std::map<uint64_t, FileInfo> files;
  for (const uint64_t n : manifest->tile_files) {
    const std::string tp = tiles_path(n);
    std::error_code ec;
    const uint64_t size = fs::file_size(tp, ec);
    if (ec) return make_error(ErrorCode::kNotFound, tp, "a tiles file the snapshot names is missing");
    if (size < kTilesHeaderSize + kTilesTrailerSize)
      return make_error(ErrorCode::kTruncated, tp, "shorter than a tiles file");
    files[n].bytes = size;
  }
  for (const std::vector<StoredTile>* list : {&parsed->tiles, &parsed->images}) {
    for (const StoredTile& e : *list) {
      if (e.kind == kKindDetail && e.size == 0) continue;
      const auto f = files.find(e.file);
      if (f == files.end())
        return make_error(ErrorCode::kCorrupt, ipath,
                          describe_entry(e) + " names a file the manifest does not");
      if (e.offset < kTilesHeaderSize || e.offset > f->second.bytes - kTilesTrailerSize ||
          f->second.bytes - kTilesTrailerSize - e.offset < kRecordHeaderSize + e.size)
        return make_error(ErrorCode::kCorrupt, ipath, describe_entry(e) + " lies outside its file");
    }
  }

  if (!base) base = std::make_shared<FillBase>(0);
  if (base->identity() != manifest->base_identity)
    return make_error(ErrorCode::kUnsupported, mpath,
                      "the snapshot edits the base '" + manifest->base_description +
                          "', not the session's base '" + base->describe() + "'");

  // The store now describes this snapshot.
  index_.clear();
  images_.clear();
  for (const auto& [n, fd] : fds_) ::close(fd);
  fds_.clear();
  files_ = std::move(files);
  for (const StoredTile& e : parsed->tiles) index_[TileCoord{Layer(e.kind), e.mip, e.tx, e.ty}] = e;
  for (const StoredTile& e : parsed->images) images_[e.hash] = e;
  recount_live();

  const auto fail = [&](const Error& e) -> Error {
    index_.clear();
    images_.clear();
    files_.clear();
    return e;
  };
  if (verify_tiles) {
    // Every record decodes to its hash, in file order (sequential reads).
    std::vector<const StoredTile*> order;
    for (const auto& [c, e] : index_)
      if (!(e.kind == kKindDetail && e.size == 0)) order.push_back(&e);
    std::sort(order.begin(), order.end(), [](const StoredTile* a, const StoredTile* b) {
      return a->file != b->file ? a->file < b->file : a->offset < b->offset;
    });
    for (const StoredTile* e : order) {
      auto payload = read_payload(*e);
      if (!payload) return fail(payload.error());
      std::optional<Error> bad;
      if (e->kind == kKindCoarse) {
        if (auto s = decode_region(*payload, kTileSize, kTileSize, {}, e->hash); !s) bad = s.error();
      } else if (auto s = decode_detail_region(*payload, kTileSize, kTileSize, {}, e->hash); !s) {
        bad = s.error();
      }
      if (bad)
        return fail(make_error(ErrorCode::kCorrupt, tiles_path(e->file),
                               describe_entry(*e) + ": " + bad->describe()));
    }
  }
  std::vector<StampTexture> textures;
  for (const auto& [id, e] : images_) {
    auto payload = read_payload(e);
    if (!payload) return fail(payload.error());
    StampTexture t;
    t.width = e.tx;
    t.height = e.ty;
    t.samples.resize(size_t(e.tx) * size_t(e.ty));
    for (size_t i = 0; i < t.samples.size(); ++i) t.samples[i] = load_le<uint16_t>(payload->data() + i * 2);
    t.id = texture_content_id(t.width, t.height, t.samples);
    if (t.id != id)
      return fail(
          make_error(ErrorCode::kCorrupt, tiles_path(e.file), "texture content does not match its id"));
    textures.push_back(std::move(t));
  }

  World world(manifest->world, std::move(base));
  world.set_edit_source(shared_from_this());
  for (const auto& [c, e] : index_) {
    if (!world.adopt_persisted(c, TileState{e.version, e.hash}, e.base_hash))
      return fail(make_error(ErrorCode::kCorrupt, ipath, describe_entry(e) + " is outside the world"));
  }
  world.set_initial_is_base(manifest->initial_is_base);
  if (world.world_hash() != manifest->world_hash)
    return fail(make_error(ErrorCode::kCorrupt, ipath, "world hash mismatch"));
  return LoadedSnapshot{*manifest, std::move(world), path, std::move(textures)};
}

// What one snapshot writes, captured on the owner's thread (begin), written on any thread
// (run: touches only the job and immutable tiles files), adopted on the owner's thread (finish).
struct SnapshotJob {
  std::string data_dir;
  uint64_t file = 0;  // the tiles file this snapshot writes
  SnapshotManifest manifest;
  // Tiles changed since the store's index, with their samples.
  struct Changed {
    StoredTile entry;
    std::vector<uint16_t> coarse;
    std::vector<int8_t> detail;  // empty: all zero
  };
  std::vector<Changed> changed;
  std::unordered_map<TileCoord, StoredTile, TileCoordHash> index;  // unchanged entries, then all
  std::map<uint64_t, StoredTile> images;                           // stored ones, then all
  std::vector<StampTexture> new_images;
  std::map<uint64_t, uint64_t> file_sizes;                // of the files the store's index names
  std::vector<std::pair<TileCoord, uint64_t>> persisted;  // (tile, version) clean once in place
  SnapshotWrite report;
  uint64_t tiles_file_bytes = 0;
  std::set<uint64_t> named;
};

SnapshotJobHandle::SnapshotJobHandle(std::unique_ptr<SnapshotJob> job) : job_(std::move(job)) {}
SnapshotJobHandle::SnapshotJobHandle(SnapshotJobHandle&&) noexcept = default;
SnapshotJobHandle& SnapshotJobHandle::operator=(SnapshotJobHandle&&) noexcept = default;
SnapshotJobHandle::~SnapshotJobHandle() {
  if (job_ && !done_) {
    // Never run or failed: no snapshot names its file.
    std::error_code ec;
    fs::remove(fs::path(snapshot_tiles_dir(job_->data_dir)) / snapshot_tiles_file_name(job_->file), ec);
  }
}

SnapshotJobHandle SnapshotStore::begin(const World& world, uint64_t last_seq, uint32_t next_segment_index,
                                       const TextureRegistry& textures, const SnapshotSession& session) {
  auto job = std::make_unique<SnapshotJob>();
  job->data_dir = data_dir_;
  job->file = next_file_++;
  job->report.last_seq = last_seq;
  SnapshotManifest& m = job->manifest;
  m.snapshot_id = m.last_seq = last_seq;
  m.world_hash = world.world_hash();
  m.next_segment_index = next_segment_index;
  m.world = world.params();
  m.base_identity = world.base().identity();
  m.base_description = world.base().describe();
  m.initial_is_base = world.initial_is_base();
  m.tick = session.tick;
  m.limits = session.limits;
  // Every edited tile this store does not hold at its state is copied out.
  for (const World::EditedTileInfo& t : world.edited_tiles()) {
    const auto it = index_.find(t.coord);
    if (it != index_.end() && it->second.version == t.state.version && it->second.hash == t.state.hash) {
      job->index.emplace(t.coord, it->second);
      if (!t.persisted) job->persisted.push_back({t.coord, t.state.version});
      continue;
    }
    const TileCoord& c = t.coord;
    SnapshotJob::Changed ch;
    ch.entry =
        StoredTile{uint8_t(c.layer), c.mip, c.tx, c.ty, t.state.version, t.state.hash, t.base_hash, 0, 0, 0};
    visit_layer(c.layer, [&](auto row) {
      using R = decltype(row);
      const auto samples = world.tile_samples<R>(c);
      samples_of<R>(ch).assign(samples.begin(), samples.end());
    });
    job->changed.push_back(std::move(ch));
    job->persisted.push_back({c, t.state.version});
  }
  job->images = images_;
  for (const StampTexture* t : textures.all())
    if (!images_.count(t->id)) job->new_images.push_back(*t);
  for (const auto& [n, f] : files_) job->file_sizes[n] = f.bytes;
  return SnapshotJobHandle(std::move(job));
}

namespace {

// The tiles file of a snapshot job, written on the storage's worker in phases: the header, the
// changed tiles, the new images, the compaction of sparse older files, and the trailer (record
// count and checksum), fsynced. Records go out in 4 MiB writes under a running checksum; every
// record written is indexed in the job.
class TilesFileWriter {
 public:
  TilesFileWriter(SnapshotJob& job, std::string dir, std::string path, int fd)
      : job_(job), report_(job.report), dir_(std::move(dir)), path_(std::move(path)), fd_(fd) {
    XXH3_64bits_reset(sum_);
  }
  TilesFileWriter(const TilesFileWriter&) = delete;
  TilesFileWriter& operator=(const TilesFileWriter&) = delete;
  ~TilesFileWriter() { XXH3_freeState(sum_); }

  // Every phase in order; the file stays open (close() after, whatever happened).
  Status write() {
    write_header();
    LOAM_TRY(write_changed());
    LOAM_TRY(write_images());
    LOAM_TRY(compact());
    return write_trailer();
  }
  // Closes the files read for compaction and the tiles file; an error when the close fails.
  Status close() {
    for (const auto& [n, rfd] : readers_) ::close(rfd);
    if (::close(fd_) != 0) return file_error(path_, "close failed");
    return {};
  }
  uint64_t bytes() const { return offset_; }

 private:
  void write_header() {
    buf_.resize(8);
    std::memcpy(buf_.data(), kTilesMagic, 8);
    append_le<uint32_t>(buf_, kTilesFormat);
    append_le<uint32_t>(buf_, 0);
  }

  Status write_changed() {
    for (const SnapshotJob::Changed& ch : job_.changed) {
      StoredTile e = ch.entry;
      const size_t before = buf_.size() + size_t(offset_);
      if (e.kind == kKindCoarse) {
        auto enc = encode_region(RegionEncoding::kFast, ch.coarse, kTileSize, kTileSize);
        if (!enc) return enc.error();
        LOAM_TRY(add(e, *enc));
        report_.tile_raw_bytes += kTileSamples * sizeof(uint16_t);
      } else {
        if (ch.detail.empty()) {
          e.size = 0;  // all zero: the index alone records its version
          e.file = 0;
          job_.index[TileCoord{Layer::kDetail, 0, e.tx, e.ty}] = e;
        } else {
          auto enc = encode_region(RegionEncoding::kFast, ch.detail, kTileSize, kTileSize);
          if (!enc) return enc.error();
          LOAM_TRY(add(e, *enc));
        }
        report_.tile_raw_bytes += kTileSamples;
      }
      report_.tile_bytes += buf_.size() + size_t(offset_) - before;
      ++report_.tiles_written;
    }
    return {};
  }

  Status write_images() {
    for (const StampTexture& t : job_.new_images) {
      std::vector<uint8_t> raw(t.samples.size() * 2);
      for (size_t i = 0; i < t.samples.size(); ++i) store_le<uint16_t>(raw.data() + i * 2, t.samples[i]);
      LOAM_TRY(add(StoredTile{kKindImage, 0, t.width, t.height, 0, t.id, 0, 0, 0, 0}, raw));
      ++report_.images_written;
    }
    return {};
  }

  // Compaction: live records of files at most half live move here, whole files at a time,
  // within a budget that keeps the whole write (tiles, moves, the index and the manifest)
  // within twice the changed tiles' bytes.
  Status compact() {
    std::map<uint64_t, uint64_t> live;
    for (const auto& [c, e] : job_.index)
      if (e.file != job_.file && !(e.kind == kKindDetail && e.size == 0))
        live[e.file] += kRecordHeaderSize + e.size;
    for (const auto& [id, e] : job_.images)
      if (e.file != job_.file) live[e.file] += kRecordHeaderSize + e.size;
    std::vector<std::pair<double, uint64_t>> sparse;  // live fraction, file
    for (const auto& [n, l] : live) {
      const auto f = job_.file_sizes.find(n);
      if (f != job_.file_sizes.end() && f->second > 0 && 2 * l <= f->second)
        sparse.push_back({double(l) / double(f->second), n});
    }
    std::sort(sparse.begin(), sparse.end());
    const uint64_t index_size =
        kIndexHeaderSize + job_.index.size() * kIndexEntrySize + job_.images.size() * kIndexImageSize + 8;
    const uint64_t overhead = index_size + 4096;
    uint64_t budget = report_.tile_bytes > overhead ? report_.tile_bytes - overhead : 0;
    for (const auto& [fraction, n] : sparse) {
      if (live[n] > budget) continue;
      budget -= live[n];
      std::vector<StoredTile> moving;
      for (const auto& [c, e] : job_.index)
        if (e.file == n && !(e.kind == kKindDetail && e.size == 0)) moving.push_back(e);
      for (const auto& [id, e] : job_.images)
        if (e.file == n) moving.push_back(e);
      std::sort(moving.begin(), moving.end(),
                [](const StoredTile& a, const StoredTile& b) { return a.offset < b.offset; });
      for (const StoredTile& e : moving) {
        auto payload = read_record(e);
        if (!payload) return payload.error();
        LOAM_TRY(add(e, *payload));
        report_.moved_bytes += kRecordHeaderSize + e.size;
        ++report_.records_moved;
      }
    }
    return {};
  }

  Status write_trailer() {
    LOAM_TRY(flush());
    append_le<uint64_t>(buf_, records_);
    XXH3_64bits_update(sum_, buf_.data(), buf_.size());
    append_le<uint64_t>(buf_, XXH3_64bits_digest(sum_));
    LOAM_TRY(write_exact(fd_, buf_, path_));
    offset_ += buf_.size();
    buf_.clear();
    if (::fsync(fd_) != 0) return file_error(path_, "fsync failed");
    return {};
  }

  // A record of a file read for compaction (opened here: the owner's descriptors are not
  // shared), checked against its index entry.
  Result<std::vector<uint8_t>> read_record(const StoredTile& e) {
    auto it = readers_.find(e.file);
    if (it == readers_.end()) {
      const std::string rp = (fs::path(dir_) / snapshot_tiles_file_name(e.file)).string();
      const int rfd = ::open(rp.c_str(), O_RDONLY | O_CLOEXEC);
      if (rfd < 0) return file_error(rp, "cannot open");
      it = readers_.emplace(e.file, rfd).first;
    }
    std::vector<uint8_t> rec(kRecordHeaderSize + e.size);
    LOAM_TRY(pread_exact(it->second, e.offset, rec, snapshot_tiles_file_name(e.file)));
    const uint8_t* h = rec.data();
    if (h[0] != e.kind || load_le<uint64_t>(h + 18) != e.hash || load_le<uint32_t>(h + 26) != e.size)
      return make_error(ErrorCode::kCorrupt, snapshot_tiles_file_name(e.file),
                        "the record at offset " + std::to_string(e.offset) + " is not " + describe_entry(e));
    rec.erase(rec.begin(), rec.begin() + ptrdiff_t(kRecordHeaderSize));
    return rec;
  }

  Status add(StoredTile e, std::span<const uint8_t> payload) {
    e.file = job_.file;
    e.offset = offset_ + buf_.size();
    e.size = uint32_t(payload.size());
    put_record_header(buf_, e.kind, e.mip, e.tx, e.ty, e.version, e.hash, e.size);
    buf_.insert(buf_.end(), payload.begin(), payload.end());
    ++records_;
    if (e.kind == kKindImage) {
      job_.images[e.hash] = e;
    } else {
      job_.index[TileCoord{Layer(e.kind), e.mip, e.tx, e.ty}] = e;
    }
    if (buf_.size() >= (size_t(4) << 20)) LOAM_TRY(flush());
    return {};
  }

  Status flush() {
    XXH3_64bits_update(sum_, buf_.data(), buf_.size());
    LOAM_TRY(write_exact(fd_, buf_, path_));
    offset_ += buf_.size();
    buf_.clear();
    return {};
  }

  SnapshotJob& job_;
  SnapshotWrite& report_;
  std::string dir_, path_;
  int fd_;
  std::map<uint64_t, int> readers_;
  uint64_t offset_ = 0, records_ = 0;
  XXH3_state_t* sum_ = XXH3_createState();
  std::vector<uint8_t> buf_;
};

// The index and the manifest of a written job, published together (write-then-rename).
struct Published {
  std::string path;
  size_t index_bytes = 0, index_entries = 0, manifest_bytes = 0;
};
Result<Published> publish_index_and_manifest(SnapshotJob& job, const std::string& dir) {
  SnapshotWrite& report = job.report;
  std::vector<StoredTile> entries;
  entries.reserve(job.index.size());
  for (const auto& [c, e] : job.index) entries.push_back(e);
  std::sort(entries.begin(), entries.end(), [](const StoredTile& a, const StoredTile& b) {
    return TileCoord{Layer(a.kind), a.mip, a.tx, a.ty} < TileCoord{Layer(b.kind), b.mip, b.tx, b.ty};
  });
  std::vector<StoredTile> image_entries;
  for (const auto& [id, e] : job.images) image_entries.push_back(e);
  const std::vector<uint8_t> index_bin = serialize_index(entries, image_entries);
  for (const StoredTile& e : entries)
    if (!(e.kind == kKindDetail && e.size == 0)) job.named.insert(e.file);
  for (const StoredTile& e : image_entries) job.named.insert(e.file);
  SnapshotManifest& m = job.manifest;
  m.created_unix_us = now_unix_us();
  for (const StoredTile& e : entries) {
    if (e.kind == kKindCoarse && e.mip == 0) ++m.coarse_tiles;  // mip-0 edits, as format 2 counted
    if (e.kind == kKindDetail && e.size != 0) ++m.detail_tiles;
  }
  m.tiles_bytes = job.tiles_file_bytes;
  nlohmann::json j = snapshot_io::manifest_json(m, kSnapshotFormatIncremental);
  j["index_bytes"] = index_bin.size();
  j["tile_files"] = std::vector<uint64_t>(job.named.begin(), job.named.end());
  j["written"] = {{"tiles", report.tiles_written},           {"tile_bytes", report.tile_bytes},
                  {"tile_raw_bytes", report.tile_raw_bytes}, {"images", report.images_written},
                  {"records_moved", report.records_moved},   {"moved_bytes", report.moved_bytes}};
  const std::string text = j.dump(1) + "\n";
  auto published = snapshot_io::publish(
      job.data_dir, m.last_seq,
      {{"index.bin", index_bin},
       {"manifest.json", std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size())}});
  if (!published) return published.error();
  LOAM_TRY(fsync_path(dir));
  return Published{*published, index_bin.size(), entries.size(), text.size()};
}

}  // namespace

Status SnapshotStore::run(SnapshotJobHandle& handle) {
  SnapshotJob& job = *handle.job_;
  const auto started = std::chrono::steady_clock::now();
  const std::string dir = snapshot_tiles_dir(job.data_dir);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return make_error(ErrorCode::kIo, dir, "cannot create: " + ec.message());
  const std::string path = (fs::path(dir) / snapshot_tiles_file_name(job.file)).string();
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return file_error(path, "cannot create");
  TilesFileWriter tiles(job, dir, path, fd);
  const Status body = tiles.write();
  const Status closed = tiles.close();
  if (!closed.ok() && body.ok()) return closed;
  LOAM_TRY(body);
  job.tiles_file_bytes = tiles.bytes();
  auto published = publish_index_and_manifest(job, dir);
  if (!published) return published.error();
  handle.done_ = true;  // in place: the tiles file is the snapshot's now
  SnapshotWrite& report = job.report;
  report.path = published->path;
  report.index_bytes = published->index_bytes;
  report.index_entries = published->index_entries;
  report.written_bytes = job.tiles_file_bytes + published->index_bytes + published->manifest_bytes;
  report.seconds = seconds_since(started);
  return {};
}

Result<SnapshotWrite> SnapshotStore::finish(World& world, SnapshotJobHandle handle) {
  SnapshotJob& job = *handle.job_;
  if (!handle.done_)
    return make_error(ErrorCode::kInvalidArgument, "snapshot", "the snapshot was not written");
  index_ = std::move(job.index);
  images_ = std::move(job.images);
  files_[job.file].bytes = job.tiles_file_bytes;
  for (auto it = files_.begin(); it != files_.end();)
    it = job.named.count(it->first) || it->first == job.file ? std::next(it) : files_.erase(it);
  recount_live();
  world.set_edit_source(shared_from_this());
  // Tiles changed since begin() have a newer version and stay dirty.
  for (const auto& [c, version] : job.persisted) world.mark_persisted(c, version);
  return job.report;
}

Result<SnapshotWrite> SnapshotStore::write(World& world, uint64_t last_seq, uint32_t next_segment_index,
                                           const TextureRegistry& textures, const SnapshotSession& session) {
  SnapshotJobHandle job = begin(world, last_seq, next_segment_index, textures, session);
  LOAM_TRY(run(job));
  return finish(world, std::move(job));
}

Result<PruneReport> SnapshotStore::prune(const RetentionPolicy& policy) {
  PruneReport report;
  const uint32_t keep = std::max<uint32_t>(1, policy.keep_snapshots);
  remove_partial_snapshots(data_dir_);
  const std::vector<std::string> all = list_snapshots(data_dir_);  // newest first
  std::set<uint64_t> named;
  std::error_code ec;
  size_t kept = 0;
  bool oldest_set = false;
  for (const std::string& path : all) {
    auto m = read_snapshot_manifest(path);
    if (kept < keep && m) {
      ++kept;
      named.insert(m->tile_files.begin(), m->tile_files.end());
      report.oldest_needed_segment = m->next_segment_index;
      oldest_set = true;
      continue;
    }
    if (kept < keep) continue;  // unreadable: not counted, and left for an operator to see
    uint64_t bytes = 0;
    for (const auto& e : fs::recursive_directory_iterator(path, ec))
      if (e.is_regular_file(ec)) bytes += e.file_size(ec);
    if (fs::remove_all(path, ec) > 0 && !ec) {
      ++report.snapshots_removed;
      report.bytes_freed += bytes;
    }
  }
  if (!oldest_set) report.oldest_needed_segment = 0;
  // Files no kept snapshot names (and that the current index does not use: a write between
  // a snapshot and its prune cannot leave one), including orphans of failed writes.
  for (const auto& [c, e] : index_) named.insert(e.file);
  for (const auto& [id, e] : images_) named.insert(e.file);
  for (const auto& [n, size] : list_tiles_files(snapshot_tiles_dir(data_dir_))) {
    if (named.count(n) || n >= next_file_) continue;
    if (const auto fd = fds_.find(n); fd != fds_.end()) {
      ::close(fd->second);
      fds_.erase(fd);
    }
    if (fs::remove(tiles_path(n), ec) && !ec) {
      ++report.tile_files_removed;
      report.bytes_freed += size;
    }
    files_.erase(n);
  }
  LOAM_TRY(fsync_path(snapshot_tiles_dir(data_dir_)));
  return report;
}

}  // namespace loam
