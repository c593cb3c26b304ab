//! Window light that stops at stone: the GPU's shadow maps against the CPU ray-traced
//! reference (`render::reference`, rules in docs/reference-tracer.md) and against geometry
//! worked out here.
//!
//! The fixture is a pillar hall cooked from an OBJ through the real pipeline: a closed room lit
//! only through a skylight (or a window in a wall) by a slanted sun, with a pillar (or a thin
//! mullion) standing in the light. The default scene is compared camera by camera. Images are
//! small: lavapipe is a CPU renderer.
//!
//! Needs an adapter (lavapipe in CI); no adapter fails, never skips.

mod common;
use common::{flip_mean, gpu, tone_mapped};

use std::fmt::Write as _;
use std::path::Path;

use glam::Vec3;
use render::occlusion::{Blocker, WindowShadow};
use render::reference::{Reference, ReferenceSettings};
use render::{Gpu, PassId, Renderer, Scene, Settings, TargetId, TimingMethod, View};

// ---------------------------------------------------------------------------------------------
// The pillar hall: a 12 x 12 m room 8 m high, floor at y = 0.

const HALF: f32 = 6.0;
const HEIGHT: f32 = 8.0;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Opening {
    /// A 3 x 3 m skylight in the middle of the roof.
    Skylight,
    /// Two 2 m wide, 2 m tall windows in the wall at x = −6, sills at 1 m: the first at
    /// z in [−3.5, −1.5], the second at z in [1.5, 3.5].
    WallWindows,
    /// [`Opening::WallWindows`]' two windows with the wall at x = −6 left whole: each pane sits
    /// 5 cm inside it, as glazing is often modelled on walls never cut open.
    GlassOnUncutWall,
    /// A roof pierced by an n x n grid of square skylights ([`grid`]), each its own window.
    SkylightGrid(usize),
    /// One lancet 0.6 m wide and 2.4 m tall in the wall at x = −6, z in [−0.3, 0.3], sill at
    /// 1 m, its square design (a checker of 4 x 4 panes) stretched four times up the glass.
    Lancet,
}

