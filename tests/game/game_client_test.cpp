// loam_client, the game library, through its public API only (this binary links nothing else
// of Loam): against a real server, two clients dig and see the same crater, hooks hear every
// event after the view shows it, queries run on a game thread while the network thread
// publishes, and bad stamps and missing tokens are refused with a reason.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <loam/client.hpp>
#include <thread>

#include "tests/integration/server_process.h"

namespace {

using namespace std::chrono_literals;
using loam::game::Client;
using loam::game::Stamp;
using loam::game::StampKind;

std::string data_dir(const std::string& tag) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const auto dir = std::filesystem::temp_directory_path() /
                   ("loam_game_" + std::string(info->name()) + "_" + tag + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  return dir.string();
}

std::unique_ptr<Client> join(uint16_t port, const std::string& name, bool spectator = false) {
  loam::game::Options o;
  o.port = port;
  o.name = name;
  o.spectator = spectator;
  std::string error;
  auto c = Client::connect(o, &error);
  EXPECT_TRUE(c) << error;
  return c;
}

// A sample position near the world's centre.
std::pair<double, double> centre(const Client& c) {
  const auto w = c.world();
  const double h = w.meters_per_sample;
  return {std::round((w.min_x + w.max_x) / 2 / h) * h, std::round((w.min_y + w.max_y) / 2 / h) * h};
}

Stamp crater_at(double x, double y) {
  Stamp s;
  s.kind = StampKind::kCrater;
  s.x = x;
  s.y = y;
  s.radius = 12;
  s.intensity = 3;
  s.shape = 0.25;
  return s;
}

TEST(GameClient, TwoClientsSeeTheSameCraterAndHooksRunAfterTheViewShowsTheEvent) {
  loam::test::ServerProcess server;
  ASSERT_TRUE(server.start(data_dir("server"))) << server.log();
  auto a = join(server.port(), "digger");
  auto b = join(server.port(), "watcher");
  ASSERT_TRUE(a && b);
  const auto [x, y] = centre(*a);
  a->set_view(x, y, 120);
  b->set_view(x, y, 120);
  ASSERT_TRUE(a->wait_for_view(30s));
  ASSERT_TRUE(b->wait_for_view(30s));
  const double before = *a->height(x, y);
  EXPECT_EQ(*b->height(x, y), before);

  std::vector<loam::game::DeformEvent> heard;
  bool shown_when_heard = false;
  b->on_deform([&](const loam::game::DeformEvent& e) {
    heard.push_back(e);
    // The staleness bound: a hook runs only once view() reflects its event.
    shown_when_heard = b->view().event_seq() >= e.seq && *b->height(x, y) < before - 2.0;
  });
  std::vector<loam::game::StampResult> results;
  a->on_stamp_result([&](const loam::game::StampResult& r) { results.push_back(r); });

  const uint64_t ticket = a->stamp(crater_at(x, y));
  ASSERT_GT(ticket, 0u);
  ASSERT_TRUE(a->flush(5s));
  const double predicted = *a->height(x, y);
  EXPECT_LT(predicted, before - 2.0);  // shown at once, before the server answered
  ASSERT_TRUE(a->wait_settled(30s));
  a->dispatch();
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].ticket, ticket);
  EXPECT_TRUE(results[0].accepted) << results[0].error;
  const double confirmed = *a->height(x, y);
  EXPECT_EQ(confirmed, predicted);  // the prediction was exact

  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (heard.empty() && std::chrono::steady_clock::now() < deadline) {
    b->dispatch();
    std::this_thread::sleep_for(5ms);
  }
  ASSERT_EQ(heard.size(), 1u);
  EXPECT_FALSE(heard[0].own);
  EXPECT_EQ(heard[0].seq, results[0].seq);
  EXPECT_EQ(heard[0].stamp.kind, StampKind::kCrater);
  EXPECT_NEAR(heard[0].stamp.x, x, 1e-2);
  EXPECT_NEAR(heard[0].stamp.radius, 12, 1e-2);
  EXPECT_LE(heard[0].x0, x - 10);
  EXPECT_GE(heard[0].x1, x + 10);
  EXPECT_TRUE(shown_when_heard);
  // Both hold the same terrain: at every sample around the crater, the same heights.
  const auto va = a->view(), vb = b->view();
  const double h = a->world().meters_per_sample;
  for (int j = -12; j <= 12; ++j) {
    for (int i = -12; i <= 12; ++i)
      ASSERT_EQ(*va.height(x + i * h, y + j * h), *vb.height(x + i * h, y + j * h));
  }
  // A ray and a dropped sphere find the crater's floor.
  const auto ray = vb.raycast({x, y, before + 30}, {0, 0, -1}, 100);
  ASSERT_TRUE(ray.hit);
  EXPECT_NEAR(ray.hit->point.z, confirmed, 1e-9);
  const auto drop = vb.sweep_sphere({x, y, before + 30}, 0.5, {0, 0, -100});
  ASSERT_TRUE(drop.hit);
  // It rests touching the surface (the crater's wall here is steep: on it, not at the floor).
  const double cz = before + 30 - 100 * drop.hit->t;
  const auto& p = drop.hit->point;
  EXPECT_NEAR(p.z, *vb.height(p.x, p.y), 1e-6);
  EXPECT_NEAR(std::hypot(p.x - x, p.y - y, p.z - cz), 0.5, 1e-5);
  EXPECT_GE(cz - 0.5, confirmed - 1e-6);
}

