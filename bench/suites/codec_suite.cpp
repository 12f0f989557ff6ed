// Suite `codec`: the region codec against the formats users would reach for, side by side in
// the same run, on 256x256 mip-0 tiles of every DEM in data/ and ../shared/data/: zstd-1/19
// on raw samples, 16-bit PNG (OpenImageIO), LERC lossless (liblerc; and LERC + zstd-9, which
// is what GDAL's LERC_ZSTD writes), the plain MED + byte planes + zstd-1 baseline, and
// Loam's fast and best modes. Then stamp deltas (craters and bumps on real terrain) and
// mip refinement. Every Loam payload is decoded and compared before it is counted.
#include <Lerc_c_api.h>
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "bench/suites/codec_eval_set.h"
#include "dem/dem_import.h"
#include "dem/dem_raster.h"
#include "protocol/codec/fast_coder.h"
#include "protocol/codec/predictor.h"
#include "protocol/codec/region_codec.h"
#include "protocol/world.h"

namespace loam::bench {
namespace {

using Tile = std::vector<uint16_t>;
constexpr uint32_t kSide = kTileSize;

std::vector<std::string> dem_files(const std::string& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return out;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec))
    if (e.path().extension() == ".png") out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Tile> world_tiles(const World& world, int32_t mip) {
  std::vector<Tile> tiles;
  const RectI r = world.params().tile_range(mip);
  for (int64_t ty = r.y0; ty < r.y1; ++ty)
    for (int64_t tx = r.x0; tx < r.x1; ++tx) {
      const auto s = world.coarse_tile(mip, int32_t(tx), int32_t(ty));
      tiles.emplace_back(s.begin(), s.end());
    }
  return tiles;
}

// --- Peers ------------------------------------------------------------------------------

std::vector<uint8_t> zstd_bytes(const void* data, size_t size, int level) {
  std::vector<uint8_t> out(ZSTD_compressBound(size));
  out.resize(ZSTD_compress(out.data(), out.size(), data, size, level));
  return out;
}

std::vector<uint8_t> png16(const Tile& t) {
  std::vector<unsigned char> buf;
  OIIO::Filesystem::IOVecOutput vec(buf);
  OIIO::ImageSpec spec{static_cast<int>(kSide), static_cast<int>(kSide), 1, OIIO::TypeDesc::UINT16};
  void* proxy = &vec;
  spec.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy);
  auto out = OIIO::ImageOutput::create("png");
  if (!out || !out->open("tile.png", spec) || !out->write_image(OIIO::TypeDesc::UINT16, t.data())) return {};
  out->close();
  return buf;
}

bool png16_decode(const std::vector<uint8_t>& png, Tile& out) {
  OIIO::Filesystem::IOMemReader mem(png.data(), png.size());
  OIIO::ImageSpec config;
  void* proxy = &mem;
  config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy);
  auto in = OIIO::ImageInput::open("tile.png", &config);
  if (!in) return false;
  out.resize(size_t(kSide) * kSide);
  const bool ok = in->read_image(0, 0, 0, 1, OIIO::TypeDesc::UINT16, out.data());
  in->close();
  return ok;
}

std::vector<uint8_t> lerc(const Tile& t) {
  unsigned int size = 0;
  // ushort (3); max error 0.5 on integers is lossless (LERC's own lossless setting).
  if (lerc_computeCompressedSize(t.data(), 3, 1, int(kSide), int(kSide), 1, 0, nullptr, 0.5, &size) != 0)
    return {};
  std::vector<uint8_t> out(size);
  unsigned int written = 0;
  if (lerc_encode(t.data(), 3, 1, int(kSide), int(kSide), 1, 0, nullptr, 0.5, out.data(), size, &written) !=
      0)
    return {};
  out.resize(written);
  return out;
}

bool lerc_decode_tile(const std::vector<uint8_t>& blob, Tile& out) {
  out.resize(size_t(kSide) * kSide);
  return lerc_decode(blob.data(), unsigned(blob.size()), 0, nullptr, 1, int(kSide), int(kSide), 1, 3,
                     out.data()) == 0;
}

std::vector<uint8_t> med_zstd(const Tile& t, int level) {
  std::vector<uint8_t> planes(t.size() * 2);
  codec::med_forward_u16(t, kSide, kSide, planes);
  return zstd_bytes(planes.data(), planes.size(), level);
}

