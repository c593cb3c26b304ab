//! Headless renders of small synthetic packs on lavapipe, whatever GPU the machine has
//! ([`common::lavapipe`]): the committed references were rendered there. No lavapipe is a
//! failure, not a skip. Images are compared with the references using FLIP; `BLESS=1` rewrites
//! them, and a missing reference fails.

mod common;
use common::{lavapipe, load};

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use pack::{
    Background, Camera, ColourSpace, DrawRange, Light, LightKind, Material, MaterialClass,
    MipLevel, PackData, StandardVertex, Texture, TextureFormat, TextureRole, Toc, Window,
};
use render::view::{GodRaySettings, LightGeometry, god_ray_uniforms, god_rays_reference};
use render::{Gpu, PassId, Renderer, Scene, Settings, TargetId, TimingMethod, View};

const W: u32 = 320;
const H: u32 = 180;

// ---------------------------------------------------------------------------------------------
// A synthetic scene: a floor, a wall at z = 0 with a window (colour, normal map, projector),
// a sky backdrop far outside, and a light outside. The building's inside is z > 0.

struct Builder {
    placement: Placement,
    toc: Toc,
    data: PackData,
    vertices: Vec<StandardVertex>,
    indices: Vec<u32>,
    ranges: Vec<DrawRange>,
}

fn mip_chain(w: u32, h: u32, level0: Vec<u8>) -> (Vec<MipLevel>, Vec<Vec<u8>>) {
    let mut levels = vec![level0];
    let mut mips = vec![MipLevel {
        width: w,
        height: h,
        section: 0,
    }];
    let (mut cw, mut ch) = (w, h);
    while cw > 1 || ch > 1 {
        let (nw, nh) = ((cw / 2).max(1), (ch / 2).max(1));
        let prev = levels.last().unwrap();
        let mut next = vec![0u8; (nw * nh * 4) as usize];
        for y in 0..nh {
            for x in 0..nw {
                for c in 0..4 {
                    let mut sum = 0u32;
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let sx = (x * 2 + dx).min(cw - 1);
                        let sy = (y * 2 + dy).min(ch - 1);
                        sum += prev[((sy * cw + sx) * 4 + c) as usize] as u32;
                    }
                    next[((y * nw + x) * 4 + c) as usize] = ((sum + 2) / 4) as u8;
                }
            }
        }
        levels.push(next);
        mips.push(MipLevel {
            width: nw,
            height: nh,
            section: 0,
        });
        (cw, ch) = (nw, nh);
    }
    (mips, levels)
}

impl Builder {
    fn new(placement: Placement) -> Self {
        Self {
            placement,
            toc: Toc::default(),
            data: PackData::default(),
            vertices: Vec::new(),
            indices: Vec::new(),
            ranges: Vec::new(),
        }
    }

    fn texture(
        &mut self,
        name: &str,
        role: TextureRole,
        size: u32,
        f: impl Fn(f32, f32) -> [u8; 4],
    ) -> u32 {
        let mut px = Vec::with_capacity((size * size * 4) as usize);
        for y in 0..size {
            for x in 0..size {
                px.extend_from_slice(&f(
                    (x as f32 + 0.5) / size as f32,
                    (y as f32 + 0.5) / size as f32,
                ));
            }
        }
        let (mips, levels) = mip_chain(size, size, px);
        self.toc.textures.push(Texture {
            name: name.into(),
            role,
            colour_space: if role == TextureRole::Normal {
                ColourSpace::Linear
            } else {
                ColourSpace::Srgb
            },
            format: TextureFormat::Rgba8,
            supercompression: pack::Supercompression::None,
            width: size,
            height: size,
            mips,
        });
        self.data.textures.push(levels);
        self.toc.textures.len() as u32 - 1
    }

    #[allow(clippy::too_many_arguments)]
    fn material(
        &mut self,
        name: &str,
        class: MaterialClass,
        diffuse: [f32; 3],
        emissive: [f32; 3],
        tex: Option<u32>,
        normal: Option<u32>,
        projector: Option<u32>,
    ) -> u16 {
        self.toc.materials.push(Material {
            name: name.into(),
            class,
            diffuse,
            specular: [0.05; 3],
            shininess: 16.0,
            emissive,
            diffuse_texture: tex,
            normal_texture: normal,
            projector_texture: projector,
            projector_margin: [0.0; 2],
        });
        self.toc.materials.len() as u16 - 1
    }

    /// A quad `origin + u*a + v*b`, (u, v) in [0,1]², facing `normal`, with UVs scaled by `uv`.
    fn quad(&mut self, material: u16, origin: Vec3, a: Vec3, b: Vec3, normal: Vec3, uv: Vec2) {
        let base = self.vertices.len() as u32;
        for (u, v) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            self.vertices.push(StandardVertex {
                position: self.placement.at(origin + a * u + b * v).to_array(),
                normal: normal.to_array(),
                uv: [u * uv.x, v * uv.y],
                tangent: a.normalize().extend(1.0).to_array(),
                material: [material, 0],
                colour: pack::vertex::WHITE,
            });
        }
        let first = self.indices.len() as u32;
        self.indices
            .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        match self.ranges.last_mut() {
            Some(r) if r.material == material => r.index_count += 6,
            _ => self.ranges.push(DrawRange {
                material,
                first_index: first,
                index_count: 6,
            }),
        }
    }

    fn finish(self) -> Vec<u8> {
        common::encode_scene(
            self.toc,
            self.data,
            &self.vertices,
            &self.indices,
            self.ranges,
        )
    }
}

/// Where the scene's positions go (geometry, window frames, the lamp, cameras).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Placement {
    /// Added to every position.
    offset: Vec3,
    /// Positions are first rounded as f32 stores them at this offset, so a scene at the origin
    /// can hold exactly the geometry of one far from it.
    quantum: Vec3,
    /// Every length is multiplied by this (a lamp's intensity by its square, so the light
    /// lands as bright).
    scale: f32,
}

impl Placement {
    const ORIGIN: Self = Self {
        offset: Vec3::ZERO,
        quantum: Vec3::ZERO,
        scale: 1.0,
    };

    fn at(&self, p: Vec3) -> Vec3 {
        // (q + p) rounds as f32 storage at q would; subtracting q again is exact.
        self.offset + ((self.quantum + p * self.scale) - self.quantum)
    }

