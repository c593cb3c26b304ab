# DDS fixtures written by Pillow 11.3.0 from third-party images; prints the SHA-256 of Pillow's
# own RGBA8 decode of each.
import hashlib
from PIL import Image
import pathlib
T = pathlib.Path(__file__).resolve().parent.parent  # tests/data/third_party
bricks = Image.open(f"{T}/crytek-sponza/spnza_bricks_a_diff.crop128.tga").convert("RGB")
corner = Image.open(f"{T}/gltf/TextureCoordinateTest/TextureCoordinateTemplate.png").convert("L").crop((0, 0, 128, 128))
glass = bricks.copy()
glass.putalpha(corner)  # the bricks, with the template's top-left corner as alpha
py = Image.open(f"{T}/cpython/python.jpg").convert("RGB")
out = []
def save(img, name, **kw):
    img.save(name, **kw)
    back = Image.open(name).convert("RGBA")
    out.append(f"{name} {back.width} {back.height} {hashlib.sha256(back.tobytes()).hexdigest()}")
save(bricks, "bricks_dxt1.dds", pixel_format="DXT1")
save(glass, "glass_dxt3.dds", pixel_format="DXT3")
save(glass, "glass_dxt5.dds", pixel_format="DXT5")
save(glass, "glass_bc3_dx10.dds", pixel_format="BC3")
save(bricks, "bricks_bc5_dx10.dds", pixel_format="BC5")
save(glass, "glass_rgba.dds")
save(py, "python_rgb.dds")
print("\n".join(out))
# Pillow's decode of the block-compressed ones, kept whole: block decoders may round the
# interpolated colours differently, so the test compares texels, not hashes.
for name in ["bricks_dxt1", "glass_dxt3", "glass_dxt5", "glass_bc3_dx10", "bricks_bc5_dx10"]:
    Image.open(f"{name}.dds").convert("RGBA").save(f"{name}.pillow.png", optimize=True)