std::vector<uint8_t> loam_encode(RegionEncoding e, const Tile& t) {
  return *encode_region(e, std::span<const uint16_t>(t), kSide, kSide);
}

struct Codec {
  std::string name;
  std::function<std::vector<uint8_t>(const Tile&)> encode;
  std::function<bool(const std::vector<uint8_t>&, Tile&)> decode;  // may be empty
  bool lossless_checked = true;
};

std::vector<Codec> codecs() {
  auto zstd_dec = [](const std::vector<uint8_t>& b, Tile& out) {
    out.resize(size_t(kSide) * kSide);
    return ZSTD_decompress(out.data(), out.size() * 2, b.data(), b.size()) == out.size() * 2;
  };
  auto loam_dec = [](const std::vector<uint8_t>& b, Tile& out) {
    auto r = decode_region(b, kSide, kSide);
    if (!r) return false;
    out = std::move(*r);
    return true;
  };
  auto med_dec = [](const std::vector<uint8_t>& b, Tile& out) {
    std::vector<uint8_t> planes(size_t(kSide) * kSide * 2);
    if (ZSTD_decompress(planes.data(), planes.size(), b.data(), b.size()) != planes.size()) return false;
    out.resize(size_t(kSide) * kSide);
    codec::med_inverse_u16(planes, kSide, kSide, out);
    return true;
  };
  return {
      {"zstd-1 raw", [](const Tile& t) { return zstd_bytes(t.data(), t.size() * 2, 1); }, zstd_dec},
      {"zstd-19 raw", [](const Tile& t) { return zstd_bytes(t.data(), t.size() * 2, 19); }, zstd_dec},
      {"PNG16 (OIIO)", png16, png16_decode},
      {"LERC (liblerc)", lerc, lerc_decode_tile},
      {"LERC+zstd-9",
       [](const Tile& t) {
         const auto l = lerc(t);
         return zstd_bytes(l.data(), l.size(), 9);
       },
       {}},
      {"MED+planes+zstd-1", [](const Tile& t) { return med_zstd(t, 1); }, med_dec},
      {"MED+planes+zstd-19", [](const Tile& t) { return med_zstd(t, 19); }, med_dec},
      {"loam fast", [](const Tile& t) { return loam_encode(RegionEncoding::kFast, t); }, loam_dec},
      {"loam best", [](const Tile& t) { return loam_encode(RegionEncoding::kBest, t); }, loam_dec},
  };
}

struct Cell {
  double bytes = 0;
  double encode_s = 0, decode_s = 0;  // for all tiles of the DEM
  bool ok = true;
};

// A crater as the stamp kinds make one (bowl, raised rim), or a gaussian bump, added to `s`
// (w x h, the whole world) with rounding and saturation. Returns the bounding rect touched.
RectI apply_stamp(std::vector<uint16_t>& s, int64_t w, int64_t h, double cx, double cy, double r,
                  double depth, bool crater) {
  const RectI box = RectI{int64_t(cx - 2 * r) - 1, int64_t(cy - 2 * r) - 1, int64_t(cx + 2 * r) + 2,
                          int64_t(cy + 2 * r) + 2}
                        .intersect({0, 0, w, h});
  for (int64_t y = box.y0; y < box.y1; ++y)
    for (int64_t x = box.x0; x < box.x1; ++x) {
      const double d = std::hypot(double(x) - cx, double(y) - cy) / r;
      double dz;
      if (crater) {
        dz = d < 1 ? -depth * (1 - d * d) + 0.3 * depth * d * d * d * d
                   : (d < 2 ? 0.3 * depth * std::exp(-8 * (d - 1) * (d - 1)) * (2 - d) : 0.0);
      } else {
        dz = depth * std::exp(-2 * d * d);
      }
      uint16_t& v = s[size_t(y * w + x)];
      v = uint16_t(std::clamp(std::round(v + dz), 0.0, 65535.0));
    }
  return box;
}

// The 1-minute load average (Linux), or a negative number where it cannot be read: timings
// on a shared machine are only comparable within one run.
double load_average() {
  double v = -1;
  if (FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%lf", &v) != 1) v = -1;
    std::fclose(f);
  }
  return v;
}

