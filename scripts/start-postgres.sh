#!/usr/bin/env bash
# Start the local PostgreSQL server (Debian's cluster) if it is installed but not answering.
# The tests use postgresql://postgres@127.0.0.1:5432/test (override with FIBRECUT_TEST_PG_URL).
set -uo pipefail
if command -v pg_isready >/dev/null 2>&1 && pg_isready -q -h 127.0.0.1 -p 5432; then
  exit 0
fi
if command -v pg_ctlcluster >/dev/null 2>&1 && [ -d /etc/postgresql ]; then
  for v in $(ls /etc/postgresql); do
    pg_ctlcluster --skip-systemctl-redirect "$v" main start 2>/dev/null || true
  done
  for _ in $(seq 1 20); do
    pg_isready -q -h 127.0.0.1 -p 5432 && exit 0
    sleep 0.5
  done
fi
echo "PostgreSQL is not installed or did not start (Debian: apt-get install postgresql)" >&2
exit 1
