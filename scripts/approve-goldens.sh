#!/usr/bin/env bash
# Re-renders the golden images (the terrain views, materials and shadows, the HUD, the viewer's window) and replaces the committed
# ones in tests/golden/images/ (after a deliberate change to the renderer). Review the new
# images (git diff shows them changed; open them) before committing.
# Usage: scripts/approve-goldens.sh [build folder, default build/release]
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build/release}"
if [ ! -x "$build/tests/loam_gl_tests" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  ninja -C "$build" loam_gl_tests loam_e2e_tests
fi
LOAM_APPROVE_GOLDENS="$PWD/tests/golden/images" "$build/tests/loam_gl_tests" --gtest_filter='ClipmapGolden.*:MaterialsGolden.*:HudGolden.*'
# The viewer's window on live sessions (a real server each) needs an X display.
xvfb=()
if [ -z "${DISPLAY:-}" ]; then xvfb=(xvfb-run -a -s "-screen 0 1280x1024x24"); fi
LOAM_APPROVE_GOLDENS="$PWD/tests/golden/images" "${xvfb[@]}" "$build/tests/loam_e2e_tests" --gtest_filter='ViewerWindow.*'
git status --short tests/golden/images
