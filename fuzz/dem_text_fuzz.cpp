// libFuzzer target for the DEM text Loam parses itself (files a user brings, so untrusted): the
// JSON sidecar beside a DEM (parse_sidecar, check_sidecar_matches) and the ESRI ASCII grid
// check (dem/ascii_grid_check.h). The first byte picks which; the rest is the text.
// Properties checked (abort on violation):
//  - each returns a value or an error, never crashes, leaks or reads out of bounds;
//  - a parsed sidecar's numbers are finite and in their documented ranges, and it matches the
//    width, height and sample type it states;
//  - the grid check's verdict is the same whether the text comes whole or in two pieces split
//    anywhere (the split point comes from the input too).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <string>

#include "dem/ascii_grid_check.h"
#include "dem/dem_sidecar.h"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "dem_text_fuzz property violated: %s\n", what);
  std::abort();
}

std::string verdict(const loam::Status& st) { return st.ok() ? std::string("ok") : st.error().describe(); }

void sidecar(const std::string& text) {
  auto s = loam::parse_sidecar(text, "fuzz.json");
  if (!s) return;
  if (s->meters_per_sample && !(std::isfinite(*s->meters_per_sample) && *s->meters_per_sample > 0))
    fail("a sidecar's meters per sample is not finite and positive");
  if (!(std::isfinite(s->anisotropy) && s->anisotropy > 0))
    fail("a sidecar's anisotropy is not finite and positive");
  if (s->width && s->height && s->sample_type && !s->loam_world) {
    if (!loam::check_sidecar_matches(*s, *s->width, *s->height, *s->sample_type, "fuzz.json").ok())
      fail("a sidecar does not match the size and type it states");
  }
}

void ascii_grid(std::span<const uint8_t> text, size_t split) {
  const std::string whole = verdict(loam::check_ascii_grid(text, "fuzz.asc"));
  loam::AsciiGridChecker c("fuzz.asc");
  const auto* p = reinterpret_cast<const char*>(text.data());
  split = text.empty() ? 0 : split % (text.size() + 1);
  loam::Status st = c.feed(std::span<const char>(p, split));
  if (st.ok()) st = c.feed(std::span<const char>(p + split, text.size() - split));
  if (st.ok()) st = c.finish();
  if (verdict(st) != whole) fail("the grid check's verdict depends on where the text was split");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  const std::span<const uint8_t> text(data + 2, size - 2);
  if (data[0] & 1) {
    ascii_grid(text, size_t(data[1]) * 7);
  } else {
    sidecar(std::string(reinterpret_cast<const char*>(text.data()), text.size()));
  }
  return 0;
}
