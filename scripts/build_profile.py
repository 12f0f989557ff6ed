#!/usr/bin/env python3
"""Summarizes a finished Ninja build: where its compile time went.

Reads BUILD_DIR/.ninja_log (each step's start and end) and `ninja -t deps` (each object's
headers), and writes TABLE.md and TABLE.csv: the wall time, the compile and link seconds, the
slowest steps, the seconds per target, and the seconds of the objects that include each heavy
header. Run it on a cold build (no compiler cache) of one configuration for numbers that mean
anything; scripts/build-profile.sh does that.
"""
import argparse
import collections
import csv
import os
import subprocess

# Headers whose code every including object compiles again: the groups the profile reports.
HEAVY = {
    "CLI11": "CLI/CLI.hpp",
    "GoogleTest": "gtest/gtest.h",
    "Asio": "asio.hpp",
    "nlohmann/json": "nlohmann/json.hpp",
    "GDAL": "gdal",
    "OpenImageIO": "OpenImageIO/",
    "GLM": "glm/glm.hpp",
    "ImGui": "imgui.h",
}


def read_log(build):
    """The last run of each output: (start_s, end_s, output)."""
    steps = {}
    with open(os.path.join(build, ".ninja_log")) as f:
        for line in f:
            if line.startswith("#"):
                continue
            p = line.rstrip("\n").split("\t")
            if len(p) < 4:
                continue
            steps[p[3]] = (int(p[0]) / 1000.0, int(p[1]) / 1000.0)
    return steps


def read_deps(build):
    out = subprocess.run(["ninja", "-C", build, "-t", "deps"], capture_output=True, text=True, check=True).stdout
    deps = collections.defaultdict(list)
    obj = None
    for line in out.splitlines():
        if line and not line[0].isspace():
            obj = line.split(":")[0]
        elif obj and line.strip():
            deps[obj].append(line.strip())
    return deps


def target_of(output):
    # ".../CMakeFiles/<target>.dir/..." for objects; the output's own name for links.
    if "CMakeFiles/" in output and ".dir/" in output:
        return output.split("CMakeFiles/")[1].split(".dir/")[0]
    return os.path.basename(output)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--table", required=True, help="path prefix of the .md and .csv written")
    ap.add_argument("--title", default="build")
    ap.add_argument("--note", default="", help="a paragraph on how the build was run")
    args = ap.parse_args()

    steps = read_log(args.build)
    deps = read_deps(args.build)
    objects = {o: e - s for o, (s, e) in steps.items() if o.endswith(".o")}
    links = {o: e - s for o, (s, e) in steps.items() if not o.endswith(".o")}
    wall = max(e for _, e in steps.values()) - min(s for s, _ in steps.values())
    per_target = collections.defaultdict(lambda: [0, 0.0])
    for o, t in objects.items():
        per_target[target_of(o)][0] += 1
        per_target[target_of(o)][1] += t
    heavy = {}
    for name, needle in HEAVY.items():
        hit = [o for o in objects if any(needle in h for h in deps.get(o, []))]
        heavy[name] = (len(hit), sum(objects[o] for o in hit))

    lines = [f"# {args.title}", ""]
    if args.note:
        lines += [args.note, ""]
    lines += [
        "| wall s | compile s (sum over jobs) | link and other s | objects |",
        "|---:|---:|---:|---:|",
        f"| {wall:.0f} | {sum(objects.values()):.0f} | {sum(links.values()):.0f} | {len(objects)} |",
        "",
        "Seconds of the objects that include each heavy header (an object can count in several rows):",
        "",
        "| header | objects | compile s |",
        "|---|---:|---:|",
    ]
    for name, (n, t) in sorted(heavy.items(), key=lambda kv: -kv[1][1]):
        lines.append(f"| {name} | {n} | {t:.0f} |")
    lines += ["", "Per target:", "", "| target | objects | compile s |", "|---|---:|---:|"]
    for name, (n, t) in sorted(per_target.items(), key=lambda kv: -kv[1][1]):
        lines.append(f"| {name} | {n} | {t:.0f} |")
    lines += ["", "The 15 slowest steps:", "", "| step | s |", "|---|---:|"]
    for o, t in sorted({**objects, **links}.items(), key=lambda kv: -kv[1])[:15]:
        lines.append(f"| `{o}` | {t:.1f} |")
    with open(args.table + ".md", "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(args.table + ".csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["step", "target", "kind", "seconds"])
        for o, t in sorted(objects.items(), key=lambda kv: -kv[1]):
            w.writerow([o, target_of(o), "compile", f"{t:.3f}"])
        for o, t in sorted(links.items(), key=lambda kv: -kv[1]):
            w.writerow([o, target_of(o), "link", f"{t:.3f}"])
    print(f"{args.title}: {wall:.0f} s wall, {sum(objects.values()):.0f} s compiling, {len(objects)} objects")


if __name__ == "__main__":
    main()
