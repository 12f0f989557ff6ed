// Suite `query`: what the game library's terrain queries cost (client/query/): height and
// normal at a point, raycasts (a pick straight down, a 100 m aim, a 2 km grazing sight line) and
// sphere and capsule sweeps (a walker's step, a falling body, a 200 m projectile), each on a
// snapshot of the embedded terrain and of a rough synthetic world, per query on one core. Every
// answer is exact on the triangles the renderer draws (tests/unit/terrain_query_test.cpp checks
// them against brute force); the table says how much of the terrain each query looked at.
// Also: publishing a snapshot (per changed tile), taking the latest one, and queries while
// another thread publishes a snapshot every millisecond.
#include <atomic>
#include <cmath>
#include <cstdio>
#include <functional>
#include <glm/geometric.hpp>
#include <numbers>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench/harness.h"
#include "client/query/snapshot_builder.h"
#include "client/query/terrain_query.h"
#include "dem/default_terrain.h"
#include "protocol/world.h"

namespace loam::bench {
namespace {

std::vector<TileCoord> all_tiles(const WorldParams& p) {
  std::vector<TileCoord> out;
  const RectI t = p.tile_range(0);
  for (int64_t ty = t.y0; ty < t.y1; ++ty) {
    for (int64_t tx = t.x0; tx < t.x1; ++tx) out.push_back({Layer::kCoarse, 0, int32_t(tx), int32_t(ty)});
  }
  return out;
}

World rough_world(int32_t tiles) {
  WorldParams p;
  p.meters_per_sample = 1.0;
  p.tiles_x = p.tiles_y = tiles;
  World w(p);
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> noise(-150, 150);
  const RectI r = p.sample_rect();
  std::vector<uint16_t> s(size_t(r.area()));
  for (int64_t y = r.y0; y < r.y1; ++y) {
    for (int64_t x = r.x0; x < r.x1; ++x) {
      const double h = 30000 + 8000 * std::sin(double(x) * 0.013) * std::cos(double(y) * 0.017) + noise(rng);
      s[size_t((y - r.y0) * r.width() + (x - r.x0))] = uint16_t(h);
    }
  }
  (void)w.write_coarse(r, s);
  (void)w.commit(1);
  return w;
}

struct Terrain {
  std::string name;
  World world;
};

int run_query(const Context& ctx, Report& report) {
  std::vector<Terrain> terrains;
  {
    auto d = load_default_terrain();
    if (!d) {
      std::fprintf(stderr, "query: %s\n", d.error().describe().c_str());
      return 1;
    }
    terrains.push_back({"embedded crop", std::move(d->world)});
  }
  terrains.push_back({"rough synthetic (1 m, 1 m noise)", rough_world(ctx.quick ? 2 : 8)});

  Table table("query", {"terrain", "query", "ns per query (median)", "p10..p90", "triangles tested",
                        "blocks visited", "blocks skipped", "hits %", "answer"});
  Table publish("query_publish", {"terrain", "what", "cost", "spread"});
  const int n = ctx.quick ? 200 : 4000;
  for (const Terrain& t : terrains) {
    const WorldParams& p = t.world.params();
    const std::vector<TileCoord> held = all_tiles(p);
    query::SnapshotBuilder builder(p);
    const auto snap = builder.build(t.world, held, {}, 1, 0);
    const query::TerrainSnapshot& s = *snap;
    const double h = p.meters_per_sample;
    const RectI r = p.sample_rect();
    const double x0 = double(r.x0) * h + 300, x1 = double(r.x1 - 1) * h - 300;
    const double y0 = double(r.y0) * h + 300, y1 = double(r.y1 - 1) * h - 300;
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> ux(x0, x1), uy(y0, y1), ang(0, 2 * std::numbers::pi);
    struct Point {
      double x, y, ground;
      double a;
    };
    std::vector<Point> pts;
    for (int i = 0; i < n; ++i) {
      const double x = ux(rng), y = uy(rng);
      pts.push_back({x, y, *query::height_at(s, x, y), ang(rng)});
    }
    auto dir = [](double a, double dz) { return glm::normalize(glm::dvec3{std::cos(a), std::sin(a), dz}); };

    struct Case {
      std::string name, answer;
      std::function<bool(const Point&, query::QueryWork&)> run;
    };
    std::vector<Case> cases = {
        {"height at a point", "exact (sample or triangle plane)",
         [&](const Point& q, query::QueryWork&) { return query::height_at(s, q.x, q.y).has_value(); }},
        {"normal at a point", "exact (triangle's plane)",
         [&](const Point& q, query::QueryWork&) { return query::normal_at(s, q.x, q.y).has_value(); }},
        {"raycast down from 50 m (a pick under the cursor)", "exact",
         [&](const Point& q, query::QueryWork& w) {
           return query::raycast(s, {q.x, q.y, q.ground + 50}, {0, 0, -1}, 1000, &w).hit.has_value();
         }},
        {"raycast 100 m from eye height, 10 degrees down (aiming)", "exact",
         [&](const Point& q, query::QueryWork& w) {
           return query::raycast(s, {q.x, q.y, q.ground + 1.8}, dir(q.a, -0.176), 100, &w).hit.has_value();
         }},
        {"raycast 2 km level from 30 m up (a sight line)", "exact",
         [&](const Point& q, query::QueryWork& w) {
           return query::raycast(s, {q.x, q.y, q.ground + 30}, dir(q.a, 0.0), 2000, &w).hit.has_value();
         }},
        {"sphere 0.4 m, a walker's 1/60 s step with gravity", "exact (contact time to 1e-7 m)",
         [&](const Point& q, query::QueryWork& w) {
           const glm::dvec3 c{q.x, q.y, q.ground + 0.45};
           const glm::dvec3 m{0.023 * std::cos(q.a), 0.023 * std::sin(q.a), -0.1};
           return query::sweep_capsule(s, {c, c, 0.4}, m, &w).contact.has_value();
         }},
        {"capsule 1.8 m tall, 0.3 m radius, a walker's step", "exact (contact time to 1e-7 m)",
         [&](const Point& q, query::QueryWork& w) {
           const glm::dvec3 a{q.x, q.y, q.ground + 0.35}, b{q.x, q.y, q.ground + 1.5};
           const glm::dvec3 m{0.023 * std::cos(q.a), 0.023 * std::sin(q.a), -0.1};
           return query::sweep_capsule(s, {a, b, 0.3}, m, &w).contact.has_value();
         }},
        {"sphere 1 m falling 40 m", "exact (contact time to 1e-7 m)",
         [&](const Point& q, query::QueryWork& w) {
           const glm::dvec3 c{q.x, q.y, q.ground + 30};
           return query::sweep_capsule(s, {c, c, 1.0}, {0, 0, -40}, &w).contact.has_value();
         }},
        {"sphere 0.2 m, a 200 m shot 5 degrees down", "exact (contact time to 1e-7 m)",
         [&](const Point& q, query::QueryWork& w) {
           const glm::dvec3 c{q.x, q.y, q.ground + 10};
           return query::sweep_capsule(s, {c, c, 0.2}, dir(q.a, -0.087) * 200.0, &w).contact.has_value();
         }},
    };
    for (const Case& c : cases) {
      query::QueryWork work;
      int hits = 0;
      for (const Point& q : pts) hits += c.run(q, work) ? 1 : 0;
      query::QueryWork scratch;
      const Timing tm = measure(ctx, [&] {
        for (const Point& q : pts) (void)c.run(q, scratch);
      });
      const double per = double(pts.size());
      table.add_row({t.name, c.name, fmt(tm.median_s / per * 1e9, 0),
                     fmt(tm.p10_s / per * 1e9, 0) + ".." + fmt(tm.p90_s / per * 1e9, 0) + " ns",
                     fmt(double(work.triangles_tested) / per, 1), fmt(double(work.blocks_visited) / per, 2),
                     fmt(double(work.blocks_skipped) / per, 2), fmt(100.0 * hits / per, 1), c.answer});
      std::printf("  %s, %s: %.0f ns\n", t.name.c_str(), c.name.c_str(), tm.median_s / per * 1e9);
    }

    // Publishing: one tile changed (a stamp), and every tile (a first snapshot).
    const std::vector<query::ChangedRect> one{{Layer::kCoarse, {r.x0 + 10, r.y0 + 10, r.x0 + 40, r.y0 + 40}}};
    const Timing one_tile = measure(ctx, [&] { (void)builder.build(t.world, held, one, 2, 0); });
    publish.add_row(
        {t.name,
         "publish a snapshot after a stamp in one tile (" + std::to_string(held.size()) + " tiles held)",
         fmt(one_tile.median_s * 1e6, 1) + " us", one_tile.spread()});
    const Timing whole = measure(ctx, [&] {
      query::SnapshotBuilder fresh(p);
      (void)fresh.build(t.world, held, {}, 1, 0);
    });
    publish.add_row({t.name, "a first snapshot, per tile copied",
                     fmt(whole.median_s / double(held.size()) * 1e6, 1) + " us", whole.spread()});
    publish.add_row({t.name, "snapshot memory", fmt(double(s.bytes()) / (1 << 20), 1) + " MiB", ""});

    // The latest snapshot, taken from the slot, while another thread publishes every millisecond.
    query::SnapshotSlot slot;
    slot.publish(snap);
    const Timing take = measure(ctx, [&] {
      for (int i = 0; i < 1000; ++i) {
        auto v = slot.take();
        (void)v;
      }
    });
    publish.add_row({t.name, "take the latest snapshot (no publisher)",
                     fmt(take.median_s / 1000 * 1e9, 0) + " ns", take.spread()});
    std::atomic<bool> stop{false};
    std::thread publisher([&] {
      while (!stop) {
        slot.publish(builder.build(t.world, held, one, 3, 0));
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    });
    const Timing busy = measure(ctx, [&] {
      for (const Point& q : pts) {
        const auto v = slot.take();
        (void)query::height_at(*v, q.x, q.y);
      }
    });
    stop = true;
    publisher.join();
    publish.add_row({t.name, "take + height query while a thread publishes each ms",
                     fmt(busy.median_s / double(pts.size()) * 1e9, 0) + " ns", busy.spread()});
  }
  report.paragraph(
      "Each query on a snapshot holding every tile of the terrain, " + std::to_string(n) +
      " random positions at least 300 m from the edges, one core, no locks (release build). Answers are "
      "exact on the surface the renderer draws at full resolution (each cell split along its "
      "(x, y)-(x+1, y+1) diagonal): heights at samples are the samples, rays and sweeps match brute "
      "force over every triangle in the unit tests. Rays walk 16 x 16-sample blocks and skip those whose "
      "height range the ray passes above or below; sweeps visit the blocks their swept box meets in the "
      "order the shape reaches them and stop at the first contact. `triangles tested` is per query.");
  report.table(std::move(table));
  report.paragraph(
      "Publishing copies only the tiles a change touched (128 KiB each) and shares the rest with the "
      "last snapshot; taking the latest snapshot is one atomic shared-pointer load (std::atomic<shared_ptr>, "
      "a short internal lock), so a game thread's query costs the same while the network thread publishes.");
  report.table(std::move(publish));
  return 0;
}

}  // namespace

LOAM_BENCH_SUITE(query, "query: height, normal, raycast and sweep costs of the game library", run_query);

}  // namespace loam::bench
