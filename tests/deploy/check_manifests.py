#!/usr/bin/env python3
"""Checks deploy/'s manifests against the programs they run (tests/deploy/deploy_test.sh).

- Every command line in the Dockerfile (ENTRYPOINT, CMD, HEALTHCHECK), the compose files
  and the Kubernetes manifests (containers' command + args, exec probes) runs loam-server,
  loam-client or loam-probe with flags that program's --help lists, for the subcommand they
  follow.
- Every key of an ini file (deploy/server.ini, the ConfigMap's server.ini) is a
  `loam-server serve` flag.
- The image's runtime packages provide every shared library the installed programs link,
  and the ones libepoxy loads at run time (EGL, OpenGL, Mesa's llvmpipe).

Usage: check_manifests.py SOURCE_DIR INSTALLED_BIN_DIR
"""
import configparser
import glob
import json
import os
import re
import subprocess
import sys

import yaml

SRC, BIN = sys.argv[1], sys.argv[2]
problems = []
checked = {"commands": 0, "flags": 0, "ini keys": 0, "libraries": 0}
help_cache = {}


def help_text(program, subcommand):
    key = (program, subcommand)
    if key not in help_cache:
        argv = [os.path.join(BIN, program)] + ([subcommand] if subcommand else []) + ["--help"]
        out = subprocess.run(argv, capture_output=True, text=True, check=False)
        help_cache[key] = out.stdout + out.stderr
    return help_cache[key]


def subcommands(program):
    text = help_text(program, None)
    section = text.split("SUBCOMMANDS:")[-1] if "SUBCOMMANDS:" in text else text.split("Subcommands:")[-1]
    return set(re.findall(r"^\s+([a-z][a-z-]*)\s", section, re.M))


def flag_listed(flag, text):
    return re.search(r"(^|[\s,])" + re.escape(flag) + r"([\s,=]|$)", text, re.M) is not None


def check_command(argv, where):
    if not argv:
        return
    program = os.path.basename(str(argv[0]))
    if program not in ("loam-server", "loam-client", "loam-probe"):
        problems.append(f"{where}: runs {program}, not loam-server, loam-client or loam-probe")
        return
    checked["commands"] += 1
    subs = subcommands(program) if program != "loam-probe" else set()
    subcommand = None
    for token in map(str, argv[1:]):
        if subcommand is None and token in subs:
            subcommand = token
            continue
        if token.startswith("--"):
            flag = token.split("=", 1)[0]
            checked["flags"] += 1
            if not flag_listed(flag, help_text(program, subcommand)):
                problems.append(f"{where}: {program} {subcommand or ''} has no flag {flag}")
    if subcommand is None and program != "loam-probe":
        problems.append(f"{where}: {program} without a subcommand")


def check_ini(text, where):
    parser = configparser.ConfigParser()
    parser.read_string(text)
    if parser.sections() != ["serve"]:
        problems.append(f"{where}: sections {parser.sections()}, expected only [serve]")
    serve_help = help_text("loam-server", "serve")
    for key in parser["serve"] if parser.has_section("serve") else []:
        checked["ini keys"] += 1
        if not flag_listed("--" + key, serve_help):
            problems.append(f"{where}: '{key}' is not a loam-server serve flag")


# The Dockerfile: JSON-array ENTRYPOINT, CMD and HEALTHCHECK CMD (continuation lines joined).
dockerfile = open(os.path.join(SRC, "deploy/Dockerfile")).read()
instructions = re.sub(r"\\\n", " ", dockerfile).splitlines()
entrypoint, cmd = [], []
for line in instructions:
    m = re.match(r"\s*(ENTRYPOINT|CMD)\s+(\[.*\])\s*$", line)
    if m:
        (entrypoint if m.group(1) == "ENTRYPOINT" else cmd)[:] = json.loads(m.group(2))
    m = re.match(r"\s*HEALTHCHECK\s.*\bCMD\s+(\[.*\])\s*$", line)
    if m:
        check_command(json.loads(m.group(1)), "Dockerfile HEALTHCHECK")
if not entrypoint:
    problems.append("Dockerfile: no ENTRYPOINT")
check_command(entrypoint + cmd, "Dockerfile ENTRYPOINT + CMD")

# Compose: a service without an entrypoint runs the image's.
for path in sorted(glob.glob(os.path.join(SRC, "deploy/compose*.yaml"))):
    doc = yaml.safe_load(open(path))
    for name, service in (doc.get("services") or {}).items():
        if "command" not in service and "entrypoint" not in service:
            continue
        ep = service.get("entrypoint", entrypoint)
        command = service.get("command", cmd if "entrypoint" not in service else [])
        check_command(list(ep) + list(command), f"{os.path.basename(path)} service {name}")

# Kubernetes: containers' command + args, exec probes, ConfigMaps' ini files.
for path in sorted(glob.glob(os.path.join(SRC, "deploy/k8s/*.yaml"))):
    for doc in yaml.safe_load_all(open(path)):
        if not doc:
            continue
        kind, name = doc.get("kind"), doc.get("metadata", {}).get("name")
        where = f"{os.path.basename(path)} {kind} {name}"
        if kind == "ConfigMap":
            for key, text in (doc.get("data") or {}).items():
                if key.endswith(".ini"):
                    check_ini(text, f"{where} {key}")
            continue
        spec = doc.get("spec", {}).get("template", {}).get("spec", {})
        for c in spec.get("containers", []):
            check_command(list(c.get("command", entrypoint)) + list(c.get("args", [])), f"{where} {c['name']}")
            for probe in ("startupProbe", "readinessProbe", "livenessProbe"):
                if "exec" in c.get(probe, {}):
                    check_command(c[probe]["exec"]["command"], f"{where} {c['name']} {probe}")

check_ini(open(os.path.join(SRC, "deploy/server.ini")).read(), "deploy/server.ini")

# The image's runtime packages against the libraries the programs need.
block = dockerfile.split("# runtime-packages-begin")[1].split("# runtime-packages-end")[0]
packages = set(re.sub(r"\\\n", " ", block).split("--no-install-recommends")[1].split("&&")[0].split())
base_image = re.compile(r"^(libc|libm|libdl|libpthread|librt|libstdc\+\+|libgcc_s|ld-linux.*)\.so")
sanitizers = re.compile(r"^lib(a|ub|l|t)san\.so")
# libepoxy opens these with dlopen, so no NEEDED entry names them.
needed = {"libEGL.so.1", "libOpenGL.so.0", "libGL.so.1", "libEGL_mesa.so.0", "dri/swrast_dri.so"}
for program in ("loam-server", "loam-client", "loam-probe", "loam"):
    out = subprocess.run(["readelf", "-d", os.path.join(BIN, program)], capture_output=True, text=True, check=True)
    needed |= set(re.findall(r"\(NEEDED\)\s+Shared library: \[([^\]]+)\]", out.stdout))
for lib in sorted(needed):
    if base_image.match(lib) or sanitizers.match(lib):
        continue
    checked["libraries"] += 1
    owner = subprocess.run(["dpkg", "-S", "*/" + lib], capture_output=True, text=True, check=False)
    owners = {line.split(":")[0] for line in owner.stdout.splitlines() if line.strip()}
    if not owners:
        problems.append(f"{lib}: no Debian package owns it here")
    elif not owners & packages:
        problems.append(f"{lib} comes from {sorted(owners)}, which the Dockerfile does not install")

for p in problems:
    print("check_manifests: " + p, file=sys.stderr)
print("check_manifests: " + ", ".join(f"{v} {k}" for k, v in checked.items()) + (" checked" if not problems else ""))
sys.exit(1 if problems else 0)
