//! Helpers shared by the cooker's integration tests.

// Each test crate compiles this module and uses a different subset of it.
#![allow(dead_code)]

use std::ffi::OsStr;
use std::process::{Command, Output};

/// A command running the `cooker` binary this package builds.
pub fn command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_cooker"))
}

/// Copies the folder `from` into `to` (created), recursively.
pub fn copy_dir(from: &std::path::Path, to: &std::path::Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let dest = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_dir(&p, &dest);
        } else {
            std::fs::copy(&p, &dest).unwrap();
        }
    }
}

/// Runs the cooker with `args` and waits for it.
pub fn cooker(args: &[&dyn AsRef<OsStr>]) -> Output {
    let mut c = command();
    for a in args {
        c.arg(a);
    }
    c.output().expect("cooker runs")
}

/// Panics when a line of `msg` says the same thing twice: after the `error:`/`warning:` label,
/// no `": "`-separated part may contain another. That is how an error that prints its cause
/// and also returns it as its `source` shows up in a printed chain
/// (`x.pack: No such file…: No such file…`, `writing x.pack: x.pack: …`).
pub fn assert_said_once(msg: &str) {
    for line in msg.lines() {
        let parts: Vec<&str> = line
            .split(": ")
            .skip_while(|p| matches!(*p, "error" | "warning" | "note"))
            .map(str::trim)
            .filter(|p| p.len() >= 4)
            .collect();
        for (i, a) in parts.iter().enumerate() {
            for (j, b) in parts.iter().enumerate() {
                assert!(
                    i == j || !a.contains(b),
                    "repeated {b:?} in the message line {line:?}"
                );
            }
        }
    }
}

/// A small scene in `dir` (a floor, two windows with their designs, one of which lights
/// nothing and is skipped), cooked in tens of milliseconds; returns the manifest's path.
pub fn small_scene(dir: &std::path::Path) -> std::path::PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(
        dir.join("scene.obj"),
        "mtllib scene.mtl\n\
         v -5 0 0\nv 5 0 0\nv 5 0 10\nv -5 0 10\n\
         v 0 2 0\nv 1 2 0\nv 1 4 0\nv 0 4 0\n\
         v 100 2 0\nv 101 2 0\nv 101 4 0\nv 100 4 0\n\
         vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\n\
         g floor\nusemtl stone\nf 1 4 3\nf 1 3 2\n\
         g windows\nusemtl lit\nf 5/1 6/2 7/3\nf 5/1 7/3 8/4\n\
         usemtl dark\nf 9/1 10/2 11/3\nf 9/1 11/3 12/4\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("scene.mtl"),
        "newmtl stone\nKd 0.5 0.5 0.5\nnewmtl lit\nKd 1 1 1\nnewmtl dark\nKd 1 1 1\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        r#"
[[mesh]]
source = "scene.obj"

[[rule]]
match = "stone"
class = "floor"

[[rule]]
match = "{lit,dark}"
on = ["material"]
class = "window-upper"

[[window]]
material = "lit"
design = "lit.png"

[[window]]
material = "dark"
design = "dark.png"

[light]
type = "directional"
direction = [0.0, -1.0, 1.0]
angular_size_deg = 0.53
colour = [1.0, 1.0, 1.0]
intensity = 1.0
"#,
    )
    .unwrap();
    for (name, blue) in [("lit.png", 200u8), ("dark.png", 90)] {
        design(&dir.join(name), blue);
    }
    dir.join("scene.toml")
}

/// Writes a small window design; `blue` tells designs apart.
pub fn design(path: &std::path::Path, blue: u8) {
    image::RgbaImage::from_fn(16, 32, |x, y| {
        image::Rgba([(x * 15) as u8, (y * 7) as u8, blue, 255])
    })
    .save(path)
    .unwrap();
}
