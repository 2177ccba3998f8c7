#!/usr/bin/env bash
# Installs the Debian packages the test suite needs when they are missing (needs root + apt):
#   chromium  - the HTML-report browser test
#   xvfb      - a virtual X server for the window-projector tests (tests start their own Xvfb)
#   cloudcompare - CloudCompare's command line reads the reconstruct PLY in tests/test_export_command.py
#   libusb-1.0-0 - a shared library Open3D's wheel loads at import (registration, meshing)
set -euo pipefail
missing=()
command -v chromium >/dev/null 2>&1 || missing+=(chromium)
command -v Xvfb >/dev/null 2>&1 || missing+=(xvfb)
command -v CloudCompare >/dev/null 2>&1 || missing+=(cloudcompare)
{ ldconfig -p 2>/dev/null | grep -q 'libusb-1.0.so.0'; } || missing+=(libusb-1.0-0)
if [ ${#missing[@]} -eq 0 ]; then exit 0; fi
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
  echo "installing Debian packages for the tests: ${missing[*]}..." >&2
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
else
  echo "missing Debian packages: ${missing[*]} (chromium: the report browser test; xvfb: the window-projector tests; cloudcompare: the PLY reader test; libusb-1.0-0: Open3D); install them with apt-get" >&2
  exit 1
fi
