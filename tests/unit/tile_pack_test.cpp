// Tile packs (protocol/base/tile_pack.h) and the streamed import into them (dem/pack_import.h):
// the mip pyramid built from rows equals World's mips for any size and origin, a pack's tiles
// equal the whole-raster import's at every mip, a world on a pack stamps exactly like a world
// on the DEM, evicted tiles come back with the same hash, and a damaged, truncated or
// incomplete pack is an Error naming what is wrong, never terrain.
#include "protocol/base/tile_pack.h"

#include <gdal.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <vector>

#include "dem/dem_import.h"
#include "dem/gdal_errors.h"
#include "dem/pack_import.h"
#include "protocol/base/tile_row_pyramid.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/tile_hash.h"
#include "protocol/world.h"

namespace loam {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir() {
  const fs::path dir =
      fs::temp_directory_path() / ("loam_pack_test_" + std::to_string(::getpid()) + "_" +
                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A float32 TIFF of rough terrain (hills plus noise), with NaN holes when asked.
void write_tiff(const fs::path& path, int w, int h, uint32_t seed, bool holes, bool flat = false) {
  std::vector<float> px(size_t(w) * size_t(h));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> noise(-3.0f, 3.0f);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float v =
          flat ? 120.5f
               : 800.0f + 300.0f * std::sin(float(x) * 0.013f) * std::cos(float(y) * 0.021f) + noise(rng);
      if (holes && (x * 7 + y * 3) % 211 == 0) v = NAN;
      px[size_t(y) * size_t(w) + size_t(x)] = v;
    }
  }
  ensure_gdal_ready();
  // Striped, 16 rows a strip: the import reads whole strips.
  const char* options[] = {"BLOCKYSIZE=16", nullptr};
  GDALDatasetH ds = GDALCreate(GDALGetDriverByName("GTiff"), path.string().c_str(), w, h, 1, GDT_Float32,
                               const_cast<char**>(options));
  ASSERT_NE(ds, nullptr);
  ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Write, 0, 0, w, h, px.data(), w, h, GDT_Float32, 0, 0),
            CE_None);
  GDALClose(ds);
}

void expect_pack_equals_world(const TilePackBase& pack, const World& w) {
  ASSERT_EQ(pack.params().tiles_x, w.params().tiles_x);
  ASSERT_EQ(pack.params().tiles_y, w.params().tiles_y);
  std::vector<uint16_t> tile(kTileSamples);
  for (int32_t m = 0; m < w.params().mip_count(); ++m) {
    const RectI t = w.params().tile_range(m);
    for (int64_t ty = t.y0; ty < t.y1; ++ty) {
      for (int64_t tx = t.x0; tx < t.x1; ++tx) {
        ASSERT_TRUE(pack.read_tile(m, int32_t(tx), int32_t(ty), tile).ok());
        const auto expected = w.coarse_tile(m, int32_t(tx), int32_t(ty));
        ASSERT_TRUE(std::equal(tile.begin(), tile.end(), expected.begin(), expected.end()))
            << "mip " << m << " tile " << tx << "," << ty;
      }
    }
  }
}

World random_world(const WorldParams& p, uint32_t seed) {
  const RectI r = p.sample_rect();
  std::vector<uint16_t> samples(size_t(r.area()));
  std::mt19937 rng(seed);
  for (auto& v : samples) v = uint16_t(rng());
  auto w = World::from_samples(p, samples);
  EXPECT_TRUE(w.ok());
  return std::move(*w);
}

