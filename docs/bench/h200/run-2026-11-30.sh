#!/bin/bash
# Device run: per-pass GPU timings, first frame, memory, images of the current viewer on an H200.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
cd .dev && for b in viewer bench cooker; do xz -d -k -f $b.xz; chmod +x $b; done
L=$OUT/log.txt
{
nvidia-smi -L; nvidia-smi --query-gpu=driver_version,clocks.sm,clocks.max.sm --format=csv
nproc
echo "== sha of the pack cooked here vs there"
sha256sum scene.pack
RAYON_NUM_THREADS=16 ./cooker cook ../assets-src/scene.toml -o there.pack --no-cache 2>&1 | tail -1
sha256sum there.pack
echo "== first frame / full quality, 5 runs, -v"
for i in 1 2 3 4 5; do /usr/bin/env python3 - <<'PY'
import resource, subprocess, sys
r = subprocess.run(["./viewer","scene.pack","--headless","--camera","nave","--out","/tmp/ff","-v"],capture_output=True,text=True)
print("rc",r.returncode, "maxrss_MB", resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss*1024/1e6)
print("\n".join(l for l in (r.stdout+r.stderr).splitlines() if "frame" in l or "quality" in l or "adapter" in l.lower())[:3000])
PY
done
for s in 1280x720 1920x1080 3840x2160; do
  echo "== passes $s"; timeout 120 ./viewer scene.pack --headless --camera all --size $s --bench 30 --out /tmp/b$s 2>&1 | tail -60
  echo "== passes $s no occlusion"; timeout 120 ./viewer scene.pack --headless --camera all --size $s --bench 30 --no-occlusion --out /tmp/c$s 2>&1 | tail -60
done
echo "== images"
./viewer scene.pack --headless --camera all --size 1280x720 --out /tmp/img 2>&1 | tail -3
tar -C /tmp/img -cf $OUT/h200-frames.tar .
echo done
} > $L 2>&1
cat $L | tail -c 11000
