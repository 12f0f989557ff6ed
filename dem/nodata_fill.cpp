#include "dem/nodata_fill.h"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace loam {

namespace {
constexpr int32_t kNone = INT32_MAX;

// Rows emitted per downward sweep: the sweep walks the rows in flight, so a block of half the
// search distance walks each row three times and holds 1.5 x search rows.
int block_rows(int search) { return std::max(1, search / 2); }
}  // namespace

Result<NodataFill> NodataFill::parse(std::string_view text) {
  if (text == "interpolate") return NodataFill{};
  if (text == "min") return NodataFill{Mode::kMin, 0};
  constexpr std::string_view prefix = "value:";
  if (text.substr(0, prefix.size()) == prefix) {
    const std::string_view num = text.substr(prefix.size());
    double v = 0;
    const auto [end, ec] = std::from_chars(num.data(), num.data() + num.size(), v);
    if (ec == std::errc() && end == num.data() + num.size() && std::isfinite(v) && std::fabs(v) <= 1e6)
      return NodataFill{Mode::kValue, v};
    return make_error(ErrorCode::kInvalidArgument, "nodata-fill",
                      "value:H needs a height H in metres within +-1000 km, not '" + std::string(num) + "'");
  }
  return make_error(ErrorCode::kInvalidArgument, "nodata-fill",
                    "'" + std::string(text) + "' is not interpolate, min or value:H");
}

std::string NodataFill::to_string() const {
  switch (mode) {
    case Mode::kInterpolate: return "interpolate";
    case Mode::kMin: return "min";
    case Mode::kValue: {
      char buf[64];
      const auto r = std::to_chars(buf, buf + sizeof buf, value_m);  // shortest round trip
      return "value:" + std::string(buf, r.ptr);
    }
  }
  return "interpolate";
}

NodataInterpolator::NodataInterpolator(int64_t width, Emit emit, int search)
    : width_(width), search_(std::max(1, search)), emit_(std::move(emit)) {
  const size_t w = size_t(std::max<int64_t>(width, 0));
  above_.assign(w, {0, kNone});
  above_left_ = above_right_ = above_;
  next_.resize(w);
}

size_t NodataInterpolator::buffer_bytes() const {
  size_t n = 0;
  for (const Row& r : rows_) n += (r.v.capacity() + r.sum_w.capacity() + r.sum.capacity()) * sizeof(double);
  return n + 7 * size_t(width_) * sizeof(Seen);
}

void NodataInterpolator::add(Row& r, size_t x, const Seen& s, double step_sq) {
  if (s.steps == kNone || s.steps > search_) return;
  const double w = 1.0 / (double(s.steps) * double(s.steps) * step_sq);
  r.sum_w[x] += w;
  r.sum[x] += w * s.v;
}

NodataInterpolator::Seen NodataInterpolator::further(const Seen& s) {
  return s.steps == kNone ? s : Seen{s.v, s.steps + 1};
}

void NodataInterpolator::carry(std::vector<Seen>& c, const std::vector<double>& row, int dx) {
  const size_t w = row.size();
  for (size_t x = 0; x < w; ++x) {
    const int64_t from = int64_t(x) - dx;
    if (!std::isnan(row[x]))
      next_[x] = {row[x], 0};
    else if (from < 0 || from >= int64_t(w))
      next_[x] = {0, kNone};
    else
      next_[x] = further(c[size_t(from)]);
  }
  c.swap(next_);
}

