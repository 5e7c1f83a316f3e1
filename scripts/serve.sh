#!/usr/bin/env bash
# Install fibrecut into ./.venv (if needed) and start the service with its dashboard and a
# local worker pool on the embedded default: SQLite in ./fibrecut-data, http://127.0.0.1:8000.
# Extra arguments go to `fibrecut serve` (e.g. --port 8080 --workers 4).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if [ ! -x .venv/bin/fibrecut ]; then
  "$PY" -m venv .venv
  .venv/bin/pip install -q --upgrade pip
  .venv/bin/pip install -q -e .
fi
exec .venv/bin/fibrecut serve "$@"
