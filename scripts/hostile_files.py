#!/usr/bin/env python3
"""Hostile DEM files against `loam-server import`: each is made here (Python's standard
library only), imported by a child process, and its exit code, error line and peak RSS
(getrusage of the child, via wait4) are recorded.

  hostile_files.py --server PATH --out DIR [--table bench/results/hostile-files] [--check]

Every hostile case must exit with 1 and a `loam-server: error:` line (not a crash, not 0);
every DEM that is odd but valid (a NoData hole, south-up, geographic with or without
--project) must import (exit 0) with the line its report must hold. Each import may allocate
at most 64 MB over the floor (the peak RSS of `loam-server --version`, the
program's own start-up: ~130 MB in a release build, ~240 MB under ASan, whose shadow memory
and allocator would eat an absolute limit); the script exits 1 when one does not. With --table it writes the
Markdown table TABLE.md and TABLE.csv. scripts/hostile-files.sh runs it on a release build.
"""
import argparse
import concurrent.futures
import csv
import io
import json
import math
import os
import random
import struct
import subprocess
import sys
import time
import zlib

# A 16000x16000 float raster would be 1 GB; a refused import may hold a strip or two.
OVER_FLOOR_LIMIT_KB = 64 * 1024


# --- PNG -------------------------------------------------------------------------------------
def png_chunk(kind, data):
    body = kind + data
    return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)


def png(width, height, rows, bit_depth=16, color_type=0, idat=None, palette=None):
    """A PNG of the given rows (bytes per row, without filter bytes), or raw IDAT bytes."""
    if idat is None:
        idat = zlib.compress(b"".join(b"\0" + r for r in rows), 6)
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0)
    plte = png_chunk(b"PLTE", palette) if palette else b""
    return (b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", ihdr) + plte + png_chunk(b"IDAT", idat)
            + png_chunk(b"IEND", b""))


def gray16_rows(width, height, seed=1):
    rng = random.Random(seed)
    rows = []
    for y in range(height):
        row = bytearray()
        for x in range(width):
            v = int(1000 + 300 * math.sin(x * 0.05) * math.cos(y * 0.04) + rng.randint(0, 20))
            row += struct.pack(">H", v)
        rows.append(bytes(row))
    return rows


def png_claiming(width, height):
    # A stored deflate block that says 1023 bytes and holds 900: ~1 KB in all.
    idat = b"\x78\x01\x00\xff\x03\x00\xfc" + bytes((i * 7) & 0xFF for i in range(900))
    return png(width, height, None, idat=idat)


# --- TIFF ------------------------------------------------------------------------------------
def tiff(width, height, sample_bytes, bits, sample_format, strips, rows_per_strip, extra_tags=()):
    """A little-endian TIFF; `strips` are the strip payloads (may be shorter than claimed)."""
    tags = [
        (256, 4, 1, width),
        (257, 4, 1, height),
        (258, 3, 1, bits),
        (259, 3, 1, 1),
        (262, 3, 1, 1),
        (277, 3, 1, 1),
        (278, 4, 1, rows_per_strip),
        (339, 3, 1, sample_format),
    ]
    n = len(strips)
    claimed = [min(rows_per_strip, height - i * rows_per_strip) * width * sample_bytes for i in range(n)]
    ntags = len(tags) + 2 + len(extra_tags)
    ifd_size = 2 + ntags * 12 + 4
    arrays_at = 8 + ifd_size
    offsets_at, counts_at = arrays_at, arrays_at + 4 * n
    data_at = counts_at + 4 * n
    offsets, at = [], data_at
    for s in strips:
        offsets.append(at)
        at += len(s)
    entries = tags + [
        (273, 4, n, offsets[0] if n == 1 else offsets_at),
        (279, 4, n, claimed[0] if n == 1 else counts_at),
    ] + list(extra_tags)
    entries.sort()
    out = bytearray(b"II" + struct.pack("<HI", 42, 8) + struct.pack("<H", ntags))
    for tag, typ, count, value in entries:
        out += struct.pack("<HHII", tag, typ, count, value)
    out += struct.pack("<I", 0)
    out += b"".join(struct.pack("<I", o) for o in offsets) + b"".join(struct.pack("<I", c) for c in claimed)
    for s in strips:
        out += s
    return bytes(out)


