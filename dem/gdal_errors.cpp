#include "dem/gdal_errors.h"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal.h>

#include <mutex>

namespace loam {
namespace {

constexpr size_t kMaxMessages = 3;
constexpr size_t kMaxMessageChars = 240;
constexpr int64_t kGdalCacheBytes = int64_t(64) << 20;

void CPL_STDCALL capture_handler(CPLErr error_class, CPLErrorNum, const char* message) {
  auto* capture = static_cast<GdalErrorCapture*>(CPLGetErrorHandlerUserData());
  if (capture) capture->record(int(error_class), message);
}

std::string printable(const char* message) {
  std::string out;
  for (const char* p = message ? message : ""; *p && out.size() < kMaxMessageChars; ++p) {
    const unsigned char c = static_cast<unsigned char>(*p);
    out.push_back(c >= 0x20 && c < 0x7f ? char(c) : '?');
  }
  return out;
}

}  // namespace

GdalErrorCapture::GdalErrorCapture() { CPLPushErrorHandlerEx(capture_handler, this); }

GdalErrorCapture::~GdalErrorCapture() { CPLPopErrorHandler(); }

void GdalErrorCapture::record(int error_class, const char* message) {
  if (error_class == CE_Debug || error_class == CE_None) return;
  const bool failure = error_class == CE_Failure || error_class == CE_Fatal;
  failures_ += failure ? 1 : 0;
  std::vector<std::string>& list = failure ? errors_ : warnings_;
  std::string text = printable(message);
  // GDAL repeats a driver's message inside its own ("IReadBlock failed ...: <the message>"):
  // keep the first, most specific, once.
  for (const std::string& m : list) {
    if (!m.empty() && (text.find(m) != std::string::npos || m.find(text) != std::string::npos)) return;
  }
  if (list.size() < kMaxMessages) list.push_back(std::move(text));
}

std::string GdalErrorCapture::text(const std::string& fallback) const {
  const std::vector<std::string>& list = errors_.empty() ? warnings_ : errors_;
  std::string out;
  for (const std::string& m : list) {
    if (m.empty()) continue;
    if (!out.empty()) out += "; ";
    out += m;
  }
  return out.empty() ? fallback : out;
}

void ensure_gdal_ready() {
  static std::once_flag once;
  std::call_once(once, [] {
    GdalErrorCapture quiet;
    // A VRT is untrusted input too: no Python pixel functions (gdal_source.cpp refuses raw
    // bands and nested VRTs).
    CPLSetConfigOption("GDAL_VRT_ENABLE_PYTHON", "NO");
    GDALAllRegister();
    GDALSetCacheMax64(kGdalCacheBytes);
  });
}

}  // namespace loam