TEST(GameClient, AGameThreadQueriesWhileTheNetworkThreadPublishes) {
  loam::test::ServerProcess server;
  ASSERT_TRUE(server.start(data_dir("server"))) << server.log();
  auto a = join(server.port(), "digger");
  ASSERT_TRUE(a);
  const auto [x, y] = centre(*a);
  a->set_view(x, y, 150);
  ASSERT_TRUE(a->wait_for_view(30s));
  std::atomic<bool> stop{false};
  std::atomic<uint64_t> queries{0}, misses{0};
  std::atomic<bool> generations_ordered{true};
  std::thread game([&] {
    uint64_t last = 0;
    int k = 0;
    while (!stop) {
      const auto v = a->view();
      if (v.generation() < last) generations_ordered = false;
      last = v.generation();
      const double qx = x + (k % 41 - 20) * 1.25, qy = y + (k / 41 % 41 - 20) * 1.25;
      const auto hgt = v.height(qx, qy);
      const auto n = v.normal(qx, qy);
      if (!hgt || !n || !std::isfinite(*hgt)) ++misses;
      ++k;
      ++queries;
    }
  });
  for (int i = 0; i < 20; ++i) {
    Stamp s = crater_at(x + (i % 5 - 2) * 15.0, y + (i / 5 - 2) * 15.0);
    s.radius = 6;
    s.intensity = 0.5;
    ASSERT_GT(a->stamp(s), 0u);
    std::this_thread::sleep_for(10ms);
  }
  ASSERT_TRUE(a->wait_settled(60s));
  stop = true;
  game.join();
  EXPECT_GT(queries.load(), 1000u);
  EXPECT_EQ(misses.load(), 0u);
  EXPECT_TRUE(generations_ordered.load());
  EXPECT_EQ(a->view().own_stamps_shown(), 0u);
  // The HUD's numbers: a round trip measured, bytes counted, the server's clients and ticks.
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  loam::game::SessionStats st;
  while (std::chrono::steady_clock::now() < deadline) {
    st = a->session();
    if (st.rtt_ms > 0 && st.server_clients > 0 && st.server_sequence >= 20) break;
    std::this_thread::sleep_for(50ms);
  }
  EXPECT_TRUE(st.connected);
  EXPECT_GT(st.rtt_ms, 0.0);
  EXPECT_LT(st.rtt_ms, 5000.0);
  EXPECT_GE(st.server_clients, 1u);
  EXPECT_GE(st.server_sequence, 20u);
  EXPECT_GT(st.bytes_in, 0u);
  EXPECT_GT(st.bytes_out, 0u);
  EXPECT_GT(st.tiles_held, 0u);
}

TEST(GameClient, BadStampsAreRefusedWithTheReasonAndSpectatorsCannotDig) {
  loam::test::ServerProcess server;
  ASSERT_TRUE(server.start(data_dir("server"))) << server.log();
  auto a = join(server.port(), "digger");
  ASSERT_TRUE(a);
  const auto [x, y] = centre(*a);
  std::string error;
  Stamp nan_radius = crater_at(x, y);
  nan_radius.radius = std::nan("");
  EXPECT_EQ(a->stamp(nan_radius, &error), 0u);
  EXPECT_NE(error.find("radius"), std::string::npos) << error;
  Stamp huge = crater_at(x, y);
  huge.intensity = 1e9;
  EXPECT_EQ(a->stamp(huge, &error), 0u);
  EXPECT_NE(error.find("intensity"), std::string::npos) << error;
  auto watcher = join(server.port(), "watcher", true);
  ASSERT_TRUE(watcher);
  EXPECT_EQ(watcher->stamp(crater_at(x, y), &error), 0u);
  EXPECT_NE(error.find("spectator"), std::string::npos) << error;
  // A texture the server never registered: sent, and the server's refusal reported.
  Stamp texture = crater_at(x, y);
  texture.kind = StampKind::kTexture;
  texture.shape = 0;
  texture.texture_id = 0x1234;
  std::vector<loam::game::StampResult> results;
  a->on_stamp_result([&](const loam::game::StampResult& r) { results.push_back(r); });
  const uint64_t ticket = a->stamp(texture, &error);
  ASSERT_GT(ticket, 0u) << error;
  ASSERT_TRUE(a->wait_settled(30s));
  a->dispatch();
  ASSERT_EQ(results.size(), 1u);
  EXPECT_FALSE(results[0].accepted);
  EXPECT_FALSE(results[0].error.empty());
}

TEST(GameClient, AServerWithTokensRefusesAClientWithout) {
  const std::string dir = data_dir("server");
  std::filesystem::create_directories(dir);
  {
    std::ofstream f(dir + "/tokens");
    f << "editor 0123456789abcdef0123456789abcdef\n";
  }
  loam::test::ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--tokens-file", dir + "/tokens"})) << server.log();
  loam::game::Options o;
  o.port = server.port();
  std::string error;
  EXPECT_FALSE(Client::connect(o, &error));
  EXPECT_FALSE(error.empty());
  o.token = "not hex";
  EXPECT_FALSE(Client::connect(o, &error));
  EXPECT_NE(error.find("token"), std::string::npos) << error;
  o.token = "0123456789abcdef0123456789abcdef";
  auto c = Client::connect(o, &error);
  EXPECT_TRUE(c) << error;
}

}  // namespace
