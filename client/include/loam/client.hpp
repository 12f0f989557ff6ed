// Loam's client library for game code: connect to a Loam server, follow the terrain around a
// point of view, query it (height, normal, raycast, sphere and capsule sweeps), hear of every
// deformation, and deform it with any stamp kind.
//
// Threads. A Client runs its own network thread: it receives the server's tiles and events,
// keeps the terrain the player sees (the confirmed state plus the player's own stamps not yet
// settled, shown at once), and publishes an immutable TerrainView after each change. Every
// method may be called from any thread; queries run on a view without locks, so a game thread
// can query while the network thread works. Callbacks run only inside dispatch(), on the
// thread that calls it.
//
// Staleness. A view reflects every event the display had applied when it was published, and
// every own stamp submitted before it (event_seq() and generation() say which); flush() waits
// until what was submitted before it shows in view(). At a sample's position a height query
// returns that sample exactly; between samples it is the plane of the triangle the renderer
// draws there (each cell split along its (x, y)-(x+1, y+1) diagonal), plus the detail layer.
//
// Units: meters. x and y are world meters (x = sample column * meters per sample, y grows with
// the sample row, i.e. southward in a DEM), z is height, up.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#define LOAM_CLIENT_API __attribute__((visibility("default")))

namespace loam::query {
class TerrainSnapshot;
}

namespace loam::game {

inline constexpr int kApiVersion = 1;

struct Vec3 {
  double x = 0, y = 0, z = 0;
};

enum class StampKind : uint8_t {
  kTexture = 0,
  kGaussian = 1,
  kCrater = 2,
  kFootprint = 3,
  kFlatten = 4,
  kShockwave = 5
};
enum class Blend : uint8_t { kAdd = 0, kSubtract = 1, kMin = 2, kMax = 3 };
enum class Layer : uint8_t { kCoarse = 0, kDetail = 1 };

// A deformation in world units (docs/stamps.md gives each field's meaning per kind).
struct Stamp {
  StampKind kind = StampKind::kGaussian;
  Layer layer = Layer::kCoarse;
  Blend blend = Blend::kAdd;
  double x = 0, y = 0;   // centre, meters
  double radius = 1;     // meters
  double rotation = 0;   // radians, counter-clockwise
  double intensity = 0;  // meters (crater, footprint: depth); flatten: strength 0..1
  double target = 0;     // flatten: target height, meters
  double shape = 0;      // crater: rim height relative to depth
  double damping = 0;    // shockwave
  double speed = 0.5;    // shockwave Courant number
  uint32_t steps = 0;    // shockwave
  uint32_t seed = 0;
  uint64_t texture_id = 0;         // texture: an image registered on the server
  bool volume_conserving = false;  // crater
};

struct Options {
  std::string host = "127.0.0.1";
  uint16_t port = 7777;
  std::string name = "game";
  std::string token;       // 32 hex digits where the server requires tokens
  bool spectator = false;  // watch only (no stamps)
  bool tls = false;        // TLS, verified against the system's CAs or `tls_ca_file`
  std::string tls_ca_file;
  std::string tls_fingerprint;  // SHA-256 of the server's certificate, pinned (implies tls)
  std::chrono::milliseconds connect_timeout{10000};
};

struct WorldInfo {
  double meters_per_sample = 1;
  double min_x = 0, min_y = 0, max_x = 0, max_y = 0;  // the area heights are defined on
  int32_t detail_factor = 1;
  uint32_t client_id = 0;
};

struct RayHit {
  double distance = 0;  // along the normalized direction
  Vec3 point, normal;
};

struct SweepHit {
  double t = 0;  // fraction of the motion travelled at first contact
  Vec3 point;    // on the terrain
  Vec3 normal;   // from the terrain toward the shape
  bool started_inside = false;
};

// A ray or sweep's answer: `hit` empty means no contact; `reached_unloaded` means the path
// crossed terrain not held yet (it passes through as if open).
template <typename Hit>
struct Trace {
  std::optional<Hit> hit;
  bool reached_unloaded = false;
};

// The terrain at one moment. Cheap to copy (it shares the samples); valid after the client is
// gone. Every query answers from this same state.
class LOAM_CLIENT_API TerrainView {
 public:
  TerrainView();
  ~TerrainView();
  TerrainView(const TerrainView&);
  TerrainView& operator=(const TerrainView&);

