#include "tests/determinism/stamp_sequence.h"

#include <cmath>
#include <vector>

#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"

namespace loam::determinism {

uint64_t golden_stamp_sequence_hash(std::string* error) {
  WorldParams p;
  p.meters_per_sample = 1.0;
  p.meters_per_unit = 1.0 / 64.0;
  p.height_offset = 0.0;
  p.detail_factor = 4;
  p.detail_meters_per_unit = 0.005;
  p.origin_tile_x = -1;
  p.origin_tile_y = -1;
  p.tiles_x = 2;
  p.tiles_y = 2;
  World w(p, 32768);
  TextureRegistry reg;
  const std::vector<uint16_t> img = {0, 0, 65535, 65535, 0, 0, 65535, 65535};  // left black, right white
  const uint64_t tex = reg.add(4, 2, img).value();
  uint64_t state = 0x2545F4914F6CDD1Dull;
  auto next = [&](uint32_t n) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return uint32_t((state >> 33) % n);
  };
  for (uint64_t seq = 1; seq <= 60; ++seq) {
    StampParams s;
    s.kind = StampKind(next(kStampKindCount));
    s.layer = next(3) == 0 ? Layer::kDetail : Layer::kCoarse;
    s.center_x = double(int32_t(next(4000)) - 2000) / 8.0;
    s.center_y = double(int32_t(next(4000)) - 2000) / 8.0;
    s.radius = 0.5 + double(next(400)) / 10.0;
    s.rotation = double(next(1000)) / 100.0;
    s.intensity = (double(next(200)) - 100.0) / (s.layer == Layer::kCoarse ? 20.0 : 200.0);
    s.shape = double(next(100)) / 100.0;
    s.texture_id = tex;
    s.steps = 1 + next(20);
    s.speed = 0.2 + double(next(70)) / 100.0;
    s.damping = double(next(10)) / 100.0;
    if (s.kind == StampKind::kFlatten) s.intensity = double(next(100)) / 100.0;
    if (s.kind == StampKind::kFootprint) s.intensity = std::fabs(s.intensity);
    if (s.kind == StampKind::kCrater) s.volume_conserving = next(2) == 1;
    const double target = s.layer == Layer::kCoarse ? double(next(900)) + 100.0 : 0.1;
    if (s.kind == StampKind::kGaussian || s.kind == StampKind::kTexture) s.blend = BlendMode(next(4));
    // Only flatten and the min/max blends take a target (the draw stays, so the sequence does).
    if (s.kind == StampKind::kFlatten || s.blend == BlendMode::kMin || s.blend == BlendMode::kMax)
      s.target = target;
    const auto q = validate_stamp(s, w.params(), {}, &reg);
    if (!q.ok()) {
      if (error && error->empty()) *error = "stamp " + std::to_string(seq) + ": " + q.error().describe();
      continue;
    }
    const auto applied = apply_stamp(w, q.value(), &reg);
    if (!applied.ok() && error && error->empty())
      *error = "stamp " + std::to_string(seq) + ": " + applied.error().describe();
    w.commit(seq);
  }
  return w.content_hash();  // the content: the stamp arithmetic is what this pins
}

}  // namespace loam::determinism