// The lines that reach a new row from the rows above it (the carries hold, per column, the
// nearest valid sample at or above the previous row) and along the row itself.
void NodataInterpolator::look_up_and_sideways(Row& r) {
  const size_t w = r.v.size();
  const bool holes = std::any_of(r.v.begin(), r.v.end(), [](double v) { return std::isnan(v); });
  if (holes) {
    r.sum_w.assign(w, 0.0);
    r.sum.assign(w, 0.0);
    Seen left{0, kNone};
    for (size_t x = 0; x < w; ++x) {
      if (!std::isnan(r.v[x])) {
        left = {r.v[x], 0};
        continue;
      }
      left = further(left);
      add(r, x, left, 1.0);
      add(r, x, further(above_[x]), 1.0);
      if (x > 0) add(r, x, further(above_left_[x - 1]), 2.0);
      if (x + 1 < w) add(r, x, further(above_right_[x + 1]), 2.0);
    }
    Seen right{0, kNone};
    for (size_t x = w; x-- > 0;) {
      if (!std::isnan(r.v[x])) {
        right = {r.v[x], 0};
        continue;
      }
      right = further(right);
      add(r, x, right, 1.0);
    }
  }
  // The carries move down to this row.
  carry(above_, r.v, 0);
  carry(above_left_, r.v, 1);
  carry(above_right_, r.v, -1);
}

// The lines from below: a sweep up through every row in flight, adding to the first
// `first_done` rows (whose rows within the search distance below are all in flight).
void NodataInterpolator::look_down(size_t first_done) {
  const size_t w = size_t(width_);
  below_.assign(w, {0, kNone});
  below_left_ = below_right_ = below_;
  for (size_t i = rows_.size(); i-- > 0;) {
    Row& r = rows_[i];
    if (i < first_done && !r.sum_w.empty()) {
      for (size_t x = 0; x < w; ++x) {
        if (!std::isnan(r.v[x])) continue;
        add(r, x, further(below_[x]), 1.0);
        if (x > 0) add(r, x, further(below_left_[x - 1]), 2.0);
        if (x + 1 < w) add(r, x, further(below_right_[x + 1]), 2.0);
      }
    }
    carry(below_, r.v, 0);
    carry(below_left_, r.v, 1);
    carry(below_right_, r.v, -1);
  }
}

Status NodataInterpolator::emit_front(size_t count) {
  for (size_t i = 0; i < count; ++i) {
    Row& r = rows_[i];
    if (r.sum_w.empty()) {
      LOAM_TRY(emit_(r.v, r.v));
      continue;
    }
    out_.resize(r.v.size());
    for (size_t x = 0; x < r.v.size(); ++x) {
      out_[x] = r.v[x];
      if (!std::isnan(r.v[x])) continue;
      if (r.sum_w[x] > 0) {
        out_[x] = r.sum[x] / r.sum_w[x];
        ++filled_;
      } else {
        ++unreached_;
      }
    }
    LOAM_TRY(emit_(out_, r.v));
  }
  // Emitted rows give their buffers to the rows still to come.
  std::rotate(rows_.begin(), rows_.begin() + ptrdiff_t(count), rows_.end());
  rows_.resize(rows_.size() - count);
  return {};
}

Status NodataInterpolator::push(std::span<const double> row) {
  if (int64_t(row.size()) != width_)
    return make_error(ErrorCode::kInvalidArgument, "nodata fill", "row width differs from the raster's");
  Row r;
  r.v.assign(row.begin(), row.end());
  look_up_and_sideways(r);
  rows_.push_back(std::move(r));
  const size_t block = size_t(block_rows(search_));
  if (rows_.size() < size_t(search_) + block) return {};
  look_down(block);
  return emit_front(block);
}

Status NodataInterpolator::finish() {
  look_down(rows_.size());
  return emit_front(rows_.size());
}

int64_t interpolate_nodata(std::span<double> samples, int64_t width, int search) {
  if (width <= 0) return 0;
  size_t at = 0;
  NodataInterpolator f(
      width,
      [&](std::span<const double> row, std::span<const double>) {
        std::copy(row.begin(), row.end(), samples.begin() + ptrdiff_t(at));
        at += row.size();
        return Status{};
      },
      search);
  const int64_t rows = int64_t(samples.size()) / width;
  for (int64_t y = 0; y < rows; ++y) {
    // Rows are copied in before any is written back: the filler lags, so row y is pushed
    // before row y - lag is emitted over it.
    (void)f.push(samples.subspan(size_t(y * width), size_t(width)));
  }
  (void)f.finish();
  return f.filled();
}

}  // namespace loam