/// The centres (in x and in z) of an n x n skylight grid's holes, spread evenly over the roof,
/// and the holes' half size (0.3 of their spacing): 7 x 7 holes of 0.9 m at −4.5, −3, …, 4.5.
fn grid(n: usize) -> (Vec<f32>, f32) {
    let pitch = 2.0 * HALF / (n + 1) as f32;
    let centres = (1..=n).map(|i| -HALF + pitch * i as f32).collect();
    (centres, 0.3 * pitch)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Sun {
    Directional {
        travel: Vec3,
        angular_size_deg: f32,
    },
    Lamp {
        position: Vec3,
        radius: f32,
        intensity: f32,
    },
    /// A lamp whose light is limited to a cone around `axis` (half-angles in degrees).
    Spot {
        position: Vec3,
        radius: f32,
        intensity: f32,
        axis: Vec3,
        inner_deg: f32,
        outer_deg: f32,
    },
}

#[derive(Clone, Debug)]
struct Hall {
    opening: Opening,
    light: Sun,
    /// Boxes standing on the floor (or anywhere): min and max corners.
    boxes: Vec<(Vec3, Vec3)>,
    /// Added to every position (and camera).
    offset: Vec3,
    /// (name, position, target) of the manifest's cameras, before the offset.
    cameras: Vec<(&'static str, Vec3, Vec3)>,
}

/// The sun of the skylight fixtures: slanted 17° from vertical towards +x, a little to +z.
const SKY_TRAVEL: Vec3 = Vec3::new(0.3, -1.0, 0.1);

/// The pillar: 0.6 x 0.6 m, 5 m tall, standing in the skylight's light.
const PILLAR: (Vec3, Vec3) = (Vec3::new(1.5, 0.0, 0.2), Vec3::new(2.1, 5.0, 0.8));

impl Hall {
    fn pillar() -> Self {
        Self {
            opening: Opening::Skylight,
            light: Sun::Directional {
                travel: SKY_TRAVEL,
                angular_size_deg: 2.0,
            },
            boxes: vec![PILLAR],
            offset: Vec3::ZERO,
            cameras: vec![
                (
                    "overview",
                    Vec3::new(-4.5, 5.5, -4.8),
                    Vec3::new(2.4, 0.0, 0.8),
                ),
                ("down", Vec3::new(2.6, 3.0, 0.6), Vec3::new(2.6, 0.0, 0.61)),
                ("side", Vec3::new(5.5, 2.5, -3.5), Vec3::new(2.4, 0.0, 0.8)),
            ],
        }
    }
}

/// An OBJ under construction: quads with their own UVs and one normal each.
#[derive(Default)]
struct Obj {
    text: String,
    v: usize,
    vn: usize,
}

impl Obj {
    /// `o + s·a + t·b`, (s, t) in [0, 1]², UV (s, t), facing `n`.
    fn quad(&mut self, mtl: &str, o: Vec3, a: Vec3, b: Vec3, n: Vec3) {
        let t = &mut self.text;
        let _ = writeln!(t, "usemtl {mtl}");
        for p in [o, o + a, o + a + b, o + b] {
            let _ = writeln!(t, "v {} {} {}", p.x, p.y, p.z);
        }
        let _ = writeln!(t, "vn {} {} {}", n.x, n.y, n.z);
        let (v, vn) = (self.v, self.vn + 1);
        // OBJ texture coordinates: one set per corner, shared by every quad.
        let _ = writeln!(
            t,
            "f {}/1/{vn} {}/2/{vn} {}/3/{vn}\nf {}/1/{vn} {}/3/{vn} {}/4/{vn}",
            v + 1,
            v + 2,
            v + 3,
            v + 1,
            v + 3,
            v + 4
        );
        self.v += 4;
        self.vn += 1;
    }

    /// Five faces of a box (no bottom), facing out.
    fn block(&mut self, mtl: &str, lo: Vec3, hi: Vec3) {
        let d = hi - lo;
        let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
        self.quad(mtl, lo + y, z, x, Vec3::Y);
        self.quad(mtl, lo, x, y, Vec3::NEG_Z);
        self.quad(mtl, lo + z, y, x, Vec3::Z);
        self.quad(mtl, lo, y, z, Vec3::NEG_X);
        self.quad(mtl, lo + x, z, y, Vec3::X);
    }

    fn finish(self) -> String {
        format!("vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n{}", self.text)
    }
}

/// Cooks the hall; returns the pack's bytes.
fn cook_hall(hall: &Hall, dir: &Path) -> Vec<u8> {
    let o = hall.offset;
    let (h, top) = (HALF, HEIGHT);
    let mut obj = Obj::default();
    // Floor and walls face into the room.
    obj.quad(
        "floor",
        o + Vec3::new(-h, 0.0, -h),
        Vec3::Z * 2.0 * h,
        Vec3::X * 2.0 * h,
        Vec3::Y,
    );
    let wall = |obj: &mut Obj, corner: Vec3, a: Vec3, b: Vec3, n: Vec3| {
        obj.quad("stone", o + corner, a, b, n);
    };
    wall(
        &mut obj,
        Vec3::new(-h, 0.0, -h),
        Vec3::X * 2.0 * h,
        Vec3::Y * top,
        Vec3::Z,
    );
    wall(
        &mut obj,
        Vec3::new(-h, 0.0, h),
        Vec3::Y * top,
        Vec3::X * 2.0 * h,
        Vec3::NEG_Z,
    );
    wall(
        &mut obj,
        Vec3::new(h, 0.0, -h),
        Vec3::Y * top,
        Vec3::Z * 2.0 * h,
        Vec3::NEG_X,
    );
    let roof = |obj: &mut Obj, x0: f32, x1: f32, z0: f32, z1: f32| {
        obj.quad(
            "stone",
            o + Vec3::new(x0, top, z0),
            Vec3::X * (x1 - x0),
            Vec3::Z * (z1 - z0),
            Vec3::NEG_Y,
        );
    };
    // The wall at x = −6 is whole unless its windows are the opening.
    if !matches!(hall.opening, Opening::WallWindows | Opening::Lancet) {
        wall(
            &mut obj,
            Vec3::new(-h, 0.0, -h),
            Vec3::Z * 2.0 * h,
            Vec3::Y * top,
            Vec3::X,
        );
    }
    // A piece of the wall at x = −6, z in [z0, z1], y in [y0, y1], around its openings.
    let x = -h;
    let piece = |obj: &mut Obj, z0: f32, z1: f32, y0: f32, y1: f32| {
        obj.quad(
            "stone",
            o + Vec3::new(x, y0, z0),
            Vec3::Z * (z1 - z0),
            Vec3::Y * (y1 - y0),
            Vec3::X,
        );
    };
    match hall.opening {
        Opening::Skylight => {
            let s = 1.5;
            roof(&mut obj, -h, h, -h, -s);
            roof(&mut obj, -h, h, s, h);
            roof(&mut obj, -h, -s, -s, s);
            roof(&mut obj, s, h, -s, s);
            obj.quad(
                "glass_a",
                o + Vec3::new(-s, top, -s),
                Vec3::X * 2.0 * s,
                Vec3::Z * 2.0 * s,
                Vec3::NEG_Y,
            );
        }
        Opening::SkylightGrid(n) => {
            let (centres, half) = grid(n);
            // Full-width strips between the rows of holes, pieces between the holes of a row.
            let mut z = -h;
            for (row, &cz) in centres.iter().enumerate() {
                roof(&mut obj, -h, h, z, cz - half);
                let mut x = -h;
                for (col, &cx) in centres.iter().enumerate() {
                    roof(&mut obj, x, cx - half, cz - half, cz + half);
                    obj.quad(
                        &format!("glass_{row}_{col}"),
                        o + Vec3::new(cx - half, top, cz - half),
                        Vec3::X * 2.0 * half,
                        Vec3::Z * 2.0 * half,
                        Vec3::NEG_Y,
                    );
                    x = cx + half;
                }
                roof(&mut obj, x, h, cz - half, cz + half);
                z = cz + half;
            }
            roof(&mut obj, -h, h, z, h);
        }
        Opening::GlassOnUncutWall => {
            roof(&mut obj, -h, h, -h, h);
            for (z0, name) in [(-3.5, "glass_a"), (1.5, "glass_b")] {
                obj.quad(
                    name,
                    o + Vec3::new(-h + 0.05, 1.0, z0),
                    Vec3::Z * 2.0,
                    Vec3::Y * 2.0,
                    Vec3::X,
                );
            }
        }
        Opening::WallWindows => {
            roof(&mut obj, -h, h, -h, h);
            piece(&mut obj, -h, -3.5, 0.0, top);
            piece(&mut obj, -1.5, 1.5, 0.0, top);
            piece(&mut obj, 3.5, h, 0.0, top);
            for (z0, name) in [(-3.5, "glass_a"), (1.5, "glass_b")] {
                piece(&mut obj, z0, z0 + 2.0, 0.0, 1.0);
                piece(&mut obj, z0, z0 + 2.0, 3.0, top);
                obj.quad(
                    name,
                    o + Vec3::new(x, 1.0, z0),
                    Vec3::Z * 2.0,
                    Vec3::Y * 2.0,
                    Vec3::X,
                );
            }
        }
        Opening::Lancet => {
            roof(&mut obj, -h, h, -h, h);
            piece(&mut obj, -h, -0.3, 0.0, top);
            piece(&mut obj, 0.3, h, 0.0, top);
            piece(&mut obj, -0.3, 0.3, 0.0, 1.0);
            piece(&mut obj, -0.3, 0.3, 3.4, top);
            obj.quad(
                "glass_a",
                o + Vec3::new(x, 1.0, -0.3),
                Vec3::Z * 0.6,
                Vec3::Y * 2.4,
                Vec3::X,
            );
        }
    }
    for &(lo, hi) in &hall.boxes {
        obj.block("pillar", o + lo, o + hi);
    }
    std::fs::write(dir.join("hall.obj"), obj.finish()).unwrap();
    // Warm glass with a faint tint gradient, so the projected pattern is visible but smooth; the
    // lancet's panes are sharp-edged, so its blur shows.
    let design = if hall.opening == Opening::Lancet {
        image::RgbaImage::from_fn(64, 64, |x, y| {
            image::Rgba(if (x / 16 + y / 16) % 2 == 0 {
                [235, 190, 120, 255]
            } else {
                [60, 80, 200, 255]
            })
        })
    } else {
        image::RgbaImage::from_fn(64, 64, |x, y| {
            image::Rgba([
                235,
                (200.0 + x as f32 * 0.5) as u8,
                (150.0 + y as f32 * 0.8) as u8,
                255,
            ])
        })
    };
    design.save(dir.join("design.png")).unwrap();
    let light = match hall.light {
        Sun::Directional {
            travel: t,
            angular_size_deg,
        } => format!(
            "type = \"directional\"\ndirection = [{}, {}, {}]\nangular_size_deg = {angular_size_deg}\n\
             intensity = 3.0\n",
            t.x, t.y, t.z
        ),
        Sun::Lamp {
            position,
            radius,
            intensity,
        } => {
            let p = position + o;
            format!(
                "type = \"point\"\nposition = [{}, {}, {}]\nradius = {radius}\n\
                 intensity = {intensity}\n",
                p.x, p.y, p.z
            )
        }
        Sun::Spot {
            position,
            radius,
            intensity,
            axis: a,
            inner_deg,
            outer_deg,
        } => {
            let p = position + o;
            format!(
                "type = \"spot\"\nposition = [{}, {}, {}]\nradius = {radius}\n\
                 direction = [{}, {}, {}]\ninner_cone_deg = {inner_deg}\n\
                 outer_cone_deg = {outer_deg}\nintensity = {intensity}\n",
                p.x, p.y, p.z, a.x, a.y, a.z
            )
        }
    };
    let mut manifest = format!(
        "# A pillar hall lit through its roof or walls; written by tests/tests/shadows.rs.\n\n\
         [[mesh]]\nsource = \"hall.obj\"\n\n\
         [[rule]]\nmatch = \"floor\"\nclass = \"floor\"\ndiffuse = [0.7, 0.7, 0.7]\n\
         specular = [0.0, 0.0, 0.0]\n\n\
         [[rule]]\nmatch = \"{{stone,pillar}}\"\nclass = \"wall\"\ndiffuse = [0.6, 0.58, 0.55]\n\
         specular = [0.0, 0.0, 0.0]\n\n\
         [[rule]]\nmatch = \"glass_*\"\nclass = \"window-upper\"\n\n\
         [[window]]\nmaterial = \"glass_*\"\ndesign = \"design.png\"\n\n\
         [light]\n{light}"
    );
    for (name, p, target) in &hall.cameras {
        let (p, target) = (*p + o, *target + o);
        let _ = write!(
            manifest,
            "\n[[camera]]\nname = \"{name}\"\nposition = [{}, {}, {}]\n\
             target = [{}, {}, {}]\nfov_y_deg = 50.0\nnear = 0.05\nfar = 100.0\n",
            p.x, p.y, p.z, target.x, target.y, target.z
        );
    }
    let path = dir.join("hall.toml");
    std::fs::write(&path, manifest).unwrap();
    let m = cook::Manifest::load(&path).unwrap();
    let out = cook::cook(&m, &cook::Settings::new(&m)).unwrap();
    pack::encode(out.toc, &out.data).unwrap()
}

/// The ray-traced reference of a cooked hall, and its settings without ambient light (as
/// [`no_ambient`] for the GPU).
fn hall_reference(bytes: &[u8]) -> (Reference, ReferenceSettings) {
    let pack = pack::Pack::from_bytes("<hall>", bytes).unwrap();
    let settings = ReferenceSettings {
        ambient: [0.0; 3],
        ..Default::default()
    };
    (Reference::from_pack(&pack), settings)
}

fn no_ambient() -> Settings {
    Settings {
        ambient: [0.0; 3],
        ..Default::default()
    }
}

fn without_occlusion(mut s: Settings) -> Settings {
    s.shadows.enabled = false;
    s
}

/// The lit pass of camera `camera` at `w`×`h` and the view it was drawn from.
fn lit(
    gpu: &Gpu,
    scene: &Scene,
    camera: usize,
    (w, h): (u32, u32),
    settings: Settings,
) -> (Vec<[f32; 4]>, View, render::FrameReport) {
    let mut r = Renderer::headless(gpu, scene, w, h, settings).unwrap();
    let view = r.view_for(&scene.toc().cameras[camera]);
    let report = r.render(gpu, scene, &view, TimingMethod::None).unwrap();
    let (_, _, px) = r.read_target(gpu, TargetId::Lit).unwrap();
    (px, view, report)
}

/// The lit pass drawn at four times the size and averaged 4 x 4 down to `size`: 16 samples
/// per pixel, as the reference takes (`ReferenceSettings::default`), so the comparison is of
/// the light, not of how each filters a pixel's footprint (the GPU has no antialiasing, and its
/// mip filter is wider than a pixel's box). At 2 x 2 the default scene's `floor` camera read
/// FLIP 0.055 instead of 0.040, from the projected patterns' minification alone.
fn lit_supersampled(
    gpu: &Gpu,
    scene: &Scene,
    camera: usize,
    (w, h): (u32, u32),
    settings: Settings,
) -> (Vec<[f32; 4]>, View) {
    // Same aspect ratio, so the same view.
    let (px, view, _) = lit(gpu, scene, camera, (4 * w, 4 * h), settings);
    let mut out = vec![[0.0f32; 4]; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let mut sum = [0.0f32; 4];
            for (dx, dy) in (0..16).map(|k| (k % 4, k / 4)) {
                let p = px[((4 * y + dy) * 4 * w + 4 * x + dx) as usize];
                for c in 0..4 {
                    sum[c] += p[c] / 16.0;
                }
            }
            out[(y * w + x) as usize] = sum;
        }
    }
    (out, view)
}

fn luminance(p: [f32; 4]) -> f32 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

/// The pixel (x right, y down) a world point lands on, if on screen.
fn pixel_of(view: &View, p: Vec3, (w, h): (u32, u32)) -> Option<(u32, u32)> {
    let c = view.clip(p.extend(1.0));
    if c.w <= 0.0 {
        return None;
    }
    let x = (c.x / c.w + 1.0) * 0.5 * w as f32;
    let y = (1.0 - c.y / c.w) * 0.5 * h as f32;
    ((0.0..w as f32).contains(&x) && (0.0..h as f32).contains(&y)).then_some((x as u32, y as u32))
}

/// Mean luminance over the 3 x 3 pixels around where `p` lands.
fn around(px: &[[f32; 4]], view: &View, p: Vec3, size: (u32, u32)) -> f32 {
    let (x, y) = pixel_of(view, p, size).unwrap_or_else(|| panic!("{p} is off screen"));
    let mut sum = 0.0;
    let mut n = 0.0;
    for dy in -1i32..=1 {
        for dx in -1i32..=1 {
            let (xx, yy) = (x as i32 + dx, y as i32 + dy);
            if (0..size.0 as i32).contains(&xx) && (0..size.1 as i32).contains(&yy) {
                sum += luminance(px[(yy as u32 * size.0 + xx as u32) as usize]);
                n += 1.0;
            }
        }
    }
    sum / n
}

/// The floor point whose line to the sun passes `p` (travelling along `travel`).
fn on_floor_behind(p: Vec3, travel: Vec3) -> Vec3 {
    p + travel * (-p.y / travel.y)
}

/// The pillar hall is committed in `tests/data/pillar-hall/` for the bench report and for
/// viewing (`viewer tests/data/pillar-hall/hall.toml`); it must be what [`Hall::pillar`]
/// builds (`BLESS=1` rewrites it).
fn committed_fixture_is_current(built: &Path) {
    let committed = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/pillar-hall");
    let bless = std::env::var_os("BLESS").is_some_and(|v| v == "1");
    for name in ["hall.obj", "hall.toml", "design.png"] {
        let (a, b) = (built.join(name), committed.join(name));
        if bless {
            std::fs::create_dir_all(&committed).unwrap();
            std::fs::copy(&a, &b).unwrap();
            continue;
        }
        let same = if name.ends_with(".png") {
            let load = |p: &Path| image::open(p).map(|i| i.into_rgba8());
            matches!((load(&a), load(&b)), (Ok(x), Ok(y)) if x == y)
        } else {
            std::fs::read(&a).ok() == std::fs::read(&b).ok()
        };
        assert!(
            same,
            "{} differs from what Hall::pillar builds; run with BLESS=1 after checking",
            b.display()
        );
    }
}

/// Mean FLIP of the GPU's lit pass against the reference (both tone mapped); both images and
/// the FLIP map are written to the test's temporary folder for a look.
fn compare(name: &str, (w, h): (u32, u32), traced: &[[f32; 4]], gpu: &[[f32; 4]]) -> f32 {
    let (a, b) = (tone_mapped(w, h, traced), tone_mapped(w, h, gpu));
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("shadows");
    std::fs::create_dir_all(&out).unwrap();
    a.save(out.join(format!("{name}-reference.png"))).unwrap();
    b.save(out.join(format!("{name}-gpu.png"))).unwrap();
    flip_mean(&a, &b)
}

// ---------------------------------------------------------------------------------------------

/// The issue's own test: the floor behind the pillar, on the line to the sun, receives at most
/// 35% of the window light beside it (the renderer without occlusion shows it as bright), its
/// soft edge is as wide as the physical penumbra, and the GPU's lit pass matches the
/// ray-traced reference.
#[test]
fn pillar_in_the_skylight_casts_a_shadow_like_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let hall = Hall::pillar();
    let bytes = cook_hall(&hall, dir.path());
    committed_fixture_is_current(dir.path());
    let gpu = gpu();
    let scene = common::load(&gpu, &bytes);
    assert_eq!(
        scene.window_shadows(),
        &[WindowShadow::Occluded(Blocker::Inside)],
        "the pillar stands in the skylight's light"
    );
    let (reference, rs) = hall_reference(&bytes);

    // Seen from above: the shadow behind the pillar's middle, and a point beside it.
    let size = (160, 160);
    let (on, view, report) = lit(&gpu, &scene, 1, size, no_ambient());
    assert!(
        report
            .passes
            .iter()
            .any(|p| p.pass == PassId::Shadows && p.skipped.is_none()),
        "{report:?}"
    );
    let (off, _, _) = lit(&gpu, &scene, 1, size, without_occlusion(no_ambient()));
    let traced = reference.render_lit(&view, size.0, size.1, &rs);
    let centre = (PILLAR.0 + PILLAR.1) * 0.5;
    let behind = on_floor_behind(centre, SKY_TRAVEL);
    let beside = behind + Vec3::new(0.0, 0.0, -1.0);
    for (what, px) in [("GPU", &on), ("reference", &traced)] {
        let (b, s) = (
            around(px, &view, behind, size),
            around(px, &view, beside, size),
        );
        eprintln!(
            "{what}: behind the pillar {b:.4}, beside it {s:.4}: {:.1} %",
            b / s * 100.0
        );
        assert!(s > 0.05, "{what}: no window light beside the pillar ({s})");
        assert!(
            b <= 0.35 * s,
            "{what}: the floor behind the pillar gets {:.0} % of the light beside it",
            b / s * 100.0
        );
    }
    // Plain projective texturing lights it fully: this test can fail.
    let (b, s) = (
        around(&off, &view, behind, size),
        around(&off, &view, beside, size),
    );
    assert!(b > 0.8 * s, "without occlusion: {b} against {s}");

    // The soft edge: across the shadow's side cast by the pillar's vertical edge at height 3 m,
    // the 10–90 % rise is about the physical penumbra, 0.687 θ D for a uniform disc of
    // angular diameter θ at distance D (the 10 % and 90 % chords sit at ±0.687 of its radius).
    let travel = SKY_TRAVEL;
    let corner = Vec3::new(PILLAR.1.x, 3.0, PILLAR.0.z);
    let edge = on_floor_behind(corner, travel);
    let distance = (corner - edge).length();
    let theta = 2.0f32.to_radians();
    let physical = 0.687 * theta * distance;
    // Across the edge on the floor, perpendicular to the light's horizontal travel.
    let across = Vec3::new(-travel.z, 0.0, travel.x).normalize();
    let profile = |px: &[[f32; 4]], lit_side: &[[f32; 4]]| {
        (-40..=40)
            .map(|k| {
                let d = k as f32 * 0.005;
                let p = edge + across * d;
                (
                    d,
                    around(px, &view, p, size) / around(lit_side, &view, p, size).max(1e-6),
                )
            })
            .collect::<Vec<_>>()
    };
    let rise = |prof: &[(f32, f32)]| {
        // The profile goes from light (away from the pillar) into shadow, or back.
        let first = |f: &dyn Fn(f32) -> bool| prof.iter().find(|(_, v)| f(*v)).map(|(d, _)| *d);
        let last =
            |f: &dyn Fn(f32) -> bool| prof.iter().rev().find(|(_, v)| f(*v)).map(|(d, _)| *d);
        let (a, b) = if prof[0].1 > prof[prof.len() - 1].1 {
            (last(&|v| v > 0.9), first(&|v| v < 0.1))
        } else {
            (last(&|v| v < 0.1), first(&|v| v > 0.9))
        };
        (b.unwrap() - a.unwrap()).abs()
    };
    for (what, px) in [("GPU", &on), ("reference", &traced)] {
        let prof = profile(px, &off);
        let width = rise(&prof);
        eprintln!(
            "{what}: penumbra 10-90 % {:.1} cm, physical {:.1} cm",
            width * 100.0,
            physical * 100.0
        );
        assert!(
            width >= 0.5 * physical && width <= 1.8 * physical,
            "{what}: penumbra {width} m, physical {physical} m; profile {prof:?}"
        );
    }

    // Against the reference, from the two viewpoints a visitor would take and the close-up
    // from above. The close-up read 0.104 while the shadow map's taps counted the skylight's
    // own frame a second time over the projector's penumbra (0.039 since they count only
    // through the glass; the side view 0.037 then, 0.011 now).
    for camera in [0, 1, 2] {
        let size = (160, 120);
        let (px, view) = lit_supersampled(&gpu, &scene, camera, size, no_ambient());
        let traced = reference.render_lit(&view, size.0, size.1, &rs);
        let flip = compare(
            &format!("hall-{}", hall.cameras[camera].0),
            size,
            &traced,
            &px,
        );
        let (off, _) =
            lit_supersampled(&gpu, &scene, camera, size, without_occlusion(no_ambient()));
        let flip_off = flip_mean(
            &tone_mapped(size.0, size.1, &traced),
            &tone_mapped(size.0, size.1, &off),
        );
        eprintln!(
            "hall camera {}: FLIP mean {flip:.4} (without occlusion {flip_off:.4})",
            hall.cameras[camera].0
        );
        assert!(flip <= 0.05, "camera {camera}: FLIP mean {flip}");
    }
}

