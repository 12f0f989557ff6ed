// loam-client: the client program.
//   view     the viewer: a window over a live session (GLFW, HUD), or --headless (EGL)
//   render   draw one frame or a camera path headless through EGL into PNGs, from a live
//            session, a DEM, a snapshot or the embedded terrain (client/render_command.h)
//   bot      the headless bot (no GL): joins, deforms with seeded random stamps, checks hashes
//   probe    the health check: joins as a spectator, asks for Stats, prints one line or JSON
#include <CLI/CLI.hpp>
#include <cstdio>
#include <map>

#include "app/cli_checks.h"
#include "client/bot.h"
#include "client/connect_options.h"
#include "client/probe.h"
#ifdef LOAM_HAVE_RENDER
#include "client/render_command.h"
#endif
#ifdef LOAM_HAVE_VIEWER
#include "client/view/viewer_app.h"
#endif

namespace {

bool parse_size(const std::string& size, int32_t& w, int32_t& h) {
  return std::sscanf(size.c_str(), "%dx%d", &w, &h) == 2 && w > 0 && h > 0 && w <= 16384 && h <= 16384;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace loam;
  CLI::App app{"loam-client: Loam's client (viewer, headless renderer, bot)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "loam-client " LOAM_VERSION " (protocol " +
                                        std::to_string(wire::kProtocolMajor) + "." +
                                        std::to_string(wire::kProtocolMinor) + ")");
  client::TokenSource token_src;
  // Every number is range-checked as it is parsed (app/cli_checks.h), naming the option.
  using cli::Bound;

  client::BotOptions bo;
  auto* bot = app.add_subcommand("bot", "Join a session and deform it with random stamps");
  bot->add_option("--host", bo.host)->capture_default_str();
  bot->add_option("--port", bo.port)->capture_default_str()->check(cli::IntRange(1, 65535));
  bot->add_option("--name", bo.name)->capture_default_str();
  bot->add_option("--stamps", bo.stamps, "How many stamps to send")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1000000000));
  bot->add_option("--rate", bo.rate, "Stamps per second")
      ->capture_default_str()
      ->check(cli::FiniteRange(0.1, 1000.0));
  bot->add_option("--seed", bo.seed)->capture_default_str()->check(cli::IntRange(0, UINT32_MAX));
  bot->add_option(
         "--roam", bo.roam_mps,
         "Walk a loop across the world at this speed (m/s), subscribing by distance as a viewer does "
         "and stamping near itself (0: stay, subscribed to every mip-0 tile)")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 10000));
  client::add_token_options(bot, token_src);
  client::add_tls_options(bot, bo.tls);

  client::ProbeOptions po;
  double probe_timeout_s = 5.0;
  auto* probe = app.add_subcommand("probe", "Health check: join as a spectator, print the session's state");
  probe->add_option("--host", po.host)->capture_default_str();
  probe->add_option("--port", po.port)->capture_default_str()->check(cli::IntRange(1, 65535));
  probe->add_option("--timeout", probe_timeout_s, "Seconds for connect, handshake and Stats")
      ->capture_default_str()
      ->check(cli::FiniteRange(0.1, 600.0));
  probe->add_flag("--json", po.json, "One JSON object instead of a line of text");
  client::add_token_options(probe, token_src);
  client::add_tls_options(probe, po.tls);

#ifdef LOAM_HAVE_RENDER
  render::RenderCommandOptions ro;
  std::string size = "1280x720";
  auto* render_cmd = app.add_subcommand("render", "Render one frame or a camera path headless (EGL) to PNG");
  auto* src_dem = render_cmd->add_option("--dem", ro.dem, "DEM file (default: the embedded default terrain)");
  auto* src_snap = render_cmd->add_option("--snapshot", ro.snapshot,
                                          "Snapshot folder, or a data folder (its newest snapshot)");
  auto* src_server =
      render_cmd->add_option("--server", ro.server, "HOST:PORT of a loam-server: render its live session");
  src_dem->excludes(src_snap)->excludes(src_server);
  src_snap->excludes(src_server);
  render_cmd->add_option("--camera", ro.camera, "Camera position x,y,z (world meters)")
      ->delimiter(',')
      ->check(cli::Finite());
  render_cmd->add_option("--look", ro.look, "Point looked at x,y,z (world meters; not the camera's position)")
      ->delimiter(',')
      ->check(cli::Finite());
  render_cmd->add_option("--size", size, "WIDTHxHEIGHT")->capture_default_str();
  render_cmd->add_option("--out", ro.out, "PNG file (a path numbers them: out_0000.png, ...)")
      ->capture_default_str()
      ->check(cli::PngFile());
  render_cmd->add_option("--path", ro.path, "Camera path file: one 'x y z tx ty tz' line per frame");
  render_cmd->add_flag("!--no-morph", ro.morph, "Disable geomorphing (shows level pops)");
  render_cmd->add_option("--n", ro.n, "Vertices per clipmap level side (2^k - 1)")
      ->capture_default_str()
      ->check(cli::IntRange(7, 1023));
  render_cmd->add_option("--levels", ro.levels, "Clipmap levels (0: from --view-distance)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 24));
  render_cmd->add_option("--view-distance", ro.view_distance, "Meters")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1e7, Bound::kOpen));
  render_cmd->add_option("--fov", ro.fov_y_degrees, "Vertical field of view, degrees")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 180, Bound::kOpen, Bound::kOpen));
  client::add_token_options(render_cmd, token_src);
  client::add_tls_options(render_cmd, ro.tls);
#endif

