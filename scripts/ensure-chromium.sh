#!/usr/bin/env bash
# Kept for existing callers: scripts/ensure-system-packages.sh installs Chromium (and Xvfb).
exec bash "$(dirname "$0")/ensure-system-packages.sh"
