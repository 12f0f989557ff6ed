// A 64-bit hash or id as the 16 lowercase hex digits every Loam tool prints (log lines, JSON
// views, replay output), so they compare as text. Pure.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace loam {

inline std::string hex64(uint64_t v) {
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

}  // namespace loam
