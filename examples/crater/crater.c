/* The crater example through the C API (loam_client.h): connect, dig, query.
 *   loam-crater-c HOST PORT   (LOAM_TOKEN=HEX where the server requires tokens) */
#include <loam_client.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static void on_result(uint64_t ticket, int accepted, uint64_t seq, const char* error, void* user) {
  *(int*)user = accepted;
  printf("stamp %llu: %s (seq %llu) %s\n", (unsigned long long)ticket, accepted ? "accepted" : "rejected",
         (unsigned long long)seq, error);
}

int main(int argc, char** argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: loam-crater-c HOST PORT\n");
    return 2;
  }
  loam_options options = loam_default_options();
  options.host = argv[1];
  options.port = (uint16_t)atoi(argv[2]);
  options.name = "crater-example-c";
  options.token = getenv("LOAM_TOKEN");
  char error[256];
  loam_client* client = loam_connect(&options, error, sizeof error);
  if (!client) {
    fprintf(stderr, "loam-crater-c: cannot connect: %s\n", error);
    return 1;
  }
  const loam_world_info w = loam_world(client);
  const double x = round((w.min_x + w.max_x) / 4 / w.meters_per_sample) * w.meters_per_sample;
  const double y = round((w.min_y + w.max_y) / 4 / w.meters_per_sample) * w.meters_per_sample;
  loam_set_view(client, x, y, 100.0);
  int ok = loam_wait_for_view(client, 30000);
  double before = 0, after = 0;
  loam_view* view = loam_view_acquire(client);
  ok = ok && loam_height(view, x, y, &before);
  loam_view_release(view);

  int accepted = 0;
  loam_on_stamp_result(client, on_result, &accepted);
  loam_stamp crater = loam_default_stamp();
  crater.kind = LOAM_CRATER;
  crater.x = x;
  crater.y = y;
  crater.radius = 10.0;
  crater.intensity = 2.0;
  crater.volume_conserving = 1;
  ok = ok && loam_submit_stamp(client, &crater, error, sizeof error) != 0;
  ok = ok && loam_wait_settled(client, 30000);
  loam_dispatch(client);
  view = loam_view_acquire(client);
  ok = ok && loam_height(view, x, y, &after);
  loam_sweep_hit hit = {0};
  const loam_vec3 from = {x, y, before + 5.0}, motion = {0, 0, -50.0};
  ok = ok && loam_sweep_sphere(view, from, 0.25, motion, &hit, NULL);
  loam_view_release(view);
  printf("height %.3f m before, %.3f m after; a 0.25 m sphere lands at %.3f m\n", before, after,
         from.z + motion.z * hit.t - 0.25);
  ok = ok && accepted && before - after > 1.0;
  printf("loam-crater-c: %s\n", ok ? "ok" : "FAILED");
  loam_disconnect(client);
  return ok ? 0 : 1;
}
