#!/usr/bin/env bash
# Install everything the tests need (Debian packages, .venv, the project with
# its test extras), check the import contracts (pyproject.toml,
# [tool.importlinter]) and run the whole suite; the GUI tests run under Xvfb.
source "$(dirname "$0")/_env.sh"
install_debs
install_venv test
.venv/bin/lint-imports --no-cache || { echo "Import contracts broken (above)." >&2; exit 1; }
export QT_QPA_PLATFORM=offscreen
exec xvfb-run -a -s "-screen 0 1600x1000x24" .venv/bin/python -m pytest "$@"