  // Empty where the point's samples are not loaded (outside the view) or outside the world.
  std::optional<double> height(double x, double y) const;
  std::optional<Vec3> normal(double x, double y) const;
  Trace<RayHit> raycast(const Vec3& origin, const Vec3& direction, double max_distance) const;
  Trace<SweepHit> sweep_sphere(const Vec3& center, double radius, const Vec3& motion) const;
  Trace<SweepHit> sweep_capsule(const Vec3& a, const Vec3& b, double radius, const Vec3& motion) const;

  uint64_t event_seq() const;       // the newest server event this view reflects
  uint64_t generation() const;      // views published before this one, plus one
  size_t own_stamps_shown() const;  // own stamps shown, not yet settled by the server
  size_t tiles() const;             // terrain tiles held

 private:
  friend class Client;
  std::shared_ptr<const query::TerrainSnapshot> s_;
};

struct DeformEvent {
  uint64_t seq = 0;                       // the server's global sequence
  uint32_t origin_client = 0;             // who made it
  bool own = false;                       // this client's
  Stamp stamp;                            // as applied (quantized, back in world units)
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // the area it changed, meters (empty: nothing)
};

// The session as a HUD shows it, refreshed about once a second by the network thread.
struct SessionStats {
  bool connected = false;
  double rtt_ms = -1;                              // the last round trip (-1: none measured yet)
  double bytes_in_per_s = 0, bytes_out_per_s = 0;  // over the last second
  uint64_t bytes_in = 0, bytes_out = 0;            // since connecting
  uint32_t server_clients = 0;                     // the server's numbers (0 until its first answer)
  uint32_t server_tick_p50_us = 0, server_tick_p99_us = 0;
  uint64_t server_sequence = 0;
  size_t tiles_held = 0;
  size_t own_stamps_unsettled = 0;
  uint32_t budget_bytes_per_s =
      0;  // what the server streams to this client within (0: unlimited or not known yet)
};

struct StampResult {
  uint64_t ticket = 0;  // stamp()'s answer
  bool accepted = false;
  uint64_t seq = 0;   // accepted: its global sequence
  std::string error;  // not accepted: why (refused, or lost with a connection to a restarted server)
};

class LOAM_CLIENT_API Client {
 public:
  // Connects and authenticates; null with `error` set when it cannot.
  static std::unique_ptr<Client> connect(const Options& options, std::string* error = nullptr);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  WorldInfo world() const;

  // Follows the terrain within `radius` meters of (x, y): its tiles are subscribed (nearest
  // first), those beyond 1.25 x radius dropped. Call as the player moves.
  void set_view(double x, double y, double radius);
  // Waits until every tile of the view is held and shows in view(); false on timeout.
  bool wait_for_view(std::chrono::milliseconds timeout);

  // The latest terrain (see TerrainView), and one-off queries on it.
  TerrainView view() const;
  std::optional<double> height(double x, double y) const { return view().height(x, y); }
  std::optional<Vec3> normal(double x, double y) const { return view().normal(x, y); }

  // Validates and submits a stamp; it shows in view() at once (after flush(), for certain)
  // where its tiles are held. Returns a ticket (> 0) that on_stamp_result reports on, or 0
  // with `error` set when the stamp is invalid (NaN, out of range, spectator...).
  uint64_t stamp(const Stamp& stamp, std::string* error = nullptr);
  // Waits until everything submitted before the call shows in view(); false on timeout.
  bool flush(std::chrono::milliseconds timeout);
  // Waits until no own stamp awaits the server's answer and its event.
  bool wait_settled(std::chrono::milliseconds timeout);

  // Hooks, called from dispatch(): every deformation event (own and others'), and the
  // server's answer to each own stamp.
  void on_deform(std::function<void(const DeformEvent&)> fn);
  void on_stamp_result(std::function<void(const StampResult&)> fn);
  // Runs the hooks for what arrived since the last call; returns how many ran.
  size_t dispatch();

  // False once the connection is lost (it is retried every second meanwhile).
  bool connected() const;
  SessionStats session() const;
  std::string last_error() const;

 private:
  struct Impl;
  explicit Client(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace loam::game