TEST(TileRowPyramid, TilesEqualTheWorldsMipsForOddSizesAndUnalignedOrigins) {
  // Origins not aligned to the coarser mips' tiles put the world's edge inside mip tiles on
  // every side, so the clamping at all four edges is exercised.
  for (const auto& [tiles_x, tiles_y, ox, oy] : std::vector<std::array<int32_t, 4>>{
           {1, 1, 0, 0}, {3, 5, 0, 0}, {5, 3, -1, 2}, {7, 2, 3, -5}, {2, 9, -7, 1}}) {
    WorldParams p;
    p.tiles_x = tiles_x;
    p.tiles_y = tiles_y;
    p.origin_tile_x = ox;
    p.origin_tile_y = oy;
    const World w = random_world(p, uint32_t(tiles_x * 31 + tiles_y));
    uint64_t tiles = 0;
    TileRowPyramid pyramid(p,
                           [&](int32_t mip, int32_t tx, int32_t ty, std::span<const uint16_t> s) -> Status {
                             const auto expected = w.coarse_tile(mip, tx, ty);
                             EXPECT_TRUE(std::equal(s.begin(), s.end(), expected.begin(), expected.end()))
                                 << tiles_x << "x" << tiles_y << " at " << ox << "," << oy << ": mip " << mip
                                 << " tile " << tx << "," << ty;
                             ++tiles;
                             return {};
                           });
    const RectI r = p.sample_rect();
    std::vector<uint16_t> row(size_t(r.width()));
    for (int64_t y = r.y0; y < r.y1; ++y) {
      w.read_coarse({r.x0, y, r.x1, y + 1}, row);
      ASSERT_TRUE(pyramid.add_row(row).ok());
    }
    EXPECT_TRUE(pyramid.done());
    EXPECT_EQ(tiles, pack_tile_count(p)) << "every tile of every mip, once";
    EXPECT_FALSE(pyramid.add_row(row).ok()) << "a row past the world's last is refused";
  }
}

TEST(PackImport, PackTilesEqualTheWholeRasterImportAtEveryMip) {
  const fs::path dir = temp_dir();
  struct Case {
    int w, h;
    bool holes, flat;
    int32_t ox, oy;
  };
  // Odd sizes (a partial tile on both axes), NoData holes, flat terrain, an unaligned origin.
  for (const Case& c : {Case{700, 300, true, false, 0, 0}, Case{257, 1031, false, false, -3, 5},
                        Case{300, 260, false, true, 0, 0}}) {
    const fs::path tif = dir / ("dem_" + std::to_string(c.w) + "x" + std::to_string(c.h) + ".tif");
    write_tiff(tif, c.w, c.h, uint32_t(c.w + c.h), c.holes, c.flat);
    ImportOptions options;
    options.origin_tile_x = c.ox;
    options.origin_tile_y = c.oy;
    auto dem = read_dem_file(tif.string());
    ASSERT_TRUE(dem.ok()) << dem.error().describe();
    auto whole = import_dem(*dem, options);
    ASSERT_TRUE(whole.ok()) << whole.error().describe();

    const fs::path pack_path = dir / (tif.stem().string() + kPackExtension);
    auto imported = import_dem_to_pack(tif.string(), pack_path.string(), {}, options);
    ASSERT_TRUE(imported.ok()) << imported.error().describe();
    EXPECT_FALSE(fs::exists(pack_path.string() + ".partial"));
    auto pack = open_tile_pack(pack_path.string());
    ASSERT_TRUE(pack.ok()) << pack.error().describe();
    EXPECT_TRUE((*pack)->params() == whole->world.params());
    expect_pack_equals_world(**pack, whole->world);
    EXPECT_TRUE((*pack)->verify().ok());
    EXPECT_EQ((*pack)->identity(), imported->pack.identity);

    const ImportReport& a = imported->import;
    const ImportReport& b = whole->report;
    EXPECT_EQ(a.min_m, b.min_m);
    EXPECT_EQ(a.max_m, b.max_m);
    EXPECT_EQ(a.nodata_count, b.nodata_count);
    EXPECT_EQ(a.nodata_interpolated, b.nodata_interpolated);
    if (c.holes) {
      EXPECT_GT(a.nodata_interpolated, 0);
    }
    EXPECT_EQ(a.apron_m, b.apron_m);
    EXPECT_EQ(a.max_error_m, b.max_error_m);
    EXPECT_DOUBLE_EQ(a.rms_error_m, b.rms_error_m);
    EXPECT_EQ(a.padded, b.padded);

    // Importing again writes the same identity (and refuses to overwrite).
    EXPECT_FALSE(import_dem_to_pack(tif.string(), pack_path.string(), {}, options).ok());
    const fs::path again = dir / (tif.stem().string() + "_again" + kPackExtension);
    auto second = import_dem_to_pack(tif.string(), again.string(), {}, options, RegionEncoding::kRaw);
    ASSERT_TRUE(second.ok());
    EXPECT_EQ(second->pack.identity, imported->pack.identity) << "the identity names samples, not encodings";
  }
}

