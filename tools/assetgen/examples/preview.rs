//! A CPU ray-traced preview of the generated scene: textures, sunlight, shadows, and sunlight
//! coloured by the glass it passes through. Slow and simple; for checking the assets by eye.
//!
//! `cargo run -p assetgen --release --example preview -- CAMERA OUT.png [WxH]`

use anyhow::{Context, Result};
use assetgen::geom::{Class, Object};
use assetgen::{Options, generate};
use glam::{Vec2, Vec3};
use image::RgbImage;
use rayon::prelude::*;

struct Hit {
    object: usize,
    t: f32,
    uv: Vec2,
    normal: Vec3,
}

fn intersect(objects: &[Object], o: Vec3, d: Vec3, skip_background: bool) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (k, obj) in objects.iter().enumerate() {
        if skip_background && obj.class == Class::Background {
            continue;
        }
        for &tri in &obj.triangles {
            let [a, b, c] = obj.corners(tri);
            let (e1, e2) = (b - a, c - a);
            let p = d.cross(e2);
            let det = e1.dot(p);
            if det.abs() < 1e-12 {
                continue;
            }
            let inv = 1.0 / det;
            let s = o - a;
            let u = s.dot(p) * inv;
            if !(0.0..=1.0).contains(&u) {
                continue;
            }
            let q = s.cross(e1);
            let v = d.dot(q) * inv;
            if v < 0.0 || u + v > 1.0 {
                continue;
            }
            let t = e2.dot(q) * inv;
            if t > 1e-4 && best.as_ref().is_none_or(|h| t < h.t) {
                let [va, vb, vc] = tri.map(|i| obj.vertices[i as usize]);
                best = Some(Hit {
                    object: k,
                    t,
                    uv: va.uv * (1.0 - u - v) + vb.uv * u + vc.uv * v,
                    normal: (va.normal * (1.0 - u - v) + vb.normal * u + vc.normal * v).normalize(),
                });
            }
        }
    }
    best
}

fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn linear_to_srgb(c: f32) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

fn sample(img: &RgbImage, uv: Vec2) -> Vec3 {
    let (w, h) = (img.width() as f32, img.height() as f32);
    let x = (uv.x.rem_euclid(1.0) * w) as u32 % img.width();
    let y = ((1.0 - uv.y).rem_euclid(1.0) * h) as u32 % img.height();
    let p = img.get_pixel(x, y).0;
    Vec3::new(
        srgb_to_linear(p[0]),
        srgb_to_linear(p[1]),
        srgb_to_linear(p[2]),
    )
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let camera = args.get(1).context("camera name")?;
    let out_path = args.get(2).context("output path")?;
    let (w, h) = match args.get(3) {
        Some(s) => {
            let (a, b) = s.split_once('x').context("WxH")?;
            (a.parse::<u32>()?, b.parse::<u32>()?)
        }
        None => (640, 360),
    };
    let out = generate(&Options::default())?;
    let load = |p: &str| -> Result<RgbImage> {
        let f = out
            .files
            .iter()
            .find(|f| f.path == p)
            .context(p.to_string())?;
        Ok(image::load_from_memory(&f.bytes)?.to_rgb8())
    };
    let floor = load("textures/floor.png")?;
    let wall = load("textures/wall.png")?;
    let sky = load("textures/sky.png")?;
    let designs: Vec<RgbImage> = out
        .scene
        .windows
        .iter()
        .map(|w| load(w.design.file()))
        .collect::<Result<_>>()?;
    let window_of = |obj: usize| out.scene.windows.iter().position(|w| w.object == obj);
    let cam = out
        .cameras
        .iter()
        .find(|c| c.name == camera)
        .context("no such camera")?;
    let sun = out.scene.layout.sun;
    let fwd = (cam.target - cam.position).normalize();
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    let tan = (cam.fov_y_deg.to_radians() / 2.0).tan();
    let objects = &out.scene.objects;

    let albedo = |hit: &Hit| -> Vec3 {
        let o = &objects[hit.object];
        match o.class {
            Class::Floor => sample(&floor, hit.uv) * 0.8,
            Class::Wall => sample(&wall, hit.uv) * 0.8,
            Class::Background => sample(&sky, hit.uv),
            _ => sample(&designs[window_of(hit.object).unwrap()], hit.uv),
        }
    };
    // Light arriving at p from the sun: through glass it takes the glass colour.
    let sunlight = |p: Vec3| -> Vec3 {
        let mut origin = p;
        let mut light = Vec3::splat(3.0);
        for _ in 0..4 {
            match intersect(objects, origin, -sun, true) {
                None => return light,
                Some(hit) => match window_of(hit.object) {
                    Some(_) => {
                        light *= albedo(&hit);
                        origin += -sun * (hit.t + 1e-3);
                    }
                    None => return Vec3::ZERO,
                },
            }
        }
        light
    };

    let mut img = RgbImage::new(w, h);
    let rows: Vec<Vec<[u8; 3]>> = (0..h)
        .into_par_iter()
        .map(|j| {
            (0..w)
                .map(|i| {
                    let sx = ((i as f32 + 0.5) / w as f32 * 2.0 - 1.0) * tan * w as f32 / h as f32;
                    let sy = (1.0 - (j as f32 + 0.5) / h as f32 * 2.0) * tan;
                    let d = (fwd + right * sx + up * sy).normalize();
                    let c = match intersect(objects, cam.position, d, false) {
                        None => Vec3::ZERO,
                        Some(hit) => {
                            let o = &objects[hit.object];
                            let a = albedo(&hit);
                            match o.class {
                                Class::Background => a,
                                Class::WindowLower | Class::WindowUpper => a * 1.2,
                                _ => {
                                    let p = cam.position + d * hit.t + hit.normal * 1e-3;
                                    let lambert = hit.normal.dot(-sun).max(0.0);
                                    a * (Vec3::splat(0.08) + sunlight(p) * lambert)
                                }
                            }
                        }
                    };
                    [
                        linear_to_srgb(c.x),
                        linear_to_srgb(c.y),
                        linear_to_srgb(c.z),
                    ]
                })
                .collect()
        })
        .collect();
    for (j, row) in rows.iter().enumerate() {
        for (i, p) in row.iter().enumerate() {
            img.put_pixel(i as u32, j as u32, image::Rgb(*p));
        }
    }
    img.save(out_path)?;
    Ok(())
}
