//! Real image inputs through the whole cooker: a TGA and a JPEG from third-party sets as OBJ
//! material textures, and a glTF whose base colour image is a base64 data URI. Level 0 of a
//! cooked 8-bit sRGB texture keeps the source's bytes, so it must equal the image crate's own
//! decode exactly (`--texture-format rgba8`); block-compressed, it decodes within the error
//! budget; damaged inputs exit 3 naming the file.

mod common;

use std::path::{Path, PathBuf};

use common::cooker;

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/third_party")
        .join(rel)
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

const TGA: &str = "crytek-sponza/spnza_bricks_a_diff.crop128.tga";
const JPEG: &str = "cpython/python.jpg";

/// An OBJ quad per texture, each with its own material whose `map_Kd` is that file (copied
/// into `dir`, so a test can damage its copy).
fn obj_scene(dir: &Path, textures: &[&str]) -> PathBuf {
    let mut obj = String::from("mtllib scene.mtl\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\n");
    let mut mtl = String::new();
    for (i, t) in textures.iter().enumerate() {
        let src = data(t);
        let name = src.file_name().unwrap().to_str().unwrap().to_string();
        std::fs::copy(&src, dir.join(&name)).unwrap();
        let x = 2 * i;
        obj += &format!(
            "v {x} 0 0\nv {} 0 0\nv {} 1 0\nv {x} 1 0\nusemtl m{i}\n",
            x + 1,
            x + 1
        );
        let b = 4 * i;
        obj += &format!(
            "f {}/1/1 {}/2/1 {}/3/1\nf {}/1/1 {}/3/1 {}/4/1\n",
            b + 1,
            b + 2,
            b + 3,
            b + 1,
            b + 3,
            b + 4
        );
        mtl += &format!("newmtl m{i}\nKd 1 1 1\nmap_Kd {name}\n");
    }
    std::fs::write(dir.join("scene.obj"), obj).unwrap();
    std::fs::write(dir.join("scene.mtl"), mtl).unwrap();
    dir.join("scene.obj")
}