// ---------------------------------------------------------------------------------------------
// The default scene, camera by camera.

/// Roofs of 49 and 256 skylights: the lit pass finds the windows whose light can reach a point
/// as a set of bits in 32-bit words, then samples those alone. The floor below every window
/// seen from above gets its light, as the reference traces it, and the floor between gets none.
/// (With the set cut to one word, window 32's patch read the light of window 0; while the
/// windows were a uniform block, windows from the 193rd on threw no light.)
#[test]
fn light_from_every_one_of_many_windows_reaches_the_floor() {
    let travel = Vec3::new(0.05, -1.0, 0.02);
    let gpu = gpu();
    // Holes per side, and a window index some of the windows seen must reach.
    for (n, beyond) in [(7, 32), (16, 192)] {
        let hall = Hall {
            opening: Opening::SkylightGrid(n),
            light: Sun::Directional {
                travel,
                angular_size_deg: 0.5,
            },
            boxes: Vec::new(),
            offset: Vec3::ZERO,
            cameras: vec![("down", Vec3::new(0.0, 7.5, 0.0), Vec3::new(0.0, 0.0, 0.01))],
        };
        let dir = tempfile::tempdir().unwrap();
        let bytes = cook_hall(&hall, dir.path());
        let scene = common::load(&gpu, &bytes);
        let windows = scene.toc().windows.clone();
        assert_eq!(windows.len(), n * n, "one window per skylight");
        let (reference, rs) = hall_reference(&bytes);
        let size = (160, 160);
        let (on, view) = lit_supersampled(&gpu, &scene, 0, size, no_ambient());
        let traced = reference.render_lit(&view, size.0, size.1, &rs);
        let pitch = grid(n).0[1] - grid(n).0[0];
        let mut seen = Vec::new();
        for (i, w) in windows.iter().enumerate() {
            let centre = Vec3::from(w.origin) + (Vec3::from(w.u_axis) + Vec3::from(w.v_axis)) * 0.5;
            let below = on_floor_behind(centre, travel);
            // A point of floor between the patches, which no window lights (towards the
            // middle, which the camera sees).
            let between = below - Vec3::new(below.x.signum(), 0.0, below.z.signum()) * pitch / 2.0;
            if pixel_of(&view, below, size).is_none() || pixel_of(&view, between, size).is_none() {
                continue;
            }
            let (g, r) = (
                around(&on, &view, below, size),
                around(&traced, &view, below, size),
            );
            let dark = around(&on, &view, between, size);
            assert!(
                r > 0.05 && (g - r).abs() <= 0.2 * r && dark < 0.1 * g,
                "{n} x {n}, window {i} ({:?}): the floor below it gets {g:.4} on the GPU, \
                 {r:.4} traced, {dark:.4} between the patches",
                w.source_materials
            );
            seen.push(i);
        }
        assert!(
            seen.len() >= 20 && seen.iter().filter(|&&i| i >= beyond).count() >= 5,
            "{n} x {n}: the camera sees the light of windows {seen:?}"
        );
        // The whole image too, outlines included: each projector carries the sun's penumbra
        // past its window's edge (half a penumbra, 3.5 cm here) as the reference traces it:
        // FLIP mean 0.026 for 7 x 7. While the light stopped at the edge of the projection it
        // read 0.101.
        let flip = compare(&format!("skylight-grid-{n}"), size, &traced, &on);
        eprintln!("skylight grid {n} x {n} from above: FLIP mean {flip:.4}");
        assert!(flip <= 0.05, "{n} x {n}: FLIP mean {flip}");
    }
}

