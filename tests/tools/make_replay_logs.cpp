// Writes the small deformation logs committed under tests/golden/replay/: one log per seed,
// each a segment 0 over the embedded default terrain holding seeded random stamps of every
// kind (the same stamps a session would log), and prints `name legacy_content legacy_world content world`
// hash lines for expected.txt. Run through tests/golden/replay/regenerate.sh.
#include <cstdio>
#include <filesystem>
#include <string>

#include "protocol/log/log_file.h"
#include "protocol/stamps/stamp_mix.h"
#include "server/replay.h"
#include "server/terrain_source.h"

using namespace loam;

namespace {

// Stamp i is of the i-th kind in turn (every kind but texture: no image is registered), drawn
// by the tests' generator; shockwaves stay small.
Result<QuantizedStamp> make_stamp(StampRng& rng, const WorldParams& w, int i) {
  RandomStampOptions o = random_stamp_options(w);
  o.kinds = {o.kinds[size_t(i) % o.kinds.size()]};
  o.max_radius_of_kind[size_t(StampKind::kShockwave)] = 6.0;
  return random_valid_stamp(rng, o, w);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
    return 2;
  }
  const std::string out = argv[1];
  std::filesystem::create_directories(out);
  for (uint32_t seed : {1u, 2u, 3u}) {
    log::InitialTerrain initial;
    auto world = server::load_initial_terrain("", &initial);
    if (!world) {
      std::fprintf(stderr, "%s\n", world.error().describe().c_str());
      return 1;
    }
    log::SegmentHeader h;
    h.world = world->params();
    h.initial = initial;
    h.created_unix_us = 1790000000000000ull + seed;  // fixed: the files are committed
    h.base_world_hash = initial.world_hash;
    const std::string name = "seed" + std::to_string(seed) + ".loamlog";
    const std::string path = out + "/" + name;
    std::filesystem::remove(path);
    auto writer = log::LogWriter::create(path, h);
    if (!writer) {
      std::fprintf(stderr, "%s\n", writer.error().describe().c_str());
      return 1;
    }
    StampRng rng(seed);
    const int count = 40 + int(seed) * 10;
    for (int i = 0; i < count; ++i) {
      const auto stamp = make_stamp(rng, world->params(), i);
      if (!stamp) {
        std::fprintf(stderr, "%s\n", stamp.error().describe().c_str());
        return 1;
      }
      const Status st = writer->append({uint64_t(i + 1), uint64_t(i / 3), seed, *stamp});
      if (!st.ok()) {
        std::fprintf(stderr, "%s\n", st.error().describe().c_str());
        return 1;
      }
    }
    if (!writer->sync().ok()) return 1;
    auto replayed = server::replay_log({path}, out);
    if (!replayed) {
      std::fprintf(stderr, "%s\n", replayed.error().describe().c_str());
      return 1;
    }
    // Legacy hashes (every tile: what the logs were first pinned with) and current ones.
    std::printf("%s %016llx %016llx %016llx %016llx\n", name.c_str(),
                (unsigned long long)replayed->world.legacy_content_hash(),
                (unsigned long long)replayed->world.legacy_world_hash(),
                (unsigned long long)replayed->world.content_hash(),
                (unsigned long long)replayed->world.world_hash());
  }
  return 0;
}
