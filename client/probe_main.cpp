// loam-probe: `loam-client probe` as a program of its own. It links no image or GL
// library, so it starts in milliseconds with a few megabytes where loam-client loads GDAL's
// and GL's libraries first: the command for health
// checks that run every few seconds (the image's HEALTHCHECK, Kubernetes' probes).
#include <CLI/CLI.hpp>
#include <cstdio>

#include "app/cli_checks.h"
#include "client/connect_options.h"
#include "client/probe.h"

int main(int argc, char** argv) {
  using namespace loam;
  CLI::App app{"loam-probe: health check of a loam-server session (a spectator handshake and Stats)"};
  app.set_version_flag("--version", "loam-probe " LOAM_VERSION " (protocol " +
                                        std::to_string(wire::kProtocolMajor) + "." +
                                        std::to_string(wire::kProtocolMinor) + ")");
  client::ProbeOptions po;
  client::TokenSource tokens;
  double timeout_s = 5.0;
  app.add_option("--host", po.host)->capture_default_str();
  app.add_option("--port", po.port)->capture_default_str()->check(cli::IntRange(1, 65535));
  app.add_option("--timeout", timeout_s, "Seconds for connect, handshake and Stats")
      ->capture_default_str()
      ->check(cli::FiniteRange(0.1, 600.0));
  app.add_flag("--json", po.json, "One JSON object instead of a line of text");
  client::add_token_options(&app, tokens);
  client::add_tls_options(&app, po.tls);
  CLI11_PARSE(app, argc, argv);
  if (!client::resolve_token("loam-probe", tokens, false, po.token)) return 2;
  po.timeout = std::chrono::milliseconds(int64_t(timeout_s * 1000));
  return client::run_probe(po);
}
