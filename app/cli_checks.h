// Range checks for numeric command-line options and config-file keys, shared by loam-server,
// loam-client and loam-probe. Each is a CLI11 Validator, so it runs on the option's text
// before conversion, for a flag and for the same key read from a --config file alike, and
// CLI11 names the option in the error ("--max-radius: must be a finite number in (0, 65536],
// got nan"). The range also shows in --help after the type ("FLOAT:(0, 65536]").
//
// Why not CLI::Range: a NaN compares false both ways and passes it, and its message differs
// per type. FiniteRange refuses NaN and infinities; IntRange refuses what is not an integer
// (a fraction, text) and anything outside [lo, hi] before an unsigned conversion could wrap.
// Parsing follows CLI11's own (strtod; strtoll with base 0, so 0x1f is 31), so the value
// checked is the value the option receives.
#pragma once

#include <CLI/CLI.hpp>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>

namespace loam::cli {

enum class Bound { kClosed, kOpen };

// A bound as a person writes it: 65536, 0.1, 1e+07.
inline std::string format_bound(double v) {
  char buf[32];
  if (std::fabs(v) < 1e15 && v == std::floor(v)) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
  } else {
    std::snprintf(buf, sizeof buf, "%g", v);
  }
  return buf;
}

// A finite number in [lo, hi], or (lo, hi] etc. with an open bound.
inline CLI::Validator FiniteRange(double lo, double hi, Bound lower = Bound::kClosed,
                                  Bound upper = Bound::kClosed) {
  const std::string range = std::string(lower == Bound::kOpen ? "(" : "[") + format_bound(lo) + ", " +
                            format_bound(hi) + (upper == Bound::kOpen ? ")" : "]");
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        const std::string why = "must be a finite number in " + range + ", got " + text;
        if (text.empty()) return why;
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (end != text.c_str() + text.size() || !std::isfinite(v)) return why;
        const bool above_lo = lower == Bound::kOpen ? v > lo : v >= lo;
        const bool below_hi = upper == Bound::kOpen ? v < hi : v <= hi;
        return above_lo && below_hi ? std::string() : why;
      },
      range, "FiniteRange");
}

// Any finite number (coordinates).
inline CLI::Validator Finite() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = text.empty() ? 0.0 : std::strtod(text.c_str(), &end);
        if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v))
          return "must be a finite number, got " + text;
        return {};
      },
      "finite", "Finite");
}

// An integer in [lo, hi].
inline CLI::Validator IntRange(int64_t lo, int64_t hi) {
  const std::string range = std::to_string(lo) + ".." + std::to_string(hi);
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        const std::string why = "must be an integer in " + range + ", got " + text;
        if (text.empty()) return why;
        char* end = nullptr;
        errno = 0;
        const long long v = std::strtoll(text.c_str(), &end, 0);
        if (errno == ERANGE || end != text.c_str() + text.size()) return why;
        return v >= lo && v <= hi ? std::string() : why;
      },
      range, "IntRange");
}

// A file written as PNG: the name must end in .png (any case), so a wrong name is refused
// before anything is drawn, not after.
inline CLI::Validator PngFile() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        const size_t n = text.size();
        const bool png = n > 4 && text[n - 4] == '.' &&
                         std::tolower(static_cast<unsigned char>(text[n - 3])) == 'p' &&
                         std::tolower(static_cast<unsigned char>(text[n - 2])) == 'n' &&
                         std::tolower(static_cast<unsigned char>(text[n - 1])) == 'g';
        return png ? std::string() : "must name a .png file, got " + text;
      },
      "FILE.png", "PngFile");
}

}  // namespace loam::cli
