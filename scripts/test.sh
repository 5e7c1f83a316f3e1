#!/usr/bin/env bash
# Install fibrecut with its test extras into ./.venv, make sure the real components the tests
# use are there (PostgreSQL on 127.0.0.1:5432 for the scaled-out path, Debian's Chromium for
# the dashboard's browser tests), then run the whole test suite. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
.venv/bin/pip install -q --upgrade pip
.venv/bin/pip install -q -e '.[test]'
bash scripts/start-postgres.sh || echo "note: PostgreSQL is not available; its tests skip (outside CI) or fail (in CI)"
bash scripts/install-browser.sh || echo "note: Chromium is not available; browser tests skip (outside CI) or fail (in CI)"
set +e
.venv/bin/python -m pytest "$@"
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
  echo "error: pytest collected no test" >&2
fi
exit "$rc"
