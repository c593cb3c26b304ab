#!/usr/bin/env bash
# The whole test suite, from a fresh clone: installs what it needs, then runs every test.
# GPU tests run on lavapipe so reference images are reproducible; they fail (not skip) when no
# Vulkan adapter can be created.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-test-deps.sh
lvp=$(compgen -G "/usr/share/vulkan/icd.d/lvp_icd*.json" | head -n 1)
export VK_DRIVER_FILES="$lvp"
export WGPU_BACKEND=vulkan
# Without a session (CI, servers) Mesa's device-select layer makes libwayland print "error:
# XDG_RUNTIME_DIR is invalid" from every GPU test; lavapipe is the only device here anyway.
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
  export NODEVICE_SELECT=1
fi
cargo test --workspace --all-targets "$@"
