// Digs a crater at the world's centre through Loam's client library and queries it: the
// height and normal there, a raycast and a sphere dropped onto it, as predicted at once and as
// confirmed by the server. Exits 0 when the confirmed crater is as deep as the stamp asked.
//   loam-crater HOST PORT   (LOAM_TOKEN=HEX where the server requires tokens)
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <loam/client.hpp>
#include <string>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: loam-crater HOST PORT\n");
    return 2;
  }
  loam::game::Options options;
  options.host = argv[1];
  options.port = uint16_t(std::atoi(argv[2]));
  options.name = "crater-example";
  if (const char* token = std::getenv("LOAM_TOKEN")) options.token = token;
  std::string error;
  auto client = loam::game::Client::connect(options, &error);
  if (!client) {
    std::fprintf(stderr, "loam-crater: cannot connect: %s\n", error.c_str());
    return 1;
  }
  const loam::game::WorldInfo w = client->world();
  // A sample position near the centre: queries there return the sample exactly.
  const double x = std::round((w.min_x + w.max_x) / 2 / w.meters_per_sample) * w.meters_per_sample;
  const double y = std::round((w.min_y + w.max_y) / 2 / w.meters_per_sample) * w.meters_per_sample;
  client->set_view(x, y, 200.0);
  if (!client->wait_for_view(std::chrono::seconds(30))) {
    std::fprintf(stderr, "loam-crater: the terrain around (%.1f, %.1f) did not arrive\n", x, y);
    return 1;
  }
  const double before = client->height(x, y).value();

  int own_events = 0;
  bool accepted = false;
  client->on_deform([&](const loam::game::DeformEvent& e) {
    if (e.own) ++own_events;
    std::printf("event %llu from client %u: %s, radius %.2f m at (%.1f, %.1f)\n", (unsigned long long)e.seq,
                e.origin_client, e.own ? "ours" : "another's", e.stamp.radius, e.stamp.x, e.stamp.y);
  });
  client->on_stamp_result([&](const loam::game::StampResult& r) {
    accepted = r.accepted;
    std::printf("stamp %llu %s%s\n", (unsigned long long)r.ticket,
                r.accepted ? "accepted" : "rejected: ", r.error.c_str());
  });

  loam::game::Stamp crater;
  crater.kind = loam::game::StampKind::kCrater;
  crater.x = x;
  crater.y = y;
  crater.radius = 16.0;
  crater.intensity = 4.0;  // depth, meters
  crater.shape = 0.2;      // rim
  if (client->stamp(crater, &error) == 0) {
    std::fprintf(stderr, "loam-crater: stamp refused: %s\n", error.c_str());
    return 1;
  }
  client->flush(std::chrono::seconds(5));
  const double predicted = client->height(x, y).value();
  if (!client->wait_settled(std::chrono::seconds(30))) {
    std::fprintf(stderr, "loam-crater: the server did not settle the stamp\n");
    return 1;
  }
  client->dispatch();

  const loam::game::TerrainView view = client->view();
  const double after = view.height(x, y).value();
  const loam::game::Vec3 n = view.normal(x + 8.0, y).value();
  const auto ray = view.raycast({x, y, before + 50.0}, {0, 0, -1}, 500.0);
  const auto drop = view.sweep_sphere({x, y, before + 10.0}, 0.5, {0, 0, -100.0});
  std::printf("height at (%.1f, %.1f): %.3f m before, %.3f m predicted, %.3f m confirmed\n", x, y, before,
              predicted, after);
  std::printf("normal on the crater wall: (%.3f, %.3f, %.3f)\n", n.x, n.y, n.z);
  if (ray.hit) std::printf("raycast down hits at %.3f m\n", ray.hit->point.z);
  if (drop.hit)
    std::printf("a 0.5 m sphere dropped from 10 m above lands with its centre at %.3f m\n",
                before + 10.0 - 100.0 * drop.hit->t);
  const bool ok = accepted && own_events == 1 && before - after > 3.0 &&
                  std::fabs(predicted - after) < 1e-9 && ray.hit &&
                  std::fabs(ray.hit->point.z - after) < 1e-6 && drop.hit && n.x < 0.0;
  std::printf("loam-crater: %s\n", ok ? "ok" : "FAILED");
  return ok ? 0 : 1;
}