    fn len(&self, x: f32) -> f32 {
        x * self.scale
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum LightSetup {
    Sun,
    Lamp,
}

const WINDOW_MIN: Vec2 = Vec2::new(-1.5, 1.0);
const WINDOW_MAX: Vec2 = Vec2::new(1.5, 4.0);

fn glass(u: f32, v: f32) -> [u8; 4] {
    // Four panes in red, blue, gold and green, separated by dark lead lines.
    let lead = (u * 4.0).fract() < 0.08 || (v * 4.0).fract() < 0.08;
    if lead {
        return [20, 20, 20, 255];
    }
    match ((u * 2.0) as u32 % 2, (v * 2.0) as u32 % 2) {
        (0, 0) => [220, 40, 40, 255],
        (1, 0) => [40, 80, 230, 255],
        (0, _) => [240, 200, 40, 255],
        _ => [40, 190, 80, 255],
    }
}

fn scene(light: Option<LightSetup>, with_window: bool, with_normals: bool) -> Vec<u8> {
    scene_at(light, with_window, with_normals, Placement::ORIGIN)
}

fn scene_at(
    light: Option<LightSetup>,
    with_window: bool,
    with_normals: bool,
    at: Placement,
) -> Vec<u8> {
    scene_builder(light, with_window, with_normals, at).finish()
}

fn scene_builder(
    light: Option<LightSetup>,
    with_window: bool,
    with_normals: bool,
    at: Placement,
) -> Builder {
    let mut b = Builder::new(at);
    let floor_tex = b.texture("floor", TextureRole::Colour, 256, |u, v| {
        let check = ((u * 8.0) as u32 + (v * 8.0) as u32).is_multiple_of(2);
        if check {
            [200, 195, 185, 255]
        } else {
            [150, 145, 140, 255]
        }
    });
    let sky_tex = b.texture("sky", TextureRole::Colour, 32, |_, v| {
        let t = v;
        [
            (120.0 + 100.0 * t) as u8,
            (170.0 + 60.0 * t) as u8,
            245,
            255,
        ]
    });
    let floor = b.material(
        "floor",
        MaterialClass::Floor,
        [0.8, 0.8, 0.8],
        [0.0; 3],
        Some(floor_tex),
        None,
        None,
    );
    let wall = b.material(
        "wall",
        MaterialClass::Wall,
        [0.7, 0.65, 0.6],
        [0.0; 3],
        None,
        None,
        None,
    );
    let sky = b.material(
        "sky",
        MaterialClass::Background,
        [1.0; 3],
        [0.0; 3],
        Some(sky_tex),
        None,
        None,
    );
    let hill = b.material(
        "hill",
        MaterialClass::Background,
        [0.15, 0.3, 0.12],
        [0.0; 3],
        None,
        None,
        None,
    );

    // Floor on both sides of the wall.
    b.quad(
        floor,
        Vec3::new(-8.0, 0.0, 12.0),
        Vec3::new(16.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -24.0),
        Vec3::Y,
        Vec2::new(4.0, 6.0),
    );
    // Wall at z = 0 around the window opening, normal facing the inside (+z).
    let n = Vec3::Z;
    let (x0, x1, y0, y1) = (WINDOW_MIN.x, WINDOW_MAX.x, WINDOW_MIN.y, WINDOW_MAX.y);
    b.quad(
        wall,
        Vec3::new(-8.0, 0.0, 0.0),
        Vec3::new(8.0 + x0, 0.0, 0.0),
        Vec3::new(0.0, 6.0, 0.0),
        n,
        Vec2::ONE,
    );
    b.quad(
        wall,
        Vec3::new(x1, 0.0, 0.0),
        Vec3::new(8.0 - x1, 0.0, 0.0),
        Vec3::new(0.0, 6.0, 0.0),
        n,
        Vec2::ONE,
    );
    b.quad(
        wall,
        Vec3::new(x0, 0.0, 0.0),
        Vec3::new(x1 - x0, 0.0, 0.0),
        Vec3::new(0.0, y0, 0.0),
        n,
        Vec2::ONE,
    );
    b.quad(
        wall,
        Vec3::new(x0, y1, 0.0),
        Vec3::new(x1 - x0, 0.0, 0.0),
        Vec3::new(0.0, 6.0 - y1, 0.0),
        n,
        Vec2::ONE,
    );
    // Sky and a hill far outside.
    b.quad(
        sky,
        Vec3::new(-80.0, 60.0, -60.0),
        Vec3::new(160.0, 0.0, 0.0),
        Vec3::new(0.0, -70.0, 0.0),
        n,
        Vec2::ONE,
    );
    b.quad(
        hill,
        Vec3::new(-30.0, -1.0, -50.0),
        Vec3::new(40.0, 0.0, 0.0),
        Vec3::new(0.0, 9.0, 0.0),
        n,
        Vec2::ONE,
    );

    if with_window {
        let colour = b.texture("glass", TextureRole::Colour, 64, glass);
        let normal = with_normals.then(|| {
            b.texture("glass_n", TextureRole::Normal, 64, |u, v| {
                // Hammered glass: a field of bumps.
                let (fx, fy) = ((u * 8.0).fract() - 0.5, (v * 8.0).fract() - 0.5);
                let (nx, ny) = (fx * 0.9, -fy * 0.9);
                let nz = (1.0 - nx * nx - ny * ny).max(0.0).sqrt();
                let e = |x: f32| ((x * 0.5 + 0.5) * 255.0).round() as u8;
                [e(nx), e(ny), e(nz), 255]
            })
        });
        let projector = b.texture("glass_p", TextureRole::Projector, 32, |u, v| {
            // The pre-blurred design: the panes without the thin leads.
            let mut c = glass(u, v);
            if c[0] == 20 {
                c = [90, 90, 90, 255];
            }
            c
        });
        let window = b.material(
            "lancet",
            MaterialClass::WindowUpper,
            [1.0; 3],
            [0.0; 3],
            Some(colour),
            normal,
            Some(projector),
        );
        // The design's v runs down: origin at the top left.
        let origin = Vec3::new(x0, y1, 0.0);
        let ua = Vec3::new(x1 - x0, 0.0, 0.0);
        let va = Vec3::new(0.0, y0 - y1, 0.0);
        b.quad(window, origin, ua, va, n, Vec2::ONE);
        // Its tangent frame: u along +x; v runs down the image, so the bitangent (+y) has
        // handedness +1 for an OpenGL (+Y up) normal map.
        b.toc.windows.push(Window {
            material: window,
            origin: at.at(origin).to_array(),
            u_axis: (ua * at.scale).to_array(),
            v_axis: (va * at.scale).to_array(),
            normal: [0.0, 0.0, 1.0],
            source_materials: Vec::new(),
        });
    }
    b.toc.light = light.map(|l| Light {
        kind: match l {
            LightSetup::Sun => LightKind::Directional {
                direction: [0.12, -0.42, 0.9],
                angular_size: 0.0093,
            },
            LightSetup::Lamp => LightKind::Point {
                position: at.at(Vec3::new(1.0, 5.0, -3.0)).to_array(),
                radius: at.len(0.3),
            },
        },
        colour: [1.0, 0.95, 0.85],
        intensity: if l == LightSetup::Lamp {
            at.len(at.len(60.0))
        } else {
            3.0
        },
    });
    b.toc.cameras = vec![
        Camera {
            name: "inside".into(),
            position: at.at(Vec3::new(0.5, 1.6, 9.0)).to_array(),
            target: at.at(Vec3::new(0.0, 2.0, 0.0)).to_array(),
            up: [0.0, 1.0, 0.0],
            fov_y: 60.0,
            near: at.len(0.05),
            far: at.len(300.0),
        },
        Camera {
            name: "outside".into(),
            position: at.at(Vec3::new(3.0, 2.0, -9.0)).to_array(),
            target: at.at(Vec3::new(0.0, 2.0, 0.0)).to_array(),
            up: [0.0, 1.0, 0.0],
            fov_y: 60.0,
            near: at.len(0.05),
            far: at.len(300.0),
        },
    ];
    b.toc.background = Background {
        colour: [0.3, 0.45, 0.75],
        panorama: None,
    };
    b
}

// ---------------------------------------------------------------------------------------------
// Reference images.

fn reference_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/reference")
}

fn out_dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("render");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Largest difference of any 8-bit channel from the reference. lavapipe renders these scenes
/// bit-exactly run to run (FLIP 0); the few LSB absorb another Mesa version's rounding, while a
/// lost feature (refraction off: `flat-glass` against `sun-inside` differs by FLIP mean 0.0024
/// only) moves some pixels by far more.
const MAX_LSB: u8 = 4;

/// Pixels one step apart that pass as the host CPU's rounding (see [`check_image`]): at most
/// one in this many, 5 %, twice what the last-bit differences between CPUs reach.
const ROUNDING_PIXELS_PER: usize = 20;

/// Compares with `data/reference/<name>.png` using FLIP (mean and 99th percentile) and the
/// largest channel difference, [`MAX_LSB`].
fn check_image(name: &str, image: &image::RgbaImage, max_mean: f32, max_p99: f32) {
    let reference_path = reference_dir().join(format!("{name}.png"));
    let actual_path = out_dir().join(format!("{name}-actual.png"));
    if std::env::var_os("BLESS").is_some_and(|v| v == "1") {
        image.save(&reference_path).unwrap();
        eprintln!("blessed {}", reference_path.display());
        return;
    }
    let Ok(reference) = image::open(&reference_path) else {
        image.save(&actual_path).unwrap();
        panic!(
            "missing reference {} (actual written to {}; run with BLESS=1 after checking it)",
            reference_path.display(),
            actual_path.display()
        );
    };
    let reference = reference.into_rgb8();
    let actual = image::DynamicImage::ImageRgba8(image.clone()).into_rgb8();
    assert_eq!(
        reference.dimensions(),
        actual.dimensions(),
        "{name}: size differs from the reference"
    );
    let (w, h) = actual.dimensions();
    let error = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w, h, &reference),
        nv_flip::FlipImageRgb8::with_data(w, h, &actual),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let mut pool = nv_flip::FlipPool::from_image(&error);
    let mean = pool.mean();
    let p99 = pool.get_percentile(0.99, false);
    let max_lsb = reference
        .as_raw()
        .iter()
        .zip(actual.as_raw())
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap_or(0);
    let differing = (reference.pixels().zip(actual.pixels()))
        .filter(|(a, b)| a != b)
        .count();
    // lavapipe compiles the shaders for the host CPU, and its results differ in the last bit
    // between instruction sets: references blessed on an AMD EPYC render on an Intel Xeon with
    // AVX-512 with 1.6-2.4 % of pixels one step apart, which FLIP's mean and p99 count (0.0012-
    // 0.0017 and 0.012-0.014 where these scenes allow 0.001 and 0.01). Such rounding is no
    // change of the picture; anything more is held to the FLIP bounds.
    let rounding = max_lsb <= 1 && differing * ROUNDING_PIXELS_PER <= (w * h) as usize;
    if !(rounding || mean <= max_mean && p99 <= max_p99 && max_lsb <= MAX_LSB) {
        image.save(&actual_path).unwrap();
        let diff = error.apply_color_lut(&nv_flip::magma_lut());
        let diff_path = out_dir().join(format!("{name}-diff.png"));
        image::RgbImage::from_raw(w, h, diff.to_vec())
            .unwrap()
            .save(&diff_path)
            .unwrap();
        panic!(
            "{name}: FLIP mean {mean:.4} (max {max_mean}), p99 {p99:.4} (max {max_p99}), \
             {max_lsb} LSB (max {MAX_LSB}); see {} and {}",
            actual_path.display(),
            diff_path.display()
        );
    }
    eprintln!(
        "{name}: FLIP mean {mean:.5}, p99 {p99:.5}, {max_lsb} LSB, {differing} pixels differ"
    );
}

