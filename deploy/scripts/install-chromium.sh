#!/usr/bin/env bash
# Installs Debian's headless-capable Chromium and its WebDriver (`chromium`,
# `chromium-driver`) that the browser tests of tests/dashboard.rs drive, when
# /usr/bin/chromedriver is absent, and prints the path of chromedriver.
# Needs root (CI runs as root); without it, it exits with status 3 and the tests say
# they skipped. Any other failure fails the tests.
set -euo pipefail
BIN=/usr/bin/chromedriver
if [ -x "$BIN" ]; then
    echo "$BIN"
    exit 0
fi
if [ "$(id -u)" -ne 0 ]; then
    echo "install-chromium.sh: chromium-driver is not installed and installing it needs root" >&2
    exit 3
fi
export DEBIAN_FRONTEND=noninteractive
apt-get install -y chromium chromium-driver >&2 || {
    apt-get update >&2
    apt-get install -y chromium chromium-driver >&2
}
"$BIN" --version >&2
echo "$BIN"
