#include "bench/harness.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace loam::bench {

std::vector<SuiteInfo>& suites() {
  static std::vector<SuiteInfo> all;
  return all;
}

std::string Timing::spread() const {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.3g..%.3g ms", p10_s * 1e3, p90_s * 1e3);
  return buf;
}

Timing measure(const Context& ctx, const std::function<void()>& fn, MeasureOptions options) {
  using clock = std::chrono::steady_clock;
  if (ctx.quick) {
    options.min_seconds = std::min(options.min_seconds, 0.02);
    options.min_runs = std::min(options.min_runs, 2);
    options.warmup = std::min(options.warmup, 1);
  }
  for (int i = 0; i < options.warmup; ++i) fn();
  std::vector<double> samples;
  const auto start = clock::now();
  while (int(samples.size()) < options.max_runs) {
    const auto t0 = clock::now();
    fn();
    const auto t1 = clock::now();
    samples.push_back(std::chrono::duration<double>(t1 - t0).count());
    const double spent = std::chrono::duration<double>(t1 - start).count();
    if (int(samples.size()) >= options.min_runs && spent >= options.min_seconds) break;
  }
  return summarize(std::move(samples));
}

Timing summarize(std::vector<double> samples) {
  Timing t;
  if (samples.empty()) return t;
  std::sort(samples.begin(), samples.end());
  auto pct = [&](double p) { return samples[size_t(p * double(samples.size() - 1) + 0.5)]; };
  t.runs = int(samples.size());
  t.median_s = pct(0.5);
  t.p10_s = pct(0.1);
  t.p90_s = pct(0.9);
  t.min_s = samples.front();
  return t;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string fmt(double v, int digits) {
  char b[32];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

std::string fmt(const char* format, double v) {
  char b[64];
  std::snprintf(b, sizeof b, format, v);
  return b;
}

std::string format_rate(double bps) {
  char buf[64];
  if (bps >= 1e9)
    std::snprintf(buf, sizeof buf, "%.2f GB/s", bps / 1e9);
  else if (bps >= 1e6)
    std::snprintf(buf, sizeof buf, "%.1f MB/s", bps / 1e6);
  else
    std::snprintf(buf, sizeof buf, "%.0f B/s", bps);
  return buf;
}

Table::Table(std::string name, std::vector<std::string> columns)
    : name_(std::move(name)), columns_(std::move(columns)) {}

void Table::add_row(std::vector<std::string> cells) {
  cells.resize(columns_.size());
  rows_.push_back(std::move(cells));
}

std::string Table::markdown() const {
  std::ostringstream out;
  out << "|";
  for (const auto& c : columns_) out << " " << c << " |";
  out << "\n|";
  for (size_t i = 0; i < columns_.size(); ++i) out << "---|";
  out << "\n";
  for (const auto& row : rows_) {
    out << "|";
    for (const auto& c : row) out << " " << c << " |";
    out << "\n";
  }
  return out.str();
}

namespace {
std::string csv_cell(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}
}  // namespace

std::string Table::csv() const {
  std::ostringstream out;
  for (size_t i = 0; i < columns_.size(); ++i) out << (i ? "," : "") << csv_cell(columns_[i]);
  out << "\n";
  for (const auto& row : rows_) {
    for (size_t i = 0; i < row.size(); ++i) out << (i ? "," : "") << csv_cell(row[i]);
    out << "\n";
  }
  return out.str();
}

void Report::table(Table t) {
  blocks_.push_back({Block::kTable, "", tables_.size()});
  tables_.push_back(std::move(t));
}

void Report::plot(Plot p) {
  blocks_.push_back({Block::kPlot, "", plots_.size()});
  plots_.push_back(std::move(p));
}

namespace {

bool write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) {
    std::fprintf(stderr, "loam-bench: cannot write %s\n", path.c_str());
    return false;
  }
  return true;
}

std::string gnuplot_quote(const std::string& s) {
  std::string out;
  for (char c : s) out += (c == '"' || c == '\\') ? ' ' : c;
  return out;
}

// Renders a plot with gnuplot (data and script kept beside the PNG for reproduction).
bool render_plot(const std::filesystem::path& dir, const Plot& p) {
  const std::filesystem::path png = dir / p.file;
  std::filesystem::path stem = png;
  stem.replace_extension("");
  std::ostringstream data, script;
  script << "set terminal pngcairo size 960,600 noenhanced\n"
         << "set output \"" << png.string() << "\"\n"
         << "set title \"" << gnuplot_quote(p.title) << "\"\n"
         << "set xlabel \"" << gnuplot_quote(p.xlabel) << "\"\n"
         << "set ylabel \"" << gnuplot_quote(p.ylabel) << "\"\n"
         << "set grid\nset key outside right top\n";
  if (p.logx) script << "set logscale x\n";
  if (p.logy) script << "set logscale y\n";
  for (size_t i = 0; i < p.series.size(); ++i) {
    if (i) data << "\n\n";
    data << "# " << p.series[i].title << "\n";
    for (const auto& [x, y] : p.series[i].points) data << x << " " << y << "\n";
  }
  const std::string dat = stem.string() + ".dat";
  script << "plot ";
  bool first = true;
  for (size_t i = 0; i < p.series.size(); ++i) {
    if (p.series[i].points.empty()) continue;
    script << (first ? "" : ", ") << "\"" << dat << "\" index " << i << " with linespoints title \""
           << gnuplot_quote(p.series[i].title) << "\"";
    first = false;
  }
  for (const auto& [label, y] : p.hlines) {
    script << (first ? "" : ", ") << y << " with lines dashtype 2 title \"" << gnuplot_quote(label) << "\"";
    first = false;
  }
  if (first) return true;  // nothing to draw
  script << "\n";
  const std::string gp = stem.string() + ".gp";
  if (!write_file(dat, data.str()) || !write_file(gp, script.str())) return false;
  const std::string cmd = "gnuplot \"" + gp + "\" 2>&1";
  if (std::system(cmd.c_str()) != 0) {
    std::fprintf(stderr, "loam-bench: gnuplot failed for %s (is gnuplot installed? scripts/setup.sh)\n",
                 gp.c_str());
    return false;
  }
  return true;
}

}  // namespace

bool Report::write(const Context& ctx) const {
  const std::filesystem::path dir(ctx.out_dir);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  std::ostringstream md;
  md << "# loam-bench: " << suite_ << "\n\n"
     << "Machine: " << ctx.machine
     << ". memcpy bandwidth measured in this run: " << format_rate(ctx.memcpy_gbps * 1e9)
     << " (one core, 64 MiB copies)."
     << (ctx.quick ? " **Quick (smoke) run: sizes reduced, numbers not representative.**" : "")
     << (ctx.sanitized ? " **Built with sanitizers: timings are meaningless.**" : "") << "\n\n";
  bool ok = true;
  for (const Block& b : blocks_) {
    switch (b.kind) {
      case Block::kText: md << b.text << "\n\n"; break;
      case Block::kTable: {
        const Table& t = tables_[b.index];
        const std::string csv = b.index == 0 ? suite_ + ".csv" : suite_ + "_" + t.name() + ".csv";
        md << t.markdown() << "\n(" << csv << ")\n\n";
        ok = write_file(dir / csv, t.csv()) && ok;
        break;
      }
      case Block::kPlot: {
        const Plot& p = plots_[b.index];
        md << "![" << p.title << "](" << p.file << ")\n\n";
        ok = render_plot(dir, p) && ok;
        break;
      }
    }
  }
  ok = write_file(dir / (suite_ + ".md"), md.str()) && ok;
  return ok;
}

}  // namespace loam::bench
