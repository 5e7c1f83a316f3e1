#!/usr/bin/env bash
# Install fibrecut with its PostgreSQL driver into ./.venv (if needed) and start the service with its dashboard and a
# local worker pool on the embedded default: SQLite in ./fibrecut-data, http://127.0.0.1:8000.
# Extra arguments go to `fibrecut serve` (e.g. --port 8080 --workers 4).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
# the postgres extra too: every path of the README (fibrecut serve/worker --db postgresql+psycopg://...)
# runs in this environment
if [ ! -x .venv/bin/fibrecut ] || ! .venv/bin/python -c "import psycopg" 2>/dev/null; then
  [ -x .venv/bin/python ] || "$PY" -m venv .venv
  .venv/bin/pip install -q --upgrade pip
  .venv/bin/pip install -q -e '.[postgres]'
fi
exec .venv/bin/fibrecut serve "$@"
