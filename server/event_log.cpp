#include "server/event_log.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <string_view>

#include "server/log_rate_limit.h"

namespace loam::server {

namespace {

// The kinds a client (authenticated or not) can cause at will.
// And tick_overrun: on a loaded machine every tick may overrun.
constexpr std::array<std::string_view, 10> kLimitedKinds = {
    "connect",         "disconnect",   "hello", "reject",       "violation",
    "deform_rejected", "client_error", "drop",  "tick_overrun", "tls_handshake_failed"};

std::mutex limit_mutex;
LogRateLimit& limit() {
  static LogRateLimit l(20.0, 200.0);
  return l;
}

double monotonic_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

void flush_suppressed_log_lines() {
  std::vector<std::pair<std::string, uint64_t>> dropped;
  {
    std::lock_guard lock(limit_mutex);
    dropped = limit().take_suppressed();
  }
  for (const auto& [kind, n] : dropped)
    log_event("log_suppressed", {{"kind", kind}, {"lines", std::to_string(n)}});
}

void log_event(const char* event, std::initializer_list<Field> fields) {
  log_event(event, std::span<const Field>(fields.begin(), fields.size()));
}

void log_event(const char* event, std::span<const Field> fields) {
  uint64_t suppressed = 0;
  if (std::find(kLimitedKinds.begin(), kLimitedKinds.end(), std::string_view(event)) != kLimitedKinds.end()) {
    std::lock_guard lock(limit_mutex);
    const LogRateLimit::Verdict v = limit().admit(event, monotonic_s());
    if (!v.emit) return;
    suppressed = v.suppressed;
  }
  const double ts =
      std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  std::string line = "loam-server ts=" + std::to_string(ts) + " event=" + event;
  for (const auto& [k, v] : fields) {
    const bool quote = v.find_first_of(" \t\"=") != std::string::npos || v.empty();
    line += std::string(" ") + k + "=";
    if (quote) {
      line += '"';
      for (char c : v) line += (c == '"' || c == '\n') ? '\'' : c;
      line += '"';
    } else {
      line += v;
    }
  }
  if (suppressed > 0) line += " suppressed=" + std::to_string(suppressed);
  line += '\n';
  std::fputs(line.c_str(), stderr);
}

}  // namespace loam::server
