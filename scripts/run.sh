#!/usr/bin/env bash
# The main job: cook the default scene and show it. With a display, the interactive viewer;
# without one, the rendered frames of every camera preset as PNGs in out/frames.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! compgen -G "/usr/share/vulkan/icd.d/*.json" >/dev/null && ! compgen -G "/etc/vulkan/icd.d/*.json" >/dev/null; then
  echo "run: no Vulkan driver found; installing lavapipe (Mesa's CPU Vulkan)" >&2
  scripts/install-test-deps.sh
fi
cargo build --release -p cooker -p viewer
mkdir -p out
target/release/cooker cook assets-src/scene.toml -o out/scene.pack
if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
  exec target/release/viewer out/scene.pack "$@"
fi
echo "run: no display; rendering headless"
target/release/viewer out/scene.pack --headless --out out/frames --camera all --size 1280x720 "$@"
echo "run: the frames are in out/frames/"
