// Writes the small deformation logs committed under tests/golden/replay/: one log per seed,
// each a segment 0 over the embedded default terrain holding seeded random stamps of every
// kind (the same stamps a session would log), and prints `name world_hash` lines for
// expected.txt. Run through tests/golden/replay/regenerate.sh.
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>

#include "protocol/log/log_file.h"
#include "protocol/stamps/stamp_validate.h"
#include "server/replay.h"
#include "server/terrain_source.h"

using namespace loam;

namespace {

QuantizedStamp make_stamp(std::mt19937& rng, const WorldParams& w, int i) {
  const RectI r = w.sample_rect();
  std::uniform_real_distribution<double> ux(double(r.x0) * w.meters_per_sample,
                                            double(r.x1 - 1) * w.meters_per_sample);
  std::uniform_real_distribution<double> uy(double(r.y0) * w.meters_per_sample,
                                            double(r.y1 - 1) * w.meters_per_sample);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (;;) {
    StampParams p;
    p.kind =
        StampKind(i % kStampKindCount == 0 ? 1 : i % kStampKindCount);  // no texture (no image registered)
    p.center_x = ux(rng);
    p.center_y = uy(rng);
    p.radius = 2.0 + 40.0 * unit(rng);
    p.rotation = 6.28 * unit(rng);
    p.intensity = -3.0 + 6.0 * unit(rng);
    p.shape = 0.3;
    if (p.kind == StampKind::kCrater) p.intensity = 0.5 + 3.0 * unit(rng), p.volume_conserving = i % 4 == 0;
    if (p.kind == StampKind::kFootprint) p.intensity = 0.3, p.radius = 3.0;
    if (p.kind == StampKind::kFlatten) p.intensity = 0.5, p.target = 30.0 * unit(rng);
    if (p.kind == StampKind::kShockwave)
      p.radius = 6.0, p.intensity = 0.5, p.steps = 30, p.speed = 0.6, p.damping = 0.02;
    if (i % 7 == 3)
      p.kind = StampKind::kGaussian, p.layer = Layer::kDetail, p.radius = 1.5, p.intensity = 0.05;
    auto q = validate_stamp(p, w);
    if (q) return *q;
  }
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
    std::mt19937 rng(seed);
    const int count = 40 + int(seed) * 10;
    for (int i = 0; i < count; ++i) {
      const Status st =
          writer->append({uint64_t(i + 1), uint64_t(i / 3), seed, make_stamp(rng, world->params(), i)});
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
    std::printf("%s %016llx %016llx\n", name.c_str(), (unsigned long long)replayed->world.content_hash(),
                (unsigned long long)replayed->world.world_hash());
  }
  return 0;
}