/// Every camera of the default scene against the reference: FLIP mean at most 0.05, and the
/// shadows explicitly: where the reference is much darker than plain projective texturing (the
/// piers, ribs and window reveals block the light), the GPU's lit pass must be dark too.
#[test]
fn default_scene_matches_the_reference_on_every_camera() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let m = cook::Manifest::load(&root.join("assets-src/scene.toml")).unwrap();
    let out = cook::cook(&m, &cook::Settings::new(&m)).unwrap();
    let bytes = pack::encode(out.toc, &out.data).unwrap();
    let gpu = gpu();
    let scene = common::load(&gpu, &bytes);
    assert!(
        scene.window_shadows().iter().all(WindowShadow::needs_map),
        "every window of the corridor sits in an embrasure whose sides shade it: {:?}",
        scene.window_shadows()
    );
    let pack = pack::Pack::from_bytes("<default scene>", &bytes).unwrap();
    let reference = Reference::from_pack(&pack);
    let size = (160, 90);
    let rs = ReferenceSettings::default();
    let mut shadow_pixels = 0;
    for (camera, c) in scene.toc().cameras.iter().enumerate() {
        let (px, view) = lit_supersampled(&gpu, &scene, camera, size, Settings::default());
        let (off, _) = lit_supersampled(
            &gpu,
            &scene,
            camera,
            size,
            without_occlusion(Settings::default()),
        );
        let traced = reference.render_lit(&view, size.0, size.1, &rs);
        let flip = compare(&format!("default-{}", c.name), size, &traced, &px);
        let flip_off = flip_mean(
            &tone_mapped(size.0, size.1, &traced),
            &tone_mapped(size.0, size.1, &off),
        );
        // Where plain projection lights the stone and the reference keeps at most half of it.
        let (mut n, mut gpu_sum, mut ref_sum, mut off_sum) = (0, 0.0, 0.0, 0.0);
        for ((g, r), o) in px.iter().zip(&traced).zip(&off) {
            let (g, r, o) = (luminance(*g), luminance(*r), luminance(*o));
            if o > 0.1 && r < 0.5 * o {
                n += 1;
                gpu_sum += g;
                ref_sum += r;
                off_sum += o;
            }
        }
        eprintln!(
            "default {}: FLIP mean {flip:.4} (without occlusion {flip_off:.4}); {n} pixels in \
             shadow: mean luminance GPU {:.3}, reference {:.3}, unoccluded {:.3}",
            c.name,
            gpu_sum / n.max(1) as f32,
            ref_sum / n.max(1) as f32,
            off_sum / n.max(1) as f32,
        );
        assert!(flip <= 0.05, "camera {}: FLIP mean {flip}", c.name);
        if n > 0 {
            // The GPU removes at least 80 % of the light the reference removes there.
            assert!(
                off_sum - gpu_sum >= 0.8 * (off_sum - ref_sum),
                "camera {}: in {n} shadowed pixels the GPU keeps {gpu_sum}, the reference \
                 {ref_sum}, plain projection {off_sum}",
                c.name
            );
        }
        shadow_pixels += n;
    }
    assert!(
        shadow_pixels >= 200,
        "only {shadow_pixels} shadowed pixels seen"
    );
}

// ---------------------------------------------------------------------------------------------
// Thin occluders, grazing light, far from the origin, a lamp's per-window maps.

/// The floor light behind `blocker`'s point, as a fraction of the light at `beside`, in the
/// GPU's lit pass and the reference, from camera `camera`.
fn shadow_fraction(
    gpu: &Gpu,
    scene: &Scene,
    reference: &Reference,
    camera: usize,
    behind: Vec3,
    beside: Vec3,
) -> (f32, f32, f32) {
    let size = (128, 128);
    let (on, view, _) = lit(gpu, scene, camera, size, no_ambient());
    let (off, _, _) = lit(gpu, scene, camera, size, without_occlusion(no_ambient()));
    let rs = ReferenceSettings {
        ambient: [0.0; 3],
        ..Default::default()
    };
    let traced = reference.render_lit(&view, size.0, size.1, &rs);
    let f = |px: &[[f32; 4]]| {
        let s = around(px, &view, beside, size);
        assert!(s > 0.05, "no window light beside the blocker ({s})");
        around(px, &view, behind, size) / s
    };
    (f(&on), f(&traced), f(&off))
}

/// A 5 cm mullion 1.2 m tall under the real sun (0.53°): its shadow is a dark line the maps
/// must not miss nor leak through; the same hall moved 1e5 from the origin casts it alike.
#[test]
fn thin_mullion_casts_a_shadow_near_and_far_from_the_origin() {
    let gpu = gpu();
    let mullion = (Vec3::new(2.0, 0.0, 0.5), Vec3::new(2.05, 1.2, 0.55));
    let mid = (mullion.0 + mullion.1) * 0.5;
    let behind = on_floor_behind(mid, SKY_TRAVEL);
    let beside = behind + Vec3::new(0.0, 0.0, -0.3);
    let mut images = Vec::new();
    for offset in [Vec3::ZERO, Vec3::new(1e5, 0.0, -1e5)] {
        let dir = tempfile::tempdir().unwrap();
        let hall = Hall {
            light: Sun::Directional {
                travel: SKY_TRAVEL,
                angular_size_deg: 0.53,
            },
            boxes: vec![mullion],
            offset,
            cameras: vec![(
                "down",
                behind + Vec3::Y * 1.5,
                behind + Vec3::new(0.0, 0.0, 0.01),
            )],
            ..Hall::pillar()
        };
        let bytes = cook_hall(&hall, dir.path());
        let scene = common::load(&gpu, &bytes);
        assert!(scene.window_shadows()[0].needs_map());
        let reference = Reference::from_pack(&pack::Pack::from_bytes("<hall>", &bytes).unwrap());
        let (g, r, off) = shadow_fraction(
            &gpu,
            &scene,
            &reference,
            0,
            behind + offset,
            beside + offset,
        );
        eprintln!(
            "mullion at {offset}: behind it GPU {:.1} %, reference {:.1} %, unoccluded {:.1} %",
            g * 100.0,
            r * 100.0,
            off * 100.0
        );
        assert!(g <= 0.35 && r <= 0.35, "GPU {g}, reference {r}");
        assert!(off > 0.8, "without occlusion {off}");
        let (px, _, _) = lit(&gpu, &scene, 0, (128, 128), no_ambient());
        images.push(tone_mapped(128, 128, &px));
    }
    // f32 positions 1e5 away are 8 mm apart: the image moves by a fraction of a pixel.
    let flip = flip_mean(&images[0], &images[1]);
    eprintln!("mullion hall at the origin against 1e5 away: FLIP mean {flip:.4}");
    assert!(flip <= 0.02, "far from the origin: FLIP mean {flip}");
}

