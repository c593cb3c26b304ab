//! Render checks against geometry and physics computed here, not against the renderer's own
//! earlier output nor a port of its shaders: where an edge seen through tilted glass must move,
//! how a point light falls off over a floor, which way a god ray streaks, and where each pane
//! of a cooked window lands on the floor. Screen positions are computed with the pinhole model
//! written out below (cameras looking straight along an axis, so each projection is two
//! divisions), never through `render::View`'s matrices.
//!
//! Needs an adapter (lavapipe in CI); no adapter fails, never skips. Images are tiny: lavapipe
//! is a CPU renderer.

mod common;
use common::{gpu, load};

use glam::Vec3;
use pack::{
    ColourSpace, DrawRange, Light, LightKind, Material, MaterialClass, MipLevel, PackData,
    StandardVertex, Texture, TextureFormat, TextureRole, Toc, Window,
};
use render::view::GodRaySettings;
use render::{Renderer, Settings, TargetId, TimingMethod, View};

// ---------------------------------------------------------------------------------------------
// A minimal pack builder: quads with flat materials and constant textures.

#[derive(Default)]
struct Builder {
    toc: Toc,
    data: PackData,
    vertices: Vec<StandardVertex>,
    indices: Vec<u32>,
    ranges: Vec<DrawRange>,
}

