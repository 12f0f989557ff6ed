#include "protocol/base/tile_pack.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "protocol/byte_order.h"
#include "protocol/file_io.h"
#include "protocol/tile_hash.h"

namespace loam {
namespace {

constexpr char kMagic[8] = {'L', 'O', 'A', 'M', 'P', 'A', 'C', 'K'};
constexpr uint64_t kIdentityTag = 0x6b6361706d616f6cull;  // "loampack"
// The largest payload a 256 x 256 coarse tile can have: raw samples plus the header.
constexpr uint32_t kMaxTilePayload = uint32_t(kRegionHeaderSize + kTileSamples * 2 + 64);
// Header fields (byte offsets).
constexpr size_t kParamsAt = 16, kParamsEnd = 72, kTileCountAt = 72, kIndexAt = 80, kIdentityAt = 88,
                 kChecksumAt = 120;

Error io_error(const std::string& path, const std::string& what) { return file_error(path, what); }

uint64_t f64_bits(double v) {
  uint64_t u;
  std::memcpy(&u, &v, sizeof u);
  return u;
}
double bits_f64(uint64_t u) {
  double v;
  std::memcpy(&v, &u, sizeof v);
  return v;
}

void put_params(uint8_t* h, const WorldParams& p) {
  store_le<uint64_t>(h + 16, f64_bits(p.meters_per_sample));
  store_le<uint64_t>(h + 24, f64_bits(p.height_offset));
  store_le<uint64_t>(h + 32, f64_bits(p.meters_per_unit));
  store_le<int32_t>(h + 40, p.detail_factor);
  store_le<int32_t>(h + 44, p.origin_tile_x);
  store_le<int32_t>(h + 48, p.origin_tile_y);
  store_le<int32_t>(h + 52, p.tiles_x);
  store_le<int32_t>(h + 56, p.tiles_y);
  store_le<uint32_t>(h + 60, uint32_t(p.mip_count()));
  store_le<uint64_t>(h + 64, f64_bits(p.detail_meters_per_unit));
}

WorldParams get_params(const uint8_t* h) {
  WorldParams p;
  p.meters_per_sample = bits_f64(load_le<uint64_t>(h + 16));
  p.height_offset = bits_f64(load_le<uint64_t>(h + 24));
  p.meters_per_unit = bits_f64(load_le<uint64_t>(h + 32));
  p.detail_factor = load_le<int32_t>(h + 40);
  p.origin_tile_x = load_le<int32_t>(h + 44);
  p.origin_tile_y = load_le<int32_t>(h + 48);
  p.tiles_x = load_le<int32_t>(h + 52);
  p.tiles_y = load_le<int32_t>(h + 56);
  p.detail_meters_per_unit = bits_f64(load_le<uint64_t>(h + 64));
  return p;
}

// The identity: the parameters' header bytes and every tile hash in canonical order.
uint64_t pack_identity(const uint8_t* header, std::span<const uint64_t> hashes) {
  std::vector<uint8_t> record;
  record.reserve(8 + (kParamsEnd - kParamsAt) + hashes.size() * 8);
  record.resize(8);
  store_le<uint64_t>(record.data(), kIdentityTag);
  record.insert(record.end(), header + kParamsAt, header + kParamsEnd);
  for (const uint64_t h : hashes) {
    const size_t at = record.size();
    record.resize(at + 8);
    store_le<uint64_t>(record.data() + at, h);
  }
  return XXH3_64bits(record.data(), record.size());
}

}  // namespace

uint64_t pack_tile_count(const WorldParams& p) {
  uint64_t n = 0;
  for (int32_t m = 0; m < p.mip_count(); ++m) n += uint64_t(p.tile_range(m).area());
  return n;
}

std::optional<uint64_t> pack_tile_index(const WorldParams& p, int32_t mip, int32_t tx, int32_t ty) {
  if (mip < 0 || mip >= p.mip_count()) return std::nullopt;
  uint64_t at = 0;
  for (int32_t m = 0; m < mip; ++m) at += uint64_t(p.tile_range(m).area());
  const RectI r = p.tile_range(mip);
  if (!r.contains(tx, ty)) return std::nullopt;
  return at + uint64_t((ty - r.y0) * r.width() + (tx - r.x0));
}

// --- Reading ---

TilePackBase::~TilePackBase() {
  if (fd_ >= 0) ::close(fd_);
}

std::string TilePackBase::describe() const {
  char buf[96];
  std::snprintf(buf, sizeof buf, "pack %016llx (%dx%d tiles)", (unsigned long long)summary_.identity,
                summary_.params.tiles_x, summary_.params.tiles_y);
  return buf;
}

Status TilePackBase::read_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const {
  const std::string tile =
      "tile (mip " + std::to_string(mip) + ", " + std::to_string(tx) + ", " + std::to_string(ty) + ")";
  const auto at = pack_tile_index(summary_.params, mip, tx, ty);
  if (!at) return make_error(ErrorCode::kNotFound, summary_.path, tile + " is outside the world");
  if (out.size() != size_t(kTileSamples))
    return make_error(ErrorCode::kInvalidArgument, "out", "a tile is 256 x 256 samples");
  const Entry& e = index_[size_t(*at)];
  std::vector<uint8_t> payload(e.size);
  LOAM_TRY(pread_exact(fd_, e.offset, payload, summary_.path));
  auto samples = decode_region(payload, kTileSize, kTileSize, {}, e.hash);
  if (!samples) {
    return make_error(samples.error().code, summary_.path, tile + ": " + samples.error().describe());
  }
  std::copy(samples->begin(), samples->end(), out.begin());
  return {};
}

void TilePackBase::coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const {
  if (const Status st = read_tile(mip, tx, ty, out); !st.ok()) {
    // A base cannot answer "unknown" (World reads never fail): serving made-up terrain would
    // diverge every client, so a pack damaged since it was opened stops the process.
    std::fprintf(stderr, "loam: the base terrain is damaged: %s (check it with loam-server pack verify)\n",
                 st.error().describe().c_str());
    std::abort();
  }
}

Status TilePackBase::verify() const {
  std::vector<uint16_t> tile(kTileSamples);
  const WorldParams& p = summary_.params;
  for (int32_t m = 0; m < p.mip_count(); ++m) {
    const RectI r = p.tile_range(m);
    for (int32_t ty = int32_t(r.y0); ty < r.y1; ++ty) {
      for (int32_t tx = int32_t(r.x0); tx < r.x1; ++tx) LOAM_TRY(read_tile(m, tx, ty, tile));
    }
  }
  return {};
}

Result<std::shared_ptr<const TilePackBase>> open_tile_pack(const std::string& path) {
  std::shared_ptr<TilePackBase> pack(new TilePackBase());
  pack->fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (pack->fd_ < 0) {
    if (errno == ENOENT) return make_error(ErrorCode::kNotFound, path, "no such tile pack");
    return io_error(path, "cannot open the tile pack");
  }
  struct stat st {};
  if (::fstat(pack->fd_, &st) != 0) return io_error(path, "cannot stat the tile pack");
  const uint64_t file_size = uint64_t(st.st_size);
  if (file_size < kPackHeaderSize)
    return make_error(ErrorCode::kTruncated, path, "shorter than a tile pack header");

  uint8_t h[kPackHeaderSize];
  LOAM_TRY(pread_exact(pack->fd_, 0, h, path));
  if (std::memcmp(h, kMagic, sizeof kMagic) != 0)
    return make_error(ErrorCode::kCorrupt, path, "not a tile pack (bad magic)");
  const uint32_t format = load_le<uint32_t>(h + 8);
  if (format != kPackFormat)
    return make_error(ErrorCode::kUnsupported, path,
                      "tile pack format " + std::to_string(format) + " (this build reads format " +
                          std::to_string(kPackFormat) + ")");
  if (load_le<uint32_t>(h + 12) != kPackHeaderSize)
    return make_error(ErrorCode::kCorrupt, path, "header size is not " + std::to_string(kPackHeaderSize));
  if (XXH3_64bits(h, kChecksumAt) != load_le<uint64_t>(h + kChecksumAt))
    return make_error(ErrorCode::kCorrupt, path, "header checksum mismatch");

  PackSummary& s = pack->summary_;
  s.path = path;
  s.params = get_params(h);
  if (const Status v = s.params.validate(); !v.ok())
    return make_error(ErrorCode::kCorrupt, path, "world parameters: " + v.error().describe());
  if (load_le<uint32_t>(h + 60) != uint32_t(s.params.mip_count()))
    return make_error(ErrorCode::kCorrupt, path, "mip count does not match the world's size");
  s.tiles = load_le<uint64_t>(h + kTileCountAt);
  if (s.tiles != pack_tile_count(s.params))
    return make_error(ErrorCode::kCorrupt, path, "tile count does not match the world's size");
  const uint64_t index_at = load_le<uint64_t>(h + kIndexAt);
  const uint64_t index_bytes = s.tiles * kPackIndexEntrySize;
  if (index_at < kPackHeaderSize || index_at > file_size || file_size - index_at != index_bytes + 8)
    return make_error(ErrorCode::kCorrupt, path,
                      "the index does not end the file (truncated or extended pack)");
  s.file_bytes = file_size;
  s.payload_bytes = index_at - kPackHeaderSize;

  std::vector<uint8_t> index(size_t(index_bytes + 8));
  LOAM_TRY(pread_exact(pack->fd_, index_at, index, path));
  if (XXH3_64bits(index.data(), size_t(index_bytes)) != load_le<uint64_t>(index.data() + index_bytes))
    return make_error(ErrorCode::kCorrupt, path, "index checksum mismatch");
  pack->index_.resize(size_t(s.tiles));
  std::vector<uint64_t> hashes(size_t(s.tiles));
  for (size_t i = 0; i < pack->index_.size(); ++i) {
    const uint8_t* e = index.data() + i * kPackIndexEntrySize;
    TilePackBase::Entry& entry = pack->index_[i];
    entry.offset = load_le<uint64_t>(e);
    entry.size = load_le<uint32_t>(e + 8);
    entry.hash = load_le<uint64_t>(e + 12);
    hashes[i] = entry.hash;
    if (entry.size < kRegionHeaderSize || entry.size > kMaxTilePayload || entry.offset < kPackHeaderSize ||
        entry.offset > index_at || index_at - entry.offset < entry.size)
      return make_error(ErrorCode::kCorrupt, path,
                        "index entry " + std::to_string(i) + " lies outside the payloads");
  }
  s.identity = load_le<uint64_t>(h + kIdentityAt);
  if (pack_identity(h, hashes) != s.identity)
    return make_error(ErrorCode::kCorrupt, path, "the identity does not match the tiles it names");
  return std::shared_ptr<const TilePackBase>(std::move(pack));
}

// --- Writing ---

Result<TilePackWriter> TilePackWriter::create(const std::string& path, const WorldParams& params,
                                              RegionEncoding encoding) {
  LOAM_TRY(params.validate());
  if (encoding != RegionEncoding::kFast && encoding != RegionEncoding::kBest &&
      encoding != RegionEncoding::kRaw)
    return make_error(ErrorCode::kInvalidArgument, "encoding", "a pack stores tiles as raw, fast or best");
  TilePackWriter w;
  w.path_ = path;
  w.partial_ = path + ".partial";
  w.params_ = params;
  w.encoding_ = encoding;
  const uint64_t n = pack_tile_count(params);
  w.offsets_.assign(size_t(n), 0);
  w.sizes_.assign(size_t(n), 0);
  w.hashes_.assign(size_t(n), 0);
  w.fd_ = ::open(w.partial_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (w.fd_ < 0) return io_error(w.partial_, "cannot create");
  w.offset_ = kPackHeaderSize;  // the header is written last
  return w;
}

TilePackWriter::TilePackWriter(TilePackWriter&& o) noexcept
    : path_(std::move(o.path_)),
      partial_(std::move(o.partial_)),
      params_(o.params_),
      encoding_(o.encoding_),
      fd_(o.fd_),
      offset_(o.offset_),
      added_(o.added_),
      offsets_(std::move(o.offsets_)),
      sizes_(std::move(o.sizes_)),
      hashes_(std::move(o.hashes_)),
      finished_(o.finished_) {
  o.fd_ = -1;
  o.finished_ = true;
}

TilePackWriter::~TilePackWriter() {
  if (fd_ >= 0) ::close(fd_);
  if (!finished_ && !partial_.empty()) {
    std::error_code ec;
    std::filesystem::remove(partial_, ec);
  }
}

Status TilePackWriter::write_at(uint64_t offset, std::span<const uint8_t> bytes) {
  return pwrite_exact(fd_, offset, bytes, partial_);
}

Status TilePackWriter::add(int32_t mip, int32_t tx, int32_t ty, std::span<const uint16_t> samples) {
  if (fd_ < 0 || finished_) return make_error(ErrorCode::kInvalidArgument, path_, "the pack is closed");
  const auto at = pack_tile_index(params_, mip, tx, ty);
  if (!at) return make_error(ErrorCode::kInvalidArgument, path_, "tile outside the world's tile range");
  if (samples.size() != size_t(kTileSamples))
    return make_error(ErrorCode::kInvalidArgument, path_, "a tile is 256 x 256 samples");
  if (sizes_[size_t(*at)] != 0) return make_error(ErrorCode::kInvalidArgument, path_, "tile added twice");
  auto payload = encode_region(encoding_, samples, kTileSize, kTileSize);
  if (!payload) return payload.error();
  LOAM_TRY(write_at(offset_, *payload));
  offsets_[size_t(*at)] = offset_;
  sizes_[size_t(*at)] = uint32_t(payload->size());
  hashes_[size_t(*at)] = hash_coarse_tile(samples);
  offset_ += payload->size();
  ++added_;
  return {};
}

Result<PackSummary> TilePackWriter::finish() {
  if (fd_ < 0 || finished_) return make_error(ErrorCode::kInvalidArgument, path_, "the pack is closed");
  if (added_ != sizes_.size())
    return make_error(ErrorCode::kInvalidArgument, path_,
                      std::to_string(sizes_.size() - added_) + " of " + std::to_string(sizes_.size()) +
                          " tiles were never added");
  std::vector<uint8_t> index(sizes_.size() * kPackIndexEntrySize + 8);
  for (size_t i = 0; i < sizes_.size(); ++i) {
    uint8_t* e = index.data() + i * kPackIndexEntrySize;
    store_le<uint64_t>(e, offsets_[i]);
    store_le<uint32_t>(e + 8, sizes_[i]);
    store_le<uint64_t>(e + 12, hashes_[i]);
  }
  const size_t index_bytes = index.size() - 8;
  store_le<uint64_t>(index.data() + index_bytes, XXH3_64bits(index.data(), index_bytes));
  const uint64_t index_at = offset_;
  LOAM_TRY(write_at(index_at, index));

  uint8_t h[kPackHeaderSize] = {};
  std::memcpy(h, kMagic, sizeof kMagic);
  store_le<uint32_t>(h + 8, kPackFormat);
  store_le<uint32_t>(h + 12, uint32_t(kPackHeaderSize));
  put_params(h, params_);
  store_le<uint64_t>(h + kTileCountAt, uint64_t(sizes_.size()));
  store_le<uint64_t>(h + kIndexAt, index_at);
  const uint64_t identity = pack_identity(h, hashes_);
  store_le<uint64_t>(h + kIdentityAt, identity);
  store_le<uint64_t>(h + kChecksumAt, XXH3_64bits(h, kChecksumAt));
  LOAM_TRY(write_at(0, h));
  if (::fsync(fd_) != 0) return io_error(partial_, "fsync failed");
  if (::close(fd_) != 0) {
    fd_ = -1;
    return io_error(partial_, "close failed");
  }
  fd_ = -1;
  std::error_code ec;
  std::filesystem::rename(partial_, path_, ec);
  if (ec) return make_error(ErrorCode::kIo, path_, "rename failed: " + ec.message());
  // The rename is durable once the folder is.
  const std::filesystem::path dir = std::filesystem::absolute(path_, ec).parent_path();
  if (const int dfd = ::open(dir.c_str(), O_RDONLY | O_CLOEXEC); dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  finished_ = true;

  PackSummary s;
  s.path = path_;
  s.params = params_;
  s.identity = identity;
  s.tiles = sizes_.size();
  s.file_bytes = index_at + index.size();
  s.payload_bytes = index_at - kPackHeaderSize;
  return s;
}

}  // namespace loam
