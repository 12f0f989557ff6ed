// loam::game::Client: the network thread that owns the TerrainClient and its display (CPU
// stamping), and the game-facing side that reads published snapshots and queues commands.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <numbers>
#include <set>
#include <thread>
#include <variant>
#include <vector>

#include "client/include/loam/client.hpp"
#include "client/net/terrain_client.h"
#include "client/query/snapshot_builder.h"
#include "client/query/terrain_query.h"
#include "client/terrain/display_terrain.h"
#include "dem/refined_default.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/wire/access_token.h"

namespace loam::game {

namespace {

glm::dvec3 to_glm(const Vec3& v) { return {v.x, v.y, v.z}; }
Vec3 to_vec(const glm::dvec3& v) { return {v.x, v.y, v.z}; }

StampParams to_params(const Stamp& s) {
  StampParams p;
  p.kind = loam::StampKind(uint8_t(s.kind));
  p.layer = loam::Layer(uint8_t(s.layer));
  p.blend = BlendMode(uint8_t(s.blend));
  p.center_x = s.x;
  p.center_y = s.y;
  p.radius = s.radius;
  p.rotation = s.rotation;
  p.intensity = s.intensity;
  p.target = s.target;
  p.shape = s.shape;
  p.damping = s.damping;
  p.speed = s.speed;
  p.steps = s.steps;
  p.seed = s.seed;
  p.texture_id = s.texture_id;
  p.volume_conserving = s.volume_conserving;
  return p;
}

// A quantized stamp back in world units (the inverse of validate_stamp's scales).
Stamp from_quantized(const QuantizedStamp& q, const WorldParams& w) {
  const bool detail = q.layer == loam::Layer::kDetail;
  const double spacing = detail ? w.detail_meters_per_sample() : w.meters_per_sample;
  const double unit = detail ? w.detail_meters_per_unit : w.meters_per_unit;
  const double pos = spacing / double(1 << kPositionFracBits);
  Stamp s;
  s.kind = StampKind(uint8_t(q.kind));
  s.layer = Layer(uint8_t(q.layer));
  s.blend = Blend(uint8_t(q.blend));
  s.x = double(q.center_x) * pos;
  s.y = double(q.center_y) * pos;
  s.radius = double(q.radius) * pos;
  s.rotation = double(q.rotation) / double(kRotationUnitsPerTurn) * 2.0 * std::numbers::pi;
  s.intensity = double(q.intensity) / double(1 << kIntensityFracBits) * unit;
  s.target = detail ? double(q.target) * unit : w.height_meters(uint16_t(std::clamp(q.target, 0, 65535)));
  s.shape = double(q.shape) / double(kUnitFracOne);
  s.damping = double(q.damping) / double(kUnitFracOne);
  s.speed = double(q.speed) / double(kUnitFracOne);
  s.steps = q.steps;
  s.seed = q.seed;
  s.texture_id = q.texture_id;
  s.volume_conserving = (q.flags & kStampFlagVolumeConserving) != 0;
  return s;
}

// The mip-0 coarse tiles and their detail tiles within `radius` of (x, y).
std::set<TileCoord> tiles_within(const WorldParams& w, double x, double y, double radius) {
  std::set<TileCoord> out;
  const double tile_m = kTileSize * w.meters_per_sample;
  const RectI range = w.tile_range(0);
  const int64_t tx0 = std::max<int64_t>(range.x0, int64_t(std::floor((x - radius) / tile_m)));
  const int64_t tx1 = std::min<int64_t>(range.x1 - 1, int64_t(std::floor((x + radius) / tile_m)));
  const int64_t ty0 = std::max<int64_t>(range.y0, int64_t(std::floor((y - radius) / tile_m)));
  const int64_t ty1 = std::min<int64_t>(range.y1 - 1, int64_t(std::floor((y + radius) / tile_m)));
  const int32_t f = w.detail_factor;
  for (int64_t ty = ty0; ty <= ty1; ++ty) {
    for (int64_t tx = tx0; tx <= tx1; ++tx) {
      // Nearest point of the tile to the centre.
      const double nx = std::clamp(x, double(tx) * tile_m, double(tx + 1) * tile_m);
      const double ny = std::clamp(y, double(ty) * tile_m, double(ty + 1) * tile_m);
      if (std::hypot(nx - x, ny - y) > radius) continue;
      out.insert({loam::Layer::kCoarse, 0, int32_t(tx), int32_t(ty)});
      for (int32_t b = 0; b < f; ++b) {
        for (int32_t a = 0; a < f; ++a) {
          out.insert({loam::Layer::kDetail, 0, int32_t(tx * f + a), int32_t(ty * f + b)});
        }
      }
    }
  }
  return out;
}

struct ViewCommand {
  double x, y, radius;
};
struct StampCommand {
  uint64_t ticket;
  QuantizedStamp stamp;
};
using Command = std::variant<ViewCommand, StampCommand>;

}  // namespace

// --- TerrainView -----------------------------------------------------------------------------

TerrainView::TerrainView() = default;
TerrainView::~TerrainView() = default;
TerrainView::TerrainView(const TerrainView&) = default;
TerrainView& TerrainView::operator=(const TerrainView&) = default;

std::optional<double> TerrainView::height(double x, double y) const {
  if (!s_) return std::nullopt;
  return query::height_at(*s_, x, y);
}

std::optional<Vec3> TerrainView::normal(double x, double y) const {
  if (!s_) return std::nullopt;
  const auto n = query::normal_at(*s_, x, y);
  if (!n) return std::nullopt;
  return to_vec(*n);
}

Trace<RayHit> TerrainView::raycast(const Vec3& origin, const Vec3& direction, double max_distance) const {
  Trace<RayHit> out;
  if (!s_) return out;
  const query::RayResult r = query::raycast(*s_, to_glm(origin), to_glm(direction), max_distance);
  out.reached_unloaded = r.reached_unheld;
  if (r.hit) out.hit = RayHit{r.hit->distance, to_vec(r.hit->point), to_vec(r.hit->normal)};
  return out;
}

namespace {
Trace<SweepHit> to_trace(const query::SweepResult& r) {
  Trace<SweepHit> out;
  out.reached_unloaded = r.reached_unheld;
  if (r.contact) {
    out.hit = SweepHit{r.contact->t, to_vec(r.contact->point), to_vec(r.contact->normal),
                       r.contact->started_inside};
  }
  return out;
}
}  // namespace

Trace<SweepHit> TerrainView::sweep_sphere(const Vec3& center, double radius, const Vec3& motion) const {
  if (!s_) return {};
  return to_trace(query::sweep_sphere(*s_, to_glm(center), radius, to_glm(motion)));
}

Trace<SweepHit> TerrainView::sweep_capsule(const Vec3& a, const Vec3& b, double radius,
                                           const Vec3& motion) const {
  if (!s_) return {};
  return to_trace(query::sweep_capsule(*s_, query::Capsule{to_glm(a), to_glm(b), radius}, to_glm(motion)));
}

uint64_t TerrainView::event_seq() const { return s_ ? s_->stamp().event_seq : 0; }
uint64_t TerrainView::generation() const { return s_ ? s_->stamp().generation : 0; }
size_t TerrainView::own_stamps_shown() const { return s_ ? s_->stamp().own_stamps_shown : 0; }
size_t TerrainView::tiles() const { return s_ ? s_->coarse_tiles() : 0; }

// --- Client ----------------------------------------------------------------------------------

struct Client::Impl {
  Options options;
  WorldParams params;
  StampLimits limits;
  uint32_t client_id = 0;

