//! `cooker extract` on packs built in code.

mod common;

use std::path::Path;

use common::cooker;

use pack::TextureRole;
use pack::testing::{sample, sample_texture};

/// The sample pack plus a 5x3 colour texture and a 4x4 normal map with known bytes.
fn write_pack(path: &Path) -> (Vec<Vec<u8>>, Vec<Vec<u8>>) {
    let (mut toc, mut data) = sample();
    let (colour, colour_data) = sample_texture("design", TextureRole::Colour, 5, 3);
    let (normal, normal_data) = sample_texture("design normal", TextureRole::Normal, 4, 4);
    toc.textures.push(colour);
    data.textures.push(colour_data.clone());
    toc.textures.push(normal);
    data.textures.push(normal_data.clone());
    pack::write_pack(path, toc, &data).unwrap();
    (colour_data, normal_data)
}

fn read_png(path: &Path) -> image::RgbaImage {
    match image::open(path).unwrap() {
        image::DynamicImage::ImageRgba8(i) => i,
        other => panic!("expected an 8-bit RGBA PNG, got {:?}", other.color()),
    }
}

#[test]
fn every_level_round_trips_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let pack = dir.path().join("s.pack");
    let (colour, normal) = write_pack(&pack);
    for (name, levels) in [("design", &colour), ("design normal", &normal)] {
        for (mip, bytes) in levels.iter().enumerate() {
            let out = dir.path().join(format!("{name}-{mip}.png"));
            let o = cooker(&[
                &"extract",
                &pack,
                &name,
                &"--mip",
                &mip.to_string(),
                &"-o",
                &out,
            ]);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let img = read_png(&out);
            let (w, h) = (img.width(), img.height());
            assert_eq!(img.into_raw(), *bytes, "{name} mip {mip} ({w}x{h})");
        }
    }
    // Level 0 is the default; level sizes follow the pack's rule.
    let out = dir.path().join("default.png");
    assert!(
        cooker(&[&"extract", &pack, &"design", &"-o", &out])
            .status
            .success()
    );
    assert_eq!(read_png(&out).dimensions(), (5, 3));
}

#[test]
fn bad_name_or_level_is_usage_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let pack = dir.path().join("s.pack");
    write_pack(&pack);
    let out = dir.path().join("out.png");
    let o = cooker(&[&"extract", &pack, &"no such texture", &"-o", &out]);
    assert_eq!(o.status.code(), Some(2));
    // The whole line for exit 2: the pack, the name asked for, the names it has.
    assert_eq!(
        String::from_utf8_lossy(&o.stderr),
        format!(
            "error: {}: no texture named \"no such texture\"; it has [\"rose.colour\", \
             \"rose.normal\", \"design\", \"design normal\"]\n",
            pack.display()
        )
    );
    // 5x3 has levels 0..=2.
    let o = cooker(&[&"extract", &pack, &"design", &"--mip", &"3", &"-o", &out]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(&format!(
            "{}: mip level 3 of texture \"design\" does not exist: it has 3 level(s), 0 to 2",
            pack.display()
        )),
        "{err}"
    );
    assert!(!out.exists());
    // A directory, or another format's name, is bad usage too (a .jpg got PNG bytes).
    for (to, says) in [
        (
            dir.path().to_path_buf(),
            "is a directory; name the file to write in it",
        ),
        (
            dir.path().join("x.jpg"),
            "extract writes PNG; name a .png file",
        ),
    ] {
        let o = cooker(&[&"extract", &pack, &"design", &"-o", &to]);
        assert_eq!(o.status.code(), Some(2));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(says), "{err}");
    }
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "stray files left behind"
    );
}

#[test]
fn corrupt_or_missing_pack_exits_3_or_4() {
    let dir = tempfile::tempdir().unwrap();
    let pack = dir.path().join("s.pack");
    write_pack(&pack);
    let mut bytes = std::fs::read(&pack).unwrap();
    let n = bytes.len();
    bytes[n - 1] ^= 0x40;
    let bad = dir.path().join("bad.pack");
    std::fs::write(&bad, &bytes).unwrap();
    let out = dir.path().join("out.png");
    let o = cooker(&[&"extract", &bad, &"design", &"-o", &out]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("bad.pack: at byte offset") && err.contains("checksum mismatch"),
        "{err}"
    );
    let missing = dir.path().join("missing.pack");
    let o = cooker(&[&"extract", &missing, &"design", &"-o", &out]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(4), "{err}");
    // The OS's reason once, not the pack error's message and then its source again.
    assert_eq!(
        err,
        format!(
            "error: {}: No such file or directory (os error 2)\n",
            missing.display()
        )
    );
    // An output directory that does not exist is an OS error, and leaves nothing behind.
    let o = cooker(&[
        &"extract",
        &pack,
        &"design",
        &"-o",
        &dir.path().join("nope/out.png"),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(4), "{err}");
    assert_eq!(
        err,
        format!(
            "error: {}: No such file or directory (os error 2)\n",
            dir.path().join("nope/out.png").display()
        )
    );
    assert!(!out.exists());
}
