#include "dem/ascii_grid_check.h"

#include <cstdio>
#include <fstream>
#include <vector>

namespace loam {
namespace {

// Longer than any number a grid writes (GDAL prints at most 17 significant digits).
constexpr size_t kMaxToken = 64;

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }

char lower(char c) { return c >= 'A' && c <= 'Z' ? char(c - 'A' + 'a') : c; }

std::string lowered(const std::string& s) {
  std::string out = s;
  for (char& c : out) c = lower(c);
  return out;
}

// [+-] digits [. digits] [(e|E) [+-] digits], with at least one digit before the exponent; or
// nan. No locale, no hex, no inf: what a grid's writer prints for a height.
bool is_number(const std::string& t) {
  // Only a token that ends in n or N can be nan: no per-cell lowering (grids hold 2^28 cells).
  if (!t.empty() && lower(t.back()) == 'n') return lowered(t) == "nan" || lowered(t) == "-nan";
  size_t i = 0;
  if (i < t.size() && (t[i] == '+' || t[i] == '-')) ++i;
  size_t digits = 0;
  while (i < t.size() && is_digit(t[i])) ++i, ++digits;
  if (i < t.size() && t[i] == '.') {
    ++i;
    while (i < t.size() && is_digit(t[i])) ++i, ++digits;
  }
  if (digits == 0) return false;
  if (i < t.size() && (t[i] == 'e' || t[i] == 'E')) {
    ++i;
    if (i < t.size() && (t[i] == '+' || t[i] == '-')) ++i;
    size_t exp_digits = 0;
    while (i < t.size() && is_digit(t[i])) ++i, ++exp_digits;
    if (exp_digits == 0) return false;
  }
  return i == t.size();
}

// A whole number of cells in 1..2^31 (a header's ncols or nrows).
bool parse_count(const std::string& t, int64_t& out) {
  if (t.empty() || t.size() > 10) return false;
  int64_t v = 0;
  for (const char c : t) {
    if (!is_digit(c)) return false;
    v = v * 10 + (c - '0');
  }
  if (v < 1 || v > (int64_t(1) << 31)) return false;
  out = v;
  return true;
}

bool is_header_key(const std::string& k) {
  for (const char* known : {"ncols", "nrows", "xllcorner", "xllcenter", "yllcorner", "yllcenter", "cellsize",
                            "dx", "dy", "nodata_value"}) {
    if (k == known) return true;
  }
  return false;
}

std::string printable(const std::string& t) {
  std::string out;
  for (const char c : t) {
    const auto u = static_cast<unsigned char>(c);
    if (u >= 0x20 && u < 0x7F) {
      out.push_back(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", u);
      out += buf;
    }
  }
  return out;
}

}  // namespace

Status AsciiGridChecker::feed(std::span<const char> bytes) {
  if (!failed_.ok()) return failed_;
  for (const char c : bytes) {
    if (is_space(c)) {
      if (!token_.empty()) {
        if (Status st = token_end(); !st.ok()) return failed_ = st;
      }
      if (c == '\n') ++line_;
      continue;
    }
    if (c == '\0') {
      return failed_ = make_error(ErrorCode::kCorrupt, name_,
                                  "line " + std::to_string(line_) + ": a NUL byte; an ASCII grid is text");
    }
    if (token_.empty()) token_line_ = line_;
    if (token_.size() == kMaxToken) {
      return failed_ = make_error(ErrorCode::kCorrupt, name_,
                                  "line " + std::to_string(line_) + ": a token longer than " +
                                      std::to_string(kMaxToken) + " bytes ('" +
                                      printable(token_.substr(0, 16)) + "...'); an ASCII grid holds numbers");
    }
    token_.push_back(c);
  }
  return {};
}

Status AsciiGridChecker::token_end() {
  Status st = header_or_cell(token_);
  token_.clear();  // keeps its capacity: no allocation per cell
  return st;
}

Status AsciiGridChecker::header_or_cell(const std::string& t) {
  if (in_data_ && is_number(t)) {  // the common case, every cell: nothing built
    ++cells_;
    return {};
  }
  const std::string where = "line " + std::to_string(token_line_);
  if (!pending_key_.empty()) {
    // The value of a header keyword.
    const std::string key = std::move(pending_key_);
    pending_key_.clear();
    if (key == "ncols" || key == "nrows") {
      int64_t v = 0;
      if (!parse_count(t, v)) {
        return make_error(
            ErrorCode::kCorrupt, name_,
            where + ": " + key + " '" + printable(t) + "' is not a whole number of cells (1..2^31)");
      }
      (key == "ncols" ? ncols_ : nrows_) = v;
    } else if (!is_number(t)) {
      return make_error(ErrorCode::kCorrupt, name_,
                        where + ": " + key + " '" + printable(t) + "' is not a number");
    }
    return {};
  }
  if (!in_data_) {
    const std::string key = lowered(t);
    if (is_header_key(key)) {
      pending_key_ = key;
      return {};
    }
    in_data_ = true;
    if (ncols_ == 0 || nrows_ == 0) {
      return make_error(ErrorCode::kCorrupt, name_,
                        where + ": '" + printable(t) + "' before the header named ncols and nrows" +
                            (is_number(t) ? ""
                                          : " (not a header keyword: ncols, nrows, xllcorner, yllcorner, "
                                            "cellsize, nodata_value)"));
    }
  }
  if (!is_number(t)) {
    const int64_t row = cells_ / ncols_ + 1, col = cells_ % ncols_ + 1;
    return make_error(ErrorCode::kCorrupt, name_,
                      "row " + std::to_string(row) + ", column " + std::to_string(col) + " (" + where +
                          "): '" + printable(t) + "' is not a number");
  }
  ++cells_;
  return {};
}

Status AsciiGridChecker::finish() {
  if (!failed_.ok()) return failed_;
  if (!token_.empty()) {
    if (Status st = token_end(); !st.ok()) return failed_ = st;
  }
  if (!pending_key_.empty()) {
    return failed_ = make_error(ErrorCode::kTruncated, name_,
                                "the header ends at '" + pending_key_ + "' without its value");
  }
  if (ncols_ == 0 || nrows_ == 0) {
    return failed_ =
               make_error(ErrorCode::kCorrupt, name_, "no ncols and nrows header: not an ESRI ASCII grid");
  }
  return {};
}

Status check_ascii_grid(std::span<const uint8_t> text, const std::string& name) {
  AsciiGridChecker c(name);
  LOAM_TRY(c.feed(std::span<const char>(reinterpret_cast<const char*>(text.data()), text.size())));
  return c.finish();
}

Status check_ascii_grid_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kIo, path, "cannot open the file");
  AsciiGridChecker c(path);
  std::vector<char> buf(size_t(1) << 20);
  while (in) {
    in.read(buf.data(), std::streamsize(buf.size()));
    const auto got = in.gcount();
    if (got <= 0) break;
    LOAM_TRY(c.feed(std::span<const char>(buf.data(), size_t(got))));
  }
  if (in.bad()) return make_error(ErrorCode::kIo, path, "read failed");
  return c.finish();
}

}  // namespace loam
