#!/usr/bin/env bash
# Test setup: Debian's Chromium for the browser tests of tests/test_view.py (headless, no GPU needed).
# Does nothing when a Chromium is already on PATH; needs root and Debian's package archive otherwise.
# Without Chromium those tests skip and say why; the rest of the suite does not need it.
set -euo pipefail
for name in chromium chromium-browser google-chrome; do
  if command -v "$name" >/dev/null 2>&1; then
    echo "install_chromium: $name found at $(command -v "$name")"
    exit 0
  fi
done
if [[ $(id -u) -ne 0 ]] || ! command -v apt-get >/dev/null 2>&1; then
  echo "install_chromium: no Chromium, and no root apt-get to install it: browser tests will skip" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends chromium >/dev/null
echo "install_chromium: installed $(chromium --version 2>/dev/null || echo chromium)"