int run_codec(const Context& ctx, Report& report) {
  const double load_at_start = load_average();
  std::vector<std::string> files = dem_files(ctx.source_dir + "/data");
  const std::vector<std::string> shared = dem_files(ctx.shared_data_dir);
  if (shared.empty()) {
    std::printf("codec: SKIPPING shared DEMs: %s is absent\n", ctx.shared_data_dir.c_str());
    report.paragraph("**Shared DEMs skipped**: `" + ctx.shared_data_dir + "` is absent.");
  }
  files.insert(files.end(), shared.begin(), shared.end());
  if (ctx.quick && files.size() > 2) files.resize(2);
  const MeasureOptions mo{
      .warmup = 1, .min_runs = ctx.quick ? 1 : 3, .max_runs = 50, .min_seconds = ctx.quick ? 0.0 : 0.3};

  const std::vector<Codec> cs = codecs();
  std::map<std::string, std::vector<Cell>> cells;  // codec -> per DEM
  std::vector<std::string> names;
  std::vector<double> samples_per_dem;
  std::vector<bool> shared_dem;  // the targets are over ../shared/data (data/ holds a crop of one)
  std::vector<World> worlds;
  int failures = 0;

  std::vector<bool> eval_dem;  // the evaluation set (codec_eval_set.h): reported apart
  // One DEM through every codec: bytes, losslessness and speed.
  auto add_dem = [&](const std::string& name, World world, bool counted, bool evaluation) {
    std::vector<Tile> tiles = world_tiles(world, 0);
    if (ctx.quick && tiles.size() > 4) tiles.resize(4);
    names.push_back(name);
    shared_dem.push_back(counted);
    eval_dem.push_back(evaluation);
    samples_per_dem.push_back(double(tiles.size()) * kSide * kSide);
    for (const Codec& c : cs) {
      Cell cell;
      std::vector<std::vector<uint8_t>> blobs(tiles.size());
      for (size_t i = 0; i < tiles.size(); ++i) {
        blobs[i] = c.encode(tiles[i]);
        if (blobs[i].empty()) cell.ok = false;
        cell.bytes += double(blobs[i].size());
      }
      if (c.decode) {
        Tile back;
        for (size_t i = 0; i < tiles.size(); ++i)
          if (!c.decode(blobs[i], back) || back != tiles[i]) cell.ok = false;
      }
      if (!cell.ok) {
        std::fprintf(stderr, "codec: %s on %s: encode failed or not lossless\n", c.name.c_str(),
                     name.c_str());
        ++failures;
      }
      cell.encode_s = measure(
                          ctx,
                          [&] {
                            for (const Tile& t : tiles) (void)c.encode(t);
                          },
                          mo)
                          .median_s;
      if (c.decode) {
        Tile back;
        cell.decode_s = measure(
                            ctx,
                            [&] {
                              for (const auto& b : blobs) (void)c.decode(b, back);
                            },
                            mo)
                            .median_s;
      }
      cells[c.name].push_back(cell);
    }
    std::printf("  %-28s %zu tiles: best %.3f b/s, fast %.3f, LERC %.3f, PNG %.3f\n", name.c_str(),
                tiles.size(), cells["loam best"].back().bytes * 8 / samples_per_dem.back(),
                cells["loam fast"].back().bytes * 8 / samples_per_dem.back(),
                cells["LERC (liblerc)"].back().bytes * 8 / samples_per_dem.back(),
                cells["PNG16 (OIIO)"].back().bytes * 8 / samples_per_dem.back());
    if (!evaluation) worlds.push_back(std::move(world));  // the delta, refinement and ISA runs: tuning set
  };
  for (const std::string& path : files) {
    auto dem = read_dem_file(path);
    if (!dem) {
      std::fprintf(stderr, "codec: %s\n", dem.error().describe().c_str());
      ++failures;
      continue;
    }
    auto imported = import_dem(*dem);
    if (!imported) {
      std::fprintf(stderr, "codec: %s\n", imported.error().describe().c_str());
      ++failures;
      continue;
    }
    add_dem(std::filesystem::path(path).stem().string(), std::move(imported->world),
            path.rfind(ctx.source_dir + "/data", 0) != 0, false);
  }
  // The evaluation set, checked against its frozen manifest first.
  std::vector<std::string> skipped;
  std::vector<EvalDem> eval = codec_evaluation_set(ctx.shared_data_dir, skipped);
  std::vector<std::string> eval_what;
  {
    const std::string manifest_path = ctx.source_dir + "/bench/codec_eval_set.txt";
    auto manifest = read_eval_manifest(manifest_path);
    if (!manifest) {
      std::fprintf(stderr, "codec: %s\n", manifest.error().describe().c_str());
      for (const EvalDem& d : eval) std::fprintf(stderr, "%s\n", eval_manifest_line(d).c_str());
      ++failures;
    } else {
      for (const EvalDem& d : eval) {
        const auto m = std::find_if(manifest->begin(), manifest->end(),
                                    [&](const EvalManifestEntry& e) { return e.name == d.name; });
        if (m == manifest->end() || m->world_hash != d.imported.world.world_hash()) {
          std::fprintf(stderr, "codec: evaluation DEM %s differs from the frozen manifest %s:\n%s\n",
                       d.name.c_str(), manifest_path.c_str(), eval_manifest_line(d).c_str());
          ++failures;
        }
      }
      if (skipped.empty() && manifest->size() != eval.size()) {
        std::fprintf(stderr, "codec: the manifest lists %zu evaluation DEMs, the recipes make %zu\n",
                     manifest->size(), eval.size());
        ++failures;
      }
    }
    for (const std::string& s : skipped) std::printf("codec: evaluation DEM skipped: %s\n", s.c_str());
  }
  if (ctx.quick && eval.size() > 3) eval.erase(eval.begin() + 3, eval.end());
  for (EvalDem& d : eval) {
    eval_what.push_back(d.what);
    add_dem(d.name, std::move(d.imported.world), true, true);
  }
  if (names.empty()) return failures + 1;

  // Table 1: bits per sample per DEM and codec.
  {
    std::vector<std::string> cols = {"dem", "tiles"};
    for (const Codec& c : cs) cols.push_back(c.name);
    Table t("codec", cols);
    size_t tuning = 0;
    for (size_t d = 0; d < names.size(); ++d) {
      if (eval_dem[d]) continue;
      ++tuning;
      std::vector<std::string> row = {names[d], fmt("%.0f", samples_per_dem[d] / (kSide * kSide))};
      for (const Codec& c : cs) row.push_back(fmt("%.3f", cells[c.name][d].bytes * 8 / samples_per_dem[d]));
      t.add_row(row);
    }
    std::vector<std::string> gm = {"geometric mean", ""};
    for (const Codec& c : cs) {
      double lg = 0;
      for (size_t d = 0; d < names.size(); ++d)
        if (!eval_dem[d]) lg += std::log(cells[c.name][d].bytes * 8 / samples_per_dem[d]);
      gm.push_back(fmt("%.3f", std::exp(lg / double(std::max<size_t>(tuning, 1)))));
    }
    t.add_row(gm);
    report.paragraph(
        "**Tuning set** (data/ and ../shared/data, the DEMs the codec was developed against). "
        "Bits per sample (raw is 16) over all 256x256 mip-0 tiles of each DEM as Loam imports it "
        "(quantized with headroom, padding tiles included: what the server sends; the issue's baselines were "
        "taken on source samples, so absolute numbers differ). Every codec with a decoder is checked "
        "lossless on every "
        "tile. LERC is liblerc 4 with max error 0.5 (lossless for integers); LERC+zstd-9 is what GDAL's "
        "`COMPRESS=LERC_ZSTD` stores. PNG16 is OpenImageIO's PNG writer at its default settings.");
    report.table(std::move(t));
  }

  // Table 2: ratios of loam best to the peers, and the targets.
  const bool any_shared = std::find(shared_dem.begin(), shared_dem.end(), true) != shared_dem.end();
  auto ratio = [&](const std::string& a, const std::string& b, size_t d) {
    return cells[a][d].bytes / cells[b][d].bytes;
  };
  double g_lerc = 0, g_png = 0, max_lerc = 0, max_png = 0;
  double n_shared = 0;
  {
    Table t("codec_ratios", {"dem", "best / LERC", "best / LERC+zstd", "best / PNG16", "best / MED+zstd-1",
                             "fast / MED+zstd-1"});
    for (size_t d = 0; d < names.size(); ++d) {
      if (eval_dem[d]) continue;
      const double rl =
          std::max(ratio("loam best", "LERC (liblerc)", d), ratio("loam best", "LERC+zstd-9", d));
      const double rp = ratio("loam best", "PNG16 (OIIO)", d);
      if (shared_dem[d] || !any_shared) {
        g_lerc += std::log(rl);
        g_png += std::log(rp);
        max_lerc = std::max(max_lerc, rl);
        max_png = std::max(max_png, rp);
        n_shared += 1;
      }
      t.add_row({names[d], fmt("%.3f", ratio("loam best", "LERC (liblerc)", d)),
                 fmt("%.3f", ratio("loam best", "LERC+zstd-9", d)), fmt("%.3f", rp),
                 fmt("%.3f", ratio("loam best", "MED+planes+zstd-1", d)),
                 fmt("%.3f", ratio("loam fast", "MED+planes+zstd-1", d))});
    }
    g_lerc = std::exp(g_lerc / n_shared);
    g_png = std::exp(g_png / n_shared);
    t.add_row({"geometric mean (shared DEMs)", fmt("%.3f", g_lerc) + " (vs min of both)", "",
               fmt("%.3f", g_png), "", ""});
    report.paragraph(
        "Byte ratios per DEM (lower is better). The best-mode targets compare with the smaller of LERC and "
        "LERC+zstd (the stricter peer) over the shared DEMs; default_terrain (a crop of etopo5) is shown, "
        "not counted.");
    report.table(std::move(t));
  }

  // The evaluation set: bits per sample, and best against the baselines.
  double e_med19 = 0, e_png = 0, e_worst = 0;
  std::string e_worst_name;
  size_t n_eval = 0;
  {
    std::vector<std::string> cols = {"dem", "tiles"};
    for (const Codec& c : cs) cols.push_back(c.name);
    Table t("codec_eval", cols);
    Table r("codec_eval_ratios", {"dem", "recipe", "best / MED+planes+zstd-19", "best / PNG16", "best / LERC",
                                  "fast / MED+zstd-1"});
    std::vector<double> lg(cs.size(), 0.0);
    for (size_t d = 0, e = 0; d < names.size(); ++d) {
      if (!eval_dem[d]) continue;
      std::vector<std::string> row = {names[d], fmt("%.0f", samples_per_dem[d] / (kSide * kSide))};
      for (size_t k = 0; k < cs.size(); ++k) {
        const double bps = cells[cs[k].name][d].bytes * 8 / samples_per_dem[d];
        row.push_back(fmt("%.3f", bps));
        lg[k] += std::log(bps);
      }
      t.add_row(row);
      const double rm = ratio("loam best", "MED+planes+zstd-19", d),
                   rp = ratio("loam best", "PNG16 (OIIO)", d);
      e_med19 += std::log(rm);
      e_png += std::log(rp);
      if (rm > e_worst) {
        e_worst = rm;
        e_worst_name = names[d];
      }
      r.add_row({names[d], eval_what[e++], fmt("%.3f", rm), fmt("%.3f", rp),
                 fmt("%.3f", ratio("loam best", "LERC (liblerc)", d)),
                 fmt("%.3f", ratio("loam fast", "MED+planes+zstd-1", d))});
      ++n_eval;
    }
    if (n_eval > 0) {
      std::vector<std::string> gm = {"geometric mean", ""};
      for (size_t k = 0; k < cs.size(); ++k) gm.push_back(fmt("%.3f", std::exp(lg[k] / double(n_eval))));
      t.add_row(gm);
      e_med19 = std::exp(e_med19 / double(n_eval));
      e_png = std::exp(e_png / double(n_eval));
      r.add_row({"geometric mean", "", fmt("%.3f", e_med19), fmt("%.3f", e_png), "", ""});
      report.paragraph(
          "**Evaluation set** (bench/suites/codec_eval_set.h: DEMs the codec is never tuned against, made by "
          "fixed recipes and frozen by their world hashes in bench/codec_eval_set.txt, which this run "
          "checked). Bits per sample as above.");
      report.table(std::move(t));
      report.paragraph("Byte ratios on the evaluation set (lower is better), with each DEM's recipe.");
      report.table(std::move(r));
    }
  }

  // Table 3: speed per codec over all DEMs (one core).
  double total_samples = 0;
  for (double s : samples_per_dem) total_samples += s;
  std::map<std::string, std::pair<double, double>> speed;  // MB/s of raw samples: encode, decode
  {
    Table t("codec_speed", {"codec", "bits/sample (all tiles)", "encode MB/s", "decode MB/s"});
    for (const Codec& c : cs) {
      double bytes = 0, es = 0, ds = 0;
      for (const Cell& cell : cells[c.name]) {
        bytes += cell.bytes;
        es += cell.encode_s;
        ds += cell.decode_s;
      }
      const double enc = total_samples * 2 / es / 1e6, dec = ds > 0 ? total_samples * 2 / ds / 1e6 : 0;
      speed[c.name] = {enc, dec};
      t.add_row({c.name, fmt("%.3f", bytes * 8 / total_samples), fmt("%.0f", enc),
                 dec > 0 ? fmt("%.0f", dec) : "-"});
    }
    report.paragraph(
        "Speed in MB/s of raw 16-bit samples, one core, medians of repeated runs over every tile "
        "(memcpy on this machine: " +
        fmt("%.1f", ctx.memcpy_gbps) + " GB/s" +
        (load_at_start >= 0 ? fmt("; 1-minute load average when the run started: %.2f", load_at_start) : "") +
        "). The peers run in the same run, so other work on the machine slows them alike. PNG and LERC+zstd "
        "decode is not timed where no decoder is wired up (-).");
    report.table(std::move(t));
  }

  // The fast mode's body alone (no header, checksum or result vector) per instruction set,
  // so that a machine without AVX2 knows what it gets (both write the same bytes).
  {
    std::vector<Tile> all;
    for (const World& w : worlds) {
      std::vector<Tile> t = world_tiles(w, 0);
      if (ctx.quick && t.size() > 4) t.resize(4);
      all.insert(all.end(), t.begin(), t.end());
    }
    const double raw_bytes = double(all.size()) * kSide * kSide * 2;
    Table t("codec_fast_isa", {"fast mode kernels", "encode MB/s", "decode MB/s"});
    for (codec::Isa isa : {codec::Isa::kPortable, codec::Isa::kAvx2}) {
      const char* name =
          isa == codec::Isa::kAvx2 ? "AVX2 (chosen at run time)" : "portable (baseline x86-64)";
      if (isa == codec::Isa::kAvx2 && codec::detected_isa() != codec::Isa::kAvx2) {
        t.add_row({name, "- (no AVX2 here)", "-"});
        continue;
      }
      std::vector<std::vector<uint8_t>> bodies(all.size());
      Tile back(size_t(kSide) * kSide);
      for (size_t i = 0; i < all.size(); ++i) {
        codec::encode_fast_body(std::span<const uint16_t>(all[i]), kSide, kSide, bodies[i], isa);
        auto parsed = codec::parse_fast_body(bodies[i], 16);
        if (!parsed || !codec::decode_fast_body(*parsed, kSide, kSide, std::span<uint16_t>(back), isa).ok() ||
            back != all[i]) {
          std::fprintf(stderr, "codec: fast body (%s) round trip failed\n", name);
          ++failures;
        }
      }
      std::vector<uint8_t> body;
      const double es =
          measure(
              ctx,
              [&] {
                for (const Tile& tile : all) {
                  body.clear();
                  codec::encode_fast_body(std::span<const uint16_t>(tile), kSide, kSide, body, isa);
                }
              },
              mo)
              .median_s;
      const double ds =
          measure(
              ctx,
              [&] {
                for (const auto& b : bodies) {
                  auto parsed = codec::parse_fast_body(b, 16);
                  (void)codec::decode_fast_body(*parsed, kSide, kSide, std::span<uint16_t>(back), isa);
                }
              },
              mo)
              .median_s;
      t.add_row({name, fmt("%.0f", raw_bytes / es / 1e6), fmt("%.0f", raw_bytes / ds / 1e6)});
    }
    report.paragraph(
        "The fast mode's body alone (no header, checksum or result vector) with each set of kernels, "
        "over the same tiles; both write the same bytes. The targets are measured above, on whole payloads "
        "with the kernels this machine picks.");
    report.table(std::move(t));
  }

  // Deltas: craters and bumps on real terrain, per dirty tile over the changed rect.
  double worst_delta = 0;
  {
    Table t("codec_delta", {"dem", "stamp", "radius", "dirty tiles", "loam delta B", "zstd-1 plain delta B",
                            "delta / zstd-1 delta", "zstd-1 raw dirty tiles B", "delta / zstd-1 raw tiles"});
    const size_t ndem = std::min<size_t>(worlds.size(), 2);
    for (size_t d = 0; d < ndem; ++d) {
      const World& world = worlds[d];
      const RectI all = world.params().sample_rect();
      const int64_t w = all.width(), h = all.height();
      std::vector<uint16_t> before(size_t(w * h));
      world.read_coarse(all, before);
      for (bool crater : {true, false})
        for (double r : {25.0, 50.0, 100.0, 250.0}) {
          if (ctx.quick && r > 50) continue;
          std::vector<uint16_t> after = before;
          const double depth = crater ? 2 * r : r;  // height units (1/64 m by default)
          const RectI box =
              apply_stamp(after, w, h, double(w) / 2 + 0.3, double(h) / 2 + 0.6, r, depth, crater);
          double loam_b = 0, plain_b = 0, raw_b = 0;
          int dirty = 0;
          const RectI tr = tiles_overlapping(box);
          for (int64_t ty = tr.y0; ty < tr.y1; ++ty)
            for (int64_t tx = tr.x0; tx < tr.x1; ++tx) {
              const RectI tile =
                  RectI{tx * kSide, ty * kSide, (tx + 1) * kSide, (ty + 1) * kSide}.intersect({0, 0, w, h});
              RectI changed{};
              for (int64_t y = tile.y0; y < tile.y1; ++y)
                for (int64_t x = tile.x0; x < tile.x1; ++x)
                  if (before[size_t(y * w + x)] != after[size_t(y * w + x)])
                    changed = changed.unite({x, y, x + 1, y + 1});
              if (changed.empty()) continue;
              ++dirty;
              std::vector<uint16_t> b, a, raw_tile;
              std::vector<int16_t> plain;
              for (int64_t y = changed.y0; y < changed.y1; ++y)
                for (int64_t x = changed.x0; x < changed.x1; ++x) {
                  b.push_back(before[size_t(y * w + x)]);
                  a.push_back(after[size_t(y * w + x)]);
                  plain.push_back(int16_t(a.back() - b.back()));
                }
              for (int64_t y = tile.y0; y < tile.y1; ++y)
                for (int64_t x = tile.x0; x < tile.x1; ++x) raw_tile.push_back(after[size_t(y * w + x)]);
              const auto cw = uint32_t(changed.width()), chh = uint32_t(changed.height());
              const RegionRefs<uint16_t> refs{.base = b, .coarser = {}};
              auto p = encode_region(RegionEncoding::kDelta, std::span<const uint16_t>(a), cw, chh, refs);
              auto back = decode_region(*p, cw, chh, refs);
              if (!back || *back != a) {
                std::fprintf(stderr, "codec: delta round trip failed\n");
                ++failures;
              }
              loam_b += double(p->size());
              plain_b += double(zstd_bytes(plain.data(), plain.size() * 2, 1).size());
              raw_b += double(zstd_bytes(raw_tile.data(), raw_tile.size() * 2, 1).size());
            }
          worst_delta = std::max(worst_delta, loam_b / plain_b);
          t.add_row({names[d], crater ? "crater" : "gaussian", fmt("%.0f", r), fmt("%.0f", dirty),
                     fmt("%.0f", loam_b), fmt("%.0f", plain_b), fmt("%.3f", loam_b / plain_b),
                     fmt("%.0f", raw_b), fmt("%.4f", loam_b / raw_b)});
        }
    }
    report.paragraph(
        "Stamp deltas: a crater (parabolic bowl of depth 2r height units, raised rim to 2r) or a gaussian "
        "bump (height r) at the world's centre, rounded and saturated like the stamp kinds. For each dirty "
        "tile the payload covers the changed rect only; the peer is zstd-1 on the plain delta "
        "(new - old as int16 over the same rect). Target: delta <= 0.6 x zstd-1 plain delta.");
    report.table(std::move(t));
  }

  // Refinement: mip m-1 tiles given mip m, against mip m-1 sent whole (best mode).
  double worst_refine = 0, sum_refine = 0, sum_whole = 0;
  {
    Table t("codec_refine", {"dem", "mip m-1", "refine B", "whole (best) B", "refine / whole"});
    for (size_t d = 0; d < worlds.size(); ++d)
      for (int32_t mip = 0; mip < 2; ++mip) {
        if (mip >= worlds[d].params().mip_count()) continue;
        std::vector<Tile> tiles = world_tiles(worlds[d], mip);
        if (ctx.quick && tiles.size() > 4) tiles.resize(4);
        double rb = 0, wb = 0;
        for (const Tile& tile : tiles) {
          Tile coarser;
          for (uint32_t y = 0; y < kSide; y += 2)
            for (uint32_t x = 0; x < kSide; x += 2) coarser.push_back(tile[y * kSide + x]);
          const RegionRefs<uint16_t> refs{.base = {}, .coarser = coarser};
          auto p =
              encode_region(RegionEncoding::kRefine, std::span<const uint16_t>(tile), kSide, kSide, refs);
          auto back = decode_region(*p, kSide, kSide, refs);
          if (!back || *back != tile) {
            std::fprintf(stderr, "codec: refine round trip failed\n");
            ++failures;
          }
          rb += double(p->size());
          wb += double(loam_encode(RegionEncoding::kBest, tile).size());
        }
        worst_refine = std::max(worst_refine, rb / wb);
        sum_refine += rb;
        sum_whole += wb;
        t.add_row({names[d], fmt("%.0f", mip), fmt("%.0f", rb), fmt("%.0f", wb), fmt("%.3f", rb / wb)});
      }
    report.paragraph(
        "Refinement: each mip m-1 tile coded given the mip m samples it contains (its even samples), "
        "against the same tile sent whole in best mode. Target: <= 0.8.");
    report.table(std::move(t));
  }

  // Targets.
  {
    auto pass = [](bool b) { return std::string(b ? "PASS" : "MISS"); };
    double fast_ratio = 0;
    for (size_t d = 0; d < names.size(); ++d)
      if (!eval_dem[d]) fast_ratio = std::max(fast_ratio, ratio("loam fast", "MED+planes+zstd-1", d));
    const auto [fe, fd] = speed["loam fast"];
    Table t("codec_targets", {"target", "measured", "result"});
    t.add_row({"best: geomean <= 0.65 x LERC", fmt("%.3f", g_lerc), pass(g_lerc <= 0.65)});
    t.add_row({"best: geomean <= 0.68 x PNG16", fmt("%.3f", g_png), pass(g_png <= 0.68)});
    t.add_row(
        {"best: every shared DEM <= 0.80 x LERC", fmt("%.3f (worst)", max_lerc), pass(max_lerc <= 0.80)});
    t.add_row(
        {"best: every shared DEM <= 0.80 x PNG16", fmt("%.3f (worst)", max_png), pass(max_png <= 0.80)});
    if (n_eval > 0) {
      t.add_row({"evaluation set, best: geomean <= 0.92 x MED+planes+zstd-19", fmt("%.3f", e_med19),
                 pass(e_med19 <= 0.92)});
      t.add_row({"evaluation set, best: geomean <= 0.70 x PNG16", fmt("%.3f", e_png), pass(e_png <= 0.70)});
      t.add_row({"evaluation set, best: no DEM over 1.02 x MED+planes+zstd-19",
                 fmt("%.3f (worst: ", e_worst) + e_worst_name + ")", pass(e_worst <= 1.02)});
    }
    t.add_row({"fast: encode >= 500 MB/s", fmt("%.0f MB/s", fe), pass(fe >= 500)});
    t.add_row({"fast: decode >= 1000 MB/s", fmt("%.0f MB/s", fd), pass(fd >= 1000)});
    t.add_row({"fast: bytes <= MED+zstd-1 on every DEM", fmt("%.3f (worst ratio)", fast_ratio),
               pass(fast_ratio <= 1.0)});
    t.add_row({"delta: <= 0.6 x zstd-1 of plain delta", fmt("%.3f (worst)", worst_delta),
               pass(worst_delta <= 0.6)});
    t.add_row(
        {"refine: <= 0.8 x whole", fmt("%.3f (worst DEM/mip)", worst_refine), pass(worst_refine <= 0.8)});
    report.paragraph(std::string("Targets (issue 5)") +
                     (ctx.quick ? " — quick run, not representative:" : ":") +
                     fmt(" overall refinement ratio %.3f.", sum_refine / sum_whole));
    report.table(std::move(t));
  }

  // Plot: bits per sample against speed, one point per codec (encode and decode).
  {
    Plot enc{"codec_speed.png",
             "Region codecs: size against speed (all DEM tiles, one core)",
             "MB/s of raw samples (log)",
             "bits per sample",
             true,
             false,
             {},
             {}};
    for (const Codec& c : cs) {
      double bytes = 0;
      for (const Cell& cell : cells[c.name]) bytes += cell.bytes;
      Series s{c.name, {{speed[c.name].first, bytes * 8 / total_samples}}};
      if (speed[c.name].second > 0) s.points.push_back({speed[c.name].second, bytes * 8 / total_samples});
      enc.series.push_back(s);
    }
    report.paragraph(
        "Plot: each codec's encode speed (left point) and decode speed (right point) at its size.");
    report.plot(std::move(enc));
  }
  return failures;
}

}  // namespace

LOAM_BENCH_SUITE(codec, "Region codec against zstd, PNG16 and LERC; deltas and refinement (issue 5)",
                 run_codec);

}  // namespace loam::bench
