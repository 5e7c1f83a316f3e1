#!/usr/bin/env bash
# Make sure Debian's Chromium is installed for the dashboard's browser tests
# (tests/test_web_dashboard.py drives it with Playwright at /usr/bin/chromium).
# No browser is downloaded from the internet: Debian's package only, with apt-get when we
# are root; otherwise the command to run is printed and the script exits 1.
set -euo pipefail
BROWSER=${FIBRECUT_CHROMIUM:-/usr/bin/chromium}
if [ -x "$BROWSER" ]; then
  echo "chromium: $("$BROWSER" --version 2>/dev/null || echo "$BROWSER")"
  exit 0
fi
if ! command -v apt-get >/dev/null 2>&1; then
  echo "chromium is missing at $BROWSER and apt-get is not available: install Chromium with your package manager" >&2
  exit 1
fi
if [ "$(id -u)" -ne 0 ]; then
  echo "chromium is missing at $BROWSER; install it with:" >&2
  echo "  sudo apt-get update && sudo apt-get install -y chromium" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get install -y --no-install-recommends chromium || { apt-get update && apt-get install -y --no-install-recommends chromium; }
echo "chromium: $("$BROWSER" --version 2>/dev/null || echo installed)"
