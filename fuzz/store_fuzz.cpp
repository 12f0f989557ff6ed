// Fuzzes the readers of a world's stored tiles, which read files an operator may copy around or
// a disk may damage: a snapshot index (parse_snapshot_index) against a fixed world, and a tile
// pack (open_tile_pack, then every tile read) from a memory file. Neither may crash, over-read
// or allocate without bound; whatever a pack opens with must read back or be an Error.
// Seeds (corpus/store_fuzz/): pack_one_tile is `loam-server import --pack` of a 24 x 20 window
// of the shared jacksboro DEM (gdal_translate -srcwin 100 100 24 20); index_crop_world is the
// index.bin of a snapshot of the embedded crop after 30 `loam-client bot` stamps.
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include "protocol/base/tile_pack.h"
#include "protocol/snapshot/snapshot_store.h"

namespace {

loam::WorldParams world() {
  loam::WorldParams p;
  p.tiles_x = 4;
  p.tiles_y = 3;
  return p;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  (void)loam::parse_snapshot_index(bytes, world(), "index.bin");

  const int fd = memfd_create("pack", 0);
  if (fd < 0) return 0;
  if (size > 0 && ::write(fd, data, size) != ssize_t(size)) {
    ::close(fd);
    return 0;
  }
  const std::string path = "/proc/self/fd/" + std::to_string(fd);
  if (auto pack = loam::open_tile_pack(path)) {
    std::vector<uint16_t> tile(loam::kTileSamples);
    const loam::WorldParams& p = (*pack)->params();
    int reads = 0;
    for (int32_t m = 0; m < p.mip_count() && reads < 64; ++m) {
      const loam::RectI r = p.tile_range(m);
      for (int64_t ty = r.y0; ty < r.y1 && reads < 64; ++ty)
        for (int64_t tx = r.x0; tx < r.x1 && reads < 64; ++tx, ++reads)
          (void)(*pack)->read_tile(m, int32_t(tx), int32_t(ty), tile);
    }
  }
  ::close(fd);
  return 0;
}
