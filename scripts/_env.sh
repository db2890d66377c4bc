# Shared set-up for the scripts: Debian packages for Qt/VTK, a venv with the project.
# Sourced, not run.  Creates .venv beside the repo on first use.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"

# Qt's xcb platform and VTK's OpenGL need these shared libraries; Xvfb gives a
# display where there is none (CI, servers).
debs=(xvfb xauth libxcb-cursor0 libxkbcommon-x11-0 libxcb-icccm4 libxcb-keysyms1
      libxcb-image0 libxcb-render-util0 libxcb-xinerama0 libxcb-shape0 libxcb-randr0
      libegl1 libgl1 libgl1-mesa-dri libfontconfig1 libdbus-1-3 libxkbcommon0 libglib2.0-0)
install_debs() {
  command -v dpkg-query >/dev/null || return 0
  local missing=()
  for p in "${debs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
  done
  ((${#missing[@]})) || return 0
  local sudo=""
  [[ $(id -u) -eq 0 ]] || sudo="sudo"
  echo "Installing Debian packages: ${missing[*]}" >&2
  $sudo apt-get update -q >&2
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}" >&2
}

install_venv() {  # $1: the extras, e.g. "gui" or "test"
  [[ -x .venv/bin/python ]] || python3 -m venv .venv
  # pip's build chatter goes to a log, shown only when something fails.
  local log=.venv/install.log
  if ! { .venv/bin/python -m pip install -q --upgrade pip &&
         .venv/bin/python -m pip install -q -e ".[$1]"; } >"$log" 2>&1; then
    cat "$log" >&2
    echo "Installing TerraSynth into .venv failed (log above, also in $log)." >&2
    return 1
  fi
}
