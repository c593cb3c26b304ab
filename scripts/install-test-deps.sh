#!/usr/bin/env bash
# Installs what the test suite needs on a fresh Debian machine: a Vulkan driver for the headless
# GPU tests (lavapipe, Mesa's CPU Vulkan, when no GPU driver is present), and Xvfb for the
# interactive viewer's window test.
set -euo pipefail
have_lavapipe() { compgen -G "/usr/share/vulkan/icd.d/lvp_icd*.json" >/dev/null; }
have_loader() { ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1'; }
have_xvfb() { command -v xvfb-run >/dev/null && command -v xauth >/dev/null; }
if have_lavapipe && have_loader && have_xvfb; then
  exit 0
fi
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq mesa-vulkan-drivers libvulkan1 xvfb xauth >/dev/null
have_lavapipe || { echo "install-test-deps: lavapipe ICD still missing after install" >&2; exit 1; }
have_xvfb || { echo "install-test-deps: xvfb-run still missing after install" >&2; exit 1; }
