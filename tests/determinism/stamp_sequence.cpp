#include "tests/determinism/stamp_sequence.h"

#include <vector>

#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_mix.h"
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
  // The generator's default options are this sequence's (protocol/stamps/stamp_mix.h).
  RandomStampOptions options;
  options.texture_id = tex;
  StampRng rng(0x2545F4914F6CDD1Dull);
  for (uint64_t seq = 1; seq <= 60; ++seq) {
    const StampParams s = random_stamp_params(rng, options);
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
  // Every tile in canonical order (the hash this constant was first recorded with): the
  // stamp arithmetic is what this pins, not the world-hash definition.
  return w.legacy_content_hash();
}

}  // namespace loam::determinism
