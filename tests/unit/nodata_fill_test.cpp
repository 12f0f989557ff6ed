// The NoData fill (dem/nodata_fill.h): the streamed interpolation equals a direct eight-line
// search at every sample, whatever the hole shapes, row lag and raster size; fill choices parse
// and print back; a wide hole's middle stays unreached.
#include "dem/nodata_fill.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace loam {
namespace {

// The definition, sample by sample: along each of the eight lines from a missing sample, the
// first valid sample within `search` steps, weighted by one over its squared distance.
std::vector<double> eight_line_reference(const std::vector<double>& v, int w, int h, int search) {
  std::vector<double> out = v;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (!std::isnan(v[size_t(y * w + x)])) continue;
      double sw = 0, s = 0;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          if (dx == 0 && dy == 0) continue;
          for (int k = 1; k <= search; ++k) {
            const int sx = x + dx * k, sy = y + dy * k;
            if (sx < 0 || sy < 0 || sx >= w || sy >= h) break;
            const double u = v[size_t(sy * w + sx)];
            if (std::isnan(u)) continue;
            const double wt = 1.0 / (double(k) * k * (dx * dx + dy * dy));
            sw += wt;
            s += wt * u;
            break;
          }
        }
      }
      if (sw > 0) out[size_t(y * w + x)] = s / sw;
    }
  }
  return out;
}

std::vector<double> holed(int w, int h, uint32_t seed, double hole_fraction) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<double> v(size_t(w * h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) v[size_t(y * w + x)] = 100.0 + 3.0 * std::sin(x * 0.3) + 0.7 * y + u(rng);
  // Blobs of NoData of random size, and scattered single samples.
  std::uniform_int_distribution<int> px(0, w - 1), py(0, h - 1), pr(0, std::max(1, std::min(w, h) / 4));
  const int blobs = int(hole_fraction * 20);
  for (int b = 0; b < blobs; ++b) {
    const int cx = px(rng), cy = py(rng), r = pr(rng);
    for (int y = std::max(0, cy - r); y < std::min(h, cy + r + 1); ++y)
      for (int x = std::max(0, cx - r); x < std::min(w, cx + r + 1); ++x)
        if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r) v[size_t(y * w + x)] = NAN;
  }
  for (auto& s : v)
    if (u(rng) < 0.02) s = NAN;
  return v;
}

void expect_same(const std::vector<double>& a, const std::vector<double>& b, int w) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::isnan(a[i]) || std::isnan(b[i])) {
      ASSERT_EQ(std::isnan(a[i]), std::isnan(b[i])) << "sample " << i % size_t(w) << ", " << i / size_t(w);
      continue;
    }
    ASSERT_NEAR(a[i], b[i], 1e-9 * std::fabs(b[i])) << "sample " << i % size_t(w) << ", " << i / size_t(w);
  }
}

TEST(NodataFill, StreamedInterpolationEqualsTheEightLineSearchAtEverySample) {
  struct Case {
    int w, h, search;
    uint32_t seed;
  };
  // Rasters shorter and taller than the rows in flight, one column, odd searches.
  for (const Case c : {Case{37, 23, 4, 1}, Case{64, 200, 5, 2}, Case{1, 90, 3, 3}, Case{120, 7, 8, 4},
                       Case{53, 311, kNodataSearchSamples, 5}, Case{9, 9, 1, 6}}) {
    SCOPED_TRACE(testing::Message() << c.w << " x " << c.h << ", search " << c.search);
    std::vector<double> v = holed(c.w, c.h, c.seed, 0.5);
    const std::vector<double> want = eight_line_reference(v, c.w, c.h, c.search);
    int64_t missing = 0, reached = 0;
    for (size_t i = 0; i < v.size(); ++i) {
      missing += std::isnan(v[i]);
      reached += std::isnan(v[i]) && !std::isnan(want[i]);
    }
    const int64_t filled = interpolate_nodata(v, c.w, c.search);
    EXPECT_EQ(filled, reached);
    if (c.w > 1) {
      EXPECT_GT(missing, 0);
    }
    expect_same(v, want, c.w);
  }
}