  // Owned by the network thread once it runs.
  client::TerrainClient net;
  std::unique_ptr<terrain::DisplayTerrain> display;
  std::unique_ptr<query::SnapshotBuilder> builder;
  std::set<TileCoord> view_tiles;
  std::vector<TileCoord> last_held;
  uint64_t last_seq = 0;  // the last_event_seq() and overlay size last published
  size_t last_overlay = 0;
  std::map<uint32_t, uint64_t> ticket_of_seq;  // own stamps sent, awaiting their ack
  std::chrono::steady_clock::time_point next_reconnect{};
  std::chrono::steady_clock::time_point next_stats{};
  uint64_t last_bytes_in = 0, last_bytes_out = 0;

  // Shared with game threads.
  query::SnapshotSlot slot;
  mutable std::mutex mu;
  std::condition_variable cv;
  std::deque<Command> commands;
  uint64_t commands_submitted = 0, commands_published = 0;
  bool view_loaded = false;
  SessionStats stats;    // guarded by mu
  size_t unsettled = 0;  // own stamps submitted and not settled (guarded by mu)
  std::vector<DeformEvent> events;
  std::vector<StampResult> results;
  std::function<void(const DeformEvent&)> on_deform;
  std::function<void(const StampResult&)> on_result;
  std::mutex dispatch_mu;  // one dispatch() at a time, hooks included
  std::atomic<bool> connected{true};
  std::string error;
  std::atomic<uint64_t> next_ticket{1};
  std::atomic<bool> stop{false};
  std::thread thread;