/// `(width, height, mips)` of the pack's texture `name`, from `cooker info --json`.
fn texture_info(pack: &Path, name: &str) -> (u64, u64, u64) {
    let o = cooker(&[&"info", &pack, &"--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let t = v["textures"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["name"] == name)
        .unwrap_or_else(|| panic!("no texture {name:?} in {v}"));
    assert_eq!(t["role"], "colour");
    assert_eq!(t["colour_space"], "srgb");
    let n = |k: &str| t[k].as_u64().unwrap();
    (n("width"), n("height"), n("mips"))
}

fn extract(pack: &Path, name: &str, mip: u32, dir: &Path) -> image::RgbaImage {
    let out = dir.join(format!("{name}-{mip}.png"));
    let o = cooker(&[
        &"extract",
        &pack,
        &name,
        &"--mip",
        &mip.to_string(),
        &"-o",
        &out,
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    image::open(&out).unwrap().to_rgba8()
}

/// `cooker cook obj -o pack --no-cache extra…`, which must succeed; the pack and its stderr.
fn cook_obj(obj: &Path, pack: &Path, extra: &[&str]) -> (PathBuf, String) {
    // `-v`: the tests read the budget's choices, which only `-v` prints.
    let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> =
        vec![&"cook", &obj, &"-o", &pack, &"--no-cache", &"-v"];
    for e in extra {
        args.push(e);
    }
    let o = cooker(&args);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    (pack.to_path_buf(), text(&o.stderr))
}

fn mips_for(w: u64, h: u64) -> u64 {
    64 - w.max(h).leading_zeros() as u64
}

fn rms(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    let sq: f64 = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(&x, &y)| (x as f64 - y as f64).powi(2))
        .sum();
    (sq / a.as_raw().len() as f64).sqrt()
}

/// `--texture-format bc` stores BC7 (a quarter of the bytes, levels below 4x4 a whole block
/// each); `extract` decodes it, `diff` compares decoded texels with the RGBA8 pack's, and
/// `auto` keeps RGBA8 when the budget is tighter than any encoder setting reaches.
#[test]
fn block_compressed_textures_decode_within_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let obj = obj_scene(dir.path(), &[TGA]);
    let cook = |name: &str, extra: &[&str]| cook_obj(&obj, &dir.path().join(name), extra);
    let (rgba8, _) = cook("rgba8.pack", &["--texture-format", "rgba8"]);
    let (bc, log) = cook("bc.pack", &["--texture-format", "bc"]);
    assert!(log.contains("bc7"), "the choice is reported: {log}");
    let info = cooker(&[&"info", &bc, &"--json"]);
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    let t = &v["textures"][0];
    assert_eq!(t["format"], "bc7", "{t}");
    // 128x128 down to 1x1: 8 levels; the 2x2 and 1x1 levels are a block each.
    let blocks: u64 = [32 * 32, 16 * 16, 8 * 8, 4 * 4, 2 * 2, 1, 1, 1]
        .iter()
        .sum();
    assert_eq!(t["format_bytes"].as_u64(), Some(blocks * 16), "{t}");
    // zstd on top (the default) only ever makes the file's share smaller.
    assert_eq!(t["supercompression"], "zstd", "{t}");
    assert!(t["stored_bytes"].as_u64().unwrap() < blocks * 16, "{t}");
    let texels: u64 = (0..8).map(|k| (128u64 >> k).pow(2)).sum();
    assert_eq!(t["uncompressed_bytes"].as_u64(), Some(texels * 4), "{t}");

    let name = "spnza_bricks_a_diff.crop128";
    let exact = extract(&rgba8, name, 0, dir.path());
    let decoded = extract(&bc, name, 0, dir.path());
    assert_eq!(decoded.dimensions(), (128, 128));
    let e = rms(&exact, &decoded);
    assert!(e > 0.0 && e < 4.0, "BC7 level 0 is {e} LSB RMS from RGBA8");

    let d = cooker(&[&"diff", &rgba8, &bc, &"--json"]);
    assert_eq!(
        d.status.code(),
        Some(1),
        "not identical: {}",
        text(&d.stdout)
    );
    let d = cooker(&[&"diff", &rgba8, &bc, &"--tolerance-lsb", &"255"]);
    assert_eq!(d.status.code(), Some(0), "{}", text(&d.stdout));

    // No encoder setting reaches 0.1 LSB RMS on a photograph: auto keeps RGBA8 and says so.
    let (tight, log) = cook("tight.pack", &["--max-error-lsb", "0.1"]);
    assert!(log.contains("kept RGBA8"), "{log}");
    let v: serde_json::Value =
        serde_json::from_slice(&cooker(&[&"info", &tight, &"--json"]).stdout).unwrap();
    assert_eq!(v["textures"][0]["format"], "rgba8");
    // `bc` stores the most accurate setting and warns; no note says the budget chose it.
    let (_, log) = cook(
        "tight-bc.pack",
        &["--max-error-lsb", "0.1", "--texture-format", "bc"],
    );
    assert!(
        log.contains("warning: ")
            && log.contains("no block encoder setting fits the budget of")
            && log.contains("the most accurate, as texture format \"bc\" asks"),
        "{log}"
    );
    assert!(!log.contains("chosen by the error budget"), "{log}");
}

/// zstd on top of the format (the default) is lossless: `--supercompression none` stores the
/// same levels uncompressed, larger, and `diff` and `extract` see the same texels in both.
#[test]
fn supercompression_is_lossless_and_can_be_turned_off() {
    let dir = tempfile::tempdir().unwrap();
    let obj = obj_scene(dir.path(), &[TGA]);
    let cook = |name: &str, extra: &[&str]| cook_obj(&obj, &dir.path().join(name), extra);
    for format in ["rgba8", "bc"] {
        let (zstd, _) = cook(
            &format!("{format}-zstd.pack"),
            &["--texture-format", format],
        );
        let (plain, _) = cook(
            &format!("{format}-plain.pack"),
            &["--texture-format", format, "--supercompression", "none"],
        );
        let info = |p: &Path| -> serde_json::Value {
            serde_json::from_slice(&cooker(&[&"info", &p, &"--json"]).stdout).unwrap()
        };
        let (z, p) = (info(&zstd), info(&plain));
        let (tz, tp) = (&z["textures"][0], &p["textures"][0]);
        assert_eq!(
            (&tz["supercompression"], &tp["supercompression"]),
            (&"zstd".into(), &"none".into())
        );
        assert_eq!(tz["format_bytes"], tp["format_bytes"], "{tz} {tp}");
        assert_eq!(tp["stored_bytes"], tp["format_bytes"], "{tp}");
        assert!(
            tz["stored_bytes"].as_u64() < tp["stored_bytes"].as_u64(),
            "{format}: {tz} against {tp}"
        );
        // Byte for byte they differ; texel for texel, and section by section content, not.
        let d = cooker(&[&"diff", &plain, &zstd]);
        assert_eq!(d.status.code(), Some(1), "{format}: {}", text(&d.stdout));
        assert!(
            text(&d.stdout).contains("supercompression"),
            "{}",
            text(&d.stdout)
        );
        let d = cooker(&[&"diff", &plain, &zstd, &"--tolerance-lsb", &"0"]);
        assert_eq!(d.status.code(), Some(0), "{format}: {}", text(&d.stdout));
        // Only the TOC (which records the supercompression) differs; every level's content
        // is the same.
        assert!(
            text(&d.stdout).contains(" compared, 1 differ") && text(&d.stdout).contains("toc "),
            "{format}: {}",
            text(&d.stdout)
        );
        let name = "spnza_bricks_a_diff.crop128";
        for level in [0, 3] {
            assert_eq!(
                extract(&plain, name, level, dir.path()),
                extract(&zstd, name, level, dir.path()),
                "{format} level {level}"
            );
        }
    }
    let o = cooker(&[
        &"cook",
        &obj,
        &"-o",
        &dir.path().join("x.pack"),
        &"--supercompression",
        &"lz4",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("zstd, none"),
        "{}",
        text(&o.stderr)
    );
}

/// An image whose size is not a multiple of 4 (61x43, cropped from the TGA): block-compressed,
/// it keeps its logical size and level count (the padded 64x44 would have one more), decodes
/// within the budget at every level; kept RGBA8 by a budget no encoder reaches, it is
/// byte-identical to the RGBA8 pack's (cooked again unpadded).
#[test]
fn odd_sized_texture_is_padded_only_when_block_compressed() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src");
    std::fs::create_dir(&src).unwrap();
    let crop = image::open(data(TGA)).unwrap().crop_imm(3, 5, 61, 43);
    crop.save(src.join("odd.png")).unwrap();
    let obj = obj_scene(dir.path(), &[src.join("odd.png").to_str().unwrap()]);
    let cook = |name: &str, extra: &[&str]| cook_obj(&obj, &dir.path().join(name), extra);
    let (rgba8, _) = cook("rgba8.pack", &["--texture-format", "rgba8"]);
    let (bc, _) = cook("bc.pack", &["--texture-format", "bc"]);
    let (w, h, mips) = texture_info(&bc, "odd");
    assert_eq!((w, h, mips), (61, 43, mips_for(61, 43)));
    for level in 0..mips as u32 {
        let exact = extract(&rgba8, "odd", level, dir.path());
        let decoded = extract(&bc, "odd", level, dir.path());
        assert_eq!(decoded.dimensions(), exact.dimensions(), "level {level}");
        // Level 0 is the same image; smaller levels are mipped from the padded level 0, so
        // they differ from the unpadded chain's by more than the encoder alone.
        let e = rms(&exact, &decoded);
        let bound = if level == 0 { 4.0 } else { 12.0 };
        assert!(e < bound, "level {level}: {e} LSB RMS from RGBA8");
    }
    let (tight, log) = cook("tight.pack", &["--max-error-lsb", "0.1"]);
    assert!(log.contains("kept RGBA8"), "{log}");
    let d = cooker(&[&"diff", &rgba8, &tight]);
    assert_eq!(d.status.code(), Some(0), "{}", text(&d.stdout));
}

#[test]
fn real_tga_and_jpeg_cook_with_their_exact_bytes_at_level_0() {
    let dir = tempfile::tempdir().unwrap();
    let obj = obj_scene(dir.path(), &[TGA, JPEG]);
    let pack = dir.path().join("scene.pack");
    let o = cooker(&[
        &"cook",
        &obj,
        &"-o",
        &pack,
        &"--no-cache",
        &"--texture-format",
        &"rgba8",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    for (file, name, size) in [
        (TGA, "spnza_bricks_a_diff.crop128", 128),
        (JPEG, "python", 16),
    ] {
        let decoded = image::open(data(file)).unwrap().to_rgba8();
        assert_eq!(decoded.dimensions(), (size, size), "{file}");
        let (w, h, mips) = texture_info(&pack, name);
        assert_eq!((w, h), (size as u64, size as u64), "{file}");
        assert_eq!(mips, mips_for(w, h), "{file}: a full chain down to 1x1");
        let level0 = extract(&pack, name, 0, dir.path());
        assert!(
            level0 == decoded,
            "{file}: cooked level 0 differs from the image crate's decode"
        );
        // The chain is filtered, not copied: level 1 is half the size and still opaque.
        let level1 = extract(&pack, name, 1, dir.path());
        assert_eq!(level1.dimensions(), (size / 2, size / 2));
        assert!(level1.pixels().all(|p| p[3] == 255), "{file}");
        let last = extract(&pack, name, (mips - 1) as u32, dir.path());
        assert_eq!(last.dimensions(), (1, 1));
    }
}

#[test]
fn truncated_tga_and_jpeg_exit_3_naming_the_file() {
    for file in [TGA, JPEG] {
        let dir = tempfile::tempdir().unwrap();
        let obj = obj_scene(dir.path(), &[file]);
        let copy = dir.path().join(data(file).file_name().unwrap());
        let bytes = std::fs::read(&copy).unwrap();
        std::fs::write(&copy, &bytes[..bytes.len() / 2]).unwrap();
        let pack = dir.path().join("scene.pack");
        let o = cooker(&[&"cook", &obj, &"-o", &pack, &"--no-cache"]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(3), "{file}: {err}");
        assert!(
            err.contains(copy.file_name().unwrap().to_str().unwrap()),
            "{file}: the message names the file: {err}"
        );
        assert!(!pack.exists(), "{file}: a failed cook writes no pack");
    }
}

/// Standard base64 with padding (RFC 4648), enough to build a data URI.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for i in 0..4 {
            if i <= c.len() {
                s.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// The BoxTextured sample with its PNG replaced by `uri`; the buffer stays a file beside it.
fn box_with_image_uri(dir: &Path, uri: &str) -> PathBuf {
    let src = data("gltf/BoxTextured");
    std::fs::copy(src.join("BoxTextured0.bin"), dir.join("BoxTextured0.bin")).unwrap();
    let gltf = std::fs::read_to_string(src.join("BoxTextured.gltf")).unwrap();
    assert!(gltf.contains("\"CesiumLogoFlat.png\""));
    let gltf = gltf.replace("\"CesiumLogoFlat.png\"", &format!("{uri:?}"));
    let path = dir.join("box.gltf");
    std::fs::write(&path, gltf).unwrap();
    path
}

#[test]
fn gltf_data_uri_image_is_decoded_and_cooked() {
    let dir = tempfile::tempdir().unwrap();
    let png_path = data("gltf/BoxTextured/CesiumLogoFlat.png");
    let png = std::fs::read(&png_path).unwrap();
    let gltf = box_with_image_uri(
        dir.path(),
        &format!("data:image/png;base64,{}", base64(&png)),
    );
    let pack = dir.path().join("box.pack");
    let o = cooker(&[
        &"cook",
        &gltf,
        &"-o",
        &pack,
        &"--no-cache",
        &"--texture-format",
        &"rgba8",
    ]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(!err.contains("data URI"), "no longer skipped: {err}");
    let name = only_texture(&pack);
    let decoded = image::open(&png_path).unwrap().to_rgba8();
    let (w, h, mips) = texture_info(&pack, &name);
    assert_eq!((w as u32, h as u32), decoded.dimensions());
    assert_eq!(mips, mips_for(w, h));
    assert!(
        extract(&pack, &name, 0, dir.path()) == decoded,
        "level 0 differs from the PNG's decode"
    );
}

#[test]
fn malformed_data_uris_exit_3_naming_the_file() {
    for (uri, what) in [
        ("data:image/png;base64,iVBORw0KGgo!!!!", "base64"),
        ("data:image/png;base64", "','"),
        ("data:image/png,rawbytes", "not base64"),
        // Valid base64 of bytes that are no image: the decoder names the glTF's image.
        ("data:image/png;base64,AAECAwQFBgcICQ==", "box.gltf"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let gltf = box_with_image_uri(dir.path(), uri);
        let pack = dir.path().join("box.pack");
        let o = cooker(&[&"cook", &gltf, &"-o", &pack, &"--no-cache"]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(3), "{uri}: {err}");
        assert!(err.contains("box.gltf"), "{uri}: names the file: {err}");
        assert!(err.contains(what), "{uri}: says what is wrong: {err}");
        assert!(!pack.exists());
    }
}

/// The pack's only texture: its name, after checking the material samples it.
/// The name of the first texture of `pack` (in `info --json`) that `pick` accepts.
fn texture_where(pack: &Path, pick: impl Fn(&serde_json::Value) -> bool) -> String {
    let o = cooker(&[&"info", &pack, &"--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let found = v["textures"].as_array().unwrap().iter().find(|t| pick(t));
    match found {
        Some(t) => t["name"].as_str().unwrap().to_string(),
        None => panic!("no such texture in {v}"),
    }
}

fn only_texture(pack: &Path) -> String {
    let info = cooker(&[&"info", &pack, &"--json"]);
    assert_eq!(info.status.code(), Some(0), "{}", text(&info.stderr));
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    let textures = v["textures"].as_array().unwrap();
    assert_eq!(textures.len(), 1, "{v}");
    let name = textures[0]["name"].as_str().unwrap().to_string();
    let used = v["materials"]
        .as_array()
        .unwrap()
        .iter()
        .any(|m| m["diffuse_texture"] == name.as_str());
    assert!(used, "a material samples {name}: {v}");
    name
}

/// The SHA-256 of `file`'s level 0 as the C++ Basis Universal transcoder decodes it to RGBA8,
/// from `ktx2/REFERENCE`.
fn reference_texels(file: &str) -> String {
    let list = std::fs::read_to_string(data("ktx2/REFERENCE")).unwrap();
    let line = list.lines().find(|l| l.split(' ').next() == Some(file));
    let line = line.unwrap_or_else(|| panic!("no reference for {file}"));
    line.rsplit(' ').next().unwrap().to_string()
}

fn sha256_hex(img: &image::RgbaImage) -> String {
    use sha2::Digest;
    let digest = sha2::Sha256::digest(img.as_raw());
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// Models that require `KHR_texture_basisu` (glTF Transform with the Basis Universal encoder,
/// no PNG fallback): ETC1S, zstd-supercompressed UASTC, and a 211x211 design whose blocks
/// overhang its edges. Level 0 has the PNG's size and full mip chain, holds exactly the texels
/// the C++ transcoder decodes, and is close to the PNG it was encoded from but not equal (Basis
/// is lossy). The RMS bounds are the measured 4.43 / 0.66 / 4.50 with a margin.
#[test]
fn basis_universal_textures_cook_to_the_reference_transcoders_texels() {
    for (model, png, max_rms) in [
        (
            "ktx2/boxtex_etc1s.glb",
            "gltf/BoxTextured/CesiumLogoFlat.png",
            5.0,
        ),
        (
            "ktx2/boxtex_uastc.glb",
            "gltf/BoxTextured/CesiumLogoFlat.png",
            1.0,
        ),
        (
            "ktx2/boxtex_npot_etc1s.glb",
            "gltf/BoxTexturedNonPowerOfTwo/CesiumLogoFlat.png",
            5.0,
        ),
    ] {
        let file = model.rsplit('/').next().unwrap();
        let dir = tempfile::tempdir().unwrap();
        let pack = dir.path().join("box.pack");
        cook_obj(&data(model), &pack, &["--texture-format", "rgba8"]);
        let name = only_texture(&pack);
        let source = image::open(data(png)).unwrap().to_rgba8();
        let (w, h, mips) = texture_info(&pack, &name);
        assert_eq!((w as u32, h as u32), source.dimensions(), "{model:?}");
        assert_eq!(mips, mips_for(w, h));
        let level0 = extract(&pack, &name, 0, dir.path());
        assert_eq!(sha256_hex(&level0), reference_texels(file), "{model}");
        let e = rms(&level0, &source);
        assert!(e > 0.0 && e <= max_rms, "{model}: RMS {e} against the PNG");
    }
}

/// BoxTextured with a second image, a KTX2 of another design (the 512x512 template), named by
/// the texture's `KHR_texture_basisu`. With the PNG still its `source` the cook reads the PNG,
/// lossless, byte for byte; with the source removed and the extension required, the KTX2.
#[test]
fn a_png_fallback_is_preferred_to_the_basis_texture_beside_it() {
    let src = data("gltf/BoxTextured");
    for required in [false, true] {
        let dir = tempfile::tempdir().unwrap();
        for f in ["BoxTextured0.bin", "CesiumLogoFlat.png"] {
            std::fs::copy(src.join(f), dir.path().join(f)).unwrap();
        }
        std::fs::copy(
            data("ktx2/template_uastc.ktx2"),
            dir.path().join("template.ktx2"),
        )
        .unwrap();
        let mut v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(src.join("BoxTextured.gltf")).unwrap()).unwrap();
        v["images"]
            .as_array_mut()
            .unwrap()
            .push(serde_json::json!({"uri": "template.ktx2", "mimeType": "image/ktx2"}));
        v["textures"][0]["extensions"] = serde_json::json!({"KHR_texture_basisu": {"source": 1}});
        v["extensionsUsed"] = serde_json::json!(["KHR_texture_basisu"]);
        if required {
            v["textures"][0].as_object_mut().unwrap().remove("source");
            v["extensionsRequired"] = serde_json::json!(["KHR_texture_basisu"]);
        }
        let gltf = dir.path().join("box.gltf");
        std::fs::write(&gltf, serde_json::to_vec(&v).unwrap()).unwrap();
        let pack = dir.path().join("box.pack");
        cook_obj(&gltf, &pack, &["--texture-format", "rgba8"]);
        let name = only_texture(&pack);
        let level0 = extract(&pack, &name, 0, dir.path());
        if required {
            let template = "gltf/TextureCoordinateTest/TextureCoordinateTemplate.png";
            let template = image::open(data(template)).unwrap().to_rgba8();
            assert_eq!(level0.dimensions(), template.dimensions());
            let e = rms(&level0, &template);
            assert!(e > 0.0 && e < 0.5, "RMS {e} against the template");
            assert_eq!(sha256_hex(&level0), reference_texels("template_uastc.ktx2"));
        } else {
            let png = image::open(src.join("CesiumLogoFlat.png")).unwrap();
            assert!(level0 == png.to_rgba8(), "level 0 is not the PNG's texels");
        }
    }
}

/// An OBJ material's `map_Kd` may name a `.ktx2` (ETC1S or UASTC); both cook to the reference
/// transcoder's texels, close to the template they encode (measured RMS 0.97 / 0.22).
#[test]
fn obj_materials_read_basis_ktx2_files() {
    let dir = tempfile::tempdir().unwrap();
    let obj = obj_scene(
        dir.path(),
        &["ktx2/template_etc1s.ktx2", "ktx2/template_uastc.ktx2"],
    );
    let pack = dir.path().join("q.pack");
    cook_obj(&obj, &pack, &["--texture-format", "rgba8"]);
    let template = "gltf/TextureCoordinateTest/TextureCoordinateTemplate.png";
    let template = image::open(data(template)).unwrap().to_rgba8();
    for (name, max_rms) in [("template_etc1s", 1.5), ("template_uastc", 0.5)] {
        let (w, h, mips) = texture_info(&pack, name);
        assert_eq!((w as u32, h as u32, mips), (512, 512, 10));
        let level0 = extract(&pack, name, 0, dir.path());
        assert_eq!(
            sha256_hex(&level0),
            reference_texels(&format!("{name}.ktx2"))
        );
        let e = rms(&level0, &template);
        assert!(e > 0.0 && e <= max_rms, "{name}: RMS {e}");
    }
}

/// A KTX2 without a Basis payload, a truncated one, and 60 with bytes damaged: each cooks
/// (damage a decoder cannot see is still texels) or exits 3 naming the file, with no pack;
/// never a panic or an abort.
#[test]
fn damaged_or_foreign_ktx2_files_exit_3_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let run = |bytes: &[u8]| {
        std::fs::write(dir.path().join("template_uastc.ktx2"), bytes).unwrap();
        let pack = dir.path().join("q.pack");
        let _ = std::fs::remove_file(&pack);
        let obj = dir.path().join("scene.obj");
        let o = cooker(&[&"cook", &obj, &"-o", &pack, &"--no-cache"]);
        (o.status.code(), text(&o.stderr), pack.exists())
    };
    obj_scene(dir.path(), &["ktx2/template_uastc.ktx2"]);
    let good = std::fs::read(data("ktx2/template_uastc.ktx2")).unwrap();
    let raw = std::fs::read(data("ktx2/raw_rgba8.ktx2")).unwrap();
    let (code, err, packed) = run(&raw);
    assert_eq!(code, Some(3), "{err}");
    assert!(err.contains("template_uastc.ktx2") && err.contains("Vulkan format 43"));
    assert!(!packed);
    let (code, err, packed) = run(&good[..good.len() / 2]);
    assert_eq!(code, Some(3), "{err}");
    assert!(err.contains("template_uastc.ktx2") && !packed, "{err}");
    let mut rng = texture::testing::Rng(0x2545_f491_4f6c_dd1d);
    let mut next = move || rng.next_u64();
    let mut refused = 0;
    for _ in 0..60 {
        let mut bytes = good.clone();
        for _ in 0..1 + next() % 4 {
            let at = next() as usize % bytes.len();
            bytes[at] ^= 1 << (next() % 8);
        }
        match run(&bytes) {
            (Some(0), _, true) => {}
            (Some(3), err, false) if err.contains("template_uastc.ktx2") => refused += 1,
            other => panic!("damaged KTX2: {other:?}"),
        }
    }
    assert!(refused > 0, "no damage was seen in 60 files");
}

/// Older exporters write bump maps as grey heights under `map_Bump` (the Crytek bricks, turned
/// grey, here). They are read as heights: level 0 of the cooked normal map is the central
/// difference of the heights, recomputed here, the full grey range spanning 1/256 of the
/// longer side times `-bm` in depth; `-bm` on the colour map is named as not applied. Read as
/// vectors, as before, every grey texel pointed along (1, 1, 1).
#[test]
fn grey_bump_maps_are_read_as_heights_scaled_by_bm() {
    let dir = tempfile::tempdir().unwrap();
    let grey = image::open(data(TGA)).unwrap().to_luma8();
    grey.save(dir.path().join("bump.png")).unwrap();
    std::fs::copy(data(TGA), dir.path().join("bricks.tga")).unwrap();
    let obj = "mtllib w.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 -1\nv 0 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\n\
               vt 0 1\nvn 0 1 0\nusemtl floor\nf 1/1/1 2/2/1 3/3/1 4/4/1\n";
    std::fs::write(dir.path().join("w.obj"), obj).unwrap();
    let (w, h) = (grey.width() as usize, grey.height() as usize);
    let mut tilts = Vec::new();
    // The crop is an eighth of the 1024² original, so -bm 8 gives it the original's depth.
    for bm in [2.0f32, 8.0] {
        let mtl = format!(
            "newmtl floor\nKd 1 1 1\nmap_Kd -bm 2 bricks.tga\nmap_Bump -bm {bm} bump.png\n"
        );
        std::fs::write(dir.path().join("w.mtl"), mtl).unwrap();
        let pack = dir.path().join(format!("w{bm}.pack"));
        let obj = dir.path().join("w.obj");
        let (_, err) = cook_obj(&obj, &pack, &["--texture-format", "rgba8"]);
        assert!(err.contains("read as a height (bump) map"), "{err}");
        assert!(err.contains("options -bm not applied"), "{err}");
        let normals = extract(&pack, "bump.normal", 0, dir.path());
        assert_eq!(normals.dimensions(), grey.dimensions());
        let depth = bm * w.max(h) as f32 / 256.0;
        let height = |x: usize, y: usize| grey.get_pixel(x as u32, y as u32)[0] as f32 / 255.0;
        let (mut worst, mut tilt) = (0.0f32, 0.0f64);
        for y in 0..h {
            for x in 0..w {
                let (x0, x1) = (x.saturating_sub(1), (x + 1).min(w - 1));
                let (y0, y1) = (y.saturating_sub(1), (y + 1).min(h - 1));
                let dx = (height(x1, y) - height(x0, y)) / (x1 - x0) as f32 * depth;
                let dy = (height(x, y1) - height(x, y0)) / (y1 - y0) as f32 * depth;
                // +v runs up the image, rows run down it.
                let n = [-dx, dy, 1.0];
                let l = (n[0] * n[0] + n[1] * n[1] + 1.0).sqrt();
                let got = normals.get_pixel(x as u32, y as u32);
                for c in 0..3 {
                    let want = (n[c] / l * 0.5 + 0.5) * 255.0;
                    worst = worst.max((got[c] as f32 - want).abs());
                }
                tilt += 1.0 - (got[2] as f64 / 255.0 * 2.0 - 1.0);
            }
        }
        assert!(worst <= 0.51, "-bm {bm}: level 0 off by {worst} LSB");
        tilts.push(tilt / (w * h) as f64);
    }
    // The bricks' mortar tilts the surface, more at -bm 8.
    assert!(
        tilts[0] > 0.0 && tilts[1] > 0.01 && tilts[1] > 2.0 * tilts[0],
        "{tilts:?}"
    );
}

/// A two-channel normal map saved as grey with alpha, declared `normal_encoding = "rg"`, holds
/// x in its grey and y in its alpha. The cook turned it into RGBA8 first, so it was read as a
/// grey height map and stored flat (128, 128, 255), said only in a note.
#[test]
fn a_grey_and_alpha_normal_map_declared_rg_keeps_its_vectors() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = common::small_scene(dir.path());
    let toml = std::fs::read_to_string(&manifest).unwrap().replace(
        "design = \"lit.png\"",
        "design = \"lit.png\"\nnormal_map = \"up.png\"\nnormal_encoding = \"rg\"",
    );
    std::fs::write(&manifest, toml).unwrap();
    image::GrayAlphaImage::from_pixel(16, 16, image::LumaA([128, 191]))
        .save(dir.path().join("up.png"))
        .unwrap();
    let pack = dir.path().join("s.pack");
    let (_, err) = cook_obj(&manifest, &pack, &["--texture-format", "rgba8"]);
    assert!(!err.contains("height (bump) map"), "{err}");
    let normals = extract(&pack, "up.normal", 0, dir.path());
    // x = 0.004, y = 0.498: z = 0.867, stored 239 (or 238 rounded the other way).
    let p = normals.get_pixel(8, 8).0;
    assert!(
        p[0].abs_diff(128) <= 1 && p[1].abs_diff(191) <= 1 && p[2].abs_diff(238) <= 1,
        "stored {p:?}, want about (128, 191, 238)"
    );

    // `--window` replaces the entry's design and keeps its normal map: the whole entry was
    // dropped, and the window got a normal map derived from the new design.
    common::design(&dir.path().join("other.png"), 30);
    let other = dir.path().join("o.pack");
    let arg = format!("lit={}", dir.path().join("other.png").display());
    let o = cooker(&[
        &"cook",
        &manifest,
        &"-o",
        &other,
        &"--no-cache",
        &"--texture-format",
        &"rgba8",
        &"--window",
        &arg,
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    texture_info(&other, "other");
    assert_eq!(extract(&other, "up.normal", 0, dir.path()), normals);

    // Two for one window: the later wins (the first did, and the later was dropped without a
    // word), and the one left with no window is named in a warning.
    common::design(&dir.path().join("third.png"), 60);
    let later = format!("l*={}", dir.path().join("third.png").display());
    let twice = dir.path().join("t.pack");
    let o = cooker(&[
        &"cook",
        &manifest,
        &"-o",
        &twice,
        &"--no-cache",
        &"--window",
        &arg,
        &"--window",
        &later,
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    texture_info(&twice, "third");
    let info = text(&cooker(&[&"info", &twice]).stdout);
    assert!(!info.contains("other"), "{info}");
    let err = text(&o.stderr);
    assert!(
        err.contains(&format!(
            "warning: {}: --window {arg}: a later --window gives every window it matches another \
             design, so it is not used",
            manifest.display()
        )),
        "{err}"
    );

    // An image that cannot be decoded is said as the option that gave it: the scene names
    // no such file, and a bare path left the user to guess which argument it was.
    let bytes = std::fs::read(dir.path().join("third.png")).unwrap();
    let cut = dir.path().join("cut.png");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let arg = format!("lit={}", cut.display());
    let o = cooker(&[
        &"cook",
        &manifest,
        &"-o",
        &twice,
        &"--no-cache",
        &"--window",
        &arg,
    ]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains(&format!("error: --window {arg}: {}: ", cut.display())),
        "{err}"
    );
}

/// A vector normal map's strength (MTL `-bm`, glTF `normalTexture.scale`) scales x and y
/// before renormalizing, as glTF defines it; both imports give the same texture. The map is
/// the one the cooker derives from the grey Crytek bricks, so it has real slopes.
#[test]
fn normal_map_strength_scales_the_tilt_alike_in_obj_and_gltf() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    image::open(data(TGA))
        .unwrap()
        .to_luma8()
        .save(d.join("bump.png"))
        .unwrap();
    let quad = "mtllib w.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 -1\nv 0 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\n\
                vt 0 1\nvn 0 1 0\nusemtl floor\nf 1/1/1 2/2/1 3/3/1 4/4/1\n";
    std::fs::write(d.join("w.obj"), quad).unwrap();
    let cook_bump = |statement: &str, pack: &str| {
        std::fs::write(
            d.join("w.mtl"),
            format!("newmtl floor\nKd 1 1 1\nmap_Bump {statement}\n"),
        )
        .unwrap();
        cook_obj(
            &d.join("w.obj"),
            &d.join(pack),
            &["--texture-format", "rgba8"],
        );
        d.join(pack)
    };
    let bumped = cook_bump("-bm 8 bump.png", "bump.pack");
    let nrm = extract(&bumped, "bump.normal", 0, d);
    nrm.save(d.join("nrm.png")).unwrap();

    let half = extract(
        &cook_bump("-bm 0.5 nrm.png", "half.pack"),
        "nrm.normal",
        0,
        d,
    );
    let mut worst = 0.0f32;
    for (src, got) in nrm.pixels().zip(half.pixels()) {
        let v = |c: usize| src[c] as f32 / 255.0 * 2.0 - 1.0;
        let n = [v(0) * 0.5, v(1) * 0.5, v(2)];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        for c in 0..3 {
            worst = worst.max((got[c] as f32 - (n[c] / l * 0.5 + 0.5) * 255.0).abs());
        }
    }
    assert!(worst <= 0.51, "scaled level 0 off by {worst} LSB");
    assert!(half != nrm, "-bm 0.5 changed nothing");

    // glTF: BoxTextured with the map as its normal texture at scale 0.5.
    let src = data("gltf/BoxTextured");
    for f in ["BoxTextured0.bin", "CesiumLogoFlat.png"] {
        std::fs::copy(src.join(f), d.join(f)).unwrap();
    }
    let mut v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(src.join("BoxTextured.gltf")).unwrap()).unwrap();
    v["images"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"uri": "nrm.png"}));
    v["textures"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({"source": 1}));
    v["materials"][0]["normalTexture"] = serde_json::json!({"index": 1, "scale": 0.5});
    std::fs::write(d.join("box.gltf"), serde_json::to_vec(&v).unwrap()).unwrap();
    let pack = d.join("box.pack");
    let (_, err) = cook_obj(&d.join("box.gltf"), &pack, &["--texture-format", "rgba8"]);
    assert!(
        extract(&pack, "nrm.normal", 0, d) == half,
        "glTF's scale 0.5 differs"
    );
    assert!(!err.contains("its normal map"), "{err}");
    // A normal map placed otherwise than the base colour is sampled with the base colour's
    // coordinates, and the cook says so.
    for (key, value, says) in [
        (
            "texCoord",
            serde_json::json!(1),
            "reads TEXCOORD_1, its base colour TEXCOORD_0",
        ),
        (
            "extensions",
            serde_json::json!({"KHR_texture_transform": {"scale": [2.0, 2.0]}}),
            "has another KHR_texture_transform",
        ),
    ] {
        let mut v = v.clone();
        v["materials"][0]["normalTexture"][key] = value;
        std::fs::write(d.join("box.gltf"), serde_json::to_vec(&v).unwrap()).unwrap();
        let (_, err) = cook_obj(&d.join("box.gltf"), &pack, &["--texture-format", "rgba8"]);
        assert!(err.contains(says), "{key}: {err}");
    }
}

/// `dds/REFERENCE`'s SHA-256 of `file`'s level 0 as Pillow decodes it to RGBA8.
fn dds_reference(file: &str) -> String {
    let list = std::fs::read_to_string(data("dds/REFERENCE")).unwrap();
    let line = list.lines().find(|l| l.split(' ').next() == Some(file));
    let line = line.unwrap_or_else(|| panic!("no reference for {file}"));
    line.rsplit(' ').next().unwrap().to_string()
}

/// DDS files as an OBJ's `map_Kd` (Pillow wrote them from the Crytek bricks, the bricks with
/// the texture template's corner as alpha, and the CPython JPEG): DXT1, DXT3, DXT5, BC3 and
/// BC5 behind a DX10 header (typeless, as Pillow and DirectXTex write them), plain RGBA and
/// RGB. Level 0 holds the texels Pillow's decoder gives, a second implementation of the same
/// formats: exactly for plain ones, within 1 LSB for blocks (decoders round the interpolated
/// colours each their own way; measured 1).
#[test]
fn dds_textures_cook_to_the_texels_another_decoder_gives() {
    let files = [
        "bricks_dxt1.dds",
        "glass_dxt3.dds",
        "glass_dxt5.dds",
        "glass_bc3_dx10.dds",
        "bricks_bc5_dx10.dds",
        "glass_rgba.dds",
        "python_rgb.dds",
    ];
    let dir = tempfile::tempdir().unwrap();
    let rel: Vec<String> = files.iter().map(|f| format!("dds/{f}")).collect();
    let rel: Vec<&str> = rel.iter().map(String::as_str).collect();
    let obj = obj_scene(dir.path(), &rel);
    let pack = dir.path().join("dds.pack");
    cook_obj(&obj, &pack, &["--texture-format", "rgba8"]);
    let mut wrong = Vec::new();
    for f in files {
        let name = f.trim_end_matches(".dds");
        let level0 = extract(&pack, name, 0, dir.path());
        let pillow = data(&format!("dds/{name}.pillow.png"));
        if !pillow.exists() {
            if sha256_hex(&level0) != dds_reference(f) {
                wrong.push(format!("{f}: not Pillow's texels"));
            }
            continue;
        }
        let pillow = image::open(pillow).unwrap().to_rgba8();
        let worst = level0
            .as_raw()
            .iter()
            .zip(pillow.as_raw())
            .map(|(&a, &b)| a.abs_diff(b))
            .max();
        if worst != Some(0) && worst != Some(1) {
            wrong.push(format!("{f}: {worst:?} LSB from Pillow's"));
        }
    }
    assert!(wrong.is_empty(), "{wrong:?}");
}

/// BoxTextured whose texture names a DDS (the DXT1 bricks) through `MSFT_texture_dds`, required
/// and without a PNG: level 0 is the DDS's. A DDS cut short, one marked a cube map and one
/// that is no DDS past its magic exit 3 naming the file, with no pack.
#[test]
fn gltf_reads_dds_through_msft_texture_dds_and_refuses_damaged_ones() {
    let src = data("gltf/BoxTextured");
    let good = std::fs::read(data("dds/bricks_dxt1.dds")).unwrap();
    let mut cube = good.clone();
    cube[113] |= 0x02; // caps2 (byte 112) |= DDSCAPS2_CUBEMAP (0x200)
    let mut cases: Vec<(Vec<u8>, &str)> = vec![(good.clone(), "")];
    cases.push((good[..good.len() / 2].to_vec(), "level 0"));
    cases.push((cube, "cube map"));
    cases.push((b"DDS not really".to_vec(), "header"));
    for (bytes, refusal) in cases {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::copy(src.join("BoxTextured0.bin"), d.join("BoxTextured0.bin")).unwrap();
        std::fs::write(d.join("bricks.dds"), &bytes).unwrap();
        let mut v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(src.join("BoxTextured.gltf")).unwrap()).unwrap();
        v["images"] = serde_json::json!([{"uri": "bricks.dds", "mimeType": "image/vnd-ms.dds"}]);
        v["textures"] = serde_json::json!([{"sampler": 0,
            "extensions": {"MSFT_texture_dds": {"source": 0}}}]);
        v["extensionsUsed"] = serde_json::json!(["MSFT_texture_dds"]);
        v["extensionsRequired"] = serde_json::json!(["MSFT_texture_dds"]);
        std::fs::write(d.join("box.gltf"), serde_json::to_vec(&v).unwrap()).unwrap();
        let pack = d.join("box.pack");
        if refusal.is_empty() {
            cook_obj(&d.join("box.gltf"), &pack, &["--texture-format", "rgba8"]);
            let name = only_texture(&pack);
            let level0 = extract(&pack, &name, 0, d);
            let pillow = image::open(data("dds/bricks_dxt1.pillow.png")).unwrap();
            let pillow = pillow.to_rgba8();
            assert_eq!(level0.dimensions(), pillow.dimensions());
            let worst = level0.as_raw().iter().zip(pillow.as_raw());
            assert!(worst.map(|(&a, &b)| a.abs_diff(b)).max() <= Some(1));
        } else {
            let o = cooker(&[&"cook", &d.join("box.gltf"), &"-o", &pack, &"--no-cache"]);
            let err = text(&o.stderr);
            assert_eq!(o.status.code(), Some(3), "{refusal}: {err}");
            assert!(err.contains("bricks.dds") && err.contains(refusal), "{err}");
            assert!(!pack.exists());
        }
    }
}

/// `--max-texture-size` from the command line: Crytek's 128² bricks under a cap of 32 are
/// stored from their level 2, the very texels of the whole cook's level 2, and the cook says
/// so; `diff` of the two packs names the size change, sees that the capped chain is the whole
/// one's from level 2 on, and compares those levels (equal at level 2, within a rounding step
/// below). A cap of 0 is bad usage.
#[test]
fn a_size_cap_stores_a_smaller_level_and_diff_compares_what_is_shared() {
    let dir = tempfile::tempdir().unwrap();
    let obj = obj_scene(dir.path(), &[TGA]);
    let cook = |name: &str, extra: &[&str]| cook_obj(&obj, &dir.path().join(name), extra);
    let (whole, _) = cook("whole.pack", &["--texture-format", "rgba8"]);
    let (capped, log) = cook(
        "capped.pack",
        &["--texture-format", "rgba8", "--max-texture-size", "32"],
    );
    assert!(
        log.contains("128x128 is over the size cap of 32: cooked from its mip level 2, 32x32"),
        "{log}"
    );
    let name = "spnza_bricks_a_diff.crop128";
    assert_eq!(texture_info(&capped, name), (32, 32, 6));
    assert_eq!(
        extract(&capped, name, 0, dir.path()),
        extract(&whole, name, 2, dir.path())
    );

    let d = cooker(&[&"diff", &whole, &capped, &"--json"]);
    assert_eq!(d.status.code(), Some(1), "{}", text(&d.stdout));
    let v: serde_json::Value = serde_json::from_slice(&d.stdout).unwrap();
    let problems = v["problems"].to_string();
    assert!(
        problems.contains("128x128 with 8 mips in a")
            && problems.contains("b's levels are a's from level 2 on"),
        "{problems}"
    );
    let levels = v["textures"][0]["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 6, "{levels:?}");
    // Level 2 is the same; those below it are mipped again from its 8-bit texels.
    assert_eq!(
        (&levels[0]["level"], &levels[0]["max_error"]),
        (&2.into(), &0.into())
    );
    assert!(
        levels.iter().all(|l| l["max_error"].as_u64() <= Some(1)),
        "{levels:?}"
    );

    let o = cooker(&[
        &"cook",
        &obj,
        &"-o",
        &dir.path().join("x.pack"),
        &"--max-texture-size",
        &"0",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(!dir.path().join("x.pack").exists());
}

/// The cap holds for every texture, a projector's light margin included: the default scene's
/// rose projector was stored 269x269 under a cap of 256 (its design part within it).
#[test]
fn a_size_cap_bounds_projectors_with_their_margin() {
    let dir = tempfile::tempdir().unwrap();
    let pack = dir.path().join("capped.pack");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets-src/scene.toml");
    cook_obj(&scene, &pack, &["--max-texture-size", "256"]);
    let o = cooker(&[&"info", &pack, &"--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let textures = v["textures"].as_array().unwrap();
    assert!(textures.iter().any(|t| t["role"] == "projector"), "{v:#}");
    for t in textures {
        let side = t["width"]
            .as_u64()
            .unwrap()
            .max(t["height"].as_u64().unwrap());
        assert!(side <= 256, "{}: {side}", t["name"]);
    }
}

/// A design over the cap is reduced to its level within the cap before it is masked to its
/// windows, once for all of them: the pack is the one cooked from that level given as the
/// design, every texture made from it the same texels, and the cook says so once. (Masking
/// the whole of an 8000x6000 photo for each window took 3.2 GB where the cap kept 2000x1500.)
#[test]
fn a_design_over_the_cap_is_masked_from_its_level_within_the_cap() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let big = image::RgbaImage::from_fn(600, 400, |x, y| {
        image::Rgba([
            (x * 255 / 599) as u8,
            (y * 255 / 399) as u8,
            if (x / 7 + y / 5) % 2 == 0 { 40 } else { 220 },
            255,
        ])
    });
    big.save(d.join("big.png")).unwrap();
    let opts = texture::ColourOptions {
        srgb: true,
        filter: texture::MipFilter::Box,
    };
    let (k, level) = texture::first_level_within(&image::DynamicImage::ImageRgba8(big), 128, &opts)
        .unwrap()
        .unwrap();
    assert_eq!((k, level.width(), level.height()), (3, 75, 50));
    level.save(d.join("small.png")).unwrap();

    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets-src/scene.toml");
    let cook = |design: &str| {
        let window = format!("*={}", d.join(design).display());
        cook_obj(
            &scene,
            &d.join(design).with_extension("pack"),
            &[
                "--max-texture-size",
                "128",
                "--texture-format",
                "rgba8",
                "--window",
                &window,
            ],
        )
    };
    let (from_big, log) = cook("big.png");
    let (from_small, _) = cook("small.png");
    let said = "600x400 is over the size cap of 128: its windows' designs are made from its mip \
                level 3, 75x50";
    assert_eq!(log.matches(said).count(), 1, "{log}");

    let names = |pack: &Path, stem: &str| -> Vec<String> {
        let o = cooker(&[&"info", &pack, &"--json"]);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["textures"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|t| t["name"].as_str())
            .filter_map(|n| n.strip_prefix(stem).map(str::to_string))
            .collect()
    };
    let made = names(&from_big, "big.");
    assert!(made.iter().any(|n| n.starts_with("masked")), "{made:?}");
    assert_eq!(made, names(&from_small, "small."));
    for n in &made {
        assert_eq!(
            extract(&from_big, &format!("big.{n}"), 0, d),
            extract(&from_small, &format!("small.{n}"), 0, d),
            "{n}"
        );
    }
}

/// A design that covers its window's glass whole is used as it is, not masked: under a cap
/// the texture stage reduces it (and says so), and its projector's blur is sized by the
/// image it reads. The window stage had handed on its level's size with the image itself,
/// and the blur came out 16 times too narrow at a cap of 128.
#[test]
fn an_unmasked_design_over_the_cap_keeps_its_projector_blur() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::small_scene(dir.path());
    image::RgbaImage::from_fn(600, 400, |x, y| {
        image::Rgba([(x % 256) as u8, (y % 256) as u8, ((x ^ y) % 256) as u8, 255])
    })
    .save(dir.path().join("lit.png"))
    .unwrap();
    let sigma = |log: &str| {
        let at = log
            .find("lit.projector: sigma ")
            .unwrap_or_else(|| panic!("no projector note in {log}"));
        log[at..].split(" texels").next().unwrap().to_string()
    };
    let (_, whole) = cook_obj(&scene, &dir.path().join("whole.pack"), &[]);
    let (capped, log) = cook_obj(
        &scene,
        &dir.path().join("capped.pack"),
        &["--max-texture-size", "128"],
    );
    assert_eq!(sigma(&log), sigma(&whole));
    assert!(
        log.contains("lit: 600x400 is over the size cap of 128: cooked from its mip level 3"),
        "{log}"
    );
    assert!(!log.contains("its windows' designs are made"), "{log}");
    assert_eq!(texture_info(&capped, "lit"), (75, 50, 7));
}

/// Glass whose texture coordinates reach past the texture's square, tiled 2 x 2 or given in
/// metres as SketchUp writes them: its design is drawn as the glass shows it onto planar
/// coordinates, so the light falls where the glass is. A projector covers the square only:
/// the light fell on a quarter of the tiled window's patch, and the metre-mapped window's
/// came from a phantom window in the wall where the square lay, with `info` giving sizes of
/// 1 x 1.5 and 1 x 1 for a 2 x 3 window.
#[test]
fn glass_mapped_past_the_texture_square_throws_its_design_where_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Left half red, right half blue: two tiles across the glass are four bands.
    image::RgbaImage::from_fn(8, 8, |x, _| {
        if x < 4 {
            image::Rgba([220, 30, 30, 255])
        } else {
            image::Rgba([30, 30, 220, 255])
        }
    })
    .save(d.join("halves.png"))
    .unwrap();
    std::fs::write(
        d.join("w.mtl"),
        "newmtl floor\nKd 0.6 0.6 0.6\nnewmtl Glass\nKd 1 1 1\nd 0.5\nmap_Kd halves.png\n",
    )
    .unwrap();
    // A 2 x 3 m pane in the plane z = 0, over a floor in front of it; `u0` and `v0` shift its
    // coordinates by whole tiles.
    let scene = |name: &str, u0: f32, v0: f32| {
        let obj = format!(
            "mtllib w.mtl\nv -4 0 -6\nv 6 0 -6\nv 6 0 6\nv -4 0 6\nv 0 1 0\nv 2 1 0\nv 2 4 0\n\
             v 0 4 0\nvt {} {}\nvt {} {}\nvt {} {}\nvt {} {}\nusemtl floor\nf 1 4 3 2\n\
             usemtl Glass\nf 5/1 6/2 7/3 8/4\n",
            u0,
            v0,
            u0 + 2.0,
            v0,
            u0 + 2.0,
            v0 + 3.0,
            u0,
            v0 + 3.0
        );
        let path = d.join(format!("{name}.obj"));
        std::fs::write(&path, obj).unwrap();
        path
    };
    let mut bands = Vec::new();
    for (name, u0, v0) in [("tiled", 0.0, 0.0), ("metres", 5.0, 1.5)] {
        let obj = scene(name, u0, v0);
        let pack = d.join(format!("{name}.pack"));
        let (_, said) = cook_obj(&obj, &pack, &["--texture-format", "rgba8"]);
        assert!(
            said.contains("past the texture's square") && said.contains("window \"Glass\""),
            "{said}"
        );
        // The span as the `vt` lines write it (v runs up in an OBJ; it is held flipped).
        let span = format!(
            "span [{u0:.3}, {:.3}] x [{v0:.3}, {:.3}]",
            u0 + 2.0,
            v0 + 3.0
        );
        assert!(said.contains(&span), "{span}: {said}");
        let o = cooker(&[&"info", &pack, &"--json"]);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let w = &v["windows"][0];
        assert_eq!(
            (w["width"].as_f64(), w["height"].as_f64()),
            (Some(2.0), Some(3.0)),
            "{w}"
        );
        assert_eq!(w["design"], "halves.tiled", "{w}");
        let (tw, th, _) = texture_info(&pack, "halves.tiled");
        assert!(
            tw * 3 == th * 2 || (tw * 3).abs_diff(th * 2) <= 3,
            "{tw}x{th}"
        );
        let img = extract(&pack, "halves.tiled", 0, d);
        // Across the middle row: red, blue, red, blue, a quarter of the width each.
        let y = img.height() / 2;
        let seen: Vec<char> = (0..4)
            .map(|q| {
                let p = img.get_pixel((2 * q + 1) * img.width() / 8, y);
                assert_eq!(p[3], 255, "{p:?}");
                if p[0] > 150 && p[2] < 80 {
                    'r'
                } else if p[2] > 150 && p[0] < 80 {
                    'b'
                } else {
                    '?'
                }
            })
            .collect();
        bands.push(seen);
    }
    // Two tiles across, whichever way the planar coordinates run; metres 5..7 are two whole
    // tiles too, starting on a tile's edge: the same design.
    assert!(
        bands[0] == ['r', 'b', 'r', 'b'] || bands[0] == ['b', 'r', 'b', 'r'],
        "{bands:?}"
    );
    assert_eq!(bands[1], bands[0]);
}

/// A design of a single texel (one colour for the whole window) on a triangular pane, its
/// texture coordinates half the square: the light keeps to the triangle. At its own size the
/// one texel was covered, so nothing was masked and the square's other half threw light
/// through stone.
#[test]
fn a_one_texel_design_is_masked_to_its_window() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    image::RgbaImage::from_pixel(1, 1, image::Rgba([200, 150, 40, 255]))
        .save(d.join("one.png"))
        .unwrap();
    std::fs::write(
        d.join("w.mtl"),
        "newmtl floor\nKd 0.6 0.6 0.6\nnewmtl Glass\nKd 1 1 1\nd 0.5\nmap_Kd one.png\n",
    )
    .unwrap();
    let obj = d.join("w.obj");
    std::fs::write(
        &obj,
        "mtllib w.mtl\nv -4 0 -6\nv 6 0 -6\nv 6 0 6\nv -4 0 6\nv 0 1 0\nv 2 1 0\nv 0 4 0\n\
         vt 0 0\nvt 1 0\nvt 0 1\nusemtl floor\nf 1 4 3 2\nusemtl Glass\nf 5/1 6/2 7/3\n",
    )
    .unwrap();
    let pack = d.join("one.pack");
    cook_obj(&obj, &pack, &["--texture-format", "rgba8"]);
    let (w, h, _) = texture_info(&pack, "one.masked");
    assert!(w >= 32 && h >= 32, "{w}x{h}");
    let img = extract(&pack, "one.masked", 0, d);
    let (w, h) = img.dimensions();
    // The covered corner keeps the colour; the far corner of the square is cleared (v runs
    // down the image, so the pane's corner at vt 0 1 is a bottom corner).
    let lit = img
        .pixels()
        .filter(|p| p[3] == 255 && p[0] == 200 && p[1] == 150)
        .count();
    let clear = img.pixels().filter(|p| p[3] == 0).count();
    let n = (w * h) as usize;
    assert!(
        lit * 10 > n * 4 && clear * 10 > n * 4,
        "{lit} lit, {clear} clear of {n}"
    );
}

/// A design cut to its window's outline is an image the cook makes, not the file the manifest
/// names: its notes lost the manifest's line. They point at the window's `[[window]]` entry;
/// a `--window` image's notes at the image, not at the manifest, which does not name it.
#[test]
fn notes_on_a_cut_design_point_at_its_window_entry_or_its_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene");
    common::copy_dir(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets-src"),
        &scene,
    );
    let manifest = scene.join("scene.toml");
    let lines: Vec<String> = std::fs::read_to_string(&manifest)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    let o = cooker(&[
        &"cook",
        &manifest,
        &"-o",
        &dir.path().join("a.pack"),
        &"--no-cache",
        &"-v",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let said = text(&o.stderr);
    let at = format!("note: {}:", manifest.display());
    let note = said
        .lines()
        .find(|l| l.contains(": lancet.masked.projector: "))
        .unwrap_or_else(|| panic!("{said}"));
    let line: usize = note
        .strip_prefix(&at)
        .and_then(|rest| rest.split(':').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no manifest line: {note}"));
    assert!(
        lines[line - 1..(line + 2).min(lines.len())]
            .iter()
            .any(|l| l.contains("windows/lancet.png")),
        "line {line} is not the lancet's entry: {note}"
    );
    let image = scene.join("windows/rose.png");
    let o = cooker(&[
        &"cook",
        &manifest,
        &"-o",
        &dir.path().join("b.pack"),
        &"--no-cache",
        &"-v",
        &"--window",
        &format!("window_lower_1={}", image.display()),
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let said = text(&o.stderr);
    assert!(
        said.lines()
            .any(|l| l.starts_with(&format!("note: {}: rose.masked", image.display()))),
        "{said}"
    );
}

/// `normal_strength` in a manifest: on a `[[rule]]` it replaces the source's `-bm` (the grey
/// bricks under `-bm 8`, given 2, cook as `-bm 2` does); on a `[[window]]` it scales the relief
/// derived from the design: 0 is flat glass, -1 mirrors the tilt of 1.
#[test]
fn a_manifest_s_normal_strength_replaces_bm_and_scales_a_window_s_relief() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let bricks = image::open(data(TGA)).unwrap();
    bricks.to_luma8().save(d.join("bump.png")).unwrap();
    bricks.to_rgba8().save(d.join("design.png")).unwrap();
    let obj = d.join("w.obj");
    std::fs::write(
        &obj,
        "mtllib w.mtl\nv -4 0 -6\nv 6 0 -6\nv 6 0 6\nv -4 0 6\nv 0 1 0\nv 2 1 0\nv 2 3 0\n\
         v 0 3 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 1 0\nusemtl floor\n\
         f 1/1/1 4/4/1 3/3/1 2/2/1\nusemtl Glass\nf 5/1 6/2 7/3 8/4\n",
    )
    .unwrap();
    let mtl = |bm: &str| {
        std::fs::write(
            d.join("w.mtl"),
            format!(
                "newmtl floor\nKd 0.6 0.6 0.6\nmap_Bump -bm {bm} bump.png\nnewmtl Glass\nKd 1 1 1\n\
                 d 0.5\nmap_Kd design.png\n"
            ),
        )
        .unwrap();
    };
    let derived = |pack: &Path| -> image::RgbaImage {
        let name = texture_where(pack, |t| {
            t["name"].as_str().unwrap().ends_with(".derived-normal")
        });
        extract(pack, &name, 0, d)
    };

    mtl("2");
    let by_bm = cook_obj(&obj, &d.join("bm.pack"), &["--texture-format", "rgba8"]).0;
    let one = derived(&by_bm);
    mtl("8");
    let cook_with = |strength: &str, pack: &str| {
        std::fs::write(
            d.join("scene.toml"),
            format!(
                "[[mesh]]\nsource = \"w.obj\"\n\n[[rule]]\nmatch = \"floor\"\nclass = \"floor\"\n\
                 normal_strength = 2\n\n[[window]]\nmaterial = \"Glass\"\n\
                 normal_strength = {strength}\n"
            ),
        )
        .unwrap();
        cook_obj(
            &d.join("scene.toml"),
            &d.join(pack),
            &["--texture-format", "rgba8"],
        )
        .0
    };
    let flat = cook_with("0", "flat.pack");
    assert!(
        extract(&flat, "bump.normal", 0, d) == extract(&by_bm, "bump.normal", 0, d),
        "the rule's normal_strength 2 over -bm 8 differs from -bm 2"
    );
    let zero = derived(&flat);
    assert!(
        zero.pixels().all(|p| p[0] == zero.get_pixel(0, 0)[0]
            && p[1] == zero.get_pixel(0, 0)[1]
            && p[2] == 255),
        "strength 0 is not flat glass"
    );
    assert!(cook_with("1", "one.pack").exists());
    assert!(
        derived(&d.join("one.pack")) == one,
        "strength 1 is not the default"
    );
    let minus = derived(&cook_with("-1", "minus.pack"));
    let mut worst = 0i32;
    let mut tilted = 0;
    for (a, b) in one.pixels().zip(minus.pixels()) {
        for c in 0..2 {
            worst = worst.max((a[c] as i32 + b[c] as i32 - 255).abs());
        }
        worst = worst.max((a[2] as i32 - b[2] as i32).abs());
        tilted += usize::from(a[2] < 250);
    }
    assert!(
        worst <= 1,
        "strength -1 is not the mirror of 1: off by {worst}"
    );
    assert!(
        tilted > 100,
        "the derived relief is nearly flat: {tilted} texels tilted"
    );
}

/// A design that embeds a colour profile is converted to sRGB, as an image viewer shows it, and
/// the cook says so on every cook, cached or not; the same file as a model's own texture keeps
/// its bytes (glTF requires profiles to be ignored; an MTL's maps are read alike). The profile
/// is Apple's "Generic RGB Profile" (gamma 1.8), taken from Cesium's logo in
/// glTF-Sample-Models, on a mid grey: 128 there is 147 in sRGB.
#[test]
fn a_design_s_colour_profile_is_applied_and_a_model_s_texture_s_is_not() {
    use image::ImageDecoder;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let logo = std::fs::File::open(data("gltf/BoxTextured/CesiumLogoFlat.png")).unwrap();
    let mut decoder = image::codecs::png::PngDecoder::new(std::io::BufReader::new(logo)).unwrap();
    let icc = decoder.icc_profile().unwrap().expect("the logo's profile");
    let grey = image::RgbImage::from_pixel(64, 64, image::Rgb([128; 3]));
    let mut bytes = Vec::new();
    let mut enc = image::codecs::png::PngEncoder::new(&mut bytes);
    image::ImageEncoder::set_icc_profile(&mut enc, icc).unwrap();
    image::ImageEncoder::write_image(enc, grey.as_raw(), 64, 64, image::ExtendedColorType::Rgb8)
        .unwrap();
    std::fs::write(d.join("design.png"), bytes).unwrap();
    std::fs::write(
        d.join("w.mtl"),
        "newmtl floor\nKd 0.6 0.6 0.6\nnewmtl Glass\nKd 1 1 1\nd 0.5\nmap_Kd design.png\n",
    )
    .unwrap();
    std::fs::write(
        d.join("w.obj"),
        "mtllib w.mtl\nv -4 0 -6\nv 6 0 -6\nv 6 0 6\nv -4 0 6\nv 0 1 0\nv 2 1 0\nv 2 3 0\n\
         v 0 3 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl floor\nf 1 4 3 2\nusemtl Glass\n\
         f 5/1 6/2 7/3 8/4\n",
    )
    .unwrap();
    let centre = |pack: &Path| {
        let name = texture_where(pack, |t| t["role"] == "colour");
        let img = extract(pack, &name, 0, d);
        img.get_pixel(img.width() / 2, img.height() / 2).0
    };
    // The glass's own map: the model's texture, read as sRGB bytes.
    let (pack, err) = cook_obj(
        &d.join("w.obj"),
        &d.join("own.pack"),
        &["--texture-format", "rgba8"],
    );
    assert!(!err.contains("ICC profile"), "{err}");
    assert_eq!(centre(&pack)[..3], [128; 3]);
    // Named as the window's design: converted.
    std::fs::write(
        d.join("scene.toml"),
        "[[mesh]]\nsource = \"w.obj\"\n\n[[window]]\nmaterial = \"Glass\"\ndesign = \"design.png\"\n",
    )
    .unwrap();
    for (cache, pack) in [("c1", "a.pack"), ("c1", "b.pack")] {
        let o = cooker(&[
            &"cook",
            &d.join("scene.toml"),
            &"-o",
            &d.join(pack),
            &"--cache-dir",
            &d.join(cache),
            &"--texture-format",
            &"rgba8",
        ]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{err}");
        assert!(
            err.contains("design.png")
                && err.contains("converted from its ICC profile \"Generic RGB Profile\" to sRGB"),
            "{pack}: {err}"
        );
        let c = centre(&d.join(pack));
        assert!(
            c[..3].iter().all(|v| (146..=148).contains(v)),
            "{pack}: {c:?}"
        );
    }
    // Declared linear, the texels are data in linear light: read as they are, the profile
    // named as left out.
    std::fs::write(
        d.join("scene.toml"),
        "[[mesh]]\nsource = \"w.obj\"\n\n[[window]]\nmaterial = \"Glass\"\ndesign = \"design.png\"\n\
         colour_space = \"linear\"\n",
    )
    .unwrap();
    let (pack, err) = cook_obj(
        &d.join("scene.toml"),
        &d.join("lin.pack"),
        &["--texture-format", "rgba8"],
    );
    assert!(
        err.contains("design.png")
            && err.contains("its ICC profile \"Generic RGB Profile\" is not applied")
            && err.contains("colour_space = \"linear\"")
            && !err.contains("converted"),
        "{err}"
    );
    assert_eq!(centre(&pack)[..3], [128; 3]);
    // The same file given with `--window` takes the colour space of the entry it replaces the
    // design of: read as linear there (it was converted whatever the entry said), converted
    // where the entry is sRGB.
    std::fs::copy(d.join("design.png"), d.join("given.png")).unwrap();
    let given = d.join("given.png");
    let window = format!("Glass={}", given.display());
    for (entry, converted) in [("colour_space = \"linear\"\n", false), ("", true)] {
        std::fs::write(
            d.join("scene.toml"),
            format!(
                "[[mesh]]\nsource = \"w.obj\"\n\n[[window]]\nmaterial = \"Glass\"\n\
                 design = \"design.png\"\n{entry}"
            ),
        )
        .unwrap();
        let (pack, err) = cook_obj(
            &d.join("scene.toml"),
            &d.join("given.pack"),
            &["--texture-format", "rgba8", "--window", &window],
        );
        let c = centre(&pack);
        if converted {
            assert!(
                err.contains("given.png") && err.contains("converted"),
                "{err}"
            );
            assert!(c[..3].iter().all(|v| (146..=148).contains(v)), "{c:?}");
        } else {
            assert!(
                err.contains("given.png") && err.contains("is not applied"),
                "{err}"
            );
            assert_eq!(c[..3], [128; 3]);
        }
    }
}
