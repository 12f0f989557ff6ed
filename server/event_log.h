// Structured log lines on stderr: "loam-server ts=<unix s> event=<name> key=value ...".
// One line per event (connect, disconnect with reason, rejected command, tick overrun,
// stats) so operators can grep and machines can parse. The kinds a client can cause are
// rate-limited (log_rate_limit.h): 20 lines a second each, in bursts of up to 200; a line after
// dropped ones says `suppressed=N`, and flush_suppressed_log_lines() summarises the rest.
#pragma once

#include <initializer_list>
#include <span>
#include <string>
#include <utility>

namespace loam::server {

using Field = std::pair<const char*, std::string>;
void log_event(const char* event, std::initializer_list<Field> fields = {});
// The same with fields gathered at run time (the stats line, from the counters table).
void log_event(const char* event, std::span<const Field> fields);
// One `log_suppressed kind=… lines=…` line per kind with lines dropped since its last line.
void flush_suppressed_log_lines();

}  // namespace loam::server
