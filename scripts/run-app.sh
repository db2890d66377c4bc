#!/usr/bin/env bash
# Install what TerraSynth needs on first use (Debian libraries for Qt/OpenGL,
# .venv with the project), then open the desktop app on the built-in example.
# Usage: scripts/run-app.sh [PROJECT.tsproj | SKETCH.png]
source "$(dirname "$0")/_env.sh"
install_debs
install_venv gui
if [[ "$(uname -s)" == Linux && -z "${DISPLAY:-}" && -z "${WAYLAND_DISPLAY:-}" ]]; then
  echo "run-app.sh: no display (DISPLAY and WAYLAND_DISPLAY are unset), so no window can open." >&2
  echo "Running the same built-in example without the window instead:" >&2
  mkdir -p out
  .venv/bin/terrasynth-cli demo --out out/demo.tif --debug-dir out/demo-debug
  echo "Wrote out/demo.tif (and pictures in out/demo-debug/). Run this script in a graphical session for the app." >&2
  exit 0
fi
exec .venv/bin/terrasynth "$@"