fn render_camera(
    gpu: &Gpu,
    scene: &Scene,
    camera: usize,
    settings: Settings,
) -> (Renderer, render::FrameReport) {
    let mut r = Renderer::headless(gpu, scene, W, H, settings).unwrap();
    let view = r.view_for(&scene.toc().cameras[camera]);
    let report = r.render(gpu, scene, &view, TimingMethod::None).unwrap();
    (r, report)
}

fn skipped(report: &render::FrameReport, pass: PassId) -> bool {
    report
        .passes
        .iter()
        .find(|p| p.pass == pass)
        .unwrap()
        .skipped
        .is_some()
}

// ---------------------------------------------------------------------------------------------

#[test]
fn sun_through_window_matches_reference() {
    let gpu = lavapipe();
    let scene = load(&gpu, &scene(Some(LightSetup::Sun), true, true));
    let (r, report) = render_camera(&gpu, &scene, 0, Settings::default());
    assert!(
        PassId::ALL
            .iter()
            .all(|&p| !skipped(&report, p) || p == PassId::Shadows),
        "{report:?}"
    );
    // The window sits in a flat wall over an open floor: nothing can block its light, so it
    // gets no shadow map (the occluded cases are in tests/shadows.rs). The floor runs on
    // outside, beyond the window's plane, so the sun's map of what it reaches directly is
    // drawn.
    assert!(!skipped(&report, PassId::Shadows), "{report:?}");
    assert_eq!(
        scene.window_shadows(),
        &[render::occlusion::WindowShadow::Clear]
    );
    assert!(scene.beyond_windows());
    assert!(r.shadow_layout().direct.is_some() && r.shadow_layout().windows == [None]);
    assert!(report.god_ray_fade > 0.9, "the sun is in view: {report:?}");
    check_image("sun-inside", &r.read_output(&gpu).unwrap(), 1e-3, 0.01);
    let (r, report) = render_camera(&gpu, &scene, 1, Settings::default());
    assert!(
        skipped(&report, PassId::GodRays),
        "the sun is behind the outside camera: {report:?}"
    );
    check_image("sun-outside", &r.read_output(&gpu).unwrap(), 1e-3, 0.01);
}

