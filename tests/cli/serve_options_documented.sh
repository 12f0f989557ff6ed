#!/usr/bin/env bash
# docs/configuration.md is the contract for `loam-server serve`: every option its --help lists
# has a row there (`--option` in backticks), so an option added without its documentation fails.
# Usage: serve_options_documented.sh SOURCE_DIR LOAM_SERVER
set -euo pipefail
doc="$1/docs/configuration.md"
missing=()
for o in $("$2" serve --help | grep -o -- '--[a-z][a-z0-9-]*' | sort -u); do
  [ "$o" = "--help" ] && continue
  grep -q -- "\`$o\`" "$doc" || missing+=("$o")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "serve_options_documented: not in docs/configuration.md: ${missing[*]}" >&2
  exit 1
fi
echo "serve_options_documented: ok"
