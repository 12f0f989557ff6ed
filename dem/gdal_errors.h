// GDAL's errors captured instead of printed: while a GdalErrorCapture lives, every CPLError
// raised on this thread is recorded (a few messages, printable characters only), so a
// failure can name GDAL's reason in an Error and nothing reaches stderr.
#pragma once

#include <string>
#include <vector>

namespace loam {

class GdalErrorCapture {
 public:
  GdalErrorCapture();
  ~GdalErrorCapture();
  GdalErrorCapture(const GdalErrorCapture&) = delete;
  GdalErrorCapture& operator=(const GdalErrorCapture&) = delete;

  bool failed() const { return failures_ > 0; }  // a CE_Failure or CE_Fatal was raised
  // The recorded failures (or, when none, warnings) joined by "; "; `fallback` when empty.
  std::string text(const std::string& fallback) const;

  void record(int error_class, const char* message);  // called by GDAL's handler

 private:
  int failures_ = 0;
  std::vector<std::string> errors_, warnings_;
};

// Registers GDAL's drivers, caps its block cache (64 MiB) and turns off VRT Python pixel
// functions, once per process.
void ensure_gdal_ready();

}  // namespace loam
