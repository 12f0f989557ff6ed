// loam-bench SUITE... [--quick] [--out DIR]: runs speed-against-error suites and writes
// their reports. `loam-bench --list` names the suites.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/harness.h"

namespace {

// One core's memcpy bandwidth over 64 MiB buffers (bytes copied per second, median).
double measure_memcpy_gbps(const loam::bench::Context& ctx) {
  const size_t bytes = (ctx.quick ? 16u : 64u) << 20;
  std::vector<char> a(bytes, 1), b(bytes, 2);
  const loam::bench::Timing t =
      loam::bench::measure(ctx,
                           [&] {
                             std::memcpy(b.data(), a.data(), bytes);
                             a[size_t(b[bytes / 2]) % bytes] ^= 1;  // keep the copy observable
                           },
                           {.warmup = 2, .min_runs = 5, .max_runs = 50, .min_seconds = 0.3});
  return double(bytes) / t.median_s / 1e9;
}

std::string machine_description() {
  std::ifstream in("/proc/cpuinfo");
  std::string line, model = "unknown CPU";
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  }
  return model + ", " + std::to_string(std::thread::hardware_concurrency()) + " hardware threads";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loam-bench: Loam's speed-against-error benchmark suites"};
  std::vector<std::string> names;
  loam::bench::Context ctx;
  ctx.source_dir = LOAM_SOURCE_DIR;
  ctx.out_dir = std::string(LOAM_SOURCE_DIR) + "/bench/results";
  ctx.shared_data_dir = std::string(LOAM_SOURCE_DIR) + "/../shared/data";
  bool list = false;
  app.add_option("suites", names, "Suites to run (see --list)");
  app.add_flag("--quick", ctx.quick, "Smoke-test sizes (CI); numbers are not representative");
  app.add_option("--out", ctx.out_dir, "Output directory (default: bench/results)");
  app.add_option("--shared-data", ctx.shared_data_dir, "Directory of the shared DEMs");
  app.add_flag("--list", list, "List the suites");
  CLI11_PARSE(app, argc, argv);

  auto& all = loam::bench::suites();
  if (list || names.empty()) {
    for (const auto& s : all) std::printf("%-14s %s\n", s.name, s.description);
    return names.empty() && !list ? 2 : 0;
  }
  for (const auto& n : names) {
    bool found = false;
    for (const auto& s : all) found = found || n == s.name;
    if (!found) {
      std::fprintf(stderr, "loam-bench: unknown suite '%s' (see --list)\n", n.c_str());
      return 2;
    }
  }
  ctx.machine = machine_description();
#ifdef LOAM_BENCH_SANITIZED
  ctx.sanitized = true;
  std::fprintf(stderr, "loam-bench: built with sanitizers; use scripts/bench.sh for real numbers\n");
#endif
  ctx.memcpy_gbps = measure_memcpy_gbps(ctx);
  std::printf("machine: %s; memcpy %.2f GB/s\n", ctx.machine.c_str(), ctx.memcpy_gbps);
  int failures = 0;
  for (const auto& n : names) {
    for (const auto& s : all) {
      if (n != s.name) continue;
      std::printf("== %s\n", s.name);
      loam::bench::Report report(s.name);
      const auto t0 = std::chrono::steady_clock::now();
      const int rc = s.fn(ctx, report);
      const bool written = report.write(ctx);
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf("== %s: %s in %.1f s -> %s/%s.md\n", s.name, rc == 0 && written ? "ok" : "FAILED", secs,
                  ctx.out_dir.c_str(), report.name().c_str());
      failures += (rc != 0 || !written);
    }
  }
  return failures == 0 ? 0 : 1;
}
