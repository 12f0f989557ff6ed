// The layer table (protocol/layer.h): each row says what the code used to spell out per
// layer, and a third layer is one more row that the generic code takes as it is.
#include "protocol/layer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <span>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "protocol/sparse_tiles.h"

namespace loam {
namespace {

WorldParams world() {
  WorldParams p;
  p.origin_tile_x = -3;
  p.origin_tile_y = 5;
  p.tiles_x = 7;
  p.tiles_y = 3;
  p.meters_per_sample = 2.0;
  p.detail_factor = 4;
  return p;
}

TEST(LayerTable, TheRowsSayWhatWorldParamsSaysOfEachLayer) {
  const WorldParams p = world();
  EXPECT_EQ(layer_sample_rect(p, Layer::kCoarse), p.sample_rect());
  EXPECT_EQ(layer_sample_rect(p, Layer::kDetail), p.detail_sample_rect());
  EXPECT_EQ(layer_meters_per_sample(p, Layer::kCoarse), p.meters_per_sample);
  EXPECT_EQ(layer_meters_per_sample(p, Layer::kDetail), p.detail_meters_per_sample());
  EXPECT_EQ(layer_meters_per_unit(p, Layer::kCoarse), p.meters_per_unit);
  EXPECT_EQ(layer_meters_per_unit(p, Layer::kDetail), p.detail_meters_per_unit);
  EXPECT_EQ(layer_zero_meters(p, Layer::kCoarse), p.height_offset);
  for (int32_t m = 0; m < p.mip_count(); ++m)
    EXPECT_EQ(layer_tile_range(p, Layer::kCoarse, m), p.tile_range(m));
  EXPECT_TRUE(layer_tile_range(p, Layer::kCoarse, p.mip_count()).empty());
  EXPECT_EQ(layer_tile_range(p, Layer::kDetail, 0), tiles_overlapping(p.detail_sample_rect()));
  EXPECT_TRUE(layer_tile_range(p, Layer::kDetail, 1).empty());
  EXPECT_EQ(layer_min(Layer::kCoarse), 0);
  EXPECT_EQ(layer_max(Layer::kCoarse), 65535);
  EXPECT_EQ(layer_min(Layer::kDetail), -128);
  EXPECT_EQ(layer_max(Layer::kDetail), 127);
  EXPECT_EQ(layer_info(Layer::kCoarse).bytes_per_sample, 2);
  EXPECT_EQ(layer_info(Layer::kDetail).bytes_per_sample, 1);
  EXPECT_TRUE(layer_has_mip(Layer::kCoarse, 9));
  EXPECT_TRUE(layer_has_mip(Layer::kDetail, 0));
  EXPECT_FALSE(layer_has_mip(Layer::kDetail, 1));
  EXPECT_EQ(std::string(layer_info(Layer::kDetail).name), to_string(Layer::kDetail));
}

TEST(LayerTable, VisitCallsTheRowOfTheRuntimeLayerAndPerLayerIndexesByIt) {
  std::vector<std::string> seen;
  for (const Layer l : kLayers)
    seen.push_back(visit_layer(l, [](auto row) { return std::string(decltype(row)::kName); }));
  EXPECT_EQ(seen, (std::vector<std::string>{"coarse", "detail"}));
  const int bits = visit_layer(Layer::kDetail, [](auto row) { return decltype(row)::kBits; });
  EXPECT_EQ(bits, 8);
  PerLayer<int> n;
  n[Layer::kDetail] = 5;
  ++n[Layer::kCoarse];
  std::vector<std::pair<Layer, int>> each;
  n.for_each([&](Layer l, int v) { each.emplace_back(l, v); });
  EXPECT_EQ(each, (std::vector<std::pair<Layer, int>>{{Layer::kCoarse, 1}, {Layer::kDetail, 5}}));
}

// docs/world.md's layer table is this table: names, ranges, sample bytes, mips.
TEST(LayerTable, TheWorldDocsLayerTableIsTheCodes) {
  std::ifstream f(std::string(LOAM_SOURCE_DIR) + "/docs/world.md");
  ASSERT_TRUE(f) << "docs/world.md";
  size_t rows = 0;
  for (std::string line; std::getline(f, line);) {
    for (const Layer l : kLayers) {
      const LayerInfo& info = layer_info(l);
      if (line.rfind("| " + std::string(info.name) + " |", 0) != 0) continue;
      std::vector<std::string> cells;
      std::stringstream cs(line.substr(1));
      for (std::string c; std::getline(cs, c, '|');) cells.push_back(c.substr(1, c.size() - 2));
      ASSERT_GE(cells.size(), 9u) << line;
      const auto number = [](int32_t v) { return v < 0 ? "\u2212" + std::to_string(-v) : std::to_string(v); };
      EXPECT_EQ(cells[1], (info.bytes_per_sample == 2 ? "uint16" : "int8")) << line;
      EXPECT_EQ(cells[2], number(info.min) + ".." + number(info.max)) << line;
      EXPECT_EQ(cells[6].rfind("yes", 0) == 0, info.has_mips) << line;
      EXPECT_EQ(cells[7].rfind("yes", 0) == 0, info.has_base) << line;
      EXPECT_EQ(cells[8], (info.gl_internal_format == 0x8234 ? "R16UI" : "R8I")) << line;
      ++rows;
    }
  }
  EXPECT_EQ(rows, kLayerCount);
}

// A third layer: material classes, one byte per sample at twice the coarse resolution, no mips,
// no base. One row, and its member in the structs that hold a vector per layer.
struct MaterialLayer : LayerDerived<MaterialLayer> {
  using Sample = uint8_t;
  static constexpr Layer kLayer = Layer(2);
  static constexpr const char* kName = "material";
  static constexpr int32_t kMin = 0, kMax = 255;
  static constexpr bool kHasMips = false;
  static constexpr bool kHasBase = false;
  static constexpr uint32_t kGlInternalFormat = 0x8232;  // GL_R8UI
  static constexpr uint32_t kGlType = 0x1401;            // GL_UNSIGNED_BYTE
  static int32_t resolution(const WorldParams&) { return 2; }
  static double meters_per_unit(const WorldParams&) { return 1.0; }
  static double zero_meters(const WorldParams&) { return 0.0; }
  static RectI tile_range(const WorldParams& w, int32_t mip) {
    return mip == 0 ? tiles_overlapping(sample_rect(w)) : RectI{};
  }
};

}  // namespace

template <>
struct LayerMember<MaterialLayer> {
  template <class S>
  static auto& of(S& s) {
    return s.material;
  }
};

namespace {

struct ThreeLayerSamples {
  std::vector<uint16_t> coarse;
  std::vector<int8_t> detail;
  std::vector<uint8_t> material;
};

// Generic code, as the product writes it: a row's samples, filled from its range.
template <class R, class S>
size_t fill_with_max(S& s, size_t n) {
  auto& v = samples_of<R>(s);
  v.assign(n, typename R::Sample(R::kMax));
  return v.size() * R::kBytes;
}

TEST(LayerTable, AThirdLayerIsOneRowThatTheGenericCodeTakesAsItIs) {
  static_assert(LayerRow<MaterialLayer>);
  using ThreeLayers = LayerTable<CoarseLayer, DetailLayer, MaterialLayer>;
  static_assert(ThreeLayers::kCount == 3);
  const WorldParams p = world();
  const LayerInfo& m = ThreeLayers::kInfo[2];
  EXPECT_EQ(std::string(m.name), "material");
  EXPECT_EQ(m.bytes_per_sample, 1);
  EXPECT_FALSE(m.has_mips);
  EXPECT_EQ(MaterialLayer::kBits, 8);
  EXPECT_FALSE(MaterialLayer::kSigned);
  const RectI c = p.sample_rect();
  EXPECT_EQ(MaterialLayer::sample_rect(p), (RectI{c.x0 * 2, c.y0 * 2, c.x1 * 2, c.y1 * 2}));
  EXPECT_EQ(MaterialLayer::meters_per_sample(p), 1.0);
  // Dispatch reaches the new row.
  for (size_t i = 0; i < 3; ++i) {
    const std::string name =
        ThreeLayers::visit(Layer(i), [](auto row) { return std::string(decltype(row)::kName); });
    EXPECT_EQ(name, ThreeLayers::kInfo[i].name);
  }
  ThreeLayerSamples s;
  size_t bytes = 0;
  for (size_t i = 0; i < 3; ++i)
    bytes += ThreeLayers::visit(Layer(i), [&](auto row) { return fill_with_max<decltype(row)>(s, 4); });
  EXPECT_EQ(bytes, 4u * (2 + 1 + 1));
  EXPECT_EQ(s.coarse, std::vector<uint16_t>(4, 65535));
  EXPECT_EQ(s.detail, std::vector<int8_t>(4, 127));
  EXPECT_EQ(s.material, std::vector<uint8_t>(4, 255));
}

// A sparse row (no base) is stored as World stores the detail layer: the same SparseTiles,
// at the row's sample type, with no code of its own.
TEST(LayerTable, AThirdSparseLayersTilesLiveInTheStoreTheDetailLayerUses) {
  static_assert(!MaterialLayer::kHasBase);
  SparseTiles<MaterialLayer::Sample> store;
  TileResidency r;
  std::vector<std::pair<int32_t, int32_t>> reads;
  std::vector<uint8_t> persisted;  // what the "store" holds of tile (3, -2)
  const auto load = [&](int32_t tx, int32_t ty, std::span<uint8_t> out) {
    reads.push_back({tx, ty});
    std::copy(persisted.begin(), persisted.end(), out.begin());
  };
  const int64_t k = tile_key(3, -2);
  EXPECT_EQ(store.state(k).hash, SparseTiles<uint8_t>::zero_hash());
  EXPECT_EQ(store.samples(k, r, load), nullptr);  // never written: all zero

  store.writable(k, r, load)[5] = 200;
  EXPECT_EQ(store.commit(k, 7, r, load), 0u);
  EXPECT_EQ(store.version(k), 7u);
  EXPECT_EQ(store.stored_count(), 1u);
  EXPECT_EQ(store.unpersisted_bytes(), size_t(kTileSamples));
  persisted = *store.samples(k, r, load);
  EXPECT_EQ(store.state(k).hash, hash_tile(std::span<const uint8_t>(persisted)));

  // Persisted, evicted, and read back on the next use, with the key's coordinates.
  store.mark_persisted(k, 7, false, r);
  EXPECT_EQ(store.dirty_count(), 0u);
  EXPECT_EQ(r.persisted_bytes, size_t(kTileSamples));
  store.evict(k, r);
  EXPECT_EQ(r.persisted_bytes, 0u);
  EXPECT_EQ(store.bytes(), 0u);
  ASSERT_NE(store.samples(k, r, load), nullptr);
  EXPECT_EQ((*store.samples(k, r, load))[5], 200);
  EXPECT_EQ(reads, (std::vector<std::pair<int32_t, int32_t>>{{3, -2}}));
  EXPECT_EQ(r.loaded, 1u);

  // Written back to zeros, the tile is no longer stored and hashes as absent.
  store.writable(k, r, load)[5] = 0;
  EXPECT_EQ(store.commit(k, 9, r, load), 7u);
  EXPECT_EQ(store.stored_count(), 0u);
  EXPECT_EQ(store.state(k).hash, SparseTiles<uint8_t>::zero_hash());
  store.discard(k, r);
  EXPECT_EQ(store.version(k), 0u);
  EXPECT_TRUE(store.tiles().empty());
}

// Product code asks the layer table rather than naming a layer in a branch: the places that
// still do are the few where a layer means itself (the coarse heights' mips, the minimap's
// colours), at most five.
TEST(LayerTable, ProductCodeBranchesOnANamedLayerInAtMostFivePlaces) {
  namespace fs = std::filesystem;
  const std::vector<std::string> patterns = {"Layer::kCoarse ?",  "Layer::kDetail ?",  "== Layer::kCoarse",
                                             "!= Layer::kCoarse", "== Layer::kDetail", "!= Layer::kDetail"};
  std::vector<std::string> places;
  for (const char* folder : {"protocol", "server", "client", "gpu", "dem", "app"}) {
    for (const auto& e : fs::recursive_directory_iterator(fs::path(LOAM_SOURCE_DIR) / folder)) {
      const std::string ext = e.path().extension().string();
      if (!e.is_regular_file() || (ext != ".h" && ext != ".cpp")) continue;
      if (e.path().filename() == "layer.h" && e.path().parent_path().filename() == "protocol") continue;
      std::ifstream f(e.path());
      int n = 0;
      for (std::string line; std::getline(f, line);) {
        ++n;
        for (const std::string& p : patterns) {
          if (line.find(p) != std::string::npos) {
            places.push_back(e.path().string() + ":" + std::to_string(n));
            break;
          }
        }
      }
    }
  }
  std::string list;
  for (const std::string& p : places) list += "\n  " + p;
  EXPECT_LE(places.size(), 5u) << "branches on a named layer:" << list;
}

}  // namespace
}  // namespace loam