  void run();
  void step();
  void apply(const Command& c, std::vector<StampResult>& results_out);
  void publish(const std::vector<terrain::DisplayDirty>& dirty, bool force);
};

void Client::Impl::apply(const Command& c, std::vector<StampResult>& results_out) {
  if (const auto* v = std::get_if<ViewCommand>(&c)) {
    const std::set<TileCoord> want = tiles_within(params, v->x, v->y, v->radius);
    const std::set<TileCoord> keep = tiles_within(params, v->x, v->y, v->radius * 1.25);
    std::vector<TileCoord> add, drop;
    for (const TileCoord& t : want) {
      if (!view_tiles.count(t)) add.push_back(t);
    }
    for (const TileCoord& t : view_tiles) {
      if (!keep.count(t)) drop.push_back(t);
    }
    for (const TileCoord& t : drop) view_tiles.erase(t);
    for (const TileCoord& t : add) view_tiles.insert(t);
    if (!drop.empty()) (void)net.unsubscribe(drop);
    (void)net.subscribe(add, wire::Focus{v->x, v->y});
    return;
  }
  const auto& s = std::get<StampCommand>(c);
  // A texture stamp whose image this client holds is checked against it here; one whose image
  // it has not fetched goes unpredicted, and the server (which has every image) decides.
  if (s.stamp.kind == loam::StampKind::kTexture && net.textures().contains(s.stamp.texture_id)) {
    if (const Status st = check_quantized(s.stamp, params, limits, &net.textures()); !st) {
      results_out.push_back({s.ticket, false, 0, st.error().describe()});
      return;
    }
  }
  auto seq = net.deform(s.stamp);
  if (!seq) {
    results_out.push_back({s.ticket, false, 0, seq.error().describe()});
    return;
  }
  ticket_of_seq[*seq] = s.ticket;
  display->predict(*seq, s.stamp);
}

void Client::Impl::publish(const std::vector<terrain::DisplayDirty>& dirty, bool force) {
  std::vector<TileCoord> held;
  for (const TileCoord& c : net.store().held()) {
    if (c.mip == 0) held.push_back(c);
  }
  // A settled right prediction changes no sample, but the snapshot's overlay count and sequence.
  const uint64_t seq = net.last_event_seq();
  const size_t overlay = display->overlay_size();
  if (!force && dirty.empty() && held == last_held && seq == last_seq && overlay == last_overlay) return;
  last_seq = seq;
  last_overlay = overlay;
  std::vector<query::ChangedRect> changed;
  changed.reserve(dirty.size());
  for (const terrain::DisplayDirty& d : dirty) changed.push_back({d.layer, d.rect});
  slot.publish(
      builder->build(display->world(), held, changed, net.last_event_seq(), display->overlay_size()));
  last_held = std::move(held);
}

void Client::Impl::step() {
  // Commands first, so what was submitted is sent and predicted before the next publish.
  std::deque<Command> todo;
  uint64_t taken = 0;
  {
    std::lock_guard<std::mutex> lock(mu);
    todo.swap(commands);
    taken = commands_submitted;
  }
  std::vector<StampResult> new_results;
  for (const Command& c : todo) apply(c, new_results);

  if (connected) {
    const Status pumped = net.pump(std::chrono::milliseconds(todo.empty() ? 2 : 0));
    if (!pumped) {
      connected = false;
      next_reconnect = std::chrono::steady_clock::now() + std::chrono::seconds(1);
      std::lock_guard<std::mutex> lock(mu);
      error = pumped.error().describe();
    }
  } else if (std::chrono::steady_clock::now() >= next_reconnect) {
    next_reconnect = std::chrono::steady_clock::now() + std::chrono::seconds(1);
    if (const Status s = net.reconnect(options.host, options.port); s) {
      connected = true;
    } else {
      std::lock_guard<std::mutex> lock(mu);
      error = s.error().describe();
    }
  } else {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }

  const std::vector<terrain::DisplayDirty> dirty = display->sync(net);
  std::vector<DeformEvent> new_events;
  for (const client::StoreChange& ch : display->last_changes()) {
    if (ch.kind != client::StoreChange::Kind::kEvent) continue;
    DeformEvent e;
    e.seq = ch.seq;
    e.origin_client = ch.origin_client_id;
    e.own = ch.origin_client_id == client_id;
    e.stamp = from_quantized(ch.stamp, params);
    if (!ch.rect.empty()) {
      const double sp = loam::layer_meters_per_sample(params, ch.layer);
      e.x0 = double(ch.rect.x0) * sp;
      e.y0 = double(ch.rect.y0) * sp;
      e.x1 = double(ch.rect.x1 - 1) * sp;
      e.y1 = double(ch.rect.y1 - 1) * sp;
    }
    new_events.push_back(e);
  }
  for (auto it = ticket_of_seq.begin(); it != ticket_of_seq.end();) {
    const auto ack = net.ack(it->first);
    if (!ack) {
      ++it;
      continue;
    }
    StampResult r{it->second, ack->accepted, ack->global_seq, ""};
    if (ack->lost)
      r.error = "the connection was lost before the server answered (the terrain shows whether it applied)";
    else if (!ack->accepted)
      r.error = std::string(wire::to_string(ack->code)) + (ack->field.empty() ? "" : ": " + ack->field);
    new_results.push_back(r);
    it = ticket_of_seq.erase(it);
  }
  publish(dirty, !todo.empty());

  // About once a second: a Ping (round trip), a StatsRequest (the server's numbers) and the
  // byte rates since the last time.
  std::optional<SessionStats> refreshed;
  if (const auto now = std::chrono::steady_clock::now(); connected && now >= next_stats) {
    const double dt = next_stats == std::chrono::steady_clock::time_point{}
                          ? 0.0
                          : std::chrono::duration<double>(now - next_stats).count() + 1.0;
    next_stats = now + std::chrono::seconds(1);
    (void)net.ping();
    (void)net.request_stats();
    SessionStats st;
    st.connected = true;
    st.rtt_ms = net.rtt_ms().value_or(-1.0);
    st.bytes_in = net.connection().bytes_in();
    st.bytes_out = net.connection().bytes_out();
    if (dt > 0) {
      st.bytes_in_per_s = double(st.bytes_in - last_bytes_in) / dt;
      st.bytes_out_per_s = double(st.bytes_out - last_bytes_out) / dt;
    }
    last_bytes_in = st.bytes_in;
    last_bytes_out = st.bytes_out;
    if (const auto& s = net.server_stats()) {
      st.server_clients = s->clients;
      st.server_tick_p50_us = s->tick_p50_us;
      st.server_tick_p99_us = s->tick_p99_us;
      st.budget_bytes_per_s = s->client_bytes_per_second;
      st.server_sequence = s->global_sequence;
    }
    st.tiles_held = last_held.size();
    refreshed = st;
  }

  bool loaded = true;
  for (const TileCoord& t : view_tiles) loaded = loaded && net.store().holds(t);
  {
    std::lock_guard<std::mutex> lock(mu);
    commands_published = taken;
    view_loaded = loaded;
    unsettled = ticket_of_seq.size() + display->overlay_size();
    if (refreshed) stats = *refreshed;
    stats.connected = connected;
    stats.own_stamps_unsettled = unsettled;
    for (auto& e : new_events) events.push_back(std::move(e));
    for (auto& r : new_results) results.push_back(std::move(r));
  }
  cv.notify_all();
}

void Client::Impl::run() {
  while (!stop.load(std::memory_order_relaxed)) step();
}

std::unique_ptr<Client> Client::connect(const Options& options, std::string* error) {
  auto fail = [&](const std::string& why) -> std::unique_ptr<Client> {
    if (error) *error = why;
    return nullptr;
  };
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  std::optional<wire::AccessToken> token;
  if (!options.token.empty()) {
    auto t = wire::parse_access_token(options.token, "token");
    if (!t) return fail(t.error().describe());
    token = *t;
  }
  transport::TlsClientOptions tls;
  tls.enabled = options.tls || !options.tls_fingerprint.empty();
  tls.ca_file = options.tls_ca_file;
  tls.fingerprint = options.tls_fingerprint;
  impl->net.set_tls(tls);
  impl->net.set_base_provider(generate_known_base);
  const wire::Role role = options.spectator ? wire::Role::kSpectator : wire::Role::kPlayer;
  if (const Status s = impl->net.connect(options.host, options.port, options.name, role, token); !s) {
    return fail(s.error().describe());
  }
  impl->params = impl->net.welcome().world;
  impl->client_id = impl->net.welcome().client_id;
  impl->net.store().record_changes(true);
  auto display =
      terrain::DisplayTerrain::create(impl->net.store(), {}, &impl->net.textures());  // stamps on the CPU
  if (!display) return fail(display.error().describe());
  impl->display = std::move(*display);
  impl->builder = std::make_unique<query::SnapshotBuilder>(impl->params);
  impl->publish({}, true);
  Impl* raw = impl.get();
  std::unique_ptr<Client> c(new Client(std::move(impl)));
  raw->thread = std::thread([raw] { raw->run(); });
  return c;
}

Client::Client(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Client::~Client() {
  impl_->stop = true;
  if (impl_->thread.joinable()) impl_->thread.join();
}

WorldInfo Client::world() const {
  const WorldParams& w = impl_->params;
  const RectI r = w.sample_rect();
  WorldInfo info;
  info.meters_per_sample = w.meters_per_sample;
  info.min_x = double(r.x0) * w.meters_per_sample;
  info.min_y = double(r.y0) * w.meters_per_sample;
  info.max_x = double(r.x1 - 1) * w.meters_per_sample;
  info.max_y = double(r.y1 - 1) * w.meters_per_sample;
  info.detail_factor = w.detail_factor;
  info.client_id = impl_->client_id;
  return info;
}

void Client::set_view(double x, double y, double radius) {
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(radius) || radius < 0) return;
  std::lock_guard<std::mutex> lock(impl_->mu);
  impl_->commands.push_back(ViewCommand{x, y, radius});
  ++impl_->commands_submitted;
  impl_->view_loaded = false;
}

bool Client::wait_for_view(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(impl_->mu);
  const uint64_t target = impl_->commands_submitted;
  return impl_->cv.wait_for(lock, timeout,
                            [&] { return impl_->commands_published >= target && impl_->view_loaded; });
}

TerrainView Client::view() const {
  TerrainView v;
  v.s_ = impl_->slot.take();
  return v;
}

uint64_t Client::stamp(const Stamp& s, std::string* error) {
  if (impl_->options.spectator) {
    if (error) *error = "a spectator cannot deform the terrain";
    return 0;
  }
  QuantizedStamp q;
  if (s.kind == StampKind::kTexture) {
    // Quantized as the placement fields of any stamp; its image is checked on the network
    // thread where this client holds it, else by the server.
    StampParams p = to_params(s);
    p.kind = loam::StampKind::kGaussian;
    p.texture_id = 0;
    auto checked = validate_stamp(p, impl_->params, impl_->limits);
    if (!checked) {
      if (error) *error = checked.error().describe();
      return 0;
    }
    q = *checked;
    q.kind = loam::StampKind::kTexture;
    q.texture_id = s.texture_id;
  } else {
    auto checked = validate_stamp(to_params(s), impl_->params, impl_->limits);
    if (!checked) {
      if (error) *error = checked.error().describe();
      return 0;
    }
    q = *checked;
  }
  const uint64_t ticket = impl_->next_ticket.fetch_add(1);
  std::lock_guard<std::mutex> lock(impl_->mu);
  impl_->commands.push_back(StampCommand{ticket, q});
  ++impl_->commands_submitted;
  ++impl_->unsettled;
  return ticket;
}

bool Client::flush(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(impl_->mu);
  const uint64_t target = impl_->commands_submitted;
  return impl_->cv.wait_for(lock, timeout, [&] { return impl_->commands_published >= target; });
}

bool Client::wait_settled(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(impl_->mu);
  const uint64_t target = impl_->commands_submitted;
  return impl_->cv.wait_for(lock, timeout,
                            [&] { return impl_->commands_published >= target && impl_->unsettled == 0; });
}

void Client::on_deform(std::function<void(const DeformEvent&)> fn) {
  std::lock_guard<std::mutex> lock(impl_->dispatch_mu);
  impl_->on_deform = std::move(fn);
}

void Client::on_stamp_result(std::function<void(const StampResult&)> fn) {
  std::lock_guard<std::mutex> lock(impl_->dispatch_mu);
  impl_->on_result = std::move(fn);
}

size_t Client::dispatch() {
  std::lock_guard<std::mutex> dlock(impl_->dispatch_mu);
  std::vector<DeformEvent> events;
  std::vector<StampResult> results;
  {
    std::lock_guard<std::mutex> lock(impl_->mu);
    events.swap(impl_->events);
    results.swap(impl_->results);
  }
  size_t ran = 0;
  for (const StampResult& r : results) {
    if (!impl_->on_result) continue;
    impl_->on_result(r);
    ++ran;
  }
  for (const DeformEvent& e : events) {
    if (!impl_->on_deform) continue;
    impl_->on_deform(e);
    ++ran;
  }
  return ran;
}

bool Client::connected() const { return impl_->connected.load(); }

SessionStats Client::session() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return impl_->stats;
}

std::string Client::last_error() const {
  std::lock_guard<std::mutex> lock(impl_->mu);
  return impl_->error;
}

}  // namespace loam::game