def tiff_u16(width, height, values, rows_per_strip=16):
    data = struct.pack("<%dH" % len(values), *values)
    row = width * 2
    strips = [data[y * row:(y + rows_per_strip) * row] for y in range(0, height, rows_per_strip)]
    return tiff(width, height, 2, 16, 1, strips, rows_per_strip)


def tiff_rotated(width, height, values, degrees):
    """A uint16 TIFF whose ModelTransformationTag turns the grid by `degrees` (a rotated geotransform)."""
    c, s = 10 * math.cos(math.radians(degrees)), 10 * math.sin(math.radians(degrees))
    matrix = struct.pack("<16d", c, -s, 0, 500000.0, -s, -c, 0, 4100000.0, 0, 0, 0, 0, 0, 0, 0, 1)
    data = struct.pack("<%dH" % len(values), *values)
    args = (width, height, 2, 16, 1, [data], height)
    at = len(tiff(*args, extra_tags=[(34264, 12, 16, 0)]))  # the matrix goes after the pixels
    return tiff(*args, extra_tags=[(34264, 12, 16, at)]) + matrix


def geotiff(width, height, data, bits, sample_format, extras):
    """One-strip TIFF with extra tags: (tag, type, count, payload bytes); payloads over 4 bytes go
    after the pixels (GeoTIFF keys, pixel scale, tiepoint, GDAL_NODATA)."""
    sample_bytes = bits // 8
    def build(at):
        tags, tail = [], b""
        for tag, typ, count, payload in extras:
            if len(payload) <= 4:
                tags.append((tag, typ, count, struct.unpack("<I", payload.ljust(4, b"\0"))[0]))
            else:
                tags.append((tag, typ, count, at + len(tail)))
                tail += payload + (b"\0" if len(payload) % 2 else b"")
        return tiff(width, height, sample_bytes, bits, sample_format, [data], height, extra_tags=tags), tail
    head, _ = build(0)
    head, tail = build(len(head))
    return head + tail


def geo_keys(*keys):
    """GeoKeyDirectoryTag payload from (key, value) pairs (SHORT values)."""
    flat = [1, 1, 0, len(keys)]
    for k, v in keys:
        flat += [k, 0, 1, v]
    return (34735, 3, len(flat), struct.pack("<%dH" % len(flat), *flat))


def doubles(tag, *values):
    return (tag, 12, len(values), struct.pack("<%dd" % len(values), *values))


def gdal_nodata(value):
    text = (value + "\0").encode()
    return (42113, 2, len(text), text)


def tiff_claiming(width, height, present):
    return tiff(width, height, 2, 16, 1, [bytes((i * 13) & 0xFF for i in range(present))], height)


