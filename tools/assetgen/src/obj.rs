//! Wavefront OBJ + MTL text for the scene.

use std::fmt::Write;

use glam::Vec3;

use crate::geom::{Class, Object, Scene};

/// Fixed-point text without "-0.000": the same number always prints the same way.
fn num(x: f32, decimals: usize) -> String {
    let s = format!("{x:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

pub fn obj(scene: &Scene, header: &str) -> String {
    let mut out = String::new();
    for line in header.lines() {
        let _ = writeln!(out, "# {line}");
    }
    let _ = writeln!(out, "mtllib corridor.mtl");
    let mut base = 1usize;
    for o in &scene.objects {
        let _ = writeln!(out, "\no {}\nusemtl {}", o.name, o.material);
        for v in &o.vertices {
            let p = v.position;
            let _ = writeln!(out, "v {} {} {}", num(p.x, 4), num(p.y, 4), num(p.z, 4));
        }
        for v in &o.vertices {
            let _ = writeln!(out, "vt {} {}", num(v.uv.x, 5), num(v.uv.y, 5));
        }
        for v in &o.vertices {
            let n = v.normal;
            let _ = writeln!(out, "vn {} {} {}", num(n.x, 5), num(n.y, 5), num(n.z, 5));
        }
        for t in &o.triangles {
            let [a, b, c] = t.map(|i| i as usize + base);
            let _ = writeln!(out, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}");
        }
        base += o.vertices.len();
    }
    out
}

/// Shading of each material; the manifest's rules tag them by name.
struct Look {
    diffuse: Vec3,
    specular: Vec3,
    shininess: f32,
    emissive: Vec3,
    texture: Option<String>,
}

fn look(o: &Object, scene: &Scene) -> Look {
    let stone = |kd: Vec3, tex: &str| Look {
        diffuse: kd,
        specular: Vec3::splat(0.04),
        shininess: 12.0,
        emissive: Vec3::ZERO,
        texture: Some(tex.into()),
    };
    match o.class {
        Class::Floor => stone(Vec3::new(0.8, 0.78, 0.74), "textures/floor.png"),
        Class::Wall if o.material == "roof" => {
            stone(Vec3::new(0.7, 0.68, 0.64), "textures/wall.png")
        }
        Class::Wall => stone(Vec3::splat(0.8), "textures/wall.png"),
        Class::WindowLower | Class::WindowUpper => {
            let design = scene
                .windows
                .iter()
                .find(|w| w.material == o.material)
                .map(|w| w.design.file());
            Look {
                diffuse: Vec3::ONE,
                specular: Vec3::splat(0.3),
                shininess: 64.0,
                emissive: Vec3::ZERO,
                texture: design.map(str::to_string),
            }
        }
        Class::Background => Look {
            diffuse: Vec3::ONE,
            specular: Vec3::ZERO,
            shininess: 1.0,
            emissive: Vec3::ONE,
            texture: Some("textures/sky.png".into()),
        },
    }
}

pub fn mtl(scene: &Scene, header: &str) -> String {
    let mut out = String::new();
    for line in header.lines() {
        let _ = writeln!(out, "# {line}");
    }
    let mut seen = Vec::new();
    for o in &scene.objects {
        if seen.contains(&o.material) {
            continue;
        }
        seen.push(o.material.clone());
        let l = look(o, scene);
        let v = |v: Vec3| format!("{} {} {}", num(v.x, 3), num(v.y, 3), num(v.z, 3));
        let _ = writeln!(out, "\nnewmtl {}", o.material);
        let _ = writeln!(out, "Ka 0.000 0.000 0.000");
        let _ = writeln!(out, "Kd {}", v(l.diffuse));
        let _ = writeln!(out, "Ks {}", v(l.specular));
        let _ = writeln!(out, "Ke {}", v(l.emissive));
        let _ = writeln!(out, "Ns {}", num(l.shininess, 1));
        let _ = writeln!(out, "d 1.000");
        let _ = writeln!(out, "illum 2");
        if let Some(t) = l.texture {
            let _ = writeln!(out, "map_Kd {t}");
        }
    }
    out
}