impl Builder {
    /// A 4x4 texture of one texel value, with its (equally constant) mips.
    fn constant_texture(&mut self, name: &str, role: TextureRole, texel: [u8; 4]) -> u32 {
        let sizes = [4u32, 2, 1];
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
            width: 4,
            height: 4,
            mips: sizes
                .iter()
                .map(|&s| MipLevel {
                    width: s,
                    height: s,
                    section: 0,
                })
                .collect(),
        });
        self.data.textures.push(
            sizes
                .iter()
                .map(|&s| texel.repeat((s * s) as usize))
                .collect(),
        );
        self.toc.textures.len() as u32 - 1
    }

    fn material(&mut self, name: &str, class: MaterialClass, diffuse: [f32; 3]) -> u16 {
        self.toc.materials.push(Material {
            name: name.into(),
            class,
            diffuse,
            // No highlight: the lit value is then albedo · cos θ · radiance exactly.
            specular: [0.0; 3],
            shininess: 1.0,
            emissive: [0.0; 3],
            diffuse_texture: None,
            normal_texture: None,
            projector_texture: None,
            projector_margin: [0.0; 2],
        });
        self.toc.materials.len() as u16 - 1
    }

    /// The quad `origin + s·a + t·b`, (s, t) in [0, 1]², UV (s, t), tangent along `a`.
    fn quad(&mut self, material: u16, origin: Vec3, a: Vec3, b: Vec3, normal: Vec3) {
        let base = self.vertices.len() as u32;
        for (s, t) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            self.vertices.push(StandardVertex {
                position: (origin + a * s + b * t).to_array(),
                normal: normal.to_array(),
                uv: [s, t],
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

    /// A window quad (design's v running down from `origin`) and its frame in the TOC.
    fn window(&mut self, material: u16, origin: Vec3, a: Vec3, b: Vec3, normal: Vec3) {
        self.quad(material, origin, a, b, normal);
        self.toc.windows.push(Window {
            material,
            origin: origin.to_array(),
            u_axis: a.to_array(),
            v_axis: b.to_array(),
            normal: normal.to_array(),
            source_materials: Vec::new(),
        });
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

fn sun(travel: Vec3) -> Light {
    Light {
        kind: LightKind::Directional {
            direction: travel.to_array(),
            angular_size: 0.0093,
        },
        colour: [1.0; 3],
        intensity: 1.0,
    }
}

// ---------------------------------------------------------------------------------------------
// The pinhole model, written out for the two camera orientations used here.

const FOV_DEG: f32 = 60.0;

/// A camera at `eye` looking along −z, +y up: screen x is world +x.
fn looking_down_z(eye: Vec3, aspect: f32) -> View {
    View::look(eye, Vec3::NEG_Z, Vec3::Y, FOV_DEG, aspect, 0.05, 500.0)
}

/// A camera at `eye` looking straight down (−y) with +z as its up: screen right is world −x
/// (right = forward × up = −y × z), screen up world +z.
fn looking_down_y(eye: Vec3, aspect: f32) -> View {
    View::look(eye, Vec3::NEG_Y, Vec3::Z, FOV_DEG, aspect, 0.05, 500.0)
}

/// Pixel coordinates (x right, y down, pixel centres at +0.5) of normalised device
/// coordinates on a `w`×`h` image.
fn ndc_to_pixel(ndc_x: f32, ndc_y: f32, w: u32, h: u32) -> (f32, f32) {
    (
        (ndc_x + 1.0) * 0.5 * w as f32,
        (1.0 - ndc_y) * 0.5 * h as f32,
    )
}

/// Screen position of the view-space offset (right, up, forward distance): perspective divide
/// by the distance along the view, then the field of view and aspect.
fn project(right: f32, up: f32, ahead: f32, w: u32, h: u32) -> (f32, f32) {
    let k = (FOV_DEG.to_radians() * 0.5).tan();
    let aspect = w as f32 / h as f32;
    ndc_to_pixel(right / ahead / (k * aspect), up / ahead / k, w, h)
}

fn pixel<T: Copy>(px: &[T], w: u32, x: f32, y: f32) -> T {
    px[y as usize * w as usize + x as usize]
}

// ---------------------------------------------------------------------------------------------
// Refraction: a constant tilt moves a background edge by the composite's offset.

/// The composite samples the background at `uv + (n.x / aspect, −n.y) · strength`, where `n`
/// is the view-space perturbation of the glass normal. For a pixel-high image that is a shift
/// of `n.x · strength · H` pixels to the right and `n.y · strength · H` up, so the background's
/// content appears moved by the opposite: left by the first, down by the second.
#[test]
fn refraction_moves_an_edge_by_the_composite_offset() {
    const W: u32 = 128;
    const H: u32 = 64;
    const STRENGTH: f32 = 0.25;
    let gpu = gpu();
    // Glass at z = 0 filling the view, seen square on from z = 5; the backdrop at z = −50 is
    // split dark/bright at x = 0 (vertical edge) or y = 0 (horizontal edge).
    let render = |texel: [u8; 4], vertical_edge: bool, strength: f32| {
        let mut b = Builder::default();
        let (dark, bright) = if vertical_edge {
            (
                (Vec3::new(-200.0, 100.0, -50.0), Vec3::new(200.0, 0.0, 0.0)),
                (Vec3::new(0.0, 100.0, -50.0), Vec3::new(200.0, 0.0, 0.0)),
            )
        } else {
            (
                (Vec3::new(-200.0, 0.0, -50.0), Vec3::new(400.0, 0.0, 0.0)),
                (Vec3::new(-200.0, 100.0, -50.0), Vec3::new(400.0, 0.0, 0.0)),
            )
        };
        let height = if vertical_edge { 200.0 } else { 100.0 };
        let m = b.material("dark", MaterialClass::Background, [0.02; 3]);
        b.quad(m, dark.0, dark.1, Vec3::new(0.0, -height, 0.0), Vec3::Z);
        let m = b.material("bright", MaterialClass::Background, [0.9; 3]);
        b.quad(m, bright.0, bright.1, Vec3::new(0.0, -height, 0.0), Vec3::Z);
        let normal = b.constant_texture("tilt", TextureRole::Normal, texel);
        let glass = b.material("glass", MaterialClass::WindowUpper, [1.0; 3]);
        b.toc.materials[glass as usize].normal_texture = Some(normal);
        b.window(
            glass,
            Vec3::new(-8.0, 4.0, 0.0),
            Vec3::new(16.0, 0.0, 0.0),
            Vec3::new(0.0, -8.0, 0.0),
            Vec3::Z,
        );
        // No light: the god rays of a window filling the view would cover the edge.
        let scene = load(&gpu, &b.finish());
        let settings = Settings {
            refraction_strength: strength,
            ..Default::default()
        };
        let mut r = Renderer::headless(&gpu, &scene, W, H, settings).unwrap();
        let view = looking_down_z(Vec3::new(0.0, 0.0, 5.0), W as f32 / H as f32);
        r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
        r.read_output(&gpu).unwrap()
    };
    // First bright pixel along the middle row (vertical edge) or first dark one down the
    // middle column (horizontal edge).
    let edge = |img: &image::RgbaImage, vertical: bool| -> f32 {
        if vertical {
            (0..W).find(|&x| img.get_pixel(x, H / 2)[1] > 128).unwrap() as f32
        } else {
            (0..H).find(|&y| img.get_pixel(W / 2, y)[1] < 128).unwrap() as f32
        }
    };
    let byte = |b: u8| b as f32 / 255.0 * 2.0 - 1.0;
    for (texel, vertical) in [
        ([200u8, 128, 232, 255], true),
        ([128, 200, 232, 255], false),
    ] {
        // The perturbation the normals pass writes: the decoded, normalised map normal minus
        // the flat one (the glass faces the camera, so view space is world space here).
        let m = Vec3::new(byte(texel[0]), byte(texel[1]), byte(texel[2])).normalize();
        let flat = edge(&render(texel, vertical, 0.0), vertical);
        let bent = edge(&render(texel, vertical, STRENGTH), vertical);
        let (measured, predicted) = if vertical {
            (bent - flat, -m.x * STRENGTH * H as f32)
        } else {
            (bent - flat, m.y * STRENGTH * H as f32)
        };
        eprintln!(
            "{} edge: flat at {flat}, refracted at {bent}: moved {measured} px, predicted {predicted:.2}",
            if vertical { "vertical" } else { "horizontal" }
        );
        // Without refraction the edge is where the backdrop's edge projects: the centre.
        let centre = if vertical { W / 2 } else { H / 2 } as f32;
        assert_eq!(flat, centre, "edge without refraction");
        // Nearest sampling rounds the shift to whole pixels.
        assert!(
            (measured - predicted).abs() <= 1.0,
            "edge moved {measured} px, the composite formula predicts {predicted:.2}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Inverse-square falloff over a floor, with the r_min clamp.

#[test]
fn point_light_falls_off_with_the_inverse_square_and_its_clamp() {
    const W: u32 = 64;
    const H: u32 = 64;
    const ALBEDO: f32 = 0.5;
    const INTENSITY: f32 = 2.0;
    const RADIUS: f32 = 1.2;
    let light = Vec3::new(0.7, 1.0, -0.4);
    let eye = Vec3::new(0.0, 6.0, 0.0);
    let gpu = gpu();
    let mut b = Builder::default();
    let floor = b.material("floor", MaterialClass::Floor, [ALBEDO; 3]);
    b.quad(
        floor,
        Vec3::new(-20.0, 0.0, 20.0),
        Vec3::new(40.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -40.0),
        Vec3::Y,
    );
    b.toc.light = Some(Light {
        kind: LightKind::Point {
            position: light.to_array(),
            radius: RADIUS,
        },
        colour: [1.0; 3],
        intensity: INTENSITY,
    });
    let scene = load(&gpu, &b.finish());
    let settings = Settings {
        ambient: [0.0; 3],
        ..Default::default()
    };
    let mut r = Renderer::headless(&gpu, &scene, W, H, settings).unwrap();
    let view = looking_down_y(eye, 1.0);
    r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
    let (w, h, lit) = r.read_target(&gpu, TargetId::Lit).unwrap();
    assert_eq!((w, h), (W, H));

    // The floor point under each pixel centre: the ray (−x·k, −1, y·k) from the eye (screen
    // right is −x, up is +z) meets y = 0 after the eye's height.
    let k = (FOV_DEG.to_radians() * 0.5).tan();
    let floor_point = |px: u32, py: u32| {
        let nx = (px as f32 + 0.5) / W as f32 * 2.0 - 1.0;
        let ny = 1.0 - (py as f32 + 0.5) / H as f32 * 2.0;
        eye + Vec3::new(-nx * k, -1.0, ny * k) * eye.y
    };
    // Lambert with the clamped inverse square: albedo · cos θ · I / max(d², r²).
    let expected = |p: Vec3| {
        let d = light - p;
        let cos = d.y / d.length();
        ALBEDO * cos * INTENSITY / d.length_squared().max(RADIUS * RADIUS)
    };
    // Reference pixel: the one under the light (inside the clamp).
    let (rx, ry) = project(-light.x, light.z, eye.y, W, H);
    let (rx, ry) = (rx as u32, ry as u32);
    let reference = pixel(&lit, W, rx as f32, ry as f32)[0] / expected(floor_point(rx, ry));
    let (mut clamped, mut unclamped, mut worst) = (0, 0, 0.0f32);
    for py in 0..H {
        for px in 0..W {
            let p = floor_point(px, py);
            let value = lit[(py * W + px) as usize][0];
            let ratio = value / expected(p) / reference;
            if light.distance(p) < RADIUS {
                clamped += 1;
            } else {
                unclamped += 1;
            }
            worst = worst.max((ratio - 1.0).abs());
            assert!(
                (ratio - 1.0).abs() <= 0.01,
                "pixel ({px}, {py}) at {p}: lit {value}, expected ratio to the pixel under the \
                 light off by {:.2} %",
                (ratio - 1.0) * 100.0
            );
        }
    }
    eprintln!(
        "falloff: {clamped} pixels inside r_min, {unclamped} outside, worst ratio error {:.3} %, \
         absolute scale {reference:.4}",
        worst * 100.0
    );
    assert!(
        clamped >= 20 && unclamped >= 1000,
        "{clamped} / {unclamped}"
    );
    // The ratio test leaves the overall scale free; it must be 1 too.
    assert!((reference - 1.0).abs() <= 0.01, "scale {reference}");
}

/// `god_ray_falloff` averages the clamped inverse square over the centres of the windows the
/// light comes in through.
#[test]
fn god_ray_falloff_matches_hand_computed_values() {
    let window = |origin: [f32; 3], u: [f32; 3], v: [f32; 3]| Window {
        material: 0,
        origin,
        u_axis: u,
        v_axis: v,
        normal: [0.0, 0.0, 1.0],
        source_materials: Vec::new(),
    };
    // The light stands 0.5 in front of the windows' plane (z = 0), on their outer side.
    let mut toc = Toc {
        windows: vec![
            // Centre (0, 0, 0): distance² 16.25 from the light.
            window([-1.0, 1.0, 0.0], [2.0, 0.0, 0.0], [0.0, -2.0, 0.0]),
            // Centre (0, 4.5, 0): distance² 0.5, clamped to the radius 1: 1.
            window([-1.0, 5.0, 0.0], [2.0, 0.0, 0.0], [0.0, -1.0, 0.0]),
        ],
        ..Toc::default()
    };
    let lamp = |kind: LightKind| Light {
        kind,
        colour: [1.0; 3],
        intensity: 1.0,
    };
    let position = [0.0, 4.0, -0.5];
    let point = lamp(LightKind::Point {
        position,
        radius: 1.0,
    });
    let f = render::god_ray_falloff(&toc, &point);
    assert!((f - (1.0 / 16.25 + 1.0) / 2.0).abs() < 1e-6, "{f}");
    // Without the clamp's help: radius 0.25 leaves the near window at 1 / 0.5 = 2.
    let small = lamp(LightKind::Point {
        position,
        radius: 0.25,
    });
    let f = render::god_ray_falloff(&toc, &small);
    assert!((f - (1.0 / 16.25 + 2.0) / 2.0).abs() < 1e-5, "{f}");
    // A spot aimed at the far window's centre with a 10° cone: the far window (14° from its
    // centre to its edges' middles) is reached, the near one (135° off the axis) is not, so
    // the average is the far window's alone.
    let spot = lamp(LightKind::Spot {
        position,
        radius: 1.0,
        direction: [0.0, -4.0, 0.5],
        inner: 0.0,
        outer: 10f32.to_radians(),
    });
    let f = render::god_ray_falloff(&toc, &spot);
    assert!((f - 1.0 / 16.25).abs() < 1e-6, "{f}");
    // A window the light stands inside of (its plane z = -1 behind the light, its inner
    // side towards +z) casts no shafts and is left out of the average.
    toc.windows
        .push(window([-1.0, 5.0, -1.0], [2.0, 0.0, 0.0], [0.0, -1.0, 0.0]));
    let f = render::god_ray_falloff(&toc, &point);
    assert!((f - (1.0 / 16.25 + 1.0) / 2.0).abs() < 1e-6, "{f}");
    // The sun does not fall off.
    assert_eq!(render::god_ray_falloff(&toc, &sun(Vec3::NEG_Y)), 1.0);
    // No window: nothing to average, no falloff.
    toc.windows.clear();
    assert_eq!(render::god_ray_falloff(&toc, &point), 1.0);
}

// ---------------------------------------------------------------------------------------------
// God rays streak away from the light's projected position.

/// A small white window straight ahead, the camera on its inner side (its normal points at the
/// camera, the lights lie beyond it: shafts come only through windows the light passes); the
/// god rays are a radial blur towards the light, so their energy lies on the far side of the
/// window from the light's screen position.
#[test]
fn god_rays_streak_away_from_the_light() {
    const W: u32 = 96;
    const H: u32 = 54;
    let gpu = gpu();
    let eye = Vec3::ZERO;
    let blob_z = -10.0;
    let half = 0.35;
    let scene_with = |light: Light| {
        let mut b = Builder::default();
        let glass = b.material("spot", MaterialClass::WindowUpper, [1.0; 3]);
        b.window(
            glass,
            Vec3::new(-half, half, blob_z),
            Vec3::new(2.0 * half, 0.0, 0.0),
            Vec3::new(0.0, -2.0 * half, 0.0),
            Vec3::Z,
        );
        b.toc.light = Some(light);
        load(&gpu, &b.finish())
    };
    let settings = Settings {
        god_rays: GodRaySettings {
            samples: 256,
            resolution_scale: 1.0,
            jitter: false,
            ..GodRaySettings::default()
        },
        // The behind-the-camera cases must be zero from the shader itself.
        skip_invisible_god_rays: false,
        ..Default::default()
    };
    let blob = project(0.0, 0.0, -blob_z, W, H);
    let point = |p: Vec3| Light {
        kind: LightKind::Point {
            position: p.to_array(),
            radius: 0.1,
        },
        colour: [1.0; 3],
        intensity: 2000.0,
    };
    // (what, light, its view-space (right, up, ahead) when in front of the camera)
    let towards = |t: Vec3| sun(-t);
    let cases: [(&str, Light, Option<Vec3>); 7] = [
        (
            "sun upper right",
            towards(Vec3::new(0.3, 0.2, -1.0)),
            Some(Vec3::new(0.3, 0.2, 1.0)),
        ),
        (
            "sun lower left (mirrored)",
            towards(Vec3::new(-0.3, -0.2, -1.0)),
            Some(Vec3::new(-0.3, -0.2, 1.0)),
        ),
        (
            "sun off screen right",
            towards(Vec3::new(1.3, 0.1, -1.0)),
            Some(Vec3::new(1.3, 0.1, 1.0)),
        ),
        (
            "lamp upper left",
            point(Vec3::new(-4.0, 3.0, -30.0)),
            Some(Vec3::new(-4.0, 3.0, 30.0)),
        ),
        (
            "lamp lower right",
            point(Vec3::new(4.0, -2.0, -30.0)),
            Some(Vec3::new(4.0, -2.0, 30.0)),
        ),
        // Behind the camera the light projects, mirrored, onto the screen near the window; a
        // naive march draws phantom rays towards that point.
        ("sun behind", towards(Vec3::new(0.1, 0.05, 1.0)), None),
        ("lamp behind", point(Vec3::new(0.3, 0.2, 3.0)), None),
    ];
    for (what, light, in_view) in cases {
        let scene = scene_with(light);
        let mut r = Renderer::headless(&gpu, &scene, W, H, settings).unwrap();
        let view = looking_down_z(eye, W as f32 / H as f32);
        r.render(&gpu, &scene, &view, TimingMethod::None).unwrap();
        let (w, h, rays) = r.read_target(&gpu, TargetId::GodRays).unwrap();
        assert_eq!((w, h), (W, H));
        let (mut sum, mut cx, mut cy) = (0.0f64, 0.0f64, 0.0f64);
        for y in 0..H {
            for x in 0..W {
                let e = rays[(y * W + x) as usize][1] as f64;
                sum += e;
                cx += e * (x as f64 + 0.5);
                cy += e * (y as f64 + 0.5);
            }
        }
        let Some(v) = in_view else {
            assert_eq!(
                sum, 0.0,
                "{what}: god rays with the light behind the camera"
            );
            continue;
        };
        assert!(sum > 1.0, "{what}: no god rays ({sum})");
        let light_px = project(v.x, v.y, v.z, W, H);
        let streak = glam::Vec2::new((cx / sum) as f32 - blob.0, (cy / sum) as f32 - blob.1);
        let away = glam::Vec2::new(blob.0 - light_px.0, blob.1 - light_px.1);
        let angle = streak.angle_to(away).to_degrees();
        eprintln!(
            "{what}: light at ({:.1}, {:.1}) px, streak centroid offset {streak}, {angle:.1}° off",
            light_px.0, light_px.1
        );
        assert!(
            streak.length() > 1.0 && angle.abs() <= 5.0,
            "{what}: streak points {angle:.1}° away from the direction opposite the light \
             (light at {light_px:?} px, window at {blob:?}, streak offset {streak})"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Projective texturing: cook -> pack -> render.

/// Cooks a two-colour window of four panes (red top left and bottom right, blue in the other
/// two, so a mirrored u or v swaps colours) over a floor, renders the lit pass from a camera
/// looking straight down and checks, for a sun and a lamp, that the floor point on the ray
/// from the light through each pane's centre shows that pane's colour, and that a point whose
/// ray misses the window gets no light through it.
#[test]
fn cooked_window_projects_each_pane_where_its_ray_lands() {
    const S: u32 = 64;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Floor y = 0 (inside is z > 0), window x in [-1, 1], y in [2, 4] in the plane z = 0.
    // OBJ texture coordinates have v up the image: (0, 1), the design's top left, is on the
    // window's top left corner (−1, 4, 0).
    std::fs::write(
        d.join("room.obj"),
        "v -10 0 -3\nv 10 0 -3\nv 10 0 20\nv -10 0 20\n\
         v -1 4 0\nv 1 4 0\nv 1 2 0\nv -1 2 0\n\
         vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\nvn 0 1 0\nvn 0 0 1\n\
         usemtl stone\nf 1//1 4//1 3//1\nf 1//1 3//1 2//1\n\
         usemtl glass\nf 5/1/2 8/4/2 7/3/2\nf 5/1/2 7/3/2 6/2/2\n",
    )
    .unwrap();
    let red = [230u8, 30, 30, 255];
    let blue = [30u8, 30, 230, 255];
    image::RgbaImage::from_fn(32, 16, |x, y| {
        image::Rgba(if (x < 16) == (y < 8) { red } else { blue })
    })
    .save(d.join("design.png"))
    .unwrap();
    // (centre, is red): top left, top right, bottom left, bottom right.
    let panes = [
        (Vec3::new(-0.5, 3.5, 0.0), true),
        (Vec3::new(0.5, 3.5, 0.0), false),
        (Vec3::new(-0.5, 2.5, 0.0), false),
        (Vec3::new(0.5, 2.5, 0.0), true),
    ];
    // A point of the window plane outside the window, to the right of it.
    let outside = Vec3::new(1.6, 3.0, 0.0);

    let lights = [
        (
            "sun",
            "type = \"directional\"\ndirection = [0.3, -0.6, 1.0]\nangular_size_deg = 0.53\n\
             intensity = 3.0\n",
            None,
            Vec3::new(0.3, -0.6, 1.0),
        ),
        (
            "lamp",
            // About 8 units from the floor patches: 200 / 8² gives the sun's brightness.
            "type = \"point\"\nposition = [0.0, 6.0, -4.0]\nradius = 0.1\nintensity = 200.0\n",
            Some(Vec3::new(0.0, 6.0, -4.0)),
            Vec3::ZERO,
        ),
    ];
    let gpu = gpu();
    for (what, light_toml, lamp, travel) in lights {
        let manifest = format!(
            "[[mesh]]\nsource = \"room.obj\"\n\n\
             [[rule]]\nmatch = \"stone\"\nclass = \"floor\"\ndiffuse = [0.8, 0.8, 0.8]\n\
             specular = [0.0, 0.0, 0.0]\n\n\
             [[rule]]\nmatch = \"glass\"\nclass = \"window-lower\"\n\n\
             [[window]]\nmaterial = \"glass\"\ndesign = \"design.png\"\n\n\
             [light]\n{light_toml}"
        );
        let path = d.join(format!("{what}.toml"));
        std::fs::write(&path, manifest).unwrap();
        let m = cook::Manifest::load(&path).unwrap();
        let out = cook::cook(&m, &cook::Settings::new(&m)).unwrap();
        let bytes = pack::encode(out.toc, &out.data).unwrap();
        let scene = load(&gpu, &bytes);
        assert!(
            scene
                .toc()
                .materials
                .iter()
                .any(|m| m.projector_texture.is_some()),
            "{what}: the cook made no projector"
        );

        // Where the ray from the light through a window point meets the floor y = 0.
        let land = |p: Vec3| {
            let dir = match lamp {
                Some(l) => p - l,
                None => travel,
            };
            p + dir * (-p.y / dir.y)
        };
        let landing: Vec<Vec3> = panes.iter().map(|&(c, _)| land(c)).collect();
        let dark_spot = land(outside);
        // Straight down from above the middle of the landing points.
        let mid = landing.iter().sum::<Vec3>() / 4.0;
        let eye = Vec3::new(mid.x, 6.0, mid.z);
        let settings = Settings {
            ambient: [0.0; 3],
            ..Default::default()
        };
        let mut r = Renderer::headless(&gpu, &scene, S, S, settings).unwrap();
        r.render(&gpu, &scene, &looking_down_y(eye, 1.0), TimingMethod::None)
            .unwrap();
        let (_, _, lit) = r.read_target(&gpu, TargetId::Lit).unwrap();
        // Screen right is world −x, up is +z, the floor is eye.y ahead.
        let screen = |p: Vec3| project(-(p.x - eye.x), p.z - eye.z, eye.y, S, S);
        let at = |p: Vec3| {
            let (x, y) = screen(p);
            assert!(
                (0.0..S as f32).contains(&x) && (0.0..S as f32).contains(&y),
                "{what}: {p} is off screen at ({x}, {y})"
            );
            Vec3::from_slice(&pixel(&lit, S, x, y)[..3])
        };
        let mut brightest = 0.0f32;
        for (&(centre, is_red), &p) in panes.iter().zip(&landing) {
            let c = at(p);
            eprintln!("{what}: pane at {centre} lands at {p} and shows {c}");
            let (own, other) = if is_red { (c.x, c.z) } else { (c.z, c.x) };
            assert!(
                own > 4.0 * other && own > 0.05,
                "{what}: the {} pane at {centre} lands at {p}, which shows {c}",
                if is_red { "red" } else { "blue" }
            );
            brightest = brightest.max(own);
        }
        let none = at(dark_spot);
        assert!(
            none.max_element() < 0.02 * brightest,
            "{what}: light at {dark_spot}, where the ray misses the window: {none}"
        );
    }
}
