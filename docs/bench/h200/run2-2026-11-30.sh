#!/bin/bash
# Device run 2: the viewer before (f00b3c9) and after this session's sampling changes, on an H200.
set -u
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
cd .dev && xz -d -k -f viewer.xz && xz -d -k -f viewer_new.xz && chmod +x viewer viewer_new
L=$OUT/log2.txt
{
for v in viewer viewer_new; do
  ./$v scene.pack --headless --camera all --size 1280x720 --out /tmp/img/$v/scene 2>&1 | tail -1
  ./$v padded.pack --headless --camera all --size 1280x720 --out /tmp/img/$v/padded -v 2>&1 | grep -iE "padded|block|adapter|images" | head -5
done
for r in 1 2; do for v in viewer viewer_new; do
  for c in nave floor; do
    echo "== $v round $r"; ./$v scene.pack --headless --camera $c --size 1920x1080 --bench 20 --out /tmp/bb 2>&1 | grep -E "camera|lit scene|window mask|0 background|normals|total"
  done
done; done
tar -C /tmp/img -cf $OUT/frames2.tar .
echo done
} > $L 2>&1
tail -c 6000 $L
