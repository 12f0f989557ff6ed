// Layers as a type. Every property in which the coarse height layer and the detail layer
// differ is one row of the table here: the sample type and range, metres per unit and per
// sample, the resolution against the coarse grid, the sample rect of a world, whether it has
// mips and a base, its GL texture format. Code generic over layers takes a row (a LayerRow);
// code holding a runtime Layer dispatches to its row with visit_layer, or asks layer_info for
// the numbers. PerLayer<T> holds one T per layer. A new layer (material, moisture) is one more
// row: tests/unit/layer_test.cpp instantiates a third and runs generic code on it.
#pragma once

#include <array>
#include <concepts>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "protocol/geometry.h"

namespace loam {

// What a layer row must say.
template <class R>
concept LayerRow = requires(const WorldParams& w) {
  typename R::Sample;
  requires std::is_integral_v<typename R::Sample>;
  { R::kLayer } -> std::convertible_to<Layer>;
  { R::kName } -> std::convertible_to<const char*>;
  { R::kMin } -> std::convertible_to<int32_t>;
  { R::kMax } -> std::convertible_to<int32_t>;
  { R::kHasMips } -> std::convertible_to<bool>;
  { R::kHasBase } -> std::convertible_to<bool>;
  { R::kGlInternalFormat } -> std::convertible_to<uint32_t>;
  { R::kGlType } -> std::convertible_to<uint32_t>;
  { R::resolution(w) } -> std::convertible_to<int32_t>;
  { R::meters_per_unit(w) } -> std::convertible_to<double>;
  { R::zero_meters(w) } -> std::convertible_to<double>;
  { R::tile_range(w, 0) } -> std::convertible_to<RectI>;
};

// The rows' shared derivations: sample width and bits, metres per sample, the sample rect.
template <class R>
struct LayerDerived {
  static constexpr int kBytes = int(sizeof(typename R::Sample));
  static constexpr int kBits = 8 * kBytes;
  static constexpr bool kSigned = std::is_signed_v<typename R::Sample>;
  static double meters_per_sample(const WorldParams& w) { return w.meters_per_sample / R::resolution(w); }
  static RectI sample_rect(const WorldParams& w) {
    const RectI r = w.sample_rect();
    const int64_t f = R::resolution(w);
    return {r.x0 * f, r.y0 * f, r.x1 * f, r.y1 * f};
  }
};

// The heights: 16-bit units above the world's height offset, on the coarse grid, with mips, and
// untouched tiles read from the world's base.
struct CoarseLayer : LayerDerived<CoarseLayer> {
  using Sample = uint16_t;
  static constexpr Layer kLayer = Layer::kCoarse;
  static constexpr const char* kName = "coarse";
  static constexpr int32_t kMin = 0, kMax = 65535;
  static constexpr bool kHasMips = true;
  static constexpr bool kHasBase = true;
  static constexpr uint32_t kGlInternalFormat = 0x8234;  // GL_R16UI (gpu/tile_pages.cpp checks them)
  static constexpr uint32_t kGlType = 0x1403;            // GL_UNSIGNED_SHORT
  static int32_t resolution(const WorldParams&) { return 1; }
  static double meters_per_unit(const WorldParams& w) { return w.meters_per_unit; }
  static double zero_meters(const WorldParams& w) { return w.height_offset; }
  static RectI tile_range(const WorldParams& w, int32_t mip) {
    return mip >= 0 && mip < w.mip_count() ? w.tile_range(mip) : RectI{};
  }
};

// Fine offsets on the coarse heights: signed 8-bit, detail_factor samples per coarse sample,
// mip 0 only, zero where never written.
struct DetailLayer : LayerDerived<DetailLayer> {
  using Sample = int8_t;
  static constexpr Layer kLayer = Layer::kDetail;
  static constexpr const char* kName = "detail";
  static constexpr int32_t kMin = -128, kMax = 127;
  static constexpr bool kHasMips = false;
  static constexpr bool kHasBase = false;
  static constexpr uint32_t kGlInternalFormat = 0x8231;  // GL_R8I
  static constexpr uint32_t kGlType = 0x1400;            // GL_BYTE
  static int32_t resolution(const WorldParams& w) { return w.detail_factor; }
  static double meters_per_unit(const WorldParams& w) { return w.detail_meters_per_unit; }
  static double zero_meters(const WorldParams&) { return 0.0; }
  static RectI tile_range(const WorldParams& w, int32_t mip) {
    return mip == 0 ? tiles_overlapping(sample_rect(w)) : RectI{};
  }
};

static_assert(LayerRow<CoarseLayer> && LayerRow<DetailLayer>);

// A layer's numbers, for code that holds a runtime Layer and needs no sample type.
struct LayerInfo {
  const char* name;
  int32_t min, max;
  int bytes_per_sample;
  bool has_mips, has_base;
  uint32_t gl_internal_format, gl_type;
};
template <LayerRow R>
constexpr LayerInfo info_of() {
  return {R::kName, R::kMin, R::kMax, R::kBytes, R::kHasMips, R::kHasBase, R::kGlInternalFormat, R::kGlType};
}

// The table: its rows in Layer order. visit calls f with the row of a runtime layer.
template <LayerRow... Rows>
struct LayerTable {
  static constexpr size_t kCount = sizeof...(Rows);
  static constexpr std::array<LayerInfo, kCount> kInfo = {info_of<Rows>()...};
  static constexpr std::array<Layer, kCount> kLayers = {Rows::kLayer...};
  static constexpr bool ordered() {
    for (size_t i = 0; i < kCount; ++i)
      if (size_t(kLayers[i]) != i) return false;
    return true;
  }
  static_assert(ordered(), "rows must be listed in Layer order");

