// Tile packs: an imported DEM as a read-only base (tile_base.h), stored tile by tile so a
// server holds only the tiles it reads. A pack has every coarse tile of every mip as a region
// codec payload, an index, and a content hash that is the base's identity: sessions name their
// base by it, and the world hash covers it instead of every untouched tile. The server's
// importer writes packs in bounded memory from a DEM of any size (dem/pack_import.h); the
// server and the file tools read them. docs/world.md ("Tile packs") gives the byte layout.
//
// Layout (little-endian):
//   header (kPackHeaderSize bytes): magic "LOAMPACK", format, the world's parameters, mip
//     count, tile count, index offset, identity, XXH3-64 of the header bytes before it;
//   payloads, back to back, in the order they were written;
//   index at index offset: one entry per tile in canonical order (mip, then ty, then tx over
//     the mip's tile range): payload offset (u64), size (u32) and the samples' hash (u64);
//     then an XXH3-64 of the index bytes.
// The identity is an XXH3-64 of the parameters and every tile hash in canonical order, so it
// names the samples, not the encoding they were stored with.
//
// Safe on untrusted input: open_tile_pack() checks the header checksum, the parameters, the
// tile count against them, the file size, the index checksum, every entry's payload range
// and the identity before any tile is read; each tile read decodes under the region codec's
// bounds checks and its hash is compared. TileBase reads cannot fail, so a tile damaged after
// the pack was opened stops the process with a message naming the pack and the tile, rather
// than serving wrong terrain (verify() checks every tile up front; `loam-server pack verify`).
// A pack is immutable once written and safe to read from any number of threads.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "protocol/base/tile_base.h"
#include "protocol/codec/region_codec.h"
#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam {

inline constexpr uint32_t kPackFormat = 1;
inline constexpr size_t kPackHeaderSize = 128;
inline constexpr size_t kPackIndexEntrySize = 20;
inline constexpr const char* kPackExtension = ".loampack";

// Tiles of every coarse mip of a world: the pack's entry count.
uint64_t pack_tile_count(const WorldParams& p);
// Position of a tile in the canonical order, or nullopt outside the world's tile ranges.
std::optional<uint64_t> pack_tile_index(const WorldParams& p, int32_t mip, int32_t tx, int32_t ty);

struct PackSummary {
  std::string path;
  WorldParams params;
  uint64_t identity = 0;
  uint64_t tiles = 0;
  uint64_t file_bytes = 0;
  uint64_t payload_bytes = 0;
};

class TilePackBase final : public TileBase {
 public:
  ~TilePackBase() override;
  void coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const override;
  uint64_t identity() const override { return summary_.identity; }
  std::string describe() const override;

  const WorldParams& params() const { return summary_.params; }
  const PackSummary& summary() const { return summary_; }
  // Reads and checks one tile: a damaged payload is an Error naming the tile.
  Status read_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const;
  // Reads and checks every tile (a full pass over the file).
  Status verify() const;

 private:
  friend Result<std::shared_ptr<const TilePackBase>> open_tile_pack(const std::string& path);
  struct Entry {
    uint64_t offset = 0;
    uint32_t size = 0;
    uint64_t hash = 0;
  };
  TilePackBase() = default;
  int fd_ = -1;
  PackSummary summary_;
  std::vector<Entry> index_;
};

// Opens a pack and checks everything but the payloads (see above).
Result<std::shared_ptr<const TilePackBase>> open_tile_pack(const std::string& path);

// Writes a pack: tiles in any order, each exactly once, then finish(). The file is written
// as PATH.partial, fsynced and renamed into place only when complete, so a failed or
// interrupted import leaves no pack behind. Memory: the index (20 bytes a tile), not the tiles.
class TilePackWriter {
 public:
  static Result<TilePackWriter> create(const std::string& path, const WorldParams& params,
                                       RegionEncoding encoding = RegionEncoding::kFast);
  TilePackWriter(TilePackWriter&& o) noexcept;
  TilePackWriter& operator=(TilePackWriter&&) = delete;
  ~TilePackWriter();

  // Encodes and appends one tile (kTileSamples samples) of the world's tile range at `mip`.
  Status add(int32_t mip, int32_t tx, int32_t ty, std::span<const uint16_t> samples);
  uint64_t tiles_added() const { return added_; }
  uint64_t bytes_written() const { return offset_; }
  // Every tile must have been added. Writes the index and header, fsyncs and renames.
  Result<PackSummary> finish();

 private:
  TilePackWriter() = default;
  Status write_at(uint64_t offset, std::span<const uint8_t> bytes);
  std::string path_, partial_;
  WorldParams params_;
  RegionEncoding encoding_ = RegionEncoding::kFast;
  int fd_ = -1;
  uint64_t offset_ = 0;
  uint64_t added_ = 0;
  std::vector<uint64_t> offsets_;
  std::vector<uint32_t> sizes_;  // 0: not added yet
  std::vector<uint64_t> hashes_;
  bool finished_ = false;
};

}  // namespace loam
