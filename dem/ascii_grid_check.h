// Checking the text of an ESRI ASCII grid (.asc) before GDAL reads it. GDAL's reader turns any
// token it cannot parse into 0 (`banana` imports as a cell at 0 m, silently), so Loam reads the
// text itself first and refuses a grid whose header or cells are not numbers, naming the cell's
// row and column (1-based, row 1 the first data row, i.e. the north edge) and the file's line.
//
// The format: header lines `KEYWORD value` (ncols, nrows, xllcorner|xllcenter,
// yllcorner|yllcenter, cellsize or dx and dy, nodata_value; any case, any order), then
// ncols x nrows cell values separated by white space, row after row. A value is a decimal
// number (sign, digits, point, exponent) or `nan`; the count of cells is GDAL's to check.
//
// Pure and streaming: feed() takes the text in chunks of any size (a token may straddle two),
// memory stays a few hundred bytes whatever the file's size, and nothing throws.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "protocol/result.h"

namespace loam {

class AsciiGridChecker {
 public:
  explicit AsciiGridChecker(std::string name) : name_(std::move(name)) {}
  // The next bytes of the file. Once it returned an error, every later call returns it too.
  Status feed(std::span<const char> bytes);
  // The end of the file: checks the last token and that the header named its size.
  Status finish();

  int64_t cells() const { return cells_; }  // cell values seen so far

 private:
  Status token_end();
  Status header_or_cell(const std::string& token);

  std::string name_;
  std::string token_;  // the token in progress (at most kMaxToken bytes)
  Status failed_;
  int64_t line_ = 1, token_line_ = 1;
  int64_t ncols_ = 0, nrows_ = 0;
  bool in_data_ = false;
  std::string pending_key_;  // a header keyword waiting for its value
  int64_t cells_ = 0;
};

// The whole text at once (what feed() over any split of it gives).
Status check_ascii_grid(std::span<const uint8_t> text, const std::string& name);
// Streams the file in 1 MiB reads.
Status check_ascii_grid_file(const std::string& path);

}  // namespace loam