/// Glass 5 cm inside a wall never cut open, as many exported churches glaze their windows (the
/// Šibenik stand-in of `real_models.rs` among them): taken literally, the wall blocks all the
/// light, and the viewer drew such a church dark where the cooker had lit its floor. The wall
/// is taken as open behind each pane: both windows' light reaches the floor, as the reference
/// traces it, and the block standing in the first window's light still casts its shadow.
#[test]
fn glass_on_an_uncut_wall_lets_its_light_in_and_a_block_still_shadows() {
    let gpu = gpu();
    let dir = tempfile::tempdir().unwrap();
    let travel = Vec3::new(0.8, -0.55, 0.1);
    let block = (Vec3::new(-3.2, 0.0, -2.4), Vec3::new(-2.8, 0.4, -2.0));
    let hall = Hall {
        opening: Opening::GlassOnUncutWall,
        light: Sun::Directional {
            travel,
            angular_size_deg: 0.53,
        },
        boxes: vec![block],
        offset: Vec3::ZERO,
        cameras: vec![(
            "down",
            Vec3::new(-3.0, 7.5, 0.3),
            Vec3::new(-3.0, 0.0, 0.31),
        )],
    };
    let bytes = cook_hall(&hall, dir.path());
    let scene = common::load(&gpu, &bytes);
    assert_eq!(scene.backed_windows(), [true, true]);
    assert_eq!(
        scene.window_shadows(),
        &[WindowShadow::Occluded(Blocker::Inside), WindowShadow::Clear]
    );
    let (reference, rs) = hall_reference(&bytes);
    let size = (128, 128);
    let (on, view) = lit_supersampled(&gpu, &scene, 0, size, no_ambient());
    let traced = reference.render_lit(&view, size.0, size.1, &rs);
    // On the floor: the middle of the second window's patch, the floor in the block's shadow
    // and beside it in the first window's patch.
    let glass = |y: f32, z: f32| on_floor_behind(Vec3::new(-HALF + 0.05, y, z), travel);
    let second = glass(2.0, 2.5);
    let behind = on_floor_behind((block.0 + block.1) * 0.5 + Vec3::Y * 0.2, travel);
    let beside = glass(1.6, -3.0);
    let mut seen = Vec::new();
    for (what, px) in [("GPU", &on), ("reference", &traced)] {
        let (l, b, s) = (
            around(px, &view, second, size),
            around(px, &view, behind, size),
            around(px, &view, beside, size),
        );
        eprintln!("{what}: second window's light {l:.4}; behind the block {b:.4}, beside {s:.4}");
        assert!(l > 0.3 && s > 0.3, "{what}: no window light on the floor");
        assert!(
            b <= 0.35 * s,
            "{what}: the block casts no shadow ({b} against {s})"
        );
        seen.push(l);
    }
    assert!(
        (seen[0] - seen[1]).abs() <= 0.05 * seen[1],
        "the second window's light: GPU {} against the reference {}",
        seen[0],
        seen[1]
    );
    // As close to the reference as the same hall with the openings cut (and the panes in
    // them): the patches' hard outlines on the GPU (see the skylight grid) set both.
    let flip = compare("uncut-wall", size, &traced, &on);
    let cut_dir = tempfile::tempdir().unwrap();
    let cut = cook_hall(
        &Hall {
            opening: Opening::WallWindows,
            ..hall
        },
        cut_dir.path(),
    );
    let cut_scene = common::load(&gpu, &cut);
    assert_eq!(cut_scene.backed_windows(), [false, false]);
    let (cut_reference, rs) = hall_reference(&cut);
    let (cut_on, view) = lit_supersampled(&gpu, &cut_scene, 0, size, no_ambient());
    let cut_traced = cut_reference.render_lit(&view, size.0, size.1, &rs);
    let cut_flip = compare("cut-wall", size, &cut_traced, &cut_on);
    eprintln!("FLIP mean: glass on an uncut wall {flip:.4}, in cut openings {cut_flip:.4}");
    assert!(
        flip <= cut_flip + 0.005,
        "FLIP mean {flip} against {cut_flip} with the wall cut"
    );
    // The cut openings' walls are in the window's shadow map; counted there as well as by the
    // projector's blurred edge, they darkened every patch's sides (0.020).
    assert!(cut_flip <= 0.0175, "in cut openings: FLIP mean {cut_flip}");
}

/// A nave with a transept on its west side, lit through a window in the transept's south wall
/// (z = 0). That window's plane runs on through the nave: the nave's southern half lies on its
/// outer side. The lit pass took every point there for the outside and lit it with the full
/// sun, under the nave's roof; the sun's map over the whole building now says the roof stops
/// it. The transept's window light, and the sunlit outer face of its wall, are unchanged.
#[test]
fn a_transept_windows_plane_does_not_light_the_nave_beyond_it() {
    let gpu = gpu();
    let dir = tempfile::tempdir().unwrap();
    let mut obj = Obj::default();
    let (x, y, z) = (Vec3::X, Vec3::Y, Vec3::Z);
    let v = Vec3::new;
    // The nave: x in [-5, 5], z in [-10, 10], 8 m high; the transept: x in [-15, -5],
    // z in [0, 6]. Surfaces face into the building.
    obj.quad("floor", v(-5.0, 0.0, -10.0), z * 20.0, x * 10.0, y);
    obj.quad("floor", v(-15.0, 0.0, 0.0), z * 6.0, x * 10.0, y);
    obj.quad("stone", v(-5.0, 8.0, -10.0), x * 10.0, z * 20.0, -y);
    obj.quad("stone", v(-15.0, 8.0, 0.0), x * 10.0, z * 6.0, -y);
    obj.quad("stone", v(5.0, 0.0, -10.0), z * 20.0, y * 8.0, -x);
    obj.quad("stone", v(-5.0, 0.0, -10.0), x * 10.0, y * 8.0, z);
    obj.quad("stone", v(-5.0, 0.0, 10.0), y * 8.0, x * 10.0, -z);
    // The nave's west wall, open to the transept.
    obj.quad("stone", v(-5.0, 0.0, -10.0), y * 8.0, z * 10.0, x);
    obj.quad("stone", v(-5.0, 0.0, 6.0), y * 8.0, z * 4.0, x);
    obj.quad("stone", v(-15.0, 0.0, 0.0), z * 6.0, y * 8.0, x);
    obj.quad("stone", v(-15.0, 0.0, 6.0), y * 8.0, x * 10.0, -z);
    // The transept's south wall around its window (x in [-12, -8], y in [2, 5]).
    obj.quad("stone", v(-15.0, 0.0, 0.0), x * 3.0, y * 8.0, z);
    obj.quad("stone", v(-8.0, 0.0, 0.0), x * 3.0, y * 8.0, z);
    obj.quad("stone", v(-12.0, 0.0, 0.0), x * 4.0, y * 2.0, z);
    obj.quad("stone", v(-12.0, 5.0, 0.0), x * 4.0, y * 3.0, z);
    obj.quad("glass_a", v(-12.0, 2.0, 0.0), x * 4.0, y * 3.0, z);
    std::fs::write(dir.path().join("cross.obj"), obj.finish()).unwrap();
    image::RgbaImage::from_pixel(32, 32, image::Rgba([230, 210, 160, 255]))
        .save(dir.path().join("design.png"))
        .unwrap();
    // The sun, and a lamp above the roof's height south of the church (outside its bounds),
    // both through the window; `patch`: where a point of the window throws its light (one in
    // view through the nave's opening).
    let travel = v(0.3, -0.6, 0.7);
    let lamp = v(-10.0, 12.0, -14.0);
    let centre = v(-10.0, 3.5, 0.0);
    let lights = [
        (
            "sun",
            format!(
                "type = \"directional\"\ndirection = [{}, {}, {}]\nangular_size_deg = 0.53\n\
                 intensity = 3.0\n",
                travel.x, travel.y, travel.z
            ),
            on_floor_behind(centre, travel),
        ),
        (
            "lamp",
            format!(
                "type = \"point\"\nposition = [{}, {}, {}]\nradius = 0.2\nintensity = 700.0\n",
                lamp.x, lamp.y, lamp.z
            ),
            on_floor_behind(v(-8.6, 2.6, 0.0), v(-8.6, 2.6, 0.0) - lamp),
        ),
    ];
    for (name, light, patch) in lights {
        let manifest = format!(
            "[[mesh]]\nsource = \"cross.obj\"\n\n\
             [[rule]]\nmatch = \"floor\"\nclass = \"floor\"\ndiffuse = [0.7, 0.7, 0.7]\n\
             specular = [0.0, 0.0, 0.0]\n\n\
             [[rule]]\nmatch = \"stone\"\nclass = \"wall\"\ndiffuse = [0.6, 0.58, 0.55]\n\
             specular = [0.0, 0.0, 0.0]\n\n\
             [[rule]]\nmatch = \"glass_*\"\nclass = \"window-upper\"\n\n\
             [[window]]\nmaterial = \"glass_*\"\ndesign = \"design.png\"\n\n\
             [light]\n{light}\n\
             [[camera]]\nname = \"nave\"\nposition = [3.0, 6.0, 9.0]\ntarget = [-5.0, 0.0, -1.0]\n\
             fov_y_deg = 70.0\nnear = 0.05\nfar = 100.0\n\n\
             [[camera]]\nname = \"outside\"\nposition = [-10.0, 4.0, -9.0]\n\
             target = [-10.0, 2.0, 0.0]\nfov_y_deg = 70.0\nnear = 0.05\nfar = 100.0\n"
        );
        let path = dir.path().join("cross.toml");
        std::fs::write(&path, manifest).unwrap();
        let m = cook::Manifest::load(&path).unwrap();
        let out = cook::cook(&m, &cook::Settings::new(&m)).unwrap();
        let bytes = pack::encode(out.toc, &out.data).unwrap();
        let scene = common::load(&gpu, &bytes);
        let (reference, rs) = hall_reference(&bytes);
        let size = (160, 90);
        // In the nave, beyond the window's plane; in the transept, in the window's light.
        let nave_floor = v(2.0, 0.0, -6.0);
        let (on, view) = lit_supersampled(&gpu, &scene, 0, size, no_ambient());
        let (off, _, _) = lit(&gpu, &scene, 0, size, without_occlusion(no_ambient()));
        let traced = reference.render_lit(&view, size.0, size.1, &rs);
        for (what, px) in [("GPU", &on), ("reference", &traced)] {
            let (dark, lit_patch) = (
                around(px, &view, nave_floor, size),
                around(px, &view, patch, size),
            );
            eprintln!(
                "{name}, {what}: nave floor beyond the plane {dark:.4}, transept patch \
                 {lit_patch:.4}"
            );
            assert!(
                lit_patch > 0.3,
                "{name}, {what}: no window light in the transept"
            );
            assert!(
                dark <= 0.02 * lit_patch,
                "{name}, {what}: the nave's floor is lit ({dark})"
            );
        }
        // Without the maps, the old lighting: the test can fail.
        let bright = around(&off, &view, nave_floor, size);
        assert!(
            bright > 0.3,
            "{name}: without occlusion the nave floor reads {bright}"
        );
        let flip = compare(&format!("transept-{name}-nave"), size, &traced, &on);
        eprintln!("transept, {name}, nave camera: FLIP mean {flip:.4}");
        assert!(flip <= 0.03, "{name}: FLIP mean {flip}");
        // Outside, the transept's south wall faces the light: lit as before.
        let (on, view) = lit_supersampled(&gpu, &scene, 1, size, no_ambient());
        let traced = reference.render_lit(&view, size.0, size.1, &rs);
        let face = v(-13.5, 4.0, -0.01);
        let (g, r) = (
            around(&on, &view, face, size),
            around(&traced, &view, face, size),
        );
        eprintln!("{name}: outer face of the transept wall: GPU {g:.4}, reference {r:.4}");
        assert!(
            r > 0.3 && (g - r).abs() <= 0.05 * r,
            "{name}: GPU {g} against {r}"
        );
        let flip = compare(&format!("transept-{name}-outside"), size, &traced, &on);
        eprintln!("transept, {name}, outside camera: FLIP mean {flip:.4}");
        assert!(flip <= 0.03, "{name}: FLIP mean {flip}");
    }
}

