#include "client/view/viewer_app.h"

#include <epoxy/gl.h>
// After epoxy: GLFW must not pull in a second set of GL declarations.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <thread>

#include "client/controls/fly_camera.h"
#include "client/controls/stamp_tool.h"
#include "client/controls/walker.h"
#include "client/query/terrain_query.h"
#include "client/render/offscreen_target.h"
#include "client/render/reversed_depth.h"
#include "client/render/viewer_session.h"
#include "client/terrain/minimap.h"
#include "client/terrain/tile_states.h"
#include "client/view/hud.h"
#include "client/view/stamp_previews.h"
#include "client/view/viewer_window.h"
#include "gpu/egl_context.h"
#include "gpu/glfw_context.h"
#include "protocol/stamps/stamp_validate.h"

namespace loam::view {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Sends the tool's stamp for a click at a terrain point; false when the stamp is not valid here
// (outside the world, say) or the connection is gone.
bool stamp_at(render::ViewerSession& session, controls::StampTool& tool, const std::array<double, 3>& p) {
  auto q = validate_stamp(tool.at(p[0], p[1], p[2]), session.client().welcome().world, {},
                          &session.client().textures());
  if (!q) {
    std::fprintf(stderr, "viewer: %s stamp not made: %s\n", to_string(tool.kind),
                 q.error().describe().c_str());
    return false;
  }
  return session.deform(*q).ok();
}

std::string numbered(const std::string& file, int index) {
  char suffix[32];
  std::snprintf(suffix, sizeof suffix, "_%04d", index);
  const size_t dot = file.rfind('.');
  return dot == std::string::npos ? file + suffix : file.substr(0, dot) + suffix + file.substr(dot);
}

void print_stats(double t, const render::ViewerSession& s, const render::FrameStats& f, double frame_ms) {
  const render::ViewerStats v = s.stats();
  // The error-driven clipmap's budget met (the classic clipmap has none).
  char budget[48] = "";
  if (f.lod_budget_px > 0) std::snprintf(budget, sizeof budget, ", error within %.2f px", f.lod_budget_px);
  std::printf(
      "viewer %6.1f s: frame %.1f ms, %lld triangles, %d draws%s | tiles %llu/%llu | events "
      "%llu applied, %llu "
      "on "
      "the GPU | levels %llu samples filled on the GPU, %llu uploaded | GPU bus %.1f KiB up, %.1f KiB back | "
      "overlay %zu, predicted %llu, corrections %llu | divergent %llu | hashes %llu checked, %llu "
      "mismatched | terrain memory GPU %.1f MiB (%d pages), CPU %.1f MiB | RTT %.1f ms, in %.1f KiB/s, "
      "server "
      "tick p99 %.2f ms\n",
      t, frame_ms, (long long)f.triangles, f.draw_calls, budget, (unsigned long long)v.tiles_held,
      (unsigned long long)v.tiles_subscribed, (unsigned long long)v.events_applied,
      (unsigned long long)v.display.events_stamped, (unsigned long long)v.level_traffic.texels_on_gpu,
      (unsigned long long)v.level_traffic.texels_uploaded,
      double(v.display_traffic.bytes_uploaded + v.level_traffic.bytes_uploaded) / 1024.0,
      double(v.display_traffic.bytes_read_back) / 1024.0, v.overlay, (unsigned long long)v.display.predicted,
      (unsigned long long)v.display.corrections, (unsigned long long)v.display.divergent_texels,
      (unsigned long long)v.hash_checks, (unsigned long long)v.hash_mismatches,
      double(v.gpu_terrain_bytes) / (1 << 20), v.gpu_pages_resident, double(v.cpu_terrain_bytes) / (1 << 20),
      v.rtt_ms, v.bytes_in_per_s / 1024.0, v.server_tick_p99_us / 1000.0);
  std::fflush(stdout);
}

// What the last frame showed: the share of its pixels that are terrain (depth not the
// background's), read from the framebuffer. Tests and the main job's smoke run check it.
void print_coverage(const char* where, double fraction) {
  std::printf("viewer %s: terrain covers %.1f%% of the view\n", where, 100.0 * fraction);
  std::fflush(stdout);
}

double terrain_fraction(const std::vector<float>& depth) {
  if (depth.empty()) return 0.0;
  const auto n =
      std::count_if(depth.begin(), depth.end(), [](float d) { return d != scene::kBackgroundDepth; });
  return double(n) / double(depth.size());
}

int exit_code(const render::ViewerSession& s) {
  const render::ViewerStats v = s.stats();
  return v.hash_mismatches == 0 && v.display.divergent_texels == 0 ? 0 : 3;
}

// The connection is gone: join again, once a second for up to 30 s (a server restarting).
bool reconnect(render::ViewerSession& s, const ViewerAppOptions& o, const Status& why) {
  std::fprintf(stderr, "viewer: connection lost (%s); reconnecting to %s:%u\n",
               why.error().describe().c_str(), o.host.c_str(), unsigned(o.port));
  for (int attempt = 0; attempt < 30; ++attempt) {
    const Status st = s.reconnect(o.host, o.port);
    if (st.ok()) {
      std::fprintf(stderr, "viewer: reconnected as client %u\n", s.client().welcome().client_id);
      return true;
    }
    if (st.error().code == ErrorCode::kUnsupported) {  // another world, or a protocol we do not speak
      std::fprintf(stderr, "viewer: %s\n", st.error().describe().c_str());
      return false;
    }
    std::this_thread::sleep_for(std::chrono::seconds(1));
  }
  return false;
}

render::ViewerOptions session_options(const ViewerAppOptions& o) {
  render::ViewerOptions vo;
  vo.lod = o.lod;
  vo.renderer = o.renderer;
  vo.error_clipmap = o.error_clipmap;
  vo.stamping = o.stamping;
  vo.gpu_cache_pages = int32_t(o.gpu_cache_mb * 8);  // 128 KiB a coarse page
  vo.name = o.name;
  vo.token = o.token;
  vo.tls = o.tls;
  vo.role = wire::Role::kPlayer;
  return vo;
}

int run_headless(const ViewerAppOptions& o) {
  auto ctx = gpu::EglContext::create();
  if (!ctx || !ctx->make_current().ok()) {
    std::fprintf(stderr, "loam-client view: %s\n",
                 ctx ? "cannot make the EGL context current" : ctx.error().describe().c_str());
    return 1;
  }
  auto session = render::ViewerSession::connect(o.host, o.port, session_options(o));
  if (!session) {
    std::fprintf(stderr, "loam-client view: %s\n", session.error().describe().c_str());
    return 1;
  }
  render::ViewerSession& s = **session;
  auto target = render::OffscreenTarget::create(o.width, o.height);
  if (!target) {
    std::fprintf(stderr, "loam-client view: %s\n", target.error().describe().c_str());
    return 1;
  }
  std::printf(
      "viewer (headless): %s, %dx%d, %s clipmap, %d levels, %s stamping (--stamping %s), joined as "
      "client %u\n",
      ctx->renderer().c_str(), o.width, o.height, render::to_string(s.lod()), s.levels(),
      render::to_string(s.stamping()), render::to_string(o.stamping), s.client().welcome().client_id);
  // The start view: an orbit around the world's centre sized for the world (on a world of tens
  // of kilometres, a low orbit of 1.5 km: what a player sees, not the whole world from afar).
  const scene::ViewScale scale = scene::view_scale(s.client().welcome().world);
  const double cx = scale.focus_x, cy = scale.focus_y;
  const scene::GroundFn ground = display_ground(s);
  controls::StampTool tool;
  const double seconds = o.seconds > 0 ? o.seconds : 30.0;
  const auto t0 = Clock::now();
  double next_stamp = o.stamp_every_s, next_shot = o.screenshot_every_s, next_print = 1.0;
  int shots = 0;
  render::FrameStats f;
  double frame_ms = 0;
  scene::Camera cam;
  // Level coverage per frame: how often, and for how long, a level shows a coarser mip.
  int64_t frames = 0, frames_lacking = 0, frames_waiting = 0;
  double longest_wait = 0;
  // A flight loops once a minute at the asked speed (300 m/s: 2.9 km around the centre).
  const double flight_radius = o.fly_mps > 0 ? o.fly_mps * 60.0 / (2.0 * std::numbers::pi) : 0.0;
  // Walk mode: a walker at the centre looks around (a turn every 20 s) and, when asked, a crater
  // is dug under its feet: it falls to the floor and looks at the walls.
  std::optional<controls::Walker> walker;
  bool dug = false;
  auto t_prev = t0;
  for (double t = 0; t < seconds; t = seconds_since(t0)) {
    if (o.walk) {
      // The walker steps at 60 Hz through the time the frame took (up to a second), so it falls
      // and lands in real time however slow the frames are.
      const double elapsed = std::min(1.0, seconds_since(t_prev));
      t_prev = Clock::now();
      if (!walker && query::height_at(s.terrain(), cx, cy))
        walker = controls::place_walker(s.terrain(), cx, cy);
      const double yaw = 2.0 * std::numbers::pi * t / 20.0;
      if (walker) {
        for (double left = elapsed; left > 1e-9; left -= 1.0 / 60.0)
          controls::step_walker(*walker, s.terrain(), controls::WalkerInput{0, 0, yaw, false, false},
                                std::min(left, 1.0 / 60.0));
      }
      const glm::dvec3 eye =
          walker ? controls::walker_eye(*walker) : glm::dvec3{cx, cy, ground(cx, cy) + 1.65};
      cam = scene::look_at(eye.x, eye.y, eye.z, eye.x + std::cos(yaw) * 10.0, eye.y + std::sin(yaw) * 10.0,
                           eye.z - 0.8);
      cam.fov_y_degrees = 70;
      cam.near_m = 0.1;
      cam.far_m = 6000.0;
      if (walker && !dug && o.dig_under_s > 0 && t >= o.dig_under_s) {
        dug = true;
        controls::StampTool dig;
        dig.radius_m = 12.0;
        dig.select(controls::Tool::kCrater);
        if (stamp_at(s, dig, {walker->feet.x, walker->feet.y, walker->feet.z})) {
          std::printf("viewer: dug a crater under the walker at %.1f, %.1f (feet at %.2f m)\n",
                      walker->feet.x, walker->feet.y, walker->feet.z);
        }
      }
    } else if (o.fly_mps > 0) {
      cam = controls::flight_camera(cx, cy, flight_radius, 120.0, o.fly_mps, t, ground);
      cam.far_m = 8000.0;
    } else {
      cam = scene::orbit_view(scale, 2.0 * std::numbers::pi * t / 90.0, ground);
    }
    if (const Status st = s.update(cam, std::chrono::milliseconds(5)); !st.ok() && !reconnect(s, o, st))
      return 1;
    const auto f0 = Clock::now();
    target->begin(0.50f, 0.60f, 0.75f, 0.0f);
    f = s.render(cam, o.width, o.height);
    glFinish();
    frame_ms = seconds_since(f0) * 1000.0;
    const render::LevelCoverage cov = s.coverage();
    ++frames;
    frames_lacking += cov.levels_lacking > 0;
    frames_waiting += cov.longest_wait_s > 0.5;
    longest_wait = std::max(longest_wait, cov.longest_wait_s);
    if (o.stamp_every_s > 0 && t >= next_stamp) {
      next_stamp += o.stamp_every_s;
      tool.select(int(t / o.stamp_every_s) % 3 == 2 ? controls::Tool::kRaise : controls::Tool::kCrater);
      const std::vector<float> depth = target->read_depth();
      const int32_t px = o.width / 2, py = o.height / 2;
      if (auto p = scene::unproject(cam, o.width, o.height, px, py, depth[size_t(py * o.width + px)])) {
        // Big enough to see from where the camera is: a twentieth of the distance.
        tool.set_radius(
            std::clamp(0.05 * std::hypot((*p)[0] - cam.x, (*p)[1] - cam.y, (*p)[2] - cam.z), 3.0, 40.0));
        stamp_at(s, tool, *p);
      }
    }
    if (o.screenshot_every_s > 0 && t >= next_shot) {
      next_shot += o.screenshot_every_s;
      (void)render::write_png(numbered(o.screenshot, ++shots), o.width, o.height, target->read_rgba());
    }
    if (t >= next_print) {
      next_print += 1.0;
      print_stats(t, s, f, frame_ms);
    }
  }
  // Let the last stamps settle, then the final picture and numbers.
  s.wait_settled(cam, std::chrono::seconds(5));
  target->begin(0.50f, 0.60f, 0.75f, 0.0f);
  f = s.render(cam, o.width, o.height);
  const std::string last = shots > 0 ? numbered(o.screenshot, ++shots) : o.screenshot;
  if (const Status st = render::write_png(last, o.width, o.height, target->read_rgba()); !st.ok()) {
    std::fprintf(stderr, "loam-client view: %s\n", st.error().describe().c_str());
  }
  print_stats(seconds_since(t0), s, f, frame_ms);
  print_coverage("headless", terrain_fraction(target->read_depth()));
  if (walker) {
    // The terrain settled since the walker last stepped (the last events came in): it takes
    // half a second on the terrain the final view shows, as a player would see it come to rest.
    for (int i = 0; i < 30; ++i)
      controls::step_walker(*walker, s.terrain(), controls::WalkerInput{}, 1.0 / 60.0);
    std::printf(
        "viewer walker: feet at %.2f, %.2f, %.2f m, ground %.2f m, %s (%.2f s in the air, ground normal "
        "%.2f, "
        "%.2f, %.2f)\n",
        walker->feet.x, walker->feet.y, walker->feet.z,
        query::height_at(s.terrain(), walker->feet.x, walker->feet.y).value_or(-1.0),
        walker->grounded ? "standing" : "in the air", walker->airborne_s, walker->ground_normal.x,
        walker->ground_normal.y, walker->ground_normal.z);
    if (!walker->grounded) {
      // What it is caught on: the heights around its feet, 0.25 m apart.
      std::printf("viewer walker: heights around the feet (rows north to south, 0.25 m apart):\n");
      for (int j = 4; j >= -4; --j) {
        for (int i = -4; i <= 4; ++i) {
          std::printf(" %8.3f",
                      query::height_at(s.terrain(), walker->feet.x + 0.25 * i, walker->feet.y + 0.25 * j)
                          .value_or(-1.0));
        }
        std::printf("\n");
      }
    }
  }
  std::printf(
      "viewer coverage: %lld frames, %.2f%% with a level on a coarser mip, %.2f%% waiting over 0.5 s, "
      "longest wait %.2f s\n",
      (long long)frames, frames ? 100.0 * double(frames_lacking) / double(frames) : 0.0,
      frames ? 100.0 * double(frames_waiting) / double(frames) : 0.0, longest_wait);
  std::printf("viewer: final view in %s\n", last.c_str());
  return exit_code(s);
}

struct WindowState {
  double scroll = 0;
};

void on_scroll(GLFWwindow* window, double, double dy) {
  static_cast<WindowState*>(glfwGetWindowUserPointer(window))->scroll += dy;
}

int run_window(const ViewerAppOptions& o) {
  auto window = gpu::GlfwContext::create(
      {.width = o.width, .height = o.height, .title = "Loam viewer", .vsync = o.vsync, .visible = true});
  if (!window) {
    std::fprintf(stderr, "loam-client view: %s (use --headless on a machine without a display)\n",
                 window.error().describe().c_str());
    return 1;
  }
  GLFWwindow* win = window->window();
  WindowState state;
  glfwSetWindowUserPointer(win, &state);
  glfwSetScrollCallback(win, on_scroll);  // before ImGui, which chains to it
  auto session = render::ViewerSession::connect(o.host, o.port, session_options(o));
  if (!session) {
    std::fprintf(stderr, "loam-client view: %s\n", session.error().describe().c_str());
    return 1;
  }
  render::ViewerSession& s = **session;
  HudOverlay overlay(win);
  // The start view of this world: the terrain around its centre, the speed and tool sizes
  // that suit its size and spacing.
  const scene::ViewScale scale = scene::view_scale(s.client().welcome().world);
  controls::FlyCamera fly = window_start(s, scale);
  controls::StampTool tool;
  tool.select(controls::Tool::kCrater);
  scale_tool(tool, scale);
  std::printf(
      "viewer (window): %s, %dx%d, %s clipmap, %d levels, %s stamping (--stamping %s), joined as client %u; "
      "camera at %.0f, %.0f, %.0f m, speed %.0f m/s, stamp radius %.1f m (%.1f .. %.0f)\n",
      window->renderer().c_str(), o.width, o.height, render::to_string(s.lod()), s.levels(),
      render::to_string(s.stamping()), render::to_string(o.stamping), s.client().welcome().client_id, fly.x(),
      fly.y(), fly.z(), fly.speed(), tool.radius_m, tool.min_radius_m, tool.max_radius_m);
  terrain::TileStates tiles;
  StampPreviews previews;
  double next_tiles = 0;
  const scene::GroundFn ground = display_ground(s);
  bool hud = o.hud, was_left = false, was_f1 = false, was_f12 = false, was_g = false, was_space = false;
  std::optional<controls::Walker> walker;
  bool walking = o.walk;
  int shots = 0;
  double last_x = 0, last_y = 0;
  glfwGetCursorPos(win, &last_x, &last_y);
  auto last = Clock::now();
  const auto t0 = last;
  render::FrameStats f;
  double frame_ms = 0, terrain = 0;
  int code = 0;
  for (bool final = false; !final && !window->should_close();) {
    final = o.seconds > 0 && seconds_since(t0) >= o.seconds;  // draw this frame, then stop
    gpu::GlfwContext::poll_events();
    const double dt = std::min(0.1, seconds_since(last));
    last = Clock::now();
    double mx = 0, my = 0;
    glfwGetCursorPos(win, &mx, &my);
    controls::FlyInput in;
    controls::WalkerInput walk_in;
    bool shoot = false;
    if (!(hud && overlay.wants_keyboard())) {
      auto key = [&](int k) { return glfwGetKey(win, k) == GLFW_PRESS ? 1.0 : 0.0; };
      in.forward = key(GLFW_KEY_W) - key(GLFW_KEY_S);
      in.right = key(GLFW_KEY_D) - key(GLFW_KEY_A);
      in.up = key(GLFW_KEY_E) - key(GLFW_KEY_Q);
      in.fast = key(GLFW_KEY_LEFT_SHIFT) > 0 || key(GLFW_KEY_RIGHT_SHIFT) > 0;
      for (int i = 0; i < controls::kToolCount; ++i) {
        if (key(GLFW_KEY_1 + i) > 0) tool.select(controls::Tool(i));
      }
      const bool f1 = key(GLFW_KEY_F1) > 0;
      if (f1 && !was_f1) hud = !hud;
      was_f1 = f1;
      shoot = key(GLFW_KEY_F12) > 0 && !was_f12;
      was_f12 = key(GLFW_KEY_F12) > 0;
      if (key(GLFW_KEY_G) > 0 && !was_g) {
        walking = !walking;
        walker.reset();
      }
      was_g = key(GLFW_KEY_G) > 0;
      walk_in.jump = key(GLFW_KEY_SPACE) > 0 && !was_space;
      was_space = key(GLFW_KEY_SPACE) > 0;
      if (key(GLFW_KEY_ESCAPE) > 0) glfwSetWindowShouldClose(win, GLFW_TRUE);
      // The sun: Z/X turn it (azimuth), C/V lower and raise it; the shadows follow.
      const double turn = (key(GLFW_KEY_X) - key(GLFW_KEY_Z)) * 30.0 * dt,
                   lift = (key(GLFW_KEY_V) - key(GLFW_KEY_C)) * 10.0 * dt;
      if (turn != 0 || lift != 0) {
        const std::array<float, 2> sun = s.sun();
        s.set_sun(float(std::fmod(sun[0] + turn + 360.0, 360.0)), float(sun[1] + lift));
      }
    }
    const bool over_hud = hud && overlay.wants_mouse();
    if (!over_hud && glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) {
      in.turn_x = mx - last_x;
      in.turn_y = my - last_y;
    }
    last_x = mx, last_y = my;
    if (!over_hud && state.scroll != 0) tool.grow(std::pow(1.15, state.scroll));
    state.scroll = 0;
    if (walking) {
      // Walk: the keys move the walker, the mouse turns the view; the eye rides on the walker,
      // which starts under the eye (on the world's rim when the eye flew past the edge).
      walk_in.forward = in.forward;
      walk_in.right = in.right;
      walk_in.run = in.fast;
      walk_in.yaw = fly.yaw();
      const auto spawn = scene::walker_spawn(s.client().welcome().world, fly.x(), fly.y());
      if (!walker && query::height_at(s.terrain(), spawn[0], spawn[1]))
        walker = controls::place_walker(s.terrain(), spawn[0], spawn[1]);
      if (walker) {
        // At 60 Hz through the frame's time: a jump is taken on the first step only.
        for (double left = dt; left > 1e-9; left -= 1.0 / 60.0) {
          controls::step_walker(*walker, s.terrain(), walk_in, std::min(left, 1.0 / 60.0));
          walk_in.jump = false;
        }
        const glm::dvec3 eye = controls::walker_eye(*walker);
        fly.set_position(eye.x, eye.y, eye.z);
      }
      in.forward = in.right = in.up = 0;
    }
    fly.update(in, dt, ground, walking ? 0.0 : 2.0);
    int w = 0, h = 0;
    glfwGetFramebufferSize(win, &w, &h);
    if (w <= 0 || h <= 0) continue;  // minimised
    const scene::Camera cam = window_camera(fly, s.view_distance_m(), scale, walking);
    // A timed run's last frame shows the settled view: every tile it needs, every own stamp
    // confirmed (what a screenshot of it is compared on).
    if (final) (void)s.wait_settled(cam, std::chrono::seconds(20));
    const Status st = s.update(cam);
    if (!st.ok() && !reconnect(s, o, st)) {
      code = 1;
      break;
    }
    const auto f0 = Clock::now();
    begin_window_frame(w, h);
    f = s.render(cam, w, h);
    if (final) terrain = window_terrain_fraction(w, h);
    // A click deforms the terrain under the cursor (window coordinates scale to the framebuffer).
    const bool left = !over_hud && glfwGetMouseButton(win, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
    if (left && !was_left) {
      int ww = 1, wh = 1;
      glfwGetWindowSize(win, &ww, &wh);
      const double px = mx * double(w) / double(std::max(ww, 1)),
                   py = my * double(h) / double(std::max(wh, 1));
      float depth = scene::kBackgroundDepth;
      glReadPixels(int(px), h - 1 - int(py), 1, 1, GL_DEPTH_COMPONENT, GL_FLOAT, &depth);
      if (auto p = scene::unproject(cam, w, h, px, py, depth)) stamp_at(s, tool, *p);
    }
    was_left = left;
    if (hud) {
      // The cache view's tile states four times a second (they are sets of thousands of tiles).
      if (const double now = seconds_since(t0); now >= next_tiles || final) {
        next_tiles = now + 0.25;
        const client::ConfirmedStore& store = s.client().store();
        tiles.update(store.wanted(), store.held(), store.tiles_behind(), now);
      }
      previews.update(s.client().textures());
      HudStatus status;
      status.renderer = window->renderer();
      status.frame_ms = frame_ms;
      status.triangles = f.triangles;
      status.draw_calls = f.draw_calls;
      status.lod_budget_px = f.lod_budget_px;
      status.camera_x = fly.x(), status.camera_y = fly.y(), status.camera_z = fly.z();
      status.speed_mps = fly.speed();
      status.walking = walking;
      status.session = s.stats();
      overlay.draw(status,
                   terrain::layout_minimap(minimap_input(s, cam, double(w) / double(h), tiles), 240.0f),
                   tiles.counts(), tool, s.client().stamp_images(), previews);
    }
    // F12, or the last frame of a timed run: the window's picture, HUD included.
    if (shoot || final) {
      const std::string file = shoot ? numbered(o.screenshot, ++shots) : o.screenshot;
      if (render::write_png(file, w, h, read_window_rgba(w, h)).ok())
        std::printf("viewer: screenshot %s\n", file.c_str());
    }
    window->swap_buffers();
    frame_ms = seconds_since(f0) * 1000.0;
  }
  print_stats(seconds_since(t0), s, f, frame_ms);
  if (o.seconds > 0) print_coverage("window", terrain);
  return code != 0 ? code : exit_code(s);
}

}  // namespace

int run_viewer(const ViewerAppOptions& options) {
  return options.headless ? run_headless(options) : run_window(options);
}

}  // namespace loam::view