TEST(PackImport, AWorldOnThePackStampsLikeTheWorldOnTheDemAndHashesItsBase) {
  const fs::path dir = temp_dir();
  write_tiff(dir / "d.tif", 600, 520, 7, false);
  auto dem = read_dem_file((dir / "d.tif").string());
  ASSERT_TRUE(dem.ok());
  auto whole = import_dem(*dem);
  ASSERT_TRUE(whole.ok());
  ASSERT_TRUE(import_dem_to_pack((dir / "d.tif").string(), (dir / "d.loampack").string()).ok());
  auto pack = open_tile_pack((dir / "d.loampack").string());
  ASSERT_TRUE(pack.ok());
  World on_pack((*pack)->params(), *pack);
  World& dense = whole->world;
  EXPECT_EQ(on_pack.edited_coarse_tile_count(), 0u);
  const uint64_t untouched = on_pack.world_hash();
  for (const auto& [x, y, r, i] :
       std::vector<std::array<int64_t, 4>>{{256, 256, 40, -300}, {590, 10, 30, 200}}) {
    QuantizedStamp q;
    q.kind = StampKind::kCrater;
    q.center_x = x * 256;
    q.center_y = y * 256;
    q.radius = uint32_t(r * 256);
    q.intensity = int32_t(i * 256);
    q.shape = 20000;
    ASSERT_TRUE(apply_stamp(on_pack, q).ok());
    ASSERT_TRUE(apply_stamp(dense, q).ok());
  }
  on_pack.commit(1);
  dense.commit(1);
  for (int32_t m = 0; m < dense.params().mip_count(); ++m) {
    const RectI t = dense.params().tile_range(m);
    for (int64_t ty = t.y0; ty < t.y1; ++ty) {
      for (int64_t tx = t.x0; tx < t.x1; ++tx) {
        const TileCoord c{Layer::kCoarse, uint8_t(m), int32_t(tx), int32_t(ty)};
        EXPECT_EQ(on_pack.tile_state(c).hash, dense.tile_state(c).hash)
            << "mip " << m << " " << tx << "," << ty;
      }
    }
  }
  EXPECT_NE(on_pack.world_hash(), untouched);
  EXPECT_LE(on_pack.edited_coarse_tile_count(), 8u) << "only the stamped tiles and their mips are held";
}

TEST(TilePack, ATileEvictedAndReadAgainHashesTheSame) {
  const fs::path dir = temp_dir();
  write_tiff(dir / "e.tif", 800, 800, 3, true);
  ASSERT_TRUE(import_dem_to_pack((dir / "e.tif").string(), (dir / "e.loampack").string()).ok());
  auto pack = open_tile_pack((dir / "e.loampack").string());
  ASSERT_TRUE(pack.ok());
  World w((*pack)->params(), *pack);
  w.set_base_cache_budget(size_t(2) * kTileSamples * sizeof(uint16_t));
  std::vector<uint64_t> first;
  const RectI t = w.params().tile_range(0);
  for (int64_t ty = t.y0; ty < t.y1; ++ty)
    for (int64_t tx = t.x0; tx < t.x1; ++tx)
      first.push_back(hash_coarse_tile(w.coarse_tile(0, int32_t(tx), int32_t(ty))));
  w.trim_base_cache();
  EXPECT_LE(w.base_cache_bytes(), w.base_cache_budget());
  const uint64_t read = w.base_tiles_generated();
  size_t i = 0;
  for (int64_t ty = t.y0; ty < t.y1; ++ty) {
    for (int64_t tx = t.x0; tx < t.x1; ++tx) {
      EXPECT_EQ(hash_coarse_tile(w.coarse_tile(0, int32_t(tx), int32_t(ty))), first[i++]);
      w.trim_base_cache();
    }
  }
  EXPECT_GT(w.base_tiles_generated(), read) << "evicted tiles were read from the pack again";
}