/// Sunlight at 15° above the horizon through a wall window: the lit floor shows no acne
/// (drawn with the map, it keeps the light drawn without it) except in the shadow of the one
/// block that made the map necessary. The other window's light meets nothing: no map for it.
#[test]
fn grazing_light_has_no_acne() {
    let gpu = gpu();
    let dir = tempfile::tempdir().unwrap();
    let travel = Vec3::new(0.96, -0.26, 0.05);
    let hall = Hall {
        opening: Opening::WallWindows,
        light: Sun::Directional {
            travel,
            angular_size_deg: 0.53,
        },
        boxes: vec![(Vec3::new(3.0, 0.0, -2.0), Vec3::new(3.4, 0.4, -1.6))],
        offset: Vec3::ZERO,
        cameras: vec![(
            "down",
            Vec3::new(1.0, 6.0, -2.2),
            Vec3::new(1.0, 0.0, -2.19),
        )],
    };
    let bytes = cook_hall(&hall, dir.path());
    let scene = common::load(&gpu, &bytes);
    assert_eq!(
        scene.window_shadows(),
        &[WindowShadow::Occluded(Blocker::Inside), WindowShadow::Clear]
    );
    let size = (128, 128);
    let (on, _, _) = lit(&gpu, &scene, 0, size, no_ambient());
    let (off, _, _) = lit(&gpu, &scene, 0, size, without_occlusion(no_ambient()));
    let peak = off.iter().map(|p| luminance(*p)).fold(0.0f32, f32::max);
    let (mut lit_px, mut acne, mut shadowed) = (0, 0, 0);
    let mut sum = 0.0;
    for (a, b) in on.iter().zip(&off) {
        let (a, b) = (luminance(*a), luminance(*b));
        if b < 0.3 * peak {
            continue;
        }
        let ratio = a / b;
        if ratio < 0.2 {
            shadowed += 1;
        } else {
            lit_px += 1;
            sum += ratio;
            acne += (ratio < 0.95) as u32;
        }
    }
    eprintln!(
        "grazing: {lit_px} lit pixels (mean kept {:.4}, {acne} below 95 %), {shadowed} in the \
         block's shadow",
        sum / lit_px as f32
    );
    assert!(
        shadowed >= 20,
        "the block casts no shadow ({shadowed} pixels)"
    );
    assert!(lit_px >= 500, "{lit_px}");
    // Edge pixels of the block's penumbra fall between; acne would be spread over the patch.
    assert!(
        acne as f32 <= 0.03 * lit_px as f32,
        "{acne} of {lit_px} lit pixels darkened"
    );
    assert!(sum / lit_px as f32 >= 0.98);
}

/// A lamp outside two wall windows: a pillar stands in the first window's light only, so the
/// first gets a spot map through its rectangle and the second none; the shadow falls where the
/// reference has it, and the lit pass matches the reference.
#[test]
fn lamp_gets_a_map_for_the_window_whose_light_is_blocked() {
    let gpu = gpu();
    let dir = tempfile::tempdir().unwrap();
    let lamp = Vec3::new(-10.0, 5.0, -2.5);
    let pillar = (Vec3::new(-2.4, 0.0, -2.8), Vec3::new(-2.0, 3.0, -2.4));
    let hall = Hall {
        opening: Opening::WallWindows,
        light: Sun::Lamp {
            position: lamp,
            radius: 0.15,
            intensity: 400.0,
        },
        boxes: vec![pillar],
        offset: Vec3::ZERO,
        cameras: vec![
            (
                "down",
                Vec3::new(1.0, 5.5, -2.0),
                Vec3::new(1.0, 0.0, -1.99),
            ),
            ("room", Vec3::new(5.0, 3.0, 4.5), Vec3::new(-1.0, 0.5, -1.0)),
        ],
    };
    let bytes = cook_hall(&hall, dir.path());
    let scene = common::load(&gpu, &bytes);
    assert_eq!(
        scene.window_shadows(),
        &[WindowShadow::Occluded(Blocker::Inside), WindowShadow::Clear]
    );
    let mut r = Renderer::headless(&gpu, &scene, 64, 64, no_ambient()).unwrap();
    let view = r.view_for(&scene.toc().cameras[0]);
    let drawn = |report: &render::FrameReport| {
        report
            .passes
            .iter()
            .find(|p| p.pass == PassId::Shadows)
            .unwrap()
            .skipped
    };
    let first = r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
    assert_eq!(drawn(&first), None);
    let layout = r.shadow_layout();
    assert_eq!(layout.layers.len(), 1, "one spot map, for the first window");
    assert!(layout.windows[0].is_some() && layout.windows[1].is_none());
    // The maps are kept while nothing they depend on changes, the bias included.
    let mut settings = no_ambient();
    settings.shadows.bias = 2.0;
    r.set_settings(&gpu, settings);
    let second = r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
    assert!(drawn(&second).is_some_and(|why| why.starts_with("up to date")));
    r.invalidate_shadow_maps();
    let third = r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
    assert_eq!(drawn(&third), None);
    // A light that moves makes them stale; one that only changes colour does not.
    let mut scene = scene;
    let mut light = scene.toc().light.clone().unwrap();
    light.colour = [1.0, 0.5, 0.5];
    scene.set_light(Some(light.clone()));
    let recoloured = r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
    assert!(drawn(&recoloured).is_some());
    if let pack::LightKind::Point { position, .. } = &mut light.kind {
        position[1] += 0.5;
    }
    scene.set_light(Some(light));
    let moved = r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
    assert_eq!(drawn(&moved), None);
    let scene = common::load(&gpu, &bytes);

    let reference = Reference::from_pack(&pack::Pack::from_bytes("<hall>", &bytes).unwrap());
    // The floor point behind the pillar at 0.8 m, on the line from the lamp (higher up, the
    // line lands beyond the window's light).
    let mid = Vec3::new(-2.2, 0.8, -2.6);
    let behind = on_floor_behind(mid, mid - lamp);
    let beside = behind + Vec3::new(0.0, 0.0, 0.6);
    let (g, t, off) = shadow_fraction(&gpu, &scene, &reference, 0, behind, beside);
    eprintln!(
        "lamp: behind the pillar GPU {:.1} %, reference {:.1} %, unoccluded {:.1} %",
        g * 100.0,
        t * 100.0,
        off * 100.0
    );
    assert!(g <= 0.35 && t <= 0.35, "GPU {g}, reference {t}");
    assert!(off > 0.8, "without occlusion {off}");
    let size = (160, 120);
    let (px, view) = lit_supersampled(&gpu, &scene, 1, size, no_ambient());
    let traced = reference.render_lit(
        &view,
        size.0,
        size.1,
        &ReferenceSettings {
            ambient: [0.0; 3],
            ..Default::default()
        },
    );
    let flip = compare("lamp-room", size, &traced, &px);
    eprintln!("lamp hall camera room: FLIP mean {flip:.4}");
    // 0.023 while the map's taps on the window's own frame darkened the patch's edges again.
    assert!(flip <= 0.015, "FLIP mean {flip}");
}

