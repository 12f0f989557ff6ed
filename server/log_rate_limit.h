// A rate limit per kind of log line, for the lines a client can cause (connect, disconnect,
// violation, ...): a flood of connections or bad frames must not become a flood of log lines
// (a connect/close loop wrote 131 MB in a minute). Each kind has a token bucket; lines over it
// are counted, and the count is reported on the kind's next line and in a periodic summary.
// Pure: the caller passes the time.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace loam::server {

class LogRateLimit {
 public:
  LogRateLimit(double lines_per_second, double burst) : rate_(lines_per_second), burst_(burst) {}

  struct Verdict {
    bool emit = true;
    uint64_t suppressed = 0;  // lines of this kind dropped since its last emitted line
  };
  // Whether a line of `kind` at `now_s` (any monotonic seconds) may be written.
  Verdict admit(std::string_view kind, double now_s);
  // The kinds with lines dropped since their last emitted line, and how many; resets them.
  std::vector<std::pair<std::string, uint64_t>> take_suppressed();

 private:
  struct Bucket {
    double tokens = 0, last_s = 0;
    uint64_t suppressed = 0;
  };
  double rate_, burst_;
  std::map<std::string, Bucket, std::less<>> buckets_;
};

}  // namespace loam::server