/// A cathedral has more windows than the lit pass takes (`MAX_WINDOWS`): the scene keeps those
/// the light comes in through, then the largest, and renders; before, it refused the pack.
/// Here `MAX_WINDOWS + 9` small windows far behind the camera, without light, come before the
/// lit one: 10 are left out, and the image is the single window's (the lit pass projects
/// through the windows that pass light, which the renderer puts first).
#[test]
fn more_windows_than_the_lit_pass_takes_still_render_the_lit_ones() {
    let gpu = lavapipe();
    let mut b = scene_builder(Some(LightSetup::Sun), true, true, Placement::ORIGIN);
    let lit = b.toc.windows.remove(0);
    let mut dark = b.toc.materials[lit.material as usize].clone();
    dark.name = "far".into();
    dark.projector_texture = None;
    dark.projector_margin = [0.0; 2];
    b.toc.materials.push(dark);
    let dark = (b.toc.materials.len() - 1) as u16;
    for i in 0..render::MAX_WINDOWS + 9 {
        let size = 0.1 + i as f32 * 0.001;
        b.toc.windows.push(Window {
            material: dark,
            origin: [i as f32 * 0.2 - 17.0, 2.0, 1000.0],
            u_axis: [size, 0.0, 0.0],
            v_axis: [0.0, -size, 0.0],
            normal: [0.0, 0.0, -1.0],
            source_materials: vec!["far".into()],
        });
    }
    b.toc.windows.push(lit.clone());
    let scene = load(&gpu, &b.finish());
    assert_eq!(scene.toc().windows.len(), render::MAX_WINDOWS);
    assert_eq!(scene.toc().windows.last(), Some(&lit));
    let (r, _) = render_camera(&gpu, &scene, 0, Settings::default());
    check_image("sun-inside", &r.read_output(&gpu).unwrap(), 1e-3, 0.01);
}

#[test]
fn lamp_through_window_matches_reference() {
    let gpu = lavapipe();
    let scene = load(&gpu, &scene(Some(LightSetup::Lamp), true, true));
    let (r, _) = render_camera(
        &gpu,
        &scene,
        0,
        Settings {
            god_rays: render::GodRaySettings {
                resolution_scale: 0.5,
                jitter: true,
                ..GodRaySettings::default()
            },
            ..Default::default()
        },
    );
    check_image(
        "lamp-inside-half-res-rays",
        &r.read_output(&gpu).unwrap(),
        1e-3,
        0.01,
    );
}

#[test]
fn scene_without_windows_skips_window_passes() {
    let gpu = lavapipe();
    let scene = load(&gpu, &scene(Some(LightSetup::Sun), false, false));
    let (r, report) = render_camera(&gpu, &scene, 0, Settings::default());
    for p in [PassId::WindowMask, PassId::WindowNormals, PassId::GodRays] {
        assert!(
            skipped(&report, p),
            "{p:?} recorded without windows: {report:?}"
        );
    }
    assert!(!skipped(&report, PassId::Lit) && !skipped(&report, PassId::Composite));
    check_image("no-windows", &r.read_output(&gpu).unwrap(), 1e-3, 0.01);
}

/// A model's vertex colours multiply its materials' colours, decoded from sRGB exactly: the
/// floor painted (255, 128, 64) lights as the white floor times (1, 0.2158, 0.0513) in every
/// channel (a power of 2.2 would give 0.2195 and 0.0513 + 4 %), and nothing else changes; in
/// the reference tracer too.
#[test]
fn vertex_colours_multiply_the_material_colour() {
    let gpu = lavapipe();
    // The lit pass on the GPU, and traced.
    let lit = |b: Builder| {
        let bytes = b.finish();
        let scene = load(&gpu, &bytes);
        let (r, _) = render_camera(&gpu, &scene, 0, Settings::default());
        let view = r.view_for(&scene.toc().cameras[0]);
        let pack = pack::Pack::from_bytes("<painted>", &bytes).unwrap();
        let quick = render::reference::ReferenceSettings {
            pixel_samples: 1,
            light_samples: 1,
            ..Default::default()
        };
        let traced = render::reference::Reference::from_pack(&pack).render_lit(&view, W, H, &quick);
        (r.read_target(&gpu, TargetId::Lit).unwrap().2, traced)
    };
    // Without a highlight, which the colour does not tint: the floor's light is its albedo's.
    let matte = || {
        let mut b = scene_builder(Some(LightSetup::Sun), false, false, Placement::ORIGIN);
        for m in &mut b.toc.materials {
            m.specular = [0.0; 3];
        }
        b
    };
    let plain = matte();
    let floor = plain
        .toc
        .materials
        .iter()
        .position(|m| m.name == "floor")
        .unwrap() as u16;
    let mut painted = matte();
    for v in painted
        .vertices
        .iter_mut()
        .filter(|v| v.material[0] == floor)
    {
        v.colour = [255, 128, 64, 0];
    }
    let ((white, traced_white), (coloured, traced)) = (lit(plain), lit(painted));
    let want = [255.0, 128.0, 64.0].map(|c: f64| texture::srgb::srgb_to_linear(c / 255.0) as f32);
    // Half-float targets hold a few parts in a thousand; the tracer's f32, a few in a million.
    for (white, coloured, within) in [(white, coloured, 4e-3), (traced_white, traced, 1e-5)] {
        let mut floor_pixels = 0;
        for (w, c) in white.iter().zip(&coloured) {
            if w == c {
                continue;
            }
            floor_pixels += 1;
            for k in 0..3 {
                assert!(
                    (c[k] - w[k] * want[k]).abs() <= within * w[k] + 1e-4,
                    "channel {k}: {c:?} against {w:?} times {want:?}"
                );
            }
        }
        assert!(floor_pixels > (W * H / 8) as usize, "{floor_pixels}");
    }
}

#[test]
fn window_without_normal_map_skips_refraction() {
    let gpu = lavapipe();
    let scene = load(&gpu, &scene(Some(LightSetup::Sun), true, false));
    let (r, report) = render_camera(&gpu, &scene, 0, Settings::default());
    assert!(skipped(&report, PassId::WindowNormals), "{report:?}");
    assert!(!skipped(&report, PassId::WindowMask) && !skipped(&report, PassId::GodRays));
    check_image("flat-glass", &r.read_output(&gpu).unwrap(), 1e-3, 0.01);
}

// ---------------------------------------------------------------------------------------------
// Stability: the camera turned through every angle to the light.

fn sum_rgb(px: &[[f32; 4]]) -> f64 {
    px.iter().map(|p| (p[0] + p[1] + p[2]) as f64).sum()
}

