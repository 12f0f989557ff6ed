// loam_client.h: the C interface, a thin layer over loam::game::Client.
#include <algorithm>
#include <cstring>

#include "client/include/loam/client.hpp"
#include "client/include/loam_client.h"

struct loam_client {
  std::unique_ptr<loam::game::Client> client;
};
struct loam_view {
  loam::game::TerrainView view;
};

namespace {

using loam::game::Vec3;

void copy_error(const std::string& what, char* out, size_t size) {
  if (out == nullptr || size == 0) return;
  const size_t n = std::min(what.size(), size - 1);
  std::memcpy(out, what.data(), n);
  out[n] = '\0';
}

Vec3 from_c(loam_vec3 v) { return {v.x, v.y, v.z}; }
loam_vec3 to_c(const Vec3& v) { return {v.x, v.y, v.z}; }

loam::game::Stamp from_c(const loam_stamp& s) {
  loam::game::Stamp o;
  o.kind = loam::game::StampKind(uint8_t(s.kind));
  o.layer = loam::game::Layer(uint8_t(s.layer));
  o.blend = loam::game::Blend(uint8_t(s.blend));
  o.x = s.x;
  o.y = s.y;
  o.radius = s.radius;
  o.rotation = s.rotation;
  o.intensity = s.intensity;
  o.target = s.target;
  o.shape = s.shape;
  o.damping = s.damping;
  o.speed = s.speed;
  o.steps = s.steps;
  o.seed = s.seed;
  o.texture_id = s.texture_id;
  o.volume_conserving = s.volume_conserving != 0;
  return o;
}

loam_stamp to_c(const loam::game::Stamp& s) {
  loam_stamp o{};
  o.kind = int(s.kind);
  o.layer = int(s.layer);
  o.blend = int(s.blend);
  o.x = s.x;
  o.y = s.y;
  o.radius = s.radius;
  o.rotation = s.rotation;
  o.intensity = s.intensity;
  o.target = s.target;
  o.shape = s.shape;
  o.damping = s.damping;
  o.speed = s.speed;
  o.steps = s.steps;
  o.seed = s.seed;
  o.texture_id = s.texture_id;
  o.volume_conserving = s.volume_conserving ? 1 : 0;
  return o;
}

// The kinds, blends and layers the C enums name; anything else is refused before it is cast.
bool enums_valid(const loam_stamp& s) {
  return s.kind >= LOAM_TEXTURE && s.kind <= LOAM_SHOCKWAVE && s.blend >= LOAM_ADD && s.blend <= LOAM_MAX &&
         (s.layer == LOAM_COARSE || s.layer == LOAM_DETAIL);
}

int sweep_out(const loam::game::Trace<loam::game::SweepHit>& r, loam_sweep_hit* out, int* unloaded) {
  if (unloaded) *unloaded = r.reached_unloaded ? 1 : 0;
  if (!r.hit) return 0;
  if (out) *out = {r.hit->t, to_c(r.hit->point), to_c(r.hit->normal), r.hit->started_inside ? 1 : 0};
  return 1;
}

}  // namespace

