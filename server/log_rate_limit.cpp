#include "server/log_rate_limit.h"

#include <algorithm>

namespace loam::server {

LogRateLimit::Verdict LogRateLimit::admit(std::string_view kind, double now_s) {
  auto it = buckets_.find(kind);
  if (it == buckets_.end()) it = buckets_.emplace(std::string(kind), Bucket{burst_, now_s, 0}).first;
  Bucket& b = it->second;
  b.tokens = std::min(burst_, b.tokens + std::max(0.0, now_s - b.last_s) * rate_);
  b.last_s = now_s;
  if (b.tokens < 1.0) {
    ++b.suppressed;
    return {false, 0};
  }
  b.tokens -= 1.0;
  return {true, std::exchange(b.suppressed, 0)};
}

std::vector<std::pair<std::string, uint64_t>> LogRateLimit::take_suppressed() {
  std::vector<std::pair<std::string, uint64_t>> out;
  for (auto& [kind, b] : buckets_) {
    if (b.suppressed > 0) out.emplace_back(kind, std::exchange(b.suppressed, 0));
  }
  return out;
}

}  // namespace loam::server
