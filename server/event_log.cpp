#include "server/event_log.h"

#include <chrono>
#include <cstdio>

namespace loam::server {

void log_event(const char* event, std::initializer_list<Field> fields) {
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
  line += '\n';
  std::fputs(line.c_str(), stderr);
}

}  // namespace loam::server