// ---------------------------------------------------------------------------------------------
// God rays: their input is pass 1, which draws every occluder black in front of the glass.

/// A pillar between the camera and a sunlit window: the window mask the god rays blur is black
/// where the pillar covers the glass, and the rays lose light accordingly.
#[test]
fn god_rays_do_not_shine_through_an_occluder_in_front_of_the_window() {
    let gpu = gpu();
    let travel = Vec3::new(0.96, -0.26, 0.05);
    let camera = (
        "inside",
        Vec3::new(4.0, 2.0, -2.5),
        Vec3::new(-6.0, 2.3, -2.5),
    );
    let render = |boxes: Vec<(Vec3, Vec3)>| {
        let dir = tempfile::tempdir().unwrap();
        let hall = Hall {
            opening: Opening::WallWindows,
            light: Sun::Directional {
                travel,
                angular_size_deg: 0.53,
            },
            boxes,
            offset: Vec3::ZERO,
            cameras: vec![camera],
        };
        let scene = common::load(&gpu, &cook_hall(&hall, dir.path()));
        let settings = Settings {
            god_rays: render::GodRaySettings {
                resolution_scale: 1.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut r = Renderer::headless(&gpu, &scene, 96, 64, settings).unwrap();
        let view = r.view_for(&scene.toc().cameras[0]);
        let report = r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
        assert!(report.god_ray_fade > 0.5, "{report:?}");
        let (_, _, mask) = r.read_target(&gpu, TargetId::WindowMask).unwrap();
        let (_, _, rays) = r.read_target(&gpu, TargetId::GodRays).unwrap();
        let energy: f32 = rays.iter().map(|p| p[0] + p[1] + p[2]).sum();
        (mask, energy, view)
    };
    // A post 0.5 m wide halfway to the window, covering the middle of the glass.
    let post = (Vec3::new(-1.0, 0.0, -2.75), Vec3::new(-0.5, 6.0, -2.25));
    let (clear_mask, clear_energy, view) = render(vec![]);
    let (mask, energy, _) = render(vec![post]);
    let size = (96, 64);
    let centre = pixel_of(&view, Vec3::new(-6.0, 2.0, -2.5), size).unwrap();
    let at = |m: &[[f32; 4]], (x, y): (u32, u32)| m[(y * size.0 + x) as usize];
    assert!(
        at(&clear_mask, centre)[3] > 0.5,
        "the glass is seen without the post"
    );
    assert_eq!(
        at(&mask, centre),
        [0.0; 4],
        "the post hides the glass's middle"
    );
    let covered = |m: &[[f32; 4]]| m.iter().filter(|p| p[3] > 0.5).count();
    let (before, after) = (covered(&clear_mask), covered(&mask));
    eprintln!(
        "god rays: glass pixels {before} -> {after} behind the post, energy {clear_energy:.1} -> \
         {energy:.1}"
    );
    assert!(after < before * 3 / 4, "{before} -> {after}");
    assert!(
        energy < clear_energy * (after as f32 / before as f32 + 0.1),
        "the rays keep {energy} of {clear_energy} with {after} of {before} glass pixels seen"
    );
}

/// Shafts come only through windows the light passes: a spot outside the wall, aimed at the
/// first of its two windows with a 12° cone, lights only (part of) that one, and the god rays,
/// which blur pass 1's windows towards the light weighed by the light each passes, shine over
/// it and are dark over the second. They blurred every window's colour alike, and the second
/// shone as brightly as the first (0.42 against 0.44). Aimed between the windows with a
/// narrow cone, the spot passes neither, and the god-ray pass is skipped.
#[test]
fn god_rays_come_only_through_windows_the_light_passes() {
    let gpu = gpu();
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (Vec3::new(-6.0, 2.0, -2.5), Vec3::new(-6.0, 2.0, 2.5));
    let at = Vec3::new(-10.0, 2.0, 0.0);
    let hall = |aim: Vec3, outer_deg: f32| Hall {
        opening: Opening::WallWindows,
        light: Sun::Spot {
            position: at,
            radius: 0.05,
            intensity: 50.0,
            axis: aim - at,
            inner_deg: 4.0,
            outer_deg,
        },
        boxes: vec![],
        offset: Vec3::ZERO,
        cameras: vec![("wall", Vec3::new(3.0, 2.0, 0.0), Vec3::new(-6.0, 2.0, 0.0))],
    };
    let settings = Settings {
        god_rays: render::GodRaySettings {
            resolution_scale: 1.0,
            ..Default::default()
        },
        ..Default::default()
    };
    // The nearest glass is atan(1.5 / 4) = 20.6° off the axis between the windows.
    let between = hall(Vec3::new(-6.0, 2.0, 0.0), 15.0);
    let between = common::load(&gpu, &cook_hall(&between, dir.path()));
    let mut r = Renderer::headless(&gpu, &between, 96, 64, settings).unwrap();
    let view = r.view_for(&between.toc().cameras[0]);
    let report = r.render(&gpu, &between, &view, TimingMethod::None).unwrap();
    let rays = report.passes.iter().find(|p| p.pass == PassId::GodRays);
    assert_eq!(
        rays.unwrap().skipped,
        Some("the light comes in through no window"),
        "{report:?}"
    );

    let scene = common::load(&gpu, &cook_hall(&hall(a, 12.0), dir.path()));
    let size = (96, 64);
    let mut r = Renderer::headless(&gpu, &scene, size.0, size.1, settings).unwrap();
    let view = r.view_for(&scene.toc().cameras[0]);
    let report = r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
    assert!(report.god_ray_fade > 0.5, "{report:?}");
    let (_, _, mask) = r.read_target(&gpu, TargetId::WindowMask).unwrap();
    let (_, _, rays) = r.read_target(&gpu, TargetId::GodRays).unwrap();
    let at = |m: &[[f32; 4]], p: Vec3| {
        let (x, y) = pixel_of(&view, p, size).unwrap();
        let q = m[(y * size.0 + x) as usize];
        q[0] + q[1] + q[2]
    };
    // Both windows are seen, equally bright in pass 1 (the same design).
    let (mask_a, mask_b) = (at(&mask, a), at(&mask, b));
    assert!(
        mask_a > 0.1 && (mask_a - mask_b).abs() < 0.05 * mask_a,
        "{mask_a} {mask_b}"
    );
    let (rays_a, rays_b) = (at(&rays, a), at(&rays, b));
    eprintln!("god rays over the spot's window {rays_a:.4}, over the other {rays_b:.4}");
    assert!(rays_a > 0.0 && rays_b < 0.01 * rays_a, "{rays_a} {rays_b}");
}

/// A lamp above a roof of skylights over a forest of 256 pillars 1 m tall, seen from under
/// the roof: the lit pass against the reference.
///
/// - 8 x 8 skylights, a lamp 0.2 m in radius 12 m above them: the projectors' blur is the
///   lamp's penumbra in the window's plane. While it was the penumbra on the floor, 1.67 times
///   as wide here (the lamp magnifies the design on its way down), FLIP read 0.196.
/// - 24 x 24 skylights, a lamp of 0.1 m: each window whose light a pillar blocks gets a map
///   of its own, more than the 256 array layers wgpu asks of a device by default, and more
///   than the maps' memory budget holds at 1024², so they are drawn smaller. Every window is
///   kept (the lit pass took 192 while the windows were a uniform block).
#[test]
fn a_lamp_through_hundreds_of_skylights_matches_the_reference() {
    let gpu = gpu();
    let pillars: Vec<_> = (0..256)
        .map(|k| {
            let (x, z) = (-5.7 + (k % 16) as f32 * 0.75, -5.7 + (k / 16) as f32 * 0.75);
            (Vec3::new(x, 0.0, z), Vec3::new(x + 0.3, 1.0, z + 0.3))
        })
        .collect();
    // Holes per side, lamp radius, the fewest windows with maps, the largest FLIP mean.
    for (n, radius, maps, max_flip) in [(8, 0.2, 30, 0.06), (24, 0.1, 257, 0.07)] {
        let dir = tempfile::tempdir().unwrap();
        let hall = Hall {
            opening: Opening::SkylightGrid(n),
            light: Sun::Lamp {
                position: Vec3::new(0.5, 20.0, 0.3),
                radius,
                intensity: 2000.0,
            },
            boxes: pillars.clone(),
            offset: Vec3::ZERO,
            cameras: vec![("down", Vec3::new(1.0, 7.5, 1.0), Vec3::new(1.0, 0.0, 1.01))],
        };
        let bytes = cook_hall(&hall, dir.path());
        let scene = common::load(&gpu, &bytes);
        assert_eq!(scene.toc().windows.len(), n * n, "every window is kept");
        let size = (160, 90);
        let (px, view) = lit_supersampled(&gpu, &scene, 0, size, no_ambient());
        let mut r = Renderer::headless(&gpu, &scene, 16, 9, no_ambient()).unwrap();
        // Timed as `viewer --bench` times it: the shadow pass's timestamps bracket all its
        // layers, and the layers between the first and the last failed wgpu's validation.
        let report = r
            .render(&gpu, &scene, &view, TimingMethod::GpuTimestamps)
            .unwrap();
        let shadows = report
            .passes
            .iter()
            .find(|p| p.pass == PassId::Shadows)
            .unwrap();
        assert!(
            shadows.skipped.is_none() && shadows.ms.is_some(),
            "{report:?}"
        );
        let with_map = r.shadow_layout().windows.iter().flatten().count();
        assert!(with_map >= maps, "{n} x {n}: {with_map} windows with a map");
        let (reference, rs) = hall_reference(&bytes);
        let traced = reference.render_lit(&view, size.0, size.1, &rs);
        let flip = compare(&format!("lamp-skylights-{n}"), size, &traced, &px);
        eprintln!("lamp over {n} x {n} skylights: {with_map} maps, FLIP mean {flip:.4}");
        assert!(flip <= max_flip, "{n} x {n}: FLIP mean {flip}");
    }
}

/// A spot light over a roof of 7 x 7 skylights, its cone (6° full, none past 14°) aimed off
/// the middle: the floor under the skylights inside the cone is lit as the reference traces
/// it, fading across the cone's edge, and the skylights wholly outside the cone get no
/// projector (the cook skips them). Before spot lights were kept, the cook dropped the cone
/// and every skylight lit the floor.
#[test]
fn a_spot_light_lights_only_the_skylights_in_its_cone() {
    let gpu = gpu();
    let dir = tempfile::tempdir().unwrap();
    let at = Vec3::new(0.5, 20.0, 0.3);
    let aim = Vec3::new(1.5, 8.0, 1.0);
    let hall = Hall {
        opening: Opening::SkylightGrid(7),
        light: Sun::Spot {
            position: at,
            radius: 0.1,
            intensity: 2000.0,
            axis: aim - at,
            inner_deg: 6.0,
            outer_deg: 14.0,
        },
        boxes: vec![(Vec3::new(1.0, 0.0, 0.5), Vec3::new(1.4, 1.0, 0.9))],
        offset: Vec3::ZERO,
        cameras: vec![("down", Vec3::new(1.0, 7.5, 1.0), Vec3::new(1.0, 0.0, 1.01))],
    };
    let bytes = cook_hall(&hall, dir.path());
    let scene = common::load(&gpu, &bytes);
    let toc = scene.toc();
    assert!(
        matches!(
            toc.light.as_ref().unwrap().kind,
            pack::LightKind::Spot { .. }
        ),
        "{:?}",
        toc.light
    );
    // Which skylights the cone reaches, worked out here: the nearest point of each hole
    // (half size `half`, centred on the grid) within 14° of the axis.
    let (centres, half) = grid(7);
    let axis = (aim - at).normalize();
    let reached = |cx: f32, cz: f32| {
        let mut best = f32::NEG_INFINITY;
        for i in 0..=64 {
            for j in 0..=64 {
                let q = Vec3::new(
                    cx - half + 2.0 * half * i as f32 / 64.0,
                    HEIGHT,
                    cz - half + 2.0 * half * j as f32 / 64.0,
                );
                best = best.max((q - at).normalize().dot(axis));
            }
        }
        // Sampled, so only clear cases count: 0.2° either side of the cone's edge is left
        // out of the tally.
        (
            best > (13.8f32).to_radians().cos(),
            best < (14.2f32).to_radians().cos(),
        )
    };
    let (mut inside, mut outside) = (0, 0);
    for &x in &centres {
        for &z in &centres {
            let (i, o) = reached(x, z);
            inside += usize::from(i);
            outside += usize::from(o);
        }
    }
    let with_projector = toc
        .windows
        .iter()
        .filter(|w| {
            toc.materials[w.material as usize]
                .projector_texture
                .is_some()
        })
        .count();
    assert!(outside >= 10 && inside >= 10, "{inside} in, {outside} out");
    assert!(
        with_projector >= inside && with_projector <= 49 - outside,
        "{with_projector} projectors for {inside} skylights in the cone and {outside} out"
    );
    let size = (160, 90);
    let (px, view) = lit_supersampled(&gpu, &scene, 0, size, no_ambient());
    let (reference, rs) = hall_reference(&bytes);
    let traced = reference.render_lit(&view, size.0, size.1, &rs);
    let flip = compare("spot-skylights", size, &traced, &px);
    eprintln!("spot over 7 x 7 skylights: {with_projector} projectors, FLIP mean {flip:.4}");
    assert!(flip <= 0.05, "FLIP mean {flip}");
}

/// The lancet hall in a low sun, seen from above the patch its lancet throws on the floor.
fn lancet_hall() -> Hall {
    Hall {
        opening: Opening::Lancet,
        light: Sun::Directional {
            travel: Vec3::new(1.0, -0.6, 0.05),
            angular_size_deg: 2.0,
        },
        boxes: Vec::new(),
        offset: Vec3::ZERO,
        cameras: vec![(
            "patch",
            Vec3::new(-2.4, 3.5, 0.0),
            Vec3::new(-2.4, 0.0, 0.01),
        )],
    }
}

/// A square design stretched four times up a lancet: the projector's blur is the sun's penumbra
/// on the glass along each axis, so the panes' edges on the floor are as soft as the reference
/// traces them. While σ came from the texels across the lancet and was applied both ways, the
/// edges between panes up the lancet were blurred four times too wide.
#[test]
fn a_stretched_design_on_a_lancet_matches_the_reference() {
    let gpu = gpu();
    let dir = tempfile::tempdir().unwrap();
    let hall = lancet_hall();
    let bytes = cook_hall(&hall, dir.path());
    let scene = common::load(&gpu, &bytes);
    let size = (160, 90);
    let (px, view) = lit_supersampled(&gpu, &scene, 0, size, no_ambient());
    let (reference, rs) = hall_reference(&bytes);
    let traced = reference.render_lit(&view, size.0, size.1, &rs);
    let flip = compare("lancet", size, &traced, &px);
    eprintln!("stretched lancet: FLIP mean {flip:.4}");
    assert!(flip <= 0.05, "FLIP mean {flip}");
}

/// Two buildings cooked as two meshes of one scene: each lies outside the other's window
/// planes, so the lit pass took each for "outside" and lit its floor with the unfiltered sun
/// through the glass (white patches where the coloured ones belonged). A window's plane bounds
/// only its own building's inside: the lancet hall's floor is lit as it is alone.
#[test]
fn a_second_building_beyond_a_windows_plane_leaves_the_first_lit_alike() {
    let gpu = gpu();
    let dir = tempfile::tempdir().unwrap();
    let hall = lancet_hall();
    let alone = cook_hall(&hall, dir.path());
    // The same hall again, 40 units along the lancet's inside normal (+x): the first hall lies
    // beyond the second's lancet plane (x = 34).
    let path = dir.path().join("hall.toml");
    let manifest = std::fs::read_to_string(&path).unwrap().replacen(
        "[[mesh]]\nsource = \"hall.obj\"\n",
        "[[mesh]]\nsource = \"hall.obj\"\n\n[[mesh]]\nsource = \"hall.obj\"\nname = \"beside\"\n\
         translate = [40.0, 0.0, 0.0]\n",
        1,
    );
    assert!(manifest.contains("beside"));
    std::fs::write(&path, manifest).unwrap();
    let m = cook::Manifest::load(&path).unwrap();
    let out = cook::cook(&m, &cook::Settings::new(&m)).unwrap();
    let two = pack::encode(out.toc, &out.data).unwrap();

    let size = (160, 90);
    let (a, _, _) = lit(&gpu, &common::load(&gpu, &alone), 0, size, no_ambient());
    let (b, _, _) = lit(&gpu, &common::load(&gpu, &two), 0, size, no_ambient());
    let lit_px = a.iter().filter(|p| luminance(**p) > 0.05).count();
    assert!(
        lit_px > 200,
        "the camera sees the patch: {lit_px} lit pixels"
    );
    let differ = a
        .iter()
        .zip(&b)
        .filter(|(p, q)| (0..3).any(|k| (p[k] - q[k]).abs() > 0.02 * p[k].max(q[k]).max(0.05)))
        .count();
    assert!(
        differ * 100 <= lit_px,
        "{differ} of {} pixels differ with a second building beside ({lit_px} lit)",
        a.len()
    );
}