# --- the cases -------------------------------------------------------------------------------
def cases():
    rng = random.Random(13)
    w, h = 512, 512
    values = [int(1000 + 400 * math.sin(i % w * 0.03) * math.cos(i // w * 0.02)) for i in range(w * h)]
    good_tiff = tiff_u16(w, h, values)
    good_png = png(64, 48, gray16_rows(64, 48))
    corrupt_idat = bytearray(zlib.compress(b"".join(b"\0" + r for r in gray16_rows(64, 48)), 6))
    for i in range(10, len(corrupt_idat) - 4, 17):
        corrupt_idat[i] ^= 0x5A
    nan = struct.pack("<f", float("nan"))
    out = [
        ("truncated.tif", "uint16 512x512 TIFF cut to 7% of its bytes", good_tiff[: len(good_tiff) * 7 // 100], None),
        ("huge_header.png", "1 KB PNG whose header claims 30000x30000", png_claiming(30000, 30000), None),
        ("huge_under_cap.png", "1 KB PNG claiming 16000x16000 (under the 2^28 cap)", png_claiming(16000, 16000), None),
        ("huge_header.tif", "1 KB TIFF claiming 30000x30000", tiff_claiming(30000, 30000, 800), None),
        ("huge_under_cap.tif", "1 KB TIFF claiming 16000x16000 (under the cap)", tiff_claiming(16000, 16000, 800), None),
        ("corrupt_pixels.png", "PNG whose compressed pixels are damaged (CRCs fixed up)",
         png(64, 48, None, idat=bytes(corrupt_idat)), None),
        ("garbage.tif", "4 KB of random bytes named .tif", bytes(rng.getrandbits(8) for _ in range(4096)), None),
        ("flipped_header.tif", "TIFF with its directory bytes randomised",
         good_tiff[:8] + bytes(rng.getrandbits(8) for _ in range(120)) + good_tiff[128:], None),
        ("rgb.png", "8-bit RGB PNG (a photo, not a DEM)",
         png(64, 48, [bytes((x * 3 + y + c * 40) & 0xFF for x in range(64) for c in range(3)) for y in range(48)],
             8, 2), None),
        ("rgba.png", "8-bit RGBA PNG",
         png(64, 48, [bytes((x + y + c) & 0xFF for x in range(64) for c in range(4)) for y in range(48)], 8, 6),
         None),
        ("gray_alpha.png", "16-bit gray+alpha PNG",
         png(64, 48, [b"".join(struct.pack(">HH", 1000 + x, 65535) for x in range(64)) for _ in range(48)], 16, 4),
         None),
        ("zero_size.tif", "empty file", b"", None),
        ("wrong_sidecar.png", "PNG 64x48 whose sidecar says 100x48", good_png,
         json.dumps({"width": 100, "height": 48, "sample_type": "uint16", "meters_per_sample_xy": [2, 2]})),
        ("wrong_type_sidecar.png", "PNG uint16 whose sidecar says float32", good_png,
         json.dumps({"width": 64, "height": 48, "sample_type": "float32"})),
        ("bad_json_sidecar.png", "PNG whose sidecar is not JSON", good_png, "{ width: 64,"),
        ("nan_only.tif", "float32 TIFF of NaN only",
         tiff(32, 32, 4, 32, 3, [nan * (32 * 32)], 32), None),
        ("one_sample.tif", "float32 TIFF of 1x1", tiff(1, 1, 4, 32, 3, [struct.pack("<f", 5.0)], 1), None),
        ("N47E011.hgt", "SRTM HGT of 1000 bytes (not 1201^2 or 3601^2 samples)", bytes(1000), None),
        ("huge_header.asc", "ESRI ASCII grid claiming 1e9 x 1e9 cells",
         b"ncols 1000000000\nnrows 1000000000\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2 3 4\n", None),
        ("short.asc", "ESRI ASCII grid with 3 of its 40 rows",
         b"ncols 40\nnrows 40\nxllcorner 0\nyllcorner 0\ncellsize 1\n" + b"".join(
             b" ".join(b"%d" % (x + y) for x in range(40)) + b"\n" for y in range(3)), None),
        ("banana.asc", "ESRI ASCII grid with a cell that reads 'banana' (GDAL would take it as 0)",
         b"ncols 40\nnrows 40\nxllcorner 0\nyllcorner 0\ncellsize 1\n" + b"".join(
             b" ".join(b"banana" if (x, y) == (17, 29) else b"%d" % (x + y) for x in range(40)) + b"\n"
             for y in range(40)), None),
        ("banana_source.vrt", "VRT whose source is banana.asc (the grid with a 'banana' cell)",
         b'<VRTDataset rasterXSize="40" rasterYSize="40"><VRTRasterBand dataType="Float32" band="1">'
         b'<SimpleSource><SourceFilename relativeToVRT="1">banana.asc</SourceFilename><SourceBand>1</SourceBand>'
         b'</SimpleSource></VRTRasterBand></VRTDataset>', None),
        ("rotated.tif", "GeoTIFF whose geotransform is rotated by 30 degrees",
         tiff_rotated(64, 48, [1000 + (i % 64) * 3 + (i // 64) for i in range(64 * 48)], 30.0), None),
        ("missing_source.vrt", "VRT whose source file does not exist",
         b'<VRTDataset rasterXSize="64" rasterYSize="48"><VRTRasterBand dataType="UInt16" band="1">'
         b'<SimpleSource><SourceFilename relativeToVRT="1">nowhere.tif</SourceFilename><SourceBand>1</SourceBand>'
         b'</SimpleSource></VRTRasterBand></VRTDataset>', None),
        ("raw_band.vrt", "VRT raw band reading /etc/passwd as samples",
         b'<VRTDataset rasterXSize="16" rasterYSize="4"><VRTRasterBand dataType="Byte" band="1" '
         b'subClass="VRTRawRasterBand"><SourceFilename relativetoVRT="0">/etc/passwd</SourceFilename>'
         b'<ImageOffset>0</ImageOffset><PixelOffset>1</PixelOffset><LineOffset>16</LineOffset>'
         b'</VRTRasterBand></VRTDataset>', None),
        ("huge.vrt", "VRT claiming 100000x100000 samples",
         b'<VRTDataset rasterXSize="100000" rasterYSize="100000"><VRTRasterBand dataType="Float32" band="1">'
         b'</VRTRasterBand></VRTDataset>', None),
        ("palette.png", "8-bit palette (indexed colour) PNG",
         png(16, 16, [bytes(range(16)) for _ in range(16)], 8, 3, palette=bytes(range(48))), None),
        ("terrain.bmp", "a valid PNG named .bmp", good_png, None),
        ("utm_projected.tif", "UTM GeoTIFF asked to be projected (--project utm): it is in metres already",
         geotiff(64, 48, struct.pack("<%dH" % (64 * 48), *[1000 + i % 64 for i in range(64 * 48)]), 16, 1,
                 [doubles(33550, 30.0, 30.0, 0.0), doubles(33922, 0, 0, 0, 500000.0, 5000000.0, 0),
                  geo_keys((1024, 1), (1025, 1), (3072, 32633))]), None, ["--project", "utm"]),
    ]
    # Files that import, the way the DEM means them: (name, what, data, sidecar, extra args, what
    # the import's report must say).
    hole = [(x - 50) ** 2 + (y - 40) ** 2 <= 35 * 35 for y in range(90) for x in range(95)]
    rough = [int(500 + 120 * math.sin(i % 95 * 0.07) * math.cos(i // 95 * 0.05) + 30 * math.sin(i % 95 * 0.31))
             for i in range(95 * 90)]
    out += [
        ("nodata_hole.tif", "Int16 95x90 GeoTIFF with a hole of 3,853 NoData samples (imported: interpolated, "
         "not a floor at the minimum)",
         geotiff(95, 90, struct.pack("<%dh" % (95 * 90), *[-32768 if hole[i] else rough[i] for i in range(95 * 90)]),
                 16, 2, [doubles(33550, 30.0, 30.0, 0.0), doubles(33922, 0, 0, 0, 500000.0, 5000000.0, 0),
                         geo_keys((1024, 1), (1025, 1), (3072, 32633)), gdal_nodata("-32768")]),
         None, [], "3853 samples: 3853 interpolated"),
        ("south_up.tif", "GeoTIFF with a positive y pixel size (south-up; imported flipped, not mirrored)",
         geotiff(64, 48, struct.pack("<%dH" % (64 * 48), *[1000 + i // 64 for i in range(64 * 48)]), 16, 1,
                 [doubles(34264, 10, 0, 0, 500000.0, 0, 10, 0, 4100000.0, 0, 0, 0, 0, 0, 0, 0, 1)]),
         None, [], "south-up (rows flipped)"),
        ("geographic_60n.tif", "EPSG:4326 GeoTIFF at 60 N (samples twice as tall as wide) with --project aeqd "
         "(imported in square metres)",
         geotiff(64, 48, struct.pack("<%dH" % (64 * 48), *[1000 + i % 64 for i in range(64 * 48)]), 16, 1,
                 [doubles(33550, 3 / 3600, 3 / 3600, 0.0), doubles(33922, 0, 0, 0, 10.0, 60.02, 0),
                  geo_keys((1024, 2), (1025, 1), (2048, 4326))]),
         None, ["--project", "aeqd"], "warped to an azimuthal equidistant projection"),
        ("geographic_60n_plain.tif", "the same without --project (imported with the distortion reported)",
         geotiff(64, 48, struct.pack("<%dH" % (64 * 48), *[1000 + i % 64 for i in range(64 * 48)]), 16, 1,
                 [doubles(33550, 3 / 3600, 3 / 3600, 0.0), doubles(33922, 0, 0, 0, 10.0, 60.02, 0),
                  geo_keys((1024, 2), (1025, 1), (2048, 4326))]),
         None, [], "squaring the samples stretches east-west by +41"),
    ]
    return out


def run_one(server, path, command=("import",)):
    t0 = time.monotonic()
    args = [server, *command[:1]] + ([path] if path else []) + list(command[1:])
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    out = proc.stdout.read().decode("utf-8", "replace")
    err = proc.stderr.read().decode("utf-8", "replace")
    proc.stdout.close()
    proc.stderr.close()
    return proc.returncode, usage.ru_maxrss, time.monotonic() - t0, out, err


def error_line(err):
    for line in err.splitlines():
        if line.startswith("loam-server: error: "):
            return line[len("loam-server: error: "):]
    return err.strip().splitlines()[-1] if err.strip() else ""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--server", required=True)
    ap.add_argument("--out", required=True, help="folder for the generated files")
    ap.add_argument("--table", help="write TABLE.md and TABLE.csv")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rows, failures = [], []
    # The floor: the same program doing no import at all.
    _, floor_kb, _, _, _ = run_one(args.server, None, ("--version",))
    print("floor: loam-server --version peaks at %.1f MB" % (floor_kb / 1024))
    made = []
    for case in cases():
        name, what, data, sidecar = case[:4]
        args_extra = case[4] if len(case) > 4 else []
        expect = case[5] if len(case) > 5 else None
        path = os.path.join(args.out, name)
        with open(path, "wb") as f:
            f.write(data)
        side = os.path.splitext(path)[0] + ".json"
        if sidecar is not None:
            with open(side, "w") as f:
                f.write(sidecar)
        elif os.path.exists(side):
            os.remove(side)
        made.append((name, what, data, path, args_extra, expect))
    # Imports run a few at a time (each child's peak RSS is its own).
    with concurrent.futures.ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(lambda m: run_one(args.server, m[3], ("import", *m[4])), made))
    for (name, what, data, path, extra, expect), (rc, rss_kb, secs, out, err) in zip(made, results):
        if extra:
            what += " [import %s]" % " ".join(extra)
        if expect is None:
            message = error_line(err)
            ok = rc == 1 and "loam-server: error: " in err
        else:
            line = next((l for l in out.splitlines() if expect in l), "")
            message = "imported: " + " ".join(line.split())
            ok = rc == 0 and bool(line)
        # Paths in messages are the generated folder's: show the file name only.
        message = message.replace(path, name).replace(args.out + "/", "")
        ok = ok and "Sanitizer" not in err and rss_kb - floor_kb < OVER_FLOOR_LIMIT_KB
        if not ok:
            failures.append(name)
        rows.append((name, what, len(data), message, rc, rss_kb, secs, ok))
        print("%-24s exit %d  %7.1f MB  %s%s" % (name, rc, rss_kb / 1024, message, "" if ok else "  <-- FAIL"))
        if not ok and (out or err):
            print(out + err, file=sys.stderr)
    if args.table:
        with open(args.table + ".csv", "w", newline="") as f:
            wr = csv.writer(f)
            wr.writerow(["file", "what it is", "bytes", "error", "exit code", "peak RSS MB", "seconds"])
            for r in rows:
                wr.writerow([r[0], r[1], r[2], r[3], r[4], "%.1f" % (r[5] / 1024), "%.3f" % r[6]])
        with open(args.table + ".md", "w") as f:
            f.write("# Hostile files against `loam-server import`\n\n")
            f.write("Made by `scripts/hostile-files.sh` (`scripts/hostile_files.py`): every file is generated, "
                    "then imported by `loam-server import FILE` in a child process; peak RSS is the child's "
                    "`ru_maxrss` (getrusage through wait4). Every hostile case must exit 1 with an error, "
                    "and every DEM that is odd but valid (NoData holes, south-up, geographic) must import with "
                    "what its report must say; each within 64 MB over the floor. The ctest `dem.hostile_files_refused_odd_dems_imported_within_64mb_over_the_floor` "
                    "runs the same cases.\n\n")
            f.write("The floor is the program itself: `loam-server --version` peaks at %.1f MB in this run, "
                    "nearly all of it the start-up of the shared libraries it links (GDAL's are ~35 MB "
                    "here). What each case adds over the floor is what its "
                    "import allocated.\n\n" % (floor_kb / 1024))
            f.write("| file | what it is | bytes | error | exit | peak RSS MB | over the floor MB |\n"
                    "|---|---|---|---|---|---|---|\n")
            for r in rows:
                msg = r[3].replace("|", "\\|")
                f.write("| %s | %s | %d | %s | %d | %.1f | %.1f |\n"
                        % (r[0], r[1], r[2], msg, r[4], r[5] / 1024, (r[5] - floor_kb) / 1024))
            f.write("\n(hostile-files.csv)\n")
    if failures:
        print("hostile_files: FAIL: %s" % ", ".join(failures), file=sys.stderr)
        return 1
    print("hostile_files: ok (%d cases, each refused or imported as expected, within 64 MB over the floor)"
          % len(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