/// Turns the camera in 2° steps from looking straight at the light to looking directly away
/// and round again, with exact perpendicular and opposite views. Checks every HDR target for
/// NaN/Inf, god-ray energy exactly zero while the light is behind the camera (the pass is
/// forced on so the shader itself is tested), and bounds the change between neighbours.
fn sweep(setup: LightSetup, eye: Vec3) {
    const SW: u32 = 160;
    const SH: u32 = 90;
    let gpu = lavapipe();
    let scene = load(&gpu, &scene(Some(setup), true, true));
    let settings = Settings {
        skip_invisible_god_rays: false,
        ..Default::default()
    };
    let mut r = Renderer::headless(&gpu, &scene, SW, SH, settings).unwrap();
    let light = LightGeometry::from_light(scene.toc().light.as_ref().unwrap());
    let to_light = light.direction_from(eye).unwrap();
    let side = to_light.cross(Vec3::Y).normalize();
    let mut energies = Vec::new();
    for step in 0..=180 {
        let deg = step * 2;
        // Exact axes where the angle is a multiple of 90°, so "perpendicular" really is.
        let forward = match deg {
            0 | 360 => to_light,
            90 => side,
            180 => -to_light,
            270 => -side,
            _ => {
                let a = (deg as f32).to_radians();
                to_light * a.cos() + side * a.sin()
            }
        };
        let view = View::look(
            eye,
            forward,
            Vec3::Y,
            60.0,
            SW as f32 / SH as f32,
            0.05,
            300.0,
        );
        let report = r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
        assert!(!skipped(&report, PassId::GodRays));
        for id in [
            TargetId::Background,
            TargetId::WindowMask,
            TargetId::WindowNormals,
            TargetId::Lit,
            TargetId::GodRays,
        ] {
            let (_, _, px) = r.read_target(&gpu, id).unwrap();
            assert!(
                px.iter().flatten().all(|v| v.is_finite()),
                "{id:?} has NaN/Inf at {deg}°"
            );
        }
        let (_, _, rays) = r.read_target(&gpu, TargetId::GodRays).unwrap();
        let energy = sum_rgb(&rays);
        if forward.dot(to_light) <= 0.0 {
            assert_eq!(
                energy, 0.0,
                "god rays with the light behind the camera at {deg}°"
            );
            assert_eq!(report.god_ray_fade, 0.0);
        }
        energies.push((deg, energy));
    }
    let peak = energies.iter().map(|e| e.1).fold(0.0, f64::max);
    assert!(peak > 0.0, "no god rays at any angle");
    // Neighbours 2° apart: the fade and the march are continuous, so no step may exceed 20 %
    // of the brightest view (a phantom or an unclamped march shows up as a jump near 90°;
    // the window entering the view measured 14 % here).
    let worst = energies
        .windows(2)
        .map(|w| ((w[1].1 - w[0].1).abs() / peak, w[0].0))
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a });
    eprintln!(
        "{setup:?}: peak god-ray energy {peak:.1}, largest 2° step {:.3} of peak at {}°",
        worst.0, worst.1
    );
    assert!(
        worst.0 <= 0.20,
        "god-ray energy jumps by {:.3} of its peak between {}° and {}°",
        worst.0,
        worst.1,
        worst.1 + 2
    );
}

#[test]
fn god_rays_are_stable_at_every_angle_to_the_sun() {
    sweep(LightSetup::Sun, Vec3::new(0.5, 1.6, 6.0));
}

#[test]
fn god_rays_are_stable_at_every_angle_to_a_lamp() {
    sweep(LightSetup::Lamp, Vec3::new(0.5, 1.6, 6.0));
}

// ---------------------------------------------------------------------------------------------
// The god-ray sum against a CPU reference of the same march.

#[test]
fn god_rays_match_cpu_reference() {
    const SW: u32 = 64;
    const SH: u32 = 36;
    let gpu = lavapipe();
    let scene = load(&gpu, &scene(Some(LightSetup::Sun), true, true));
    let rays = GodRaySettings {
        samples: 48,
        ..GodRaySettings::default()
    };
    let mut r = Renderer::headless(
        &gpu,
        &scene,
        SW,
        SH,
        Settings {
            god_rays: rays,
            ..Default::default()
        },
    )
    .unwrap();
    let view = r.view_for(&scene.toc().cameras[0]);
    r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
    let (mw, mh, mask) = r.read_target(&gpu, TargetId::WindowMask).unwrap();
    let (gw, gh, gpu_rays) = r.read_target(&gpu, TargetId::GodRays).unwrap();
    let l = scene.toc().light.as_ref().unwrap();
    let (u, fade) = god_ray_uniforms(
        &rays,
        &view,
        &LightGeometry::from_light(l),
        Vec3::from(l.colour) * l.intensity,
        0,
    );
    assert!(fade > 0.5);
    let cpu = god_rays_reference(
        &u,
        &mask,
        mw as usize,
        mh as usize,
        gw as usize,
        gh as usize,
    );
    let peak = cpu.iter().map(|c| c.max_element()).fold(0.0f32, f32::max);
    assert!(peak > 0.05, "reference has no rays (peak {peak})");
    let mut worst = 0.0f32;
    for (g, c) in gpu_rays.iter().zip(&cpu) {
        for k in 0..3 {
            worst = worst.max((g[k] - c[k]).abs());
        }
    }
    eprintln!("god rays vs CPU reference: peak {peak:.4}, max abs error {worst:.5}");
    // f16 storage (~1e-3 relative) plus the sampler's 8-bit bilinear weights.
    assert!(
        worst <= 0.01 * peak + 2e-3,
        "GPU god rays differ from the CPU reference by {worst} (peak {peak})"
    );
}

