#!/usr/bin/env bash
# Installs the web viewer's npm dependencies from the lock file (tools/viewer/package-lock.json)
# and builds it into tools/viewer/dist: a static site (python3 -m http.server -d tools/viewer/dist)
# that also runs the shipped policies live (the Live tab, `#live`): MuJoCo compiled to
# WebAssembly comes from the npm package `mujoco-js` (pinned in the lock file and bundled into
# dist/), the models and MJCF are copied into dist/live/ from models/ and assets/ — nothing is
# downloaded when the page runs. Downloads no browser: the end-to-end tests use Debian's Chromium
# (apt-get install chromium) through playwright-core.
#
#   scripts/setup-viewer.sh            # npm ci + npm run build
#   scripts/setup-viewer.sh --test     # also run the unit tests (vitest)
#   scripts/setup-viewer.sh --with-chromium   # also apt-get install Debian's chromium (e2e test)
#   scripts/setup-viewer.sh --live-reference  # also rebuild the C++ reference of the live page
#       (tests/viewer/live_reference.cpp, live_tracking_reference.cpp, in build-viewer/) and rewrite tools/viewer/live/
#       (characters, recorded C++ steps, native distance/falls) — after a change to the
#       observation, the policies, the characters or the shipped models
set -euo pipefail
cd "$(dirname "$0")/../tools/viewer"

run_tests=0
with_chromium=0
live_reference=0
for arg in "$@"; do
  case "$arg" in
    --test) run_tests=1 ;;
    --with-chromium) with_chromium=1 ;;
    --live-reference) live_reference=1 ;;
    *) echo "setup-viewer.sh: unknown option '$arg'" >&2; exit 2 ;;
  esac
done
if [[ "$with_chromium" == 1 && ! -x /usr/bin/chromium ]]; then
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y chromium
fi

if ! command -v npm >/dev/null 2>&1; then
  echo "setup-viewer: npm not found (install Node.js >= 20, e.g. apt-get install nodejs npm)" >&2
  exit 1
fi
# playwright-core must not try to download browsers.
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1
# `npm ci` refuses a lock file that lacks other platforms' optional packages (rollup/esbuild
# binaries for macOS, Windows, …), which happens when the lock was made against a registry that
# serves only the Linux ones. Then fall back to `npm install --no-save`: it installs exactly the
# versions pinned in the lock and leaves the lock file untouched.
if ! npm ci --no-audit --no-fund; then
  echo "setup-viewer: npm ci failed; installing the lock file's versions with npm install --no-save" >&2
  npm install --no-save --no-audit --no-fund
fi
if [[ "$live_reference" == 1 ]]; then
  repo="$(cd ../.. && pwd)"
  nice -n 19 cmake -S "$repo" -B "$repo/build-viewer" -DCMAKE_BUILD_TYPE=Release
  nice -n 19 cmake --build "$repo/build-viewer" --target maskadapt_viewer_live_reference maskadapt_viewer_live_tracking_reference -j1
  "$repo/build-viewer/tests/viewer/maskadapt_viewer_live_reference" "$repo/models" "$repo/tools/viewer/live"
  "$repo/build-viewer/tests/viewer/maskadapt_viewer_live_tracking_reference" "$repo/models" "$repo/tools/viewer/live"
fi
npm run build
if [[ "$run_tests" == 1 ]]; then
  npm test
fi
if [[ ! -x /usr/bin/chromium ]]; then
  echo "setup-viewer: note: /usr/bin/chromium is missing; the viewer e2e test (ctest -R viewer_e2e) will be skipped." >&2
  echo "              install it with: apt-get install chromium" >&2
fi
echo "setup-viewer: built tools/viewer/dist — serve it with: python3 -m http.server -d tools/viewer/dist 8000"
echo "              then open http://localhost:8000/#live to run the shipped policies in the page"
