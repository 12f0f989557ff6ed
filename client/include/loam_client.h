/* Loam's client library, C interface (for engine bindings): the same Client as
 * <loam/client.hpp>, through an opaque handle. Every function may be called from any thread;
 * callbacks run inside loam_dispatch() on its caller's thread. Queries take a view (one
 * immutable state of the terrain: loam_view_acquire ... loam_view_release) so a frame's
 * queries agree with each other. Units: meters; x, y world meters, z up. */
#ifndef LOAM_CLIENT_H
#define LOAM_CLIENT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define LOAM_C_API __attribute__((visibility("default")))
#define LOAM_CLIENT_API_VERSION 1

typedef struct loam_client loam_client;
typedef struct loam_view loam_view;

typedef struct {
  double x, y, z;
} loam_vec3;

enum {
  LOAM_TEXTURE = 0,
  LOAM_GAUSSIAN = 1,
  LOAM_CRATER = 2,
  LOAM_FOOTPRINT = 3,
  LOAM_FLATTEN = 4,
  LOAM_SHOCKWAVE = 5
};
enum { LOAM_ADD = 0, LOAM_SUBTRACT = 1, LOAM_MIN = 2, LOAM_MAX = 3 };
enum { LOAM_COARSE = 0, LOAM_DETAIL = 1 };

typedef struct {
  int kind, layer, blend;
  double x, y, radius, rotation, intensity, target, shape, damping, speed;
  uint32_t steps, seed;
  uint64_t texture_id;
  int volume_conserving;
} loam_stamp;

typedef struct {
  const char* host;
  uint16_t port;
  const char* name;
  const char* token; /* 32 hex digits, or NULL */
  int spectator;
  int tls;
  const char* tls_ca_file;     /* or NULL */
  const char* tls_fingerprint; /* or NULL */
  int connect_timeout_ms;
} loam_options;

typedef struct {
  double meters_per_sample, min_x, min_y, max_x, max_y;
  int32_t detail_factor;
  uint32_t client_id;
} loam_world_info;

typedef struct {
  double distance;
  loam_vec3 point, normal;
} loam_ray_hit;

typedef struct {
  double t;
  loam_vec3 point, normal;
  int started_inside;
} loam_sweep_hit;

typedef struct {
  uint64_t seq;
  uint32_t origin_client;
  int own;
  loam_stamp stamp;
  double x0, y0, x1, y1;
} loam_deform_event;

typedef struct {
  int connected;
  double rtt_ms; /* -1: none measured yet */
  double bytes_in_per_s, bytes_out_per_s;
  uint64_t bytes_in, bytes_out;
  uint32_t server_clients, server_tick_p50_us, server_tick_p99_us;
  uint64_t server_sequence;
  size_t tiles_held, own_stamps_unsettled;
  uint32_t
      budget_bytes_per_s; /* the server's streaming budget for this client (0: unlimited or not known yet) */
} loam_session_stats;

typedef void (*loam_deform_fn)(const loam_deform_event* event, void* user);
typedef void (*loam_stamp_result_fn)(uint64_t ticket, int accepted, uint64_t seq, const char* error,
                                     void* user);

/* Defaults: 127.0.0.1:7777, name "game", 10 s to connect. */
LOAM_C_API loam_options loam_default_options(void);
/* A Gaussian bump of radius 1 m and no intensity: set the fields you need. */
LOAM_C_API loam_stamp loam_default_stamp(void);

/* NULL on failure, with the reason in `error` (up to error_size bytes, NUL-terminated). */
LOAM_C_API loam_client* loam_connect(const loam_options* options, char* error, size_t error_size);
LOAM_C_API void loam_disconnect(loam_client* client);
LOAM_C_API loam_world_info loam_world(const loam_client* client);
LOAM_C_API int loam_connected(const loam_client* client);
/* Refreshed about once a second: round trip, byte rates, the server's tick times. */
LOAM_C_API loam_session_stats loam_session(const loam_client* client);

LOAM_C_API void loam_set_view(loam_client* client, double x, double y, double radius);
/* 1 when every tile of the view is held and visible to queries, 0 on timeout. */
LOAM_C_API int loam_wait_for_view(loam_client* client, int timeout_ms);

/* The latest terrain; release every view acquired. */
LOAM_C_API loam_view* loam_view_acquire(const loam_client* client);
LOAM_C_API void loam_view_release(loam_view* view);
LOAM_C_API uint64_t loam_view_event_seq(const loam_view* view);
/* Each returns 1 with *out set, 0 where the terrain is not loaded (or no hit). */
LOAM_C_API int loam_height(const loam_view* view, double x, double y, double* out);
LOAM_C_API int loam_normal(const loam_view* view, double x, double y, loam_vec3* out);
/* *reached_unloaded (may be NULL) is set when the path crossed terrain not loaded. */
LOAM_C_API int loam_raycast(const loam_view* view, loam_vec3 origin, loam_vec3 direction, double max_distance,
                            loam_ray_hit* out, int* reached_unloaded);
LOAM_C_API int loam_sweep_sphere(const loam_view* view, loam_vec3 center, double radius, loam_vec3 motion,
                                 loam_sweep_hit* out, int* reached_unloaded);
LOAM_C_API int loam_sweep_capsule(const loam_view* view, loam_vec3 a, loam_vec3 b, double radius,
                                  loam_vec3 motion, loam_sweep_hit* out, int* reached_unloaded);

/* A ticket (> 0), or 0 with the reason in `error`. */
LOAM_C_API uint64_t loam_submit_stamp(loam_client* client, const loam_stamp* stamp, char* error,
                                      size_t error_size);
/* 1 once everything submitted before the call shows in a new view, 0 on timeout. */
LOAM_C_API int loam_flush(loam_client* client, int timeout_ms);
LOAM_C_API int loam_wait_settled(loam_client* client, int timeout_ms);

LOAM_C_API void loam_on_deform(loam_client* client, loam_deform_fn fn, void* user);
LOAM_C_API void loam_on_stamp_result(loam_client* client, loam_stamp_result_fn fn, void* user);
/* Runs the callbacks for what arrived; returns how many ran. */
LOAM_C_API size_t loam_dispatch(loam_client* client);

#ifdef __cplusplus
}
#endif

#endif /* LOAM_CLIENT_H */
