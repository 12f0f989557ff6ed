// loam-bench's harness: suites register themselves, time their work with warm-up and
// repeated runs (median and spread), and write bench/results/<suite>.md, CSV tables and PNG
// plots (gnuplot). Each run also measures this machine's memcpy bandwidth as a reference
// line, so speeds can be read against the memory floor of the machine they ran on.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace loam::bench {

struct Context {
  bool quick = false;           // smoke-test sizes (CI); numbers are not representative
  std::string out_dir;          // where <suite>.md, .csv and .png go
  std::string shared_data_dir;  // ../shared/data (may be absent)
  std::string source_dir;       // the repository (data/ lives there)
  double memcpy_gbps = 0;       // measured at start-up, one core
  std::string machine;          // CPU model and core count, for the report header
  bool sanitized = false;       // built with sanitizers: numbers are meaningless
};

struct Timing {
  double median_s = 0, p10_s = 0, p90_s = 0, min_s = 0;
  int runs = 0;
  std::string spread() const;  // "p10..p90" as text
};

struct MeasureOptions {
  int warmup = 1;
  int min_runs = 5;
  int max_runs = 1000;
  double min_seconds = 0.3;  // keep repeating until this much time is spent (quick: 0.02)
};

// Runs fn warmup times untimed, then repeatedly timed; returns the distribution.
Timing measure(const Context& ctx, const std::function<void()>& fn, MeasureOptions options = {});

// The distribution of samples timed some other way (a GPU clock, a loop with its own phases).
Timing summarize(std::vector<double> samples);

// Bytes per second -> text like "1.23 GB/s".
std::string format_rate(double bytes_per_second);
// Milliseconds from `t0` to now (steady clock).
double ms_since(std::chrono::steady_clock::time_point t0);
// `v` with `digits` decimals.
std::string fmt(double v, int digits = 2);
// `v` through a printf format that takes one double ("%.1f ms").
std::string fmt(const char* format, double v);

// A table that becomes a Markdown table in the report and a CSV file.
class Table {
 public:
  Table(std::string name, std::vector<std::string> columns);
  void add_row(std::vector<std::string> cells);
  const std::string& name() const { return name_; }
  std::string markdown() const;
  std::string csv() const;
  size_t rows() const { return rows_.size(); }

 private:
  std::string name_;
  std::vector<std::string> columns_;
  std::vector<std::vector<std::string>> rows_;
};

struct Series {
  std::string title;
  std::vector<std::pair<double, double>> points;
};

struct Plot {
  std::string file;  // PNG file name, e.g. "import_time.png"
  std::string title, xlabel, ylabel;
  bool logx = false, logy = false;
  std::vector<Series> series;
  std::vector<std::pair<std::string, double>> hlines;  // reference lines (label, y)
};

// What a suite produces; the harness writes it out.
class Report {
 public:
  explicit Report(std::string suite) : suite_(std::move(suite)) {}
  // Writes under another name (a partial run must not replace the suite's full report).
  void rename(std::string name) { suite_ = std::move(name); }
  const std::string& name() const { return suite_; }
  void paragraph(std::string text) { blocks_.push_back({Block::kText, text, 0}); }
  void table(Table t);
  void plot(Plot p);
  // Writes <out>/<suite>.md, one CSV per table (<suite>.csv for the first, <suite>_<name>.csv
  // for others) and the plots. Returns false (after printing why) on failure.
  bool write(const Context& ctx) const;

 private:
  struct Block {
    enum Kind { kText, kTable, kPlot } kind;
    std::string text;
    size_t index;
  };
  std::string suite_;
  std::vector<Block> blocks_;
  std::vector<Table> tables_;
  std::vector<Plot> plots_;
};

// A suite returns 0 on success; non-zero marks the run failed (e.g. a target missed where the
// suite treats it as an error, or an input could not be read).
using SuiteFn = int (*)(const Context&, Report&);

struct SuiteInfo {
  const char* name;
  const char* description;
  SuiteFn fn;
};
std::vector<SuiteInfo>& suites();

struct SuiteRegistration {
  SuiteRegistration(const char* name, const char* description, SuiteFn fn) {
    suites().push_back({name, description, fn});
  }
};

}  // namespace loam::bench

// Registers a suite; use once per suite at namespace scope in bench/suites/*.cpp.
#define LOAM_BENCH_SUITE(id, description, fn) \
  static ::loam::bench::SuiteRegistration loam_bench_suite_##id(#id, description, fn)
