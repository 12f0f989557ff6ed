// TileBase: the read-only terrain a session starts from, tile by tile. A World is a base plus
// edits (protocol/world.h): tiles never edited are asked of the base when needed and may be
// dropped again, so memory follows what is edited and viewed, not the world's size.
//
// A base answers any coarse tile at any mip of the world it was made for, with World's mip
// rule: mip-m sample i is mip-0 sample clamp(i * 2^m) (clamped to the world's sample rect).
// Its identity is a hash of everything that determines its samples; the world hash covers it
// instead of every untouched tile. Implementations are immutable and safe to share between
// threads and worlds.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "protocol/base/refinement.h"
#include "protocol/geometry.h"

namespace loam {

class TileBase {
 public:
  virtual ~TileBase() = default;
  // Writes the kTileSamples samples of coarse tile (mip, tx, ty) into `out`.
  virtual void coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const = 0;
  // A hash of everything that determines the samples (kind, parameters, source).
  virtual uint64_t identity() const = 0;
  // For messages and manifests: "fill 0", "refined 1024x768 x128 seed ...".
  virtual std::string describe() const = 0;
  // True when every sample of every tile is the same value (no need to cache tiles).
  virtual bool uniform() const { return false; }
};

// Every sample at one value: the base of worlds built from samples or from a fill.
class FillBase final : public TileBase {
 public:
  explicit FillBase(uint16_t value) : value_(value) {}
  void coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const override;
  uint64_t identity() const override;
  std::string describe() const override;
  bool uniform() const override { return true; }
  uint16_t value() const { return value_; }

 private:
  uint16_t value_;
};

// A refined source (refinement.h) as the base of a world of `params`: the world's sample rect
// must lie inside the refined extent; mip tiles reaching past the world's edge repeat its
// edge samples as World's mips do.
class RefinedTileBase final : public TileBase {
 public:
  static Result<std::shared_ptr<const RefinedTileBase>> create(RefinedBase refined,
                                                               const WorldParams& params);
  void coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const override;
  uint64_t identity() const override { return identity_; }
  std::string describe() const override;
  const RefinedBase& refined() const { return refined_; }

 private:
  RefinedTileBase(RefinedBase refined, const WorldParams& params);
  RefinedBase refined_;
  RectI samples_;
  uint64_t identity_ = 0;
};

}  // namespace loam