TEST(NodataFill, RowsComeOutInOrderAndTheCountsAddUp) {
  const int w = 40, h = 150, search = 6;
  const std::vector<double> v = holed(w, h, 9, 1.0);
  std::vector<double> out;
  int rows = 0;
  NodataInterpolator f(
      w,
      [&](std::span<const double> row, std::span<const double> source) {
        EXPECT_EQ(source.size(), row.size());
        ++rows;
        out.insert(out.end(), row.begin(), row.end());
        return Status{};
      },
      search);
  for (int y = 0; y < h; ++y) {
    ASSERT_TRUE(f.push(std::span<const double>(v).subspan(size_t(y * w), size_t(w))).ok());
    // Rows come out at most 1.5 search distances behind what went in.
    EXPECT_GE(rows, y + 1 - search - search / 2);
  }
  ASSERT_TRUE(f.finish().ok());
  EXPECT_EQ(rows, h);
  int64_t missing = 0, left = 0;
  for (size_t i = 0; i < v.size(); ++i) {
    missing += std::isnan(v[i]);
    left += std::isnan(out[i]);
  }
  EXPECT_EQ(f.filled() + f.unreached(), missing);
  EXPECT_EQ(f.unreached(), left);
  // A row of another width is refused, and an error from the receiver stops the filler.
  EXPECT_FALSE(f.push(std::vector<double>(size_t(w + 1), 1.0)).ok());
  NodataInterpolator failing(
      4,
      [](std::span<const double>, std::span<const double>) {
        return Status(make_error(ErrorCode::kIo, "out", "disk full"));
      },
      1);
  Status st;
  for (int y = 0; y < 4 && st.ok(); ++y) st = failing.push(std::vector<double>(4, 1.0));
  if (st.ok()) st = failing.finish();
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().message, "disk full");
}

TEST(NodataFill, AHoleWiderThanTheSearchLeavesItsMiddleUnreached) {
  const int w = 101, h = 101, search = 10;
  std::vector<double> v(size_t(w * h), 50.0);
  for (int y = 20; y < 81; ++y)
    for (int x = 20; x < 81; ++x) v[size_t(y * w + x)] = NAN;
  interpolate_nodata(v, w, search);
  EXPECT_TRUE(std::isnan(v[size_t(50 * w + 50)]));
  EXPECT_DOUBLE_EQ(v[size_t(50 * w + 21)], 50.0);  // next to the rim: the rim's height
  EXPECT_DOUBLE_EQ(v[size_t(29 * w + 29)], 50.0);  // reached along the diagonals
}

// A plane's hole fills close to the plane, with no step steeper than the plane's own slope
// allows: the rim's heights carry into the hole instead of a floor at the minimum.
TEST(NodataFill, APlanesHoleFillsWithoutCliffs) {
  const int w = 95, h = 90;
  std::vector<double> v(size_t(w * h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) v[size_t(y * w + x)] = 200.0 + 0.5 * x + 0.25 * y;
  const std::vector<double> plane = v;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if ((x - 47) * (x - 47) + (y - 45) * (y - 45) <= 35 * 35) v[size_t(y * w + x)] = NAN;
  interpolate_nodata(v, w);
  double worst = 0, steepest = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      ASSERT_FALSE(std::isnan(v[size_t(y * w + x)]));
      worst = std::max(worst, std::fabs(v[size_t(y * w + x)] - plane[size_t(y * w + x)]));
      if (x > 0) steepest = std::max(steepest, std::fabs(v[size_t(y * w + x)] - v[size_t(y * w + x - 1)]));
      if (y > 0) steepest = std::max(steepest, std::fabs(v[size_t(y * w + x)] - v[size_t((y - 1) * w + x)]));
    }
  }
  EXPECT_LT(worst, 6.0) << "the plane drops 35 m across the hole's radius";
  EXPECT_LT(steepest, 1.5) << "the plane's own steps are 0.5 m";
}

TEST(NodataFill, ChoicesParseAndPrintBack) {
  for (const char* text : {"interpolate", "min", "value:12.5", "value:-3", "value:0"}) {
    auto f = NodataFill::parse(text);
    ASSERT_TRUE(f.ok()) << text;
    EXPECT_EQ(f->to_string(), text);
  }
  EXPECT_EQ(NodataFill::parse("value:0.1")->value_m, 0.1);
  for (const char* bad : {"", "mean", "value:", "value:nan", "value:inf", "value:1e7", "value:5m", "Min"}) {
    auto f = NodataFill::parse(bad);
    ASSERT_FALSE(f.ok()) << bad;
    EXPECT_EQ(f.error().field, "nodata-fill");
  }
}

}  // namespace
}  // namespace loam
