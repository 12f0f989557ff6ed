// Suite `client`: what an event costs a viewer. A loam-server on the main job's refined world
// (`--terrain refined`), the viewer the product runs (ViewerSession with its defaults: the
// error-driven clipmap, in-process, headless at 1920x1080) at the start view, and a bot that
// stamps in front of it, where the viewer holds mip 0. Per confirmed event and per own stamp
// (radii 4 to 1024 m and a shockwave), in GPU and CPU stamping: the viewer thread's time for the
// update that takes it in (network, store, display, levels, error bounds), the GPU time of that
// update (timer queries), and the bytes it moved to and from the GPU. Then frames (steady,
// flying at 300 m/s, and in a storm of 60 stamps/s in view) and terrain memory per held tile.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench/harness.h"
#include "client/net/terrain_client.h"
#include "client/render/offscreen_target.h"
#include "client/render/viewer_session.h"
#include "client/scene/start_view.h"
#include "gpu/egl_context.h"
#include "protocol/stamps/stamp_validate.h"
#include "tests/integration/server_process.h"

namespace loam::bench {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// What the viewer moved over the bus so far (display copy and levels).
struct Bus {
  uint64_t up = 0, back = 0;
  int64_t level_gpu = 0, level_cpu = 0;
};
Bus bus(const render::ViewerSession& v) {
  const render::ViewerStats s = v.stats();
  return {s.display_traffic.bytes_uploaded + s.level_traffic.bytes_uploaded,
          s.display_traffic.bytes_read_back, int64_t(s.level_traffic.texels_on_gpu),
          int64_t(s.level_traffic.texels_uploaded)};
}

// A GL_TIME_ELAPSED query around a piece of work (0 where the driver has none).
class GpuTimer {
 public:
  GpuTimer() { glCreateQueries(GL_TIME_ELAPSED, 1, &q_); }
  ~GpuTimer() { glDeleteQueries(1, &q_); }
  GpuTimer(const GpuTimer&) = delete;
  GpuTimer& operator=(const GpuTimer&) = delete;
  void begin() { glBeginQuery(GL_TIME_ELAPSED, q_); }
  double end_us() {
    glEndQuery(GL_TIME_ELAPSED);
    GLuint64 ns = 0;
    glGetQueryObjectui64v(q_, GL_QUERY_RESULT, &ns);
    return double(ns) / 1000.0;
  }

