// Structured log lines on stderr: "loam-server ts=<unix s> event=<name> key=value ...".
// One line per event (connect, disconnect with reason, rejected command, tick overrun,
// stats) so operators can grep and machines can parse.
#pragma once

#include <initializer_list>
#include <string>
#include <utility>

namespace loam::server {

using Field = std::pair<const char*, std::string>;
void log_event(const char* event, std::initializer_list<Field> fields = {});

}  // namespace loam::server