#ifdef LOAM_HAVE_VIEWER
  view::ViewerAppOptions vo;
  std::string view_size = "1280x720";
  auto* view_cmd = app.add_subcommand("view", "View a live session: a window, or --headless (EGL)");
  view_cmd->add_option("--host", vo.host)->capture_default_str();
  view_cmd->add_option("--port", vo.port)->capture_default_str()->check(cli::IntRange(1, 65535));
  view_cmd->add_option("--name", vo.name)->capture_default_str();
  view_cmd->add_option("--size", view_size, "WIDTHxHEIGHT")->capture_default_str();
  view_cmd->add_flag("--headless", vo.headless, "No window: orbit the world, stamp now and then, write PNGs");
  view_cmd->add_option("--seconds", vo.seconds, "Stop after this long (0: until closed; headless default 30)")
      ->check(cli::FiniteRange(0, 1e7));
  view_cmd
      ->add_option("--stamp-every", vo.stamp_every_s, "Headless: a stamp at the view's centre this often (s)")
      ->check(cli::FiniteRange(0, 1e7));
  view_cmd
      ->add_option("--fly", vo.fly_mps,
                   "Headless: fly a loop around the centre at this speed (m/s) instead of orbiting")
      ->check(cli::FiniteRange(0, 5000));
  view_cmd->add_flag(
      "--walk", vo.walk,
      "Walk on the terrain (window: G toggles, Space jumps; headless: a walker at the centre)");
  view_cmd
      ->add_option("--dig-under", vo.dig_under_s,
                   "Headless walk: dig a crater under the walker at this time (s)")
      ->check(cli::FiniteRange(0, 1e7));
  view_cmd->add_option("--screenshot-every", vo.screenshot_every_s, "Headless: a PNG this often (s)")
      ->check(cli::FiniteRange(0, 1e7));
  view_cmd->add_option("--screenshot", vo.screenshot, "PNG file (numbered when several)")
      ->capture_default_str()
      ->check(cli::PngFile());
  view_cmd
      ->add_option("--lod", vo.lod,
                   "Level of detail: error (blocks chosen for a screen-space error budget) or classic "
                   "(geometry clipmap rings)")
      ->capture_default_str()
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, render::LodScheme>{{"error", render::LodScheme::kError},
                                                   {"classic", render::LodScheme::kClassic}},
          CLI::ignore_case));
  view_cmd
      ->add_option("--stamping", vo.stamping,
                   "Where the display stamps events and own stamps: gpu (the GPU tile cache), cpu, or auto "
                   "(the CPU on a software rasterizer, where it is measured faster; else the GPU)")
      ->capture_default_str()
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, render::DisplayStamping>{{"gpu", render::DisplayStamping::kGpu},
                                                         {"cpu", render::DisplayStamping::kCpu},
                                                         {"auto", render::DisplayStamping::kAuto}},
          CLI::ignore_case));
  view_cmd
      ->add_option("--gpu-cache-mb", vo.gpu_cache_mb,
                   "GPU stamping: the display's tile cache for the coarse layer (MiB, 128 KiB a tile; the "
                   "detail layer's takes half); tiles past it are evicted and filled again when next stamped")
      ->capture_default_str()
      ->check(CLI::Range(1, 256));  // 2048 pages: the array texture layers GL 4.5 guarantees
  view_cmd
      ->add_option("--lod-tolerance", vo.error_clipmap.tolerance_px,
                   "Error-driven clipmap: the screen-space error budget (pixels)")
      ->capture_default_str()
      ->check(cli::FiniteRange(0.1, 64));
  view_cmd
      ->add_option("--lod-triangles", vo.error_clipmap.max_triangles,
                   "Error-driven clipmap: the most triangles its budget may take (0: no cap); past it the "
                   "budget rises")
      ->capture_default_str()
      ->check(cli::IntRange(0, 100'000'000));
  view_cmd->add_option("--n", vo.renderer.n, "Classic clipmap: vertices per level side (2^k - 1)")
      ->capture_default_str()
      ->check(cli::IntRange(7, 1023));
  vo.renderer.view_distance = 0;  // auto: the world's (render/start_view.h)
  view_cmd
      ->add_option("--view-distance", vo.renderer.view_distance,
                   "Meters the clipmap reaches (0: 4 km, or 2.5 start-orbit radii on coarse worlds)")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1e7));
  view_cmd->add_flag("!--no-vsync", vo.vsync, "Render as fast as possible");
  view_cmd->add_flag("!--no-hud", vo.hud, "Window: start with the HUD hidden (F1 shows it)");
  client::add_token_options(view_cmd, token_src);
  client::add_tls_options(view_cmd, vo.tls);
#endif

  CLI11_PARSE(app, argc, argv);
  if (*bot)
    return client::resolve_token("loam-client bot", token_src, true, bo.token) ? client::run_bot(bo) : 2;
  if (*probe) {
    if (!client::resolve_token("loam-client probe", token_src, false, po.token)) return 2;
    po.timeout = std::chrono::milliseconds(int64_t(probe_timeout_s * 1000));
    return client::run_probe(po);
  }
#ifdef LOAM_HAVE_RENDER
  if (*render_cmd) {
    if (!parse_size(size, ro.width, ro.height)) {
      std::fprintf(stderr, "loam-client render: --size wants WIDTHxHEIGHT, got %s\n", size.c_str());
      return 2;
    }
    if (!client::resolve_token("loam-client render", token_src, false, ro.token)) return 2;
    return render::run_render_command(ro);
  }
#endif
#ifdef LOAM_HAVE_VIEWER
  if (*view_cmd) {
    if (!parse_size(view_size, vo.width, vo.height)) {
      std::fprintf(stderr, "loam-client view: --size wants WIDTHxHEIGHT, got %s\n", view_size.c_str());
      return 2;
    }
    if (!client::resolve_token("loam-client view", token_src, true, vo.token)) return 2;
    return view::run_viewer(vo);
  }
#endif
  return 0;
}