  template <class F>
  static decltype(auto) visit(Layer l, F&& f) {
    return visit_from<0, Rows...>(l, f);
  }

 private:
  template <size_t I, class First, class... Rest, class F>
  static decltype(auto) visit_from(Layer l, F& f) {
    if constexpr (sizeof...(Rest) == 0) {
      return f(First{});
    } else {
      if (size_t(l) == I) return f(First{});
      return visit_from<I + 1, Rest...>(l, f);
    }
  }
};

// Loam's layers.
using Layers = LayerTable<CoarseLayer, DetailLayer>;
inline constexpr size_t kLayerCount = Layers::kCount;
inline constexpr std::array<Layer, kLayerCount> kLayers = Layers::kLayers;

// Calls f with the row of `layer` (a CoarseLayer or a DetailLayer object).
template <class F>
decltype(auto) visit_layer(Layer layer, F&& f) {
  return Layers::visit(layer, std::forward<F>(f));
}
constexpr const LayerInfo& layer_info(Layer l) { return Layers::kInfo[size_t(l)]; }
inline int32_t layer_min(Layer l) { return layer_info(l).min; }
inline int32_t layer_max(Layer l) { return layer_info(l).max; }
// The world-dependent ones.
inline double layer_meters_per_unit(const WorldParams& w, Layer l) {
  return visit_layer(l, [&](auto row) { return decltype(row)::meters_per_unit(w); });
}
inline double layer_meters_per_sample(const WorldParams& w, Layer l) {
  return visit_layer(l, [&](auto row) { return decltype(row)::meters_per_sample(w); });
}
inline RectI layer_sample_rect(const WorldParams& w, Layer l) {
  return visit_layer(l, [&](auto row) { return decltype(row)::sample_rect(w); });
}
// The meters a layer's unit 0 stands for (the coarse heights start at the world's offset).
inline double layer_zero_meters(const WorldParams& w, Layer l) {
  return visit_layer(l, [&](auto row) { return decltype(row)::zero_meters(w); });
}
// The tiles of a layer at `mip` (empty where the layer has no such mip).
inline RectI layer_tile_range(const WorldParams& w, Layer l, int32_t mip) {
  return visit_layer(l, [&](auto row) { return decltype(row)::tile_range(w, mip); });
}
// Whether a tile of this layer may be at `mip` in any world (the detail layer: mip 0 only).
constexpr bool layer_has_mip(Layer l, int32_t mip) { return mip == 0 || layer_info(l).has_mips; }

// The member of a struct holding one sample vector per layer (`coarse`, `detail`) that is the
// row's: generic code reads and writes samples_of<R>(s).
template <class R>
struct LayerMember;
template <>
struct LayerMember<CoarseLayer> {
  template <class S>
  static auto& of(S& s) {
    return s.coarse;
  }
};
template <>
struct LayerMember<DetailLayer> {
  template <class S>
  static auto& of(S& s) {
    return s.detail;
  }
};
template <class R, class S>
auto& samples_of(S& s) {
  return LayerMember<R>::of(s);
}

// One T per layer, indexed by Layer.
template <class T>
struct PerLayer {
  std::array<T, kLayerCount> v{};
  T& operator[](Layer l) { return v[size_t(l)]; }
  const T& operator[](Layer l) const { return v[size_t(l)]; }
  auto begin() { return v.begin(); }
  auto end() { return v.end(); }
  auto begin() const { return v.begin(); }
  auto end() const { return v.end(); }
  // f(layer, value) for each layer in order.
  template <class F>
  void for_each(F&& f) {
    for (const Layer l : kLayers) f(l, (*this)[l]);
  }
  template <class F>
  void for_each(F&& f) const {
    for (const Layer l : kLayers) f(l, (*this)[l]);
  }
};

}  // namespace loam