extern "C" {

loam_options loam_default_options(void) {
  loam_options o{};
  o.host = "127.0.0.1";
  o.port = 7777;
  o.name = "game";
  o.connect_timeout_ms = 10000;
  return o;
}

loam_stamp loam_default_stamp(void) { return to_c(loam::game::Stamp{}); }

loam_client* loam_connect(const loam_options* options, char* error, size_t error_size) {
  if (options == nullptr) {
    copy_error("options: null", error, error_size);
    return nullptr;
  }
  loam::game::Options o;
  if (options->host) o.host = options->host;
  o.port = options->port;
  if (options->name) o.name = options->name;
  if (options->token) o.token = options->token;
  o.spectator = options->spectator != 0;
  o.tls = options->tls != 0;
  if (options->tls_ca_file) o.tls_ca_file = options->tls_ca_file;
  if (options->tls_fingerprint) o.tls_fingerprint = options->tls_fingerprint;
  if (options->connect_timeout_ms > 0)
    o.connect_timeout = std::chrono::milliseconds(options->connect_timeout_ms);
  std::string why;
  auto c = loam::game::Client::connect(o, &why);
  if (!c) {
    copy_error(why, error, error_size);
    return nullptr;
  }
  return new loam_client{std::move(c)};
}

void loam_disconnect(loam_client* client) { delete client; }

loam_world_info loam_world(const loam_client* client) {
  const loam::game::WorldInfo w = client->client->world();
  return {w.meters_per_sample, w.min_x, w.min_y, w.max_x, w.max_y, w.detail_factor, w.client_id};
}

int loam_connected(const loam_client* client) { return client->client->connected() ? 1 : 0; }

loam_session_stats loam_session(const loam_client* client) {
  const loam::game::SessionStats s = client->client->session();
  return {s.connected ? 1 : 0,  s.rtt_ms,          s.bytes_in_per_s, s.bytes_out_per_s,
          s.bytes_in,           s.bytes_out,       s.server_clients, s.server_tick_p50_us,
          s.server_tick_p99_us, s.server_sequence, s.tiles_held,     s.own_stamps_unsettled,
          s.budget_bytes_per_s};
}

void loam_set_view(loam_client* client, double x, double y, double radius) {
  client->client->set_view(x, y, radius);
}

int loam_wait_for_view(loam_client* client, int timeout_ms) {
  return client->client->wait_for_view(std::chrono::milliseconds(timeout_ms)) ? 1 : 0;
}

loam_view* loam_view_acquire(const loam_client* client) { return new loam_view{client->client->view()}; }
void loam_view_release(loam_view* view) { delete view; }
uint64_t loam_view_event_seq(const loam_view* view) { return view->view.event_seq(); }

int loam_height(const loam_view* view, double x, double y, double* out) {
  const auto h = view->view.height(x, y);
  if (!h) return 0;
  if (out) *out = *h;
  return 1;
}

int loam_normal(const loam_view* view, double x, double y, loam_vec3* out) {
  const auto n = view->view.normal(x, y);
  if (!n) return 0;
  if (out) *out = to_c(*n);
  return 1;
}

int loam_raycast(const loam_view* view, loam_vec3 origin, loam_vec3 direction, double max_distance,
                 loam_ray_hit* out, int* reached_unloaded) {
  const auto r = view->view.raycast(from_c(origin), from_c(direction), max_distance);
  if (reached_unloaded) *reached_unloaded = r.reached_unloaded ? 1 : 0;
  if (!r.hit) return 0;
  if (out) *out = {r.hit->distance, to_c(r.hit->point), to_c(r.hit->normal)};
  return 1;
}

int loam_sweep_sphere(const loam_view* view, loam_vec3 center, double radius, loam_vec3 motion,
                      loam_sweep_hit* out, int* reached_unloaded) {
  return sweep_out(view->view.sweep_sphere(from_c(center), radius, from_c(motion)), out, reached_unloaded);
}

int loam_sweep_capsule(const loam_view* view, loam_vec3 a, loam_vec3 b, double radius, loam_vec3 motion,
                       loam_sweep_hit* out, int* reached_unloaded) {
  return sweep_out(view->view.sweep_capsule(from_c(a), from_c(b), radius, from_c(motion)), out,
                   reached_unloaded);
}

uint64_t loam_submit_stamp(loam_client* client, const loam_stamp* stamp, char* error, size_t error_size) {
  if (stamp == nullptr || !enums_valid(*stamp)) {
    copy_error(stamp == nullptr ? "stamp: null" : "stamp: unknown kind, blend or layer", error, error_size);
    return 0;
  }
  std::string why;
  const uint64_t ticket = client->client->stamp(from_c(*stamp), &why);
  if (ticket == 0) copy_error(why, error, error_size);
  return ticket;
}

int loam_flush(loam_client* client, int timeout_ms) {
  return client->client->flush(std::chrono::milliseconds(timeout_ms)) ? 1 : 0;
}

int loam_wait_settled(loam_client* client, int timeout_ms) {
  return client->client->wait_settled(std::chrono::milliseconds(timeout_ms)) ? 1 : 0;
}

void loam_on_deform(loam_client* client, loam_deform_fn fn, void* user) {
  if (fn == nullptr) {
    client->client->on_deform(nullptr);
    return;
  }
  client->client->on_deform([fn, user](const loam::game::DeformEvent& e) {
    const loam_deform_event c{e.seq, e.origin_client, e.own ? 1 : 0, to_c(e.stamp), e.x0, e.y0, e.x1, e.y1};
    fn(&c, user);
  });
}

void loam_on_stamp_result(loam_client* client, loam_stamp_result_fn fn, void* user) {
  if (fn == nullptr) {
    client->client->on_stamp_result(nullptr);
    return;
  }
  client->client->on_stamp_result([fn, user](const loam::game::StampResult& r) {
    fn(r.ticket, r.accepted ? 1 : 0, r.seq, r.error.c_str(), user);
  });
}

size_t loam_dispatch(loam_client* client) { return client->client->dispatch(); }

}  // extern "C"