#[test]
fn sample_count_changes_accuracy_not_look() {
    let gpu = lavapipe();
    let scene = load(&gpu, &scene(Some(LightSetup::Sun), true, true));
    let mut energies = Vec::new();
    for samples in [16, 64, 256] {
        let rays = GodRaySettings {
            samples,
            ..GodRaySettings::default()
        };
        let mut r = Renderer::headless(
            &gpu,
            &scene,
            96,
            54,
            Settings {
                god_rays: rays,
                ..Default::default()
            },
        )
        .unwrap();
        let view = r.view_for(&scene.toc().cameras[0]);
        r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
        energies.push(sum_rgb(&r.read_target(&gpu, TargetId::GodRays).unwrap().2));
    }
    eprintln!("god-ray energy at 16/64/256 samples: {energies:?}");
    for e in &energies[..2] {
        let rel = (e - energies[2]).abs() / energies[2];
        assert!(
            rel < 0.05,
            "energy {e} vs {} at 256 samples ({rel:.3})",
            energies[2]
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Streaming: a first frame from the geometry and small mips, then the full-quality frame.

#[test]
fn streamed_pack_draws_early_and_ends_identical() {
    let gpu = lavapipe();
    let bytes = scene(Some(LightSetup::Sun), true, true);
    // Kept for trying the viewer on: `viewer target/tmp/render/synthetic-sun.pack --headless`.
    std::fs::write(out_dir().join("synthetic-sun.pack"), &bytes).unwrap();
    let mut reader =
        pack::StreamReader::new("<stream>", std::io::Cursor::new(bytes.clone())).unwrap();
    let first = reader.next_section().unwrap().expect("TOC");
    assert_eq!(first.role, pack::SectionRole::Toc);
    let mut scene_gpu = Scene::new(&gpu, reader.toc().unwrap()).unwrap();
    let mut r = Renderer::headless(&gpu, &scene_gpu, W, H, Settings::default()).unwrap();
    let view = r.view_for(&scene_gpu.toc().cameras[0]);
    let mut first_frame = None;
    while let Some(section) = reader.next_section().unwrap() {
        let upload = render::Upload::prepare(reader.toc().unwrap(), section, gpu.texture_caps());
        scene_gpu.upload_section(&gpu, &upload).unwrap();
        if first_frame.is_none() && scene_gpu.ready_for_first_frame() {
            assert!(
                !scene_gpu.fully_loaded(),
                "the floor's large mips should still be on their way"
            );
            scene_gpu.refresh(&gpu);
            r.render(&gpu, &scene_gpu, &view, TimingMethod::None)
                .unwrap();
            first_frame = Some(r.read_output(&gpu).unwrap());
        }
    }
    assert!(scene_gpu.fully_loaded());
    scene_gpu.refresh(&gpu);
    r.render(&gpu, &scene_gpu, &view, TimingMethod::None)
        .unwrap();
    let streamed = r.read_output(&gpu).unwrap();
    let whole = load(&gpu, &bytes);
    let (r2, _) = render_camera(&gpu, &whole, 0, Settings::default());
    assert!(
        streamed == r2.read_output(&gpu).unwrap(),
        "streamed and whole-pack frames differ"
    );
    let first_frame = first_frame.expect("a first frame before the end");
    assert!(
        first_frame != streamed,
        "the first frame should use low mips"
    );
}

// ---------------------------------------------------------------------------------------------
// Precision: the same scene far from the origin.

/// FLIP mean, FLIP 99th percentile and the largest per-channel difference (8-bit) of two
/// images of the same size.
fn image_difference(a: &image::RgbaImage, b: &image::RgbaImage) -> (f32, f32, u8) {
    let a = image::DynamicImage::ImageRgba8(a.clone()).into_rgb8();
    let b = image::DynamicImage::ImageRgba8(b.clone()).into_rgb8();
    let (w, h) = a.dimensions();
    let error = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w, h, &a),
        nv_flip::FlipImageRgb8::with_data(w, h, &b),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let mut pool = nv_flip::FlipPool::from_image(&error);
    let max = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| x.abs_diff(*y))
        .max()
        .unwrap_or(0);
    (pool.mean(), pool.get_percentile(0.99, false), max)
}

/// The default settings with god rays unjittered, so that two renders compare texel for
/// texel.
fn unjittered() -> Settings {
    Settings {
        god_rays: GodRaySettings {
            jitter: false,
            ..GodRaySettings::default()
        },
        ..Default::default()
    }
}

/// Every position of the scene (geometry, window frame, lamp, cameras) moved by 1e5 on each
/// axis renders like the scene at the origin.
///
/// f32 stores 1e5 + x to 2^-7 ≈ 0.0078 units, so the far scene's data is itself quantized
/// (here only the inside camera's height 1.6 moves, by 0.0016). Two comparisons separate that
/// from what the renderer adds: against the origin scene holding exactly the far scene's
/// (rounded) coordinates, any difference is the renderer's own precision loss; against the
/// unrounded origin scene, the difference also includes the storage rounding. A view-projection
/// matrix with a 1e5 translation in f32 fails both by far (measured before camera-relative
/// rendering: FLIP mean up to 0.32, striped walls from the inside/outside test flipping).
#[test]
fn far_from_origin_renders_like_the_origin() {
    let gpu = lavapipe();
    let settings = unjittered();
    let far = Vec3::splat(1e5);
    let placements = [
        Placement::ORIGIN,
        Placement {
            quantum: far,
            ..Placement::ORIGIN
        },
        Placement {
            offset: far,
            quantum: far,
            ..Placement::ORIGIN
        },
    ];
    let mut failures = Vec::new();
    for setup in [LightSetup::Lamp, LightSetup::Sun] {
        let scenes = placements.map(|at| load(&gpu, &scene_at(Some(setup), true, true, at)));
        for camera in 0..scenes[0].toc().cameras.len() {
            let images = scenes.each_ref().map(|s| {
                let (r, report) = render_camera(&gpu, s, camera, settings);
                (r.read_output(&gpu).unwrap(), report.god_ray_fade)
            });
            let name = &scenes[0].toc().cameras[camera].name;
            let stem = format!("far-{setup:?}-{name}").to_lowercase();
            for (image, what) in images.iter().zip(["origin", "origin-rounded", "offset"]) {
                image
                    .0
                    .save(out_dir().join(format!("{stem}-{what}.png")))
                    .unwrap();
            }
            assert_eq!(images[0].1, images[2].1, "god-ray fade differs");
            // Tolerances: with the same rounded data, lavapipe gives identical images;
            // 0.001 FLIP mean and a few LSB leave room for drivers that round the one
            // vertex-minus-camera subtraction differently. The storage rounding moves the
            // camera by 0.0016 units, which shifts edges by a fraction of a pixel: measured
            // FLIP mean 0.0037, p99 0.029, and full-range steps on single edge pixels, so
            // that comparison bounds the mean and p99 only.
            for (reference, max_mean, max_p99, max_lsb, what) in [
                (
                    1,
                    0.001,
                    0.01,
                    8u8,
                    "same rounded coordinates at the origin",
                ),
                (0, 0.006, 0.04, u8::MAX, "unrounded scene at the origin"),
            ] {
                let (mean, p99, max) = image_difference(&images[reference].0, &images[2].0);
                eprintln!(
                    "{setup:?} {name}, offset 1e5 vs {what}: FLIP mean {mean:.5}, p99 {p99:.5}, \
                     max channel difference {max} LSB"
                );
                if !(mean <= max_mean && p99 <= max_p99 && max <= max_lsb) {
                    failures.push(format!(
                        "{setup:?} {name} vs {what}: FLIP mean {mean:.5} (max {max_mean}), \
                         p99 {p99:.5} (max {max_p99}), {max} LSB (max {max_lsb})"
                    ));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "far from the origin renders differently (images in {}):\n{}",
        out_dir().display(),
        failures.join("\n")
    );
}

/// The scene a thousandth the size (a model in metres at 1:1000, or one in kilometres), or ten
/// thousand times it (a cathedral in millimetres), renders as it does at full size. The lit
/// pass's inside test stepped 0.01 units off each surface and allowed 0.001 behind a window's
/// plane, whatever the scene's size: in the small scene the outside floor along the wall was
/// taken as inside, dark but for the window's projector (FLIP mean 0.03, p99 0.9 from
/// outside), and a small church's inner walls as outside, lit whole by the sun; in the large
/// one, coarser in f32 than that slack, walls in a window's plane went in and out of the
/// building from texel to texel, in white streaks.
#[test]
fn a_scene_a_thousandth_or_ten_thousand_times_the_size_renders_alike() {
    let gpu = lavapipe();
    let settings = unjittered();
    let mut failures = Vec::new();
    for (scale, what) in [(1e-3, "1:1000"), (1e4, "10000:1")] {
        let scaled = Placement {
            scale,
            ..Placement::ORIGIN
        };
        for setup in [LightSetup::Sun, LightSetup::Lamp] {
            let scenes = [Placement::ORIGIN, scaled]
                .map(|at| load(&gpu, &scene_at(Some(setup), true, true, at)));
            for camera in 0..scenes[0].toc().cameras.len() {
                let images = scenes.each_ref().map(|s| {
                    let (r, _) = render_camera(&gpu, s, camera, settings);
                    r.read_output(&gpu).unwrap()
                });
                let name = &scenes[0].toc().cameras[camera].name;
                let stem = format!("scaled-{scale}-{setup:?}-{name}").to_lowercase();
                for (image, which) in images.iter().zip(["full", "scaled"]) {
                    image
                        .save(out_dir().join(format!("{stem}-{which}.png")))
                        .unwrap();
                }
                let (mean, p99, max) = image_difference(&images[0], &images[1]);
                eprintln!(
                    "{setup:?} {name}, {what} against 1:1: FLIP mean {mean:.5}, p99 {p99:.5}, \
                     max {max} LSB"
                );
                if !(mean <= 0.003 && p99 <= 0.03) {
                    failures.push(format!(
                        "{what} {setup:?} {name}: FLIP mean {mean:.5} (max 0.003), p99 \
                         {p99:.5} (max 0.03)"
                    ));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "the scaled scene renders differently (images in {}):\n{}",
        out_dir().display(),
        failures.join("\n")
    );
}

// ---------------------------------------------------------------------------------------------
// Sampling along triangle edges and at a design's borders.

/// The width and the window-mask target of `b`'s scene seen from `position` toward `target`.
fn window_mask_seen(
    gpu: &Gpu,
    mut b: Builder,
    position: [f32; 3],
    target: [f32; 3],
    fov_y: f32,
) -> (u32, Vec<[f32; 4]>) {
    b.toc.cameras = vec![Camera {
        name: "seen".into(),
        position,
        target,
        up: [0.0, 1.0, 0.0],
        fov_y,
        near: 0.05,
        far: 300.0,
    }];
    let scene = load(gpu, &b.finish());
    let (r, _) = render_camera(gpu, &scene, 0, unjittered());
    let (w, _, px) = r.read_target(gpu, TargetId::WindowMask).unwrap();
    (w, px)
}

/// A window's colour does not depend on which diagonal cuts its quad into triangles.
/// lavapipe's anisotropic sampling with explicit gradients read a far smaller mip at some
/// pixels along triangle edges: dots of another colour down every window's diagonal in the
/// default scene, which an NVIDIA H200 did not draw. Here 3 pixels were 0.49 apart at most in
/// the window-mask target; with implicit gradients the two cuts differ by 0.08 at most (the
/// rounding of two triangles' interpolation, on the design's lead lines).
#[test]
fn a_window_looks_the_same_whichever_diagonal_cuts_its_quad() {
    let gpu = lavapipe();
    let masks = [false, true].map(|flip| {
        let mut b = scene_builder(Some(LightSetup::Sun), true, false, Placement::ORIGIN);
        // A design finer than the pixels it covers, as real windows seen across a nave are.
        let fine = b.texture("fine glass", TextureRole::Colour, 1024, |u, v| {
            glass((u * 8.0).fract(), (v * 8.0).fract())
        });
        let window = b.toc.windows[0].material as usize;
        b.toc.materials[window].diffuse_texture = Some(fine);
        if flip {
            // The window is the last quad: corners 0-1-2-3, cut 0-2 by `quad`; cut it 1-3.
            let n = b.indices.len();
            let base = b.indices[n - 6];
            b.indices[n - 6..].copy_from_slice(&[
                base,
                base + 1,
                base + 3,
                base + 1,
                base + 2,
                base + 3,
            ]);
        }
        // Where lavapipe drew the dots (its inside camera's wider view drew none).
        window_mask_seen(&gpu, b, [0.5, 1.6, 9.0], [0.0, 2.0, 0.0], 50.0).1
    });
    let covered = masks[0].iter().filter(|p| p[3] > 0.5).count();
    assert!(covered > 2000, "the window covers only {covered} pixels");
    let (mut worst, mut at, mut off) = (0.0f32, 0, 0);
    for (i, (a, b)) in masks[0].iter().zip(&masks[1]).enumerate() {
        let d = (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f32::max);
        off += usize::from(d > 0.25);
        if d > worst {
            (worst, at) = (d, i);
        }
    }
    eprintln!("two cuts of the window: {worst:.3} apart at most");
    assert!(
        off == 0,
        "{off} window-mask pixels differ by over 0.25 between the two cuts, the most {worst:.3} \
         at ({}, {})",
        at as u32 % W,
        at as u32 / W
    );
}

/// A window's design is not tiled: filtering at its top edge shows its top row, not a blend
/// with its bottom row. An 8-texel design, blue above and red below, seen close up: with the
/// repeating sampler every material had, the top rows of the glass came out purple (an
/// outside tester's 16x12 sky-and-ground design: (165, 135, 192) where (120, 180, 255) was
/// drawn). The floor beside it tiles (coordinates to 4 and 6) and still repeats: the reference
/// images above would show it smeared otherwise.
#[test]
fn a_window_design_is_clamped_at_its_edges() {
    let gpu = lavapipe();
    let mut b = scene_builder(Some(LightSetup::Sun), true, false, Placement::ORIGIN);
    let design = b.texture("two bands", TextureRole::Colour, 8, |_, v| {
        if v < 0.5 {
            [40, 80, 250, 255]
        } else {
            [250, 30, 30, 255]
        }
    });
    let window = b.toc.windows[0].material as usize;
    b.toc.materials[window].diffuse_texture = Some(design);
    let (w, mask) = window_mask_seen(&gpu, b, [0.0, 2.5, 3.0], [0.0, 2.5, 0.0], 70.0);
    let rows: Vec<usize> = (0..mask.len() / w as usize)
        .filter(|y| (0..w as usize).any(|x| mask[y * w as usize + x][3] > 0.5))
        .collect();
    assert!(rows.len() > 40, "the window covers {} rows", rows.len());
    // The top and bottom few rows of the glass, where a repeating sampler blends the far edge.
    let mask = &mask;
    let edge = |ys: &[usize]| {
        ys.iter()
            .flat_map(|&y| (0..w as usize).map(move |x| mask[y * w as usize + x]))
            .filter(|p| p[3] > 0.5)
            .fold([0.0f32; 2], |m, p| [m[0].max(p[0]), m[1].max(p[2])])
    };
    let [top_red, _] = edge(&rows[..4]);
    let [_, bottom_blue] = edge(&rows[rows.len() - 4..]);
    assert!(
        top_red < 0.05 && bottom_blue < 0.05,
        "the glass's top rows hold red up to {top_red:.3} and its bottom rows blue up to \
         {bottom_blue:.3} (linear): the design's far edge is blended in"
    );
}

/// The background's panorama is seen where nothing covers the view, the right way round: an
/// equirectangular image of four colours around the horizon (centred on -z, +x, +z and -x, at
/// u 0.5, 0.75, 0 and 0.25) and white above is seen in each direction, scaled by the
/// background colour, and from inside it +x is on the right. It was cooked into the pack but
/// never drawn: behind windows and around the building the flat colour showed.
#[test]
fn the_panorama_is_seen_around_the_view_the_right_way_round() {
    let gpu = lavapipe();
    let (w, h) = (64u32, 32u32);
    // sRGB bytes: red, green, blue and yellow around the horizon, white in the top quarter.
    let around: [[u8; 3]; 4] = [[200, 30, 30], [30, 200, 30], [30, 30, 200], [200, 200, 30]];
    let level0: Vec<u8> = (0..w * h)
        .flat_map(|i| {
            let (x, y) = (i % w, i / w);
            let c = if y < h / 4 {
                [255, 255, 255]
            } else {
                // Stripe k is centred on u = k/4: -z (k = 2) faces the image's middle.
                let u = (x as f32 + 0.5) / w as f32;
                around[((u * 4.0 + 0.5).floor() as usize) % 4]
            };
            [c[0], c[1], c[2], 255]
        })
        .collect();
    let (mips, levels) = mip_chain(w, h, level0);
    let mut toc = Toc::default();
    let mut data = PackData::default();
    toc.textures.push(Texture {
        name: "sky".into(),
        role: TextureRole::Colour,
        colour_space: ColourSpace::Srgb,
        format: TextureFormat::Rgba8,
        supercompression: pack::Supercompression::None,
        width: w,
        height: h,
        mips,
    });
    data.textures.push(levels);
    toc.materials.push(Material {
        name: "floor".into(),
        class: MaterialClass::Floor,
        diffuse: [0.5; 3],
        specular: [0.0; 3],
        shininess: 1.0,
        emissive: [0.0; 3],
        diffuse_texture: None,
        normal_texture: None,
        projector_texture: None,
        projector_margin: [0.0; 2],
    });
    toc.background = Background {
        colour: [0.5, 0.5, 0.5],
        panorama: Some(0),
    };
    let look = |name: &str, d: Vec3| Camera {
        name: name.into(),
        position: [0.0, 0.0, 0.0],
        target: d.to_array(),
        up: if d.y.abs() > 0.5 {
            [0.0, 0.0, -1.0]
        } else {
            [0.0, 1.0, 0.0]
        },
        fov_y: 20.0,
        near: 0.05,
        far: 100.0,
    };
    toc.cameras = vec![
        look("-z", Vec3::NEG_Z),
        look("+x", Vec3::X),
        look("+z", Vec3::Z),
        look("-x", Vec3::NEG_X),
        look("up", Vec3::Y),
        Camera {
            fov_y: 90.0,
            ..look("wide -z", Vec3::NEG_Z)
        },
    ];
    // A small floor far below every view: the pack's one mesh.
    let v = |x: f32, z: f32| StandardVertex {
        position: [x, -50.0, z],
        normal: [0.0, 1.0, 0.0],
        uv: [0.0; 2],
        tangent: [1.0, 0.0, 0.0, 1.0],
        material: [0, 0],
        colour: pack::vertex::WHITE,
    };
    let bytes = common::encode_scene(
        toc,
        data,
        &[v(-1.0, -1.0), v(1.0, -1.0), v(1.0, 1.0), v(-1.0, 1.0)],
        &[0, 1, 2, 0, 2, 3],
        vec![DrawRange {
            material: 0,
            first_index: 0,
            index_count: 6,
        }],
    );
    let scene = load(&gpu, &bytes);
    // The background colour scales the panorama's linear texels.
    let expect = |c: [u8; 3]| {
        c.map(|b| {
            let l = if b as f32 / 255.0 <= 0.04045 {
                b as f32 / 255.0 / 12.92
            } else {
                ((b as f32 / 255.0 + 0.055) / 1.055).powf(2.4)
            };
            0.5 * l
        })
    };
    for (camera, want) in [
        (0, around[2]),
        (1, around[3]),
        (2, around[0]),
        (3, around[1]),
        (4, [255, 255, 255]),
    ] {
        let (r, _) = render_camera(&gpu, &scene, camera, Settings::default());
        let (tw, th, px) = r.read_target(&gpu, TargetId::Lit).unwrap();
        let centre = px[(th / 2 * tw + tw / 2) as usize];
        let want = expect(want);
        assert!(
            (0..3).all(|k| (centre[k] - want[k]).abs() < 0.01),
            "camera {:?}: {centre:?}, want {want:?}",
            scene.toc().cameras[camera].name
        );
    }
    // A view along -z 90° high (121° wide at 16:9): its edges look 60° to each side, at u
    // 0.33 and 0.67, inside the stripes centred on -x and +x.
    let (r, _) = render_camera(&gpu, &scene, 5, Settings::default());
    let (tw, th, px) = r.read_target(&gpu, TargetId::Lit).unwrap();
    let row = th / 2;
    let (left, right) = (
        px[(row * tw + 2) as usize],
        px[(row * tw + tw - 3) as usize],
    );
    // Seen from inside, the stripe centred on -x (green) lies left of -z, +x's (yellow) right.
    assert!(
        left[1] > 2.0 * left[2] && left[1] > 2.0 * left[0],
        "left {left:?}"
    );
    assert!(
        right[0] > 2.0 * right[2] && right[1] > 2.0 * right[2],
        "right {right:?}"
    );
}