std::vector<uint8_t> read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}
void write_file(const fs::path& p, const std::vector<uint8_t>& b) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(b.data()), std::streamsize(b.size()));
}

TEST(TilePack, DamageTruncationAndForeignFilesAreErrorsNamingWhat) {
  const fs::path dir = temp_dir();
  write_tiff(dir / "f.tif", 300, 300, 11, false);
  const fs::path good = dir / "f.loampack";
  ASSERT_TRUE(import_dem_to_pack((dir / "f.tif").string(), good.string()).ok());
  const std::vector<uint8_t> bytes = read_file(good);
  auto pack = open_tile_pack(good.string());
  ASSERT_TRUE(pack.ok());
  const uint64_t index_at = kPackHeaderSize + (*pack)->summary().payload_bytes;

  const fs::path bad = dir / "bad.loampack";
  auto open_error = [&](const std::vector<uint8_t>& b) {
    write_file(bad, b);
    auto r = open_tile_pack(bad.string());
    return r.ok() ? std::string() : r.error().describe();
  };
  EXPECT_NE(open_error({}).find("shorter than a tile pack header"), std::string::npos);
  auto flipped = [&](size_t at) {
    std::vector<uint8_t> b = bytes;
    b[at] ^= 0x10;
    return b;
  };
  EXPECT_NE(open_error(flipped(0)).find("bad magic"), std::string::npos);
  EXPECT_NE(open_error(flipped(20)).find("header checksum"), std::string::npos);
  EXPECT_NE(open_error(flipped(size_t(index_at) + 3)).find("index checksum"), std::string::npos);
  // Every prefix shorter than the file is refused (the index must end the file).
  for (size_t cut : {size_t(kPackHeaderSize), size_t(index_at), bytes.size() - 1}) {
    EXPECT_FALSE(open_error(std::vector<uint8_t>(bytes.begin(), bytes.begin() + ptrdiff_t(cut))).empty())
        << cut;
  }
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  EXPECT_NE(open_error(longer).find("does not end the file"), std::string::npos);
  EXPECT_EQ(open_tile_pack((dir / "missing.loampack").string()).error().code, ErrorCode::kNotFound);

  // A flipped payload byte opens (the index is intact) but the tile's read is an Error.
  write_file(bad, flipped(kPackHeaderSize + 40));
  auto damaged = open_tile_pack(bad.string());
  ASSERT_TRUE(damaged.ok()) << damaged.error().describe();
  const Status verified = (*damaged)->verify();
  ASSERT_FALSE(verified.ok());
  EXPECT_NE(verified.error().describe().find("tile (mip"), std::string::npos) << verified.error().describe();
}

TEST(TilePackWriter, AnIncompletePackIsAnErrorAndLeavesNoFile) {
  const fs::path dir = temp_dir();
  WorldParams p;
  p.tiles_x = 2;
  p.tiles_y = 1;
  const fs::path path = dir / "incomplete.loampack";
  {
    auto w = TilePackWriter::create(path.string(), p);
    ASSERT_TRUE(w.ok());
    std::vector<uint16_t> tile(kTileSamples, 7);
    ASSERT_TRUE(w->add(0, 0, 0, tile).ok());
    EXPECT_FALSE(w->add(0, 0, 0, tile).ok()) << "a tile twice";
    EXPECT_FALSE(w->add(0, 5, 0, tile).ok()) << "a tile outside the world";
    EXPECT_FALSE(w->add(0, 1, 0, std::vector<uint16_t>(10)).ok()) << "a short tile";
    auto done = w->finish();
    ASSERT_FALSE(done.ok());
    EXPECT_NE(done.error().describe().find("never added"), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(fs::exists(path.string() + ".partial"));
}

}  // namespace
}  // namespace loam
