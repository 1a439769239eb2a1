#!/bin/sh
# Install a headless browser for tests/service/test_service_live.py (the page test) when none is on PATH.
# Called by .ci/run. Non-interactive; never fails the CI run (the test skips without a browser).
set -u
for b in chromium chromium-browser google-chrome; do
    if command -v "$b" >/dev/null 2>&1; then
        echo "service/ci-install.sh: $b found at $(command -v "$b")"
        exit 0
    fi
done
if ! command -v apt-get >/dev/null 2>&1; then
    echo "service/ci-install.sh: no apt-get; the browser test will skip" >&2
    exit 0
fi
SUDO=""
if [ "$(id -u)" != "0" ]; then
    if command -v sudo >/dev/null 2>&1; then SUDO="sudo -n"; else
        echo "service/ci-install.sh: not root and no sudo; the browser test will skip" >&2
        exit 0
    fi
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq >/dev/null 2>&1 || true
$SUDO apt-get install -y -qq --no-install-recommends chromium fonts-dejavu-core >/dev/null 2>&1 \
    || echo "service/ci-install.sh: could not install chromium; the browser test will skip" >&2
exit 0