 private:
  GLuint q_ = 0;
};

struct Sample {
  double cpu_us = 0, gpu_us = 0;
  double up = 0, back = 0;
  double level_gpu = 0, level_cpu = 0;
};

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

Sample median(const std::vector<Sample>& s) {
  auto pick = [&](double Sample::*f) {
    std::vector<double> v;
    for (const Sample& x : s) v.push_back(x.*f);
    return median_of(std::move(v));
  };
  return {pick(&Sample::cpu_us), pick(&Sample::gpu_us),    pick(&Sample::up),
          pick(&Sample::back),   pick(&Sample::level_gpu), pick(&Sample::level_cpu)};
}

QuantizedStamp stamp_at(const WorldParams& w, StampKind kind, double x, double y, double r) {
  StampParams p;
  p.kind = kind;
  p.center_x = x;
  p.center_y = y;
  p.radius = r;
  p.intensity = kind == StampKind::kShockwave ? 1.0 : std::clamp(r / 8, 0.5, 20.0);
  p.shape = 0.3;
  if (kind == StampKind::kShockwave) {
    p.speed = 0.5;
    p.steps = 60;
    p.damping = 0.02;
  }
  return validate_stamp(p, w).value();
}

struct Kind {
  std::string name;
  StampKind kind;
  double radius;
};

struct ModeResult {
  std::string mode;
  std::vector<std::pair<std::string, Sample>> events, predicts, settles;
  double steady_ms = 0, flying_ms = 0, storm_ms = 0, storm_p99_ms = 0;
  int64_t triangles = 0;
  double budget_px = 0;
  double cpu_bytes_per_tile = 0, gpu_page_bytes = 0, gpu_terrain_mib = 0;
  uint64_t tiles_held = 0;
  int32_t pages = 0;
  std::string note;
};

ModeResult run_mode(const Context& ctx, uint16_t port, render::DisplayStamping stamping) {
  ModeResult r;
  r.mode = render::to_string(stamping);
  const int32_t W = ctx.quick ? 320 : 1920, H = ctx.quick ? 180 : 1080;
  render::ViewerOptions o;
  o.stamping = stamping;
  o.gpu_audit_tiles = 0;  // measured apart: the sampled check reads 128 KiB a second
  o.name = "client-suite";
  auto v = render::ViewerSession::connect("127.0.0.1", port, o);
  if (!v) {
    r.note = v.error().describe();
    return r;
  }
  render::ViewerSession& view = **v;
  auto target = render::OffscreenTarget::create(W, H);
  if (!target) {
    r.note = target.error().describe();
    return r;
  }
  const WorldParams& w = view.client().welcome().world;
  const scene::ViewScale vs = scene::view_scale(w);
  const terrain::HeightSource& ground = view.display();
  scene::Camera cam =
      scene::orbit_view(vs, 0.0, [&](double x, double y) { return terrain::ground_height(ground, x, y); });
  auto frame = [&](const scene::Camera& c) {
    const auto t0 = std::chrono::steady_clock::now();
    target->begin(0.5f, 0.6f, 0.75f, 0.0f);
    const render::FrameStats f = view.render(c, W, H);
    glFinish();
    r.triangles = f.triangles;
    r.budget_px = f.lod_budget_px;
    return ms_since(t0);
  };
  if (!view.wait_settled(cam, 120s)) r.note = "the view did not settle in 120 s; ";
  frame(cam);

  client::TerrainClient bot;
  if (!bot.connect("127.0.0.1", port, "client-suite-bot", wire::Role::kBot).ok()) {
    r.note += "the bot could not connect";
    return r;
  }
  // In front of the eye, toward the focus: held at mip 0 (the viewer holds it within 384 m).
  const double dx = vs.focus_x - cam.x, dy = vs.focus_y - cam.y, d = std::hypot(dx, dy);
  const double px = cam.x + dx / d * 200, py = cam.y + dy / d * 200;
  GpuTimer timer;
  // Takes in whatever arrived, timed; true where the store applied an event meanwhile.
  auto timed_update = [&](Sample& s) {
    const uint64_t applied = view.client().store().counters().events_applied;
    const Bus b0 = bus(view);
    timer.begin();
    const auto t0 = std::chrono::steady_clock::now();
    (void)view.update(cam, 0ms);
    s.cpu_us = ms_since(t0) * 1000.0;
    s.gpu_us = timer.end_us();
    const Bus b1 = bus(view);
    s.up = double(b1.up - b0.up), s.back = double(b1.back - b0.back);
    s.level_gpu = double(b1.level_gpu - b0.level_gpu), s.level_cpu = double(b1.level_cpu - b0.level_cpu);
    return view.client().store().counters().events_applied > applied;
  };
  const std::vector<Kind> kinds =
      ctx.quick ? std::vector<Kind>{{"crater r 16 m", StampKind::kCrater, 16}}
                : std::vector<Kind>{{"crater r 4 m", StampKind::kCrater, 4},
                                    {"crater r 16 m", StampKind::kCrater, 16},
                                    {"crater r 64 m", StampKind::kCrater, 64},
                                    {"crater r 256 m", StampKind::kCrater, 256},
                                    {"crater r 1024 m", StampKind::kCrater, 1024},
                                    {"shockwave r 8 m, 60 steps", StampKind::kShockwave, 8}};
  const int reps = ctx.quick ? 2 : 7;
  for (const Kind& k : kinds) {
    std::vector<Sample> events, predicts, settles;
    for (int i = 0; i < reps; ++i) {
      const double ox = 30.0 * (i % 3 - 1), oy = 30.0 * (i / 3 - 1);
      // A confirmed event: the bot's stamp, taken in by one update once it has arrived.
      auto seq = bot.deform(stamp_at(w, k.kind, px + ox, py + oy, k.radius));
      if (!seq || !bot.wait_until([&] { return bot.ack(*seq).has_value(); }, 30s)) continue;
      std::this_thread::sleep_for(20ms);
      Sample s;
      bool got = false;
      for (int tries = 0; tries < 50 && !got; ++tries) {
        got = timed_update(s);
        if (!got) std::this_thread::sleep_for(5ms);
      }
      if (got) events.push_back(s);
      frame(cam);
      // An own stamp: shown at once (predict), then settled when its event arrives.
      Sample p;
      const Bus b0 = bus(view);
      timer.begin();
      const auto t0 = std::chrono::steady_clock::now();
      const auto own = view.deform(stamp_at(w, k.kind, px - ox, py - oy, k.radius));
      p.cpu_us = ms_since(t0) * 1000.0;
      p.gpu_us = timer.end_us();
      // The display's share (the levels take the change at the next update).
      const Bus b1 = bus(view);
      p.up = double(b1.up - b0.up), p.back = double(b1.back - b0.back);
      if (own) predicts.push_back(p);
      Sample settle;
      bool settled = false;
      for (int tries = 0; tries < 400 && !settled && own; ++tries) {
        const size_t before = view.display().overlay_size();
        Sample u;
        timed_update(u);
        settle.cpu_us += u.cpu_us, settle.gpu_us += u.gpu_us, settle.up += u.up, settle.back += u.back;
        settle.level_gpu += u.level_gpu, settle.level_cpu += u.level_cpu;
        settled = view.display().overlay_size() < before || view.display().overlay_size() == 0;
        if (!settled) std::this_thread::sleep_for(5ms);
      }
      if (settled) settles.push_back(settle);
      frame(cam);
    }
    r.events.push_back({k.name, median(events)});
    r.predicts.push_back({k.name, median(predicts)});
    r.settles.push_back({k.name, median(settles)});
    std::printf("client: %s stamping, %s: event %.0f us, %.0f B up, %.0f B back\n", r.mode.c_str(),
                k.name.c_str(), r.events.back().second.cpu_us, r.events.back().second.up,
                r.events.back().second.back);
    std::fflush(stdout);
  }

  // Frames: steady, flying at 300 m/s (10 m a frame at 30 frames a second), a storm.
  const int frames = ctx.quick ? 3 : 20;
  std::vector<double> steady, flying, storm;
  for (int i = 0; i < frames; ++i) {
    (void)view.update(cam, 0ms);
    steady.push_back(frame(cam));
  }
  scene::Camera fly = cam;
  for (int i = 0; i < frames; ++i) {
    fly.x += dx / d * 10, fly.y += dy / d * 10;
    (void)view.update(fly, 0ms);
    flying.push_back(frame(fly));
  }
  (void)view.wait_settled(cam, 60s);
  const auto storm_start = std::chrono::steady_clock::now();
  int sent = 0;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> off(-150, 150), rad(2, 20);
  while (ms_since(storm_start) < (ctx.quick ? 500 : 3000)) {
    const int due = int(ms_since(storm_start) * 0.06);  // 60 a second
    for (; sent < due; ++sent)
      (void)bot.deform(stamp_at(w, StampKind::kCrater, px + off(rng), py + off(rng), rad(rng)));
    (void)bot.pump(0ms);
    (void)view.update(cam, 0ms);
    storm.push_back(frame(cam));
  }
  r.steady_ms = median_of(steady);
  r.flying_ms = median_of(flying);
  r.storm_ms = median_of(storm);
  std::sort(storm.begin(), storm.end());
  r.storm_p99_ms = storm.empty() ? 0 : storm[std::min(storm.size() - 1, size_t(double(storm.size()) * 0.99))];
  const render::ViewerStats s = view.stats();
  r.tiles_held = s.tiles_held;
  r.cpu_bytes_per_tile = s.tiles_held ? double(s.cpu_terrain_bytes) / double(s.tiles_held) : 0;
  r.pages = s.gpu_pages_resident;
  r.gpu_page_bytes = double(s.gpu_page_bytes);
  r.gpu_terrain_mib = double(s.gpu_terrain_bytes) / (1 << 20);
  return r;
}

int run_client(const Context& ctx, Report& report) {
  if (ctx.sanitized)
    report.paragraph("**Built with sanitizers: the numbers below are a smoke test, not measurements.**");
  auto egl = gpu::EglContext::create(gpu::EglPreference::kAny);
  if (!egl || !egl->make_current().ok()) {
    report.paragraph("Skipped: no EGL display gives an OpenGL 4.5 core context.");
    return 0;
  }
  const std::string renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const std::string dir =
      (fs::temp_directory_path() / ("loam_bench_client_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  test::ServerProcess server;
  if (!server.start(dir, {"--terrain", "refined", "--tick-hz", "60"})) {
    std::fprintf(stderr, "client: the server did not start: %s\n", server.log().c_str());
    return 1;
  }
  std::vector<ModeResult> modes;
  // The smoke run takes the GPU path alone.
  for (const auto m : {render::DisplayStamping::kGpu, render::DisplayStamping::kCpu}) {
    if (ctx.quick && m == render::DisplayStamping::kCpu) continue;
    modes.push_back(run_mode(ctx, server.port(), m));
  }
  server.kill9();
  fs::remove_all(dir);

  report.paragraph(
      "A `loam-server serve --terrain refined` (the main job's 131 km world at 1 m) and, in this process, "
      "the viewer "
      "`loam-client view` runs: `ViewerSession` with its defaults (the error-driven clipmap, " +
      std::string(ctx.quick ? "320 x 180" : "1920 x 1080") +
      ", offscreen) at the start view, in GPU stamping and in CPU stamping (`--stamping gpu|cpu`; `auto` "
      "takes the "
      "CPU on a software rasterizer). A bot stamps 200 m in front of the eye (where the viewer holds mip 0). "
      "GL: " +
      renderer + ". Machine: " + ctx.machine + ".");
  report.paragraph(
      "**Per confirmed event**: the viewer thread's time for the one `update()` that takes the event in (the "
      "network read, the confirmed store's stamp, the display's copy, the GPU copy's stamp, the levels and "
      "their "
      "error bounds), the GPU time of that update (`GL_TIME_ELAPSED`; llvmpipe runs it on the CPU, inside "
      "the "
      "first figure), the bytes it uploaded to the GPU and read back, and the level samples filled GPU to "
      "GPU "
      "against those read on the CPU and uploaded. **Own stamp**: `deform()` (shown at once: stamped on the "
      "GPU "
      "copy and the CPU copy), then the updates until it settles (its reach rebuilt from the store and "
      "uploaded, "
      "and the levels). Medians of " +
      std::to_string(ctx.quick ? 2 : 7) +
      ". The sampled audit (one 128 KiB tile a second read back) is off here.");
  Table events("events", {"stamping", "stamp", "event: viewer CPU us", "event: GPU us", "event: B up",
                          "event: B back", "event: level samples on GPU / uploaded", "own: deform() us",
                          "own: B up", "own settle: CPU us", "own settle: B up", "own settle: B back"});
  for (const ModeResult& m : modes) {
    if (!m.note.empty() && m.events.empty()) {
      report.paragraph(m.mode + " stamping: " + m.note);
      continue;
    }
    for (size_t i = 0; i < m.events.size(); ++i) {
      const Sample& e = m.events[i].second;
      const Sample& p = m.predicts[i].second;
      const Sample& s = m.settles[i].second;
      events.add_row({m.mode, m.events[i].first, fmt(e.cpu_us, 0), fmt(e.gpu_us, 0), fmt(e.up, 0),
                      fmt(e.back, 0), fmt(e.level_gpu, 0) + " / " + fmt(e.level_cpu, 0), fmt(p.cpu_us, 0),
                      fmt(p.up, 0), fmt(s.cpu_us, 0), fmt(s.up, 0), fmt(s.back, 0)});
    }
  }
  report.table(std::move(events));
  Table frames("frames",
               {"stamping", "steady ms", "flying 300 m/s ms", "storm 60/s ms (median)", "storm p99 ms",
                "triangles", "error budget met px", "tiles held", "CPU terrain B / held tile",
                "GPU pages resident", "GPU page bytes", "GPU terrain MiB"});
  for (const ModeResult& m : modes) {
    frames.add_row({m.mode, fmt(m.steady_ms, 1), fmt(m.flying_ms, 1), fmt(m.storm_ms, 1),
                    fmt(m.storm_p99_ms, 1), std::to_string(m.triangles), fmt(m.budget_px, 2),
                    std::to_string(m.tiles_held), fmt(m.cpu_bytes_per_tile, 0), std::to_string(m.pages),
                    fmt(m.gpu_page_bytes, 0), fmt(m.gpu_terrain_mib, 1)});
  }
  report.table(std::move(frames));
  report.paragraph(
      "CPU terrain bytes per held tile count the confirmed store and the display's CPU copy of every held "
      "tile "
      "(mip-0 coarse tiles are 128 KiB each; coarser mips the store alone). The GPU pages are the display's "
      "tile "
      "cache, filled only by stamps; the level textures are the rest of the GPU terrain memory.");
  return 0;
}

}  // namespace

LOAM_BENCH_SUITE(
    client, "A viewer on the refined world: CPU, GPU and bus bytes per event and own stamp, frames, memory",
    run_client);

}  // namespace loam::bench
