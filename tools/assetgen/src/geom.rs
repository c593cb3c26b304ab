//! The corridor's geometry: a closed stone shell (floor, walls, pointed vault, two end walls)
//! whose only openings are filled by window panes, dressed with piers and transverse ribs, and
//! surrounded by a sky cylinder.
//!
//! Coordinates are metres, Y up. The corridor runs from z = 0 (the entrance) to z = -length (the
//! end wall with the rose); the sunny side is x = +half_width. Every surface is single-sided,
//! wound counter-clockwise seen from inside, and the shell shares every edge exactly (no
//! T-junctions), so rasterising it leaves no cracks for the sky to leak through.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use crate::dmath;

/// A material class as the manifest names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Class {
    Floor,
    Wall,
    WindowUpper,
    WindowLower,
    Background,
}

impl Class {
    pub fn name(self) -> &'static str {
        match self {
            Class::Floor => "floor",
            Class::Wall => "wall",
            Class::WindowUpper => "window-upper",
            Class::WindowLower => "window-lower",
            Class::Background => "background",
        }
    }

    pub fn is_window(self) -> bool {
        matches!(self, Class::WindowUpper | Class::WindowLower)
    }

    /// Surfaces that catch the light coming through the windows.
    pub fn receives_light(self) -> bool {
        matches!(self, Class::Floor | Class::Wall)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vertex {
    pub position: Vec3,
    pub normal: Vec3,
    pub uv: Vec2,
}

/// One OBJ object (`o` + `usemtl`): an indexed triangle list with a single material.
#[derive(Clone, Debug)]
pub struct Object {
    pub name: String,
    pub material: String,
    pub class: Class,
    pub vertices: Vec<Vertex>,
    pub triangles: Vec<[u32; 3]>,
    lookup: HashMap<[u32; 8], u32>,
}

/// Twice the area below which a triangle counts as degenerate (m²).
pub const MIN_DOUBLE_AREA: f32 = 1e-7;

impl Object {
    fn new(name: impl Into<String>, material: impl Into<String>, class: Class) -> Self {
        Self {
            name: name.into(),
            material: material.into(),
            class,
            vertices: Vec::new(),
            triangles: Vec::new(),
            lookup: HashMap::new(),
        }
    }

    fn vertex(&mut self, position: Vec3, normal: Vec3, uv: Vec2) -> u32 {
        // -0.0 and 0.0 must weld, and they must print the same in the OBJ.
        let clean = |x: f32| if x == 0.0 { 0.0 } else { x };
        let v = Vertex {
            position: position.map(clean),
            normal: normal.map(clean),
            uv: uv.map(clean),
        };
        let key = [
            v.position.x,
            v.position.y,
            v.position.z,
            v.normal.x,
            v.normal.y,
            v.normal.z,
            v.uv.x,
            v.uv.y,
        ]
        .map(f32::to_bits);
        if let Some(&i) = self.lookup.get(&key) {
            return i;
        }
        let i = self.vertices.len() as u32;
        self.vertices.push(v);
        self.lookup.insert(key, i);
        i
    }

    /// Adds a triangle wound counter-clockwise as seen from the side `facing` points to, so
    /// callers can list corners in whatever order their decomposition produces them.
    fn triangle(&mut self, a: u32, b: u32, c: u32, facing: Vec3) {
        let [pa, pb, pc] = [a, b, c].map(|i| self.vertices[i as usize].position);
        let n = (pb - pa).cross(pc - pa);
        if n.length() < MIN_DOUBLE_AREA {
            return;
        }
        if n.dot(facing) >= 0.0 {
            self.triangles.push([a, b, c]);
        } else {
            self.triangles.push([a, c, b]);
        }
    }

    pub fn corners(&self, t: [u32; 3]) -> [Vec3; 3] {
        t.map(|i| self.vertices[i as usize].position)
    }
}

/// A plane with orthonormal in-plane axes: walls are built in 2D and mapped here.
#[derive(Clone, Copy, Debug)]
struct Plane {
    origin: Vec3,
    s: Vec3,
    t: Vec3,
    /// Faces the inside of the corridor.
    normal: Vec3,
}

impl Plane {
    /// Axes are unit vectors along world axes, so this is exact: points computed from the same
    /// 2D coordinates on different surfaces come out bit-identical and the shell welds.
    fn at(&self, p: Vec2) -> Vec3 {
        self.origin + self.s * p.x + self.t * p.y
    }
}

/// Texture coordinates of stone surfaces: one texture repeat per `tile` metres.
fn tiled(p: Vec2, tile: Vec2) -> Vec2 {
    p / tile
}

/// Adds a triangle given in plane coordinates with flat normal and a UV mapping.
fn tri2(obj: &mut Object, plane: &Plane, pts: [Vec2; 3], uv: &dyn Fn(Vec2) -> Vec2) {
    let idx = pts.map(|p| obj.vertex(plane.at(p), plane.normal, uv(p)));
    obj.triangle(idx[0], idx[1], idx[2], plane.normal);
}

fn quad2(obj: &mut Object, plane: &Plane, pts: [Vec2; 4], uv: &dyn Fn(Vec2) -> Vec2) {
    tri2(obj, plane, [pts[0], pts[1], pts[2]], uv);
    tri2(obj, plane, [pts[0], pts[2], pts[3]], uv);
}

fn rect2(obj: &mut Object, plane: &Plane, lo: Vec2, hi: Vec2, uv: &dyn Fn(Vec2) -> Vec2) {
    quad2(
        obj,
        plane,
        [lo, Vec2::new(hi.x, lo.y), hi, Vec2::new(lo.x, hi.y)],
        uv,
    );
}

/// Fan from `centre` over the closed polygon `ring` (which must be star-shaped from it).
fn fan2(obj: &mut Object, plane: &Plane, centre: Vec2, ring: &[Vec2], uv: &dyn Fn(Vec2) -> Vec2) {
    for i in 0..ring.len() {
        tri2(
            obj,
            plane,
            [centre, ring[i], ring[(i + 1) % ring.len()]],
            uv,
        );
    }
}

/// A window opening: a rectangle from the sill to the springing line, topped by a pointed arch
/// of two circular arcs of radius `radius` centred on the springing line (radius = width gives
/// the equilateral arch; radius = width / 2 a round arch).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArchShape {
    pub width: f32,
    pub sill: f32,
    pub spring: f32,
    pub radius: f32,
}

/// Segments per side of an arch.
pub const ARCH_SEGMENTS: usize = 12;

impl ArchShape {
    pub fn rise(&self) -> f32 {
        let off = self.radius - self.width / 2.0;
        (self.radius * self.radius - off * off).sqrt()
    }

    pub fn apex(&self) -> f32 {
        self.spring + self.rise()
    }

    /// Height of the opening from sill to apex.
    pub fn height(&self) -> f32 {
        self.apex() - self.sill
    }

    /// Springing line above the sill.
    pub fn spring_local(&self) -> f32 {
        self.spring - self.sill
    }

    /// The outline counter-clockwise in local coordinates (x from 0 to width, y from 0 at the
    /// sill): bottom left, bottom right, right springing, right arc, apex, left arc, left
    /// springing. The left arc mirrors the right one exactly.
    pub fn outline(&self) -> Vec<Vec2> {
        let (w, ys, r) = (
            self.width as f64,
            self.spring_local() as f64,
            self.radius as f64,
        );
        let rise = self.rise() as f64;
        let cx = w - r;
        let apex_angle = dmath::atan2(rise, w / 2.0 - cx);
        let right: Vec<Vec2> = (1..ARCH_SEGMENTS)
            .map(|k| {
                let (s, c) = dmath::sin_cos(apex_angle * k as f64 / ARCH_SEGMENTS as f64);
                Vec2::new((cx + r * c) as f32, (ys + r * s) as f32)
            })
            .collect();
        let mut out = vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(self.width, 0.0),
            Vec2::new(self.width, ys as f32),
        ];
        out.extend(right.iter().copied());
        out.push(Vec2::new(self.width / 2.0, self.height()));
        out.extend(right.iter().rev().map(|p| Vec2::new(self.width - p.x, p.y)));
        out.push(Vec2::new(0.0, ys as f32));
        out
    }

    /// Signed distance (negative inside) to the opening, in the local frame of [`outline`].
    /// Exact for the rectangle and each arc; offsetting it inwards gives the same arch shape
    /// with a smaller radius, which is how border bands follow the stonework.
    ///
    /// [`outline`]: ArchShape::outline
    pub fn sdf(&self, p: Vec2) -> f32 {
        let ys = self.spring_local();
        let mut d = (-p.x).max(p.x - self.width).max(-p.y);
        if p.y > ys {
            let left = Vec2::new(self.radius, ys);
            let right = Vec2::new(self.width - self.radius, ys);
            d = d
                .max((p - left).length() - self.radius)
                .max((p - right).length() - self.radius);
        }
        d
    }
}

/// Everything that fixes the scene's proportions.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    pub half_width: f32,
    pub bays: usize,
    pub bay: f32,
    /// Height of the side walls, where the vault springs.
    pub wall_height: f32,
    /// Radius of each arc of the pointed vault.
    pub vault_radius: f32,
    pub lower: ArchShape,
    pub upper: ArchShape,
    pub rose_centre_y: f32,
    pub rose_radius: f32,
    pub pier_width: f32,
    pub pier_depth: f32,
    /// How far the glass sits back from the inner face of the wall, in its embrasure.
    pub reveal: f32,
    pub sky_radius: f32,
    pub sky_top: f32,
    pub ground_y: f32,
    /// The direction sunlight travels (unit length).
    pub sun: Vec3,
}

pub const VAULT_SEGMENTS: usize = 16;
pub const ROSE_SEGMENTS: usize = 96;
pub const SKY_SEGMENTS: usize = 64;
const WALL_TILE: Vec2 = Vec2::new(2.4, 2.1);
const FLOOR_TILE: Vec2 = Vec2::new(2.0, 2.0);

/// Rounds to 4 decimals, as the manifest prints it, so the checks use the written value.
fn round4(v: Vec3) -> Vec3 {
    (v * 10_000.0).round() / 10_000.0
}

impl Default for Layout {
    fn default() -> Self {
        Self {
            half_width: 4.0,
            bays: 6,
            bay: 4.0,
            wall_height: 12.5,
            vault_radius: 6.4,
            lower: ArchShape {
                width: 2.0,
                sill: 1.0,
                spring: 5.5,
                radius: 2.0,
            },
            upper: ArchShape {
                width: 2.4,
                sill: 8.2,
                spring: 10.0,
                radius: 1.92,
            },
            rose_centre_y: 12.5,
            rose_radius: 3.2,
            pier_width: 0.5,
            pier_depth: 0.3,
            reveal: 0.35,
            sky_radius: 150.0,
            sky_top: 110.0,
            ground_y: -0.3,
            // From the south-east, high in the sky: it crosses the sunny wall (-x), falls
            // steeply (-y) and runs towards the entrance (+z), so it also enters the rose.
            sun: round4(Vec3::new(-0.5, -0.7, 0.5).normalize()),
        }
    }
}

impl Layout {
    pub fn length(&self) -> f32 {
        self.bay * self.bays as f32
    }

    /// z of the near (sb) and far (sa) edges of bay `i`; bay 0 is at the entrance.
    pub fn bay_span(&self, i: usize) -> (f32, f32) {
        (-(i as f32) * self.bay, -((i + 1) as f32) * self.bay)
    }

    pub fn bay_centre(&self, i: usize) -> f32 {
        let (near, far) = self.bay_span(i);
        (near + far) / 2.0
    }

    /// Heights at which both side walls have vertices on every bay boundary (the sunny wall
    /// needs them around its windows; the shaded wall and the end walls repeat them so that
    /// every edge meets a matching edge).
    fn wall_levels(&self) -> [f32; 6] {
        [
            0.0,
            self.lower.sill,
            self.lower.spring,
            self.upper.sill,
            self.upper.spring,
            self.wall_height,
        ]
    }

    /// Height of the vault above the walls. Each arc is centred on the springing line at
    /// x = +-(half_width - vault_radius), i.e. beyond the corridor's axis.
    pub fn vault_rise(&self) -> f32 {
        let off = self.vault_radius - self.half_width;
        (self.vault_radius * self.vault_radius - off * off).sqrt()
    }

    pub fn vault_apex(&self) -> f32 {
        self.wall_height + self.vault_rise()
    }

    /// The sunny (x > 0) arc of the vault, springing to apex inclusive, with radius `radius`
    /// about the same centre (smaller radii give the ribs' soffits). Points and inward normals.
    fn vault_arc(&self, radius: f32) -> Vec<(Vec2, Vec2)> {
        let cx = (self.half_width - self.vault_radius) as f64;
        let cy = self.wall_height as f64;
        let r = radius as f64;
        let rise = (r * r - cx * cx).sqrt();
        let apex_angle = dmath::atan2(rise, -cx);
        let centre = Vec2::new(cx as f32, cy as f32);
        (0..=VAULT_SEGMENTS)
            .map(|k| {
                let p = if k == VAULT_SEGMENTS {
                    Vec2::new(0.0, (cy + rise) as f32)
                } else {
                    let (s, c) = dmath::sin_cos(apex_angle * k as f64 / VAULT_SEGMENTS as f64);
                    Vec2::new((cx + r * c) as f32, (cy + r * s) as f32)
                };
                (p, (centre - p).normalize())
            })
            .collect()
    }

    /// The corridor's cross-section counter-clockwise in (x, y), with a vertex everywhere a
    /// wall or vault edge meets the end walls.
    pub fn profile(&self) -> Vec<Vec2> {
        let hw = self.half_width;
        let mut out: Vec<Vec2> = self.floor_xs().iter().map(|&x| Vec2::new(x, 0.0)).collect();
        out.extend(self.wall_levels()[1..].iter().map(|&y| Vec2::new(hw, y)));
        let arc = self.vault_arc(self.vault_radius);
        out.extend(arc[1..].iter().map(|(p, _)| *p));
        out.extend(
            arc[1..VAULT_SEGMENTS]
                .iter()
                .rev()
                .map(|(p, _)| Vec2::new(-p.x, p.y)),
        );
        out.extend(
            self.wall_levels()[1..]
                .iter()
                .rev()
                .map(|&y| Vec2::new(-hw, y)),
        );
        out
    }

    /// Where the floor has vertices across the corridor at every bay boundary. The rose's
    /// ring triangulation fans from these to the bottom of the circle; without them the fan
    /// triangles would be too long and fold over the rose.
    fn floor_xs(&self) -> [f32; 5] {
        let hw = self.half_width;
        [-hw, -hw / 2.0, 0.0, hw / 2.0, hw]
    }

    /// Circle points of the rose, counter-clockwise from angle 0, relative to its centre.
    pub fn rose_ring(&self) -> Vec<Vec2> {
        (0..ROSE_SEGMENTS)
            .map(|k| {
                let (s, c) = dmath::sin_cos(dmath::TAU * k as f64 / ROSE_SEGMENTS as f64);
                Vec2::new(
                    (self.rose_radius as f64 * c) as f32,
                    (self.rose_radius as f64 * s) as f32,
                )
            })
            .collect()
    }
}

/// The images a window can show. Each is drawn for one opening shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Design {
    /// Voronoi mosaic in a lower lancet.
    Mosaic,
    /// Stacked geometric medallions on diamond quarries in a lower lancet.
    Lancet,
    /// Interlaced grisaille with a jewelled border, for the clerestory.
    Border,
    /// The rose: radial petals and stone tracery.
    Rose,
}

impl Design {
    pub const ALL: [Design; 4] = [Design::Mosaic, Design::Lancet, Design::Border, Design::Rose];

    pub fn file(self) -> &'static str {
        match self {
            Design::Mosaic => "windows/mosaic.png",
            Design::Lancet => "windows/lancet.png",
            Design::Border => "windows/border.png",
            Design::Rose => "windows/rose.png",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NormalMap {
    Hammered,
    Reeded,
}

impl NormalMap {
    pub const ALL: [NormalMap; 2] = [NormalMap::Hammered, NormalMap::Reeded];

    pub fn file(self) -> &'static str {
        match self {
            NormalMap::Hammered => "normals/hammered.png",
            NormalMap::Reeded => "normals/reeded.png",
        }
    }
}

#[derive(Clone, Debug)]
pub struct WindowSpec {
    /// Index into [`Scene::objects`].
    pub object: usize,
    pub material: String,
    pub class: Class,
    pub design: Design,
    pub normal_map: Option<NormalMap>,
    /// Faces into the corridor.
    pub inward: Vec3,
    pub centre: Vec3,
}

#[derive(Clone, Debug)]
pub struct Scene {
    pub layout: Layout,
    pub objects: Vec<Object>,
    pub windows: Vec<WindowSpec>,
}

impl Scene {
    pub fn window_object(&self, w: &WindowSpec) -> &Object {
        &self.objects[w.object]
    }
}

/// Builds the whole scene. Pure and deterministic: the layout is the only input.
pub fn build(layout: &Layout) -> Scene {
    let mut scene = Scene {
        layout: layout.clone(),
        objects: Vec::new(),
        windows: Vec::new(),
    };
    let l = layout;
    let hw = l.half_width;
    let length = l.length();

    let sunny = Plane {
        origin: Vec3::new(hw, 0.0, 0.0),
        s: Vec3::Z,
        t: Vec3::Y,
        normal: Vec3::NEG_X,
    };
    let wall_uv = |p: Vec2| tiled(p, WALL_TILE);

    // Floor: one fan per bay, with vertices where the sunny wall's lower windows start and end.
    let mut floor = Object::new("floor", "floor_stone", Class::Floor);
    for i in 0..l.bays {
        let (near, far) = l.bay_span(i);
        let c = l.bay_centre(i);
        let (w0, w1) = (c - l.lower.width / 2.0, c + l.lower.width / 2.0);
        let xs = l.floor_xs();
        let mut ring: Vec<(f32, f32)> = xs.iter().map(|&x| (x, near)).collect();
        ring.extend([(hw, w1), (hw, w0)]);
        ring.extend(xs.iter().rev().map(|&x| (x, far)));
        let centre = floor.vertex(
            Vec3::new(0.0, 0.0, c),
            Vec3::Y,
            Vec2::new(0.0, c) / FLOOR_TILE,
        );
        let ids: Vec<u32> = ring
            .iter()
            .map(|&(x, z)| {
                floor.vertex(Vec3::new(x, 0.0, z), Vec3::Y, Vec2::new(x, z) / FLOOR_TILE)
            })
            .collect();
        for k in 0..ids.len() {
            floor.triangle(centre, ids[k], ids[(k + 1) % ids.len()], Vec3::Y);
        }
    }
    scene.objects.push(floor);

    // Sunny wall, pierced by two rows of windows; each bay is cut into rectangles around the
    // openings plus fans over the spandrels (see `arch_spandrels`).
    let mut wall = Object::new("wall_sunny", "wall_stone", Class::Wall);
    let mut windows = Vec::new();
    for i in 0..l.bays {
        let (near, far) = l.bay_span(i);
        let c = l.bay_centre(i);
        let lo = l.lower;
        let up = l.upper;
        let (l0, l1) = (c - lo.width / 2.0, c + lo.width / 2.0);
        let (u0, u1) = (c - up.width / 2.0, c + up.width / 2.0);
        // Below the lower sill, split where the window's bottom edge starts and ends.
        for (a, b) in [(far, l0), (l0, l1), (l1, near)] {
            rect2(
                &mut wall,
                &sunny,
                Vec2::new(a, 0.0),
                Vec2::new(b, lo.sill),
                &wall_uv,
            );
        }
        let openings = [(lo, l0, l1, Some((u0, u1, up.sill))), (up, u0, u1, None)];
        for (shape, s0, s1, next) in openings {
            // Mapped about the centre so the corners come out bit-identical to `c -+ width / 2`
            // as used for the neighbouring wall pieces (s0 + width would round differently).
            let outline: Vec<Vec2> = shape
                .outline()
                .iter()
                .map(|p| Vec2::new(c + (p.x - shape.width / 2.0), shape.sill + p.y))
                .collect();
            rect2(
                &mut wall,
                &sunny,
                Vec2::new(far, shape.sill),
                Vec2::new(s0, shape.spring),
                &wall_uv,
            );
            rect2(
                &mut wall,
                &sunny,
                Vec2::new(s1, shape.sill),
                Vec2::new(near, shape.spring),
                &wall_uv,
            );
            let (top, top_points) = match next {
                Some((n0, n1, sill)) => (sill, vec![Vec2::new(n0, sill), Vec2::new(n1, sill)]),
                None => (l.wall_height, Vec::new()),
            };
            arch_spandrels(
                &mut wall,
                &sunny,
                &outline,
                far,
                near,
                top,
                &top_points,
                &wall_uv,
            );
            windows.push((shape, s0, outline, i));
        }
    }
    scene.objects.push(wall);

    // The shaded wall and the vault: plain strips per bay, so their edges meet the floor's and
    // the sunny wall's bay vertices.
    let shaded = Plane {
        origin: Vec3::new(-hw, 0.0, 0.0),
        s: Vec3::Z,
        t: Vec3::Y,
        normal: Vec3::X,
    };
    let mut wall = Object::new("wall_shaded", "wall_stone", Class::Wall);
    let levels = l.wall_levels();
    for i in 0..l.bays {
        let (near, far) = l.bay_span(i);
        for y in levels.windows(2) {
            rect2(
                &mut wall,
                &shaded,
                Vec2::new(far, y[0]),
                Vec2::new(near, y[1]),
                &wall_uv,
            );
        }
    }
    scene.objects.push(wall);

    let mut roof = Object::new("vault", "roof", Class::Wall);
    let arc = l.vault_arc(l.vault_radius);
    for side in [1.0f32, -1.0] {
        let pts: Vec<(Vec3, Vec3)> = arc
            .iter()
            .map(|(p, n)| {
                (
                    Vec3::new(side * p.x, p.y, 0.0),
                    Vec3::new(side * n.x, n.y, 0.0),
                )
            })
            .collect();
        for i in 0..l.bays {
            let (near, far) = l.bay_span(i);
            for k in 0..VAULT_SEGMENTS {
                let (a, na) = pts[k];
                let (b, nb) = pts[k + 1];
                // u runs along the arc (arc length / tile), v along the corridor.
                let ua = k as f32 * 0.25;
                let ub = (k + 1) as f32 * 0.25;
                let v = |z: f32| z / WALL_TILE.y;
                let ids = [
                    roof.vertex(a.with_z(far), na, Vec2::new(ua, v(far))),
                    roof.vertex(b.with_z(far), nb, Vec2::new(ub, v(far))),
                    roof.vertex(b.with_z(near), nb, Vec2::new(ub, v(near))),
                    roof.vertex(a.with_z(near), na, Vec2::new(ua, v(near))),
                ];
                let facing = (na + nb) * 0.5;
                roof.triangle(ids[0], ids[1], ids[2], facing);
                roof.triangle(ids[0], ids[2], ids[3], facing);
            }
        }
    }
    scene.objects.push(roof);

    // End walls: the entrance is solid; the far wall is zipped around the rose.
    let profile = l.profile();
    let entrance = Plane {
        origin: Vec3::ZERO,
        s: Vec3::X,
        t: Vec3::Y,
        normal: Vec3::NEG_Z,
    };
    let mut end = Object::new("wall_entrance", "wall_stone", Class::Wall);
    let mid = Vec2::new(0.0, l.wall_height / 2.0);
    fan2(&mut end, &entrance, mid, &profile, &wall_uv);
    scene.objects.push(end);

    let far_plane = Plane {
        origin: Vec3::new(0.0, 0.0, -length),
        s: Vec3::X,
        t: Vec3::Y,
        normal: Vec3::Z,
    };
    let rose_centre = Vec2::new(0.0, l.rose_centre_y);
    let ring: Vec<Vec2> = l.rose_ring().iter().map(|p| rose_centre + *p).collect();
    let mut end = Object::new("wall_end", "wall_stone", Class::Wall);
    zip_rings(&mut end, &far_plane, rose_centre, &ring, &profile, &wall_uv);
    scene.objects.push(end);

    // Window panes, set back in their embrasures; the reveals close the shell between the
    // wall's openings and the glass. UVs span the design: u = 0 at the left edge seen from
    // inside.
    let mut reveals = Object::new("reveals", "wall_stone", Class::Wall);
    let sunny_glass = Plane {
        origin: sunny.origin + Vec3::X * l.reveal,
        ..sunny
    };
    for (k, (shape, s0, outline, bay)) in windows.into_iter().enumerate() {
        let upper = k % 2 == 1;
        let n = bay + 1;
        let (material, class, design, normal_map) = if upper {
            let normal = if bay % 2 == 0 {
                Some(NormalMap::Reeded)
            } else {
                None
            };
            (
                format!("window_upper_{n}"),
                Class::WindowUpper,
                Design::Border,
                normal,
            )
        } else if bay % 2 == 0 {
            (
                format!("window_lower_{n}"),
                Class::WindowLower,
                Design::Lancet,
                Some(NormalMap::Hammered),
            )
        } else {
            // No normal map: the cooker derives one from the design.
            (
                format!("window_lower_{n}"),
                Class::WindowLower,
                Design::Mosaic,
                None,
            )
        };
        let mut obj = Object::new(material.clone(), material.clone(), class);
        let (w, h) = (shape.width, shape.height());
        // Clamped: the corners' positions round a hair beyond the unit square.
        let uv = move |p: Vec2| {
            Vec2::new((p.x - s0) / w, (p.y - shape.sill) / h).clamp(Vec2::ZERO, Vec2::ONE)
        };
        let centre = Vec2::new(s0 + w / 2.0, shape.sill + h / 2.0);
        fan2(&mut obj, &sunny_glass, centre, &outline, &uv);
        reveal(&mut reveals, &sunny, &sunny_glass, centre, &outline);
        scene.windows.push(WindowSpec {
            object: scene.objects.len(),
            material,
            class,
            design,
            normal_map,
            inward: sunny.normal,
            centre: sunny_glass.at(centre),
        });
        scene.objects.push(obj);
    }
    let mut rose = Object::new("rose", "rose", Class::WindowUpper);
    let r = l.rose_radius;
    let uv = move |p: Vec2| {
        ((p - rose_centre + Vec2::splat(r)) / (2.0 * r)).clamp(Vec2::ZERO, Vec2::ONE)
    };
    let rose_glass = Plane {
        origin: far_plane.origin - Vec3::Z * l.reveal,
        ..far_plane
    };
    fan2(&mut rose, &rose_glass, rose_centre, &ring, &uv);
    reveal(&mut reveals, &far_plane, &rose_glass, rose_centre, &ring);
    scene.windows.push(WindowSpec {
        object: scene.objects.len(),
        material: "rose".into(),
        class: Class::WindowUpper,
        design: Design::Rose,
        normal_map: Some(NormalMap::Hammered),
        inward: far_plane.normal,
        centre: rose_glass.at(rose_centre),
    });
    scene.objects.push(rose);

    scene.objects.push(reveals);
    scene.objects.push(piers_and_ribs(l));
    scene.objects.push(sky(l));
    scene
}

/// The embrasure of an opening: one flat quad per outline edge from the wall's face to the
/// glass, facing into the opening.
fn reveal(obj: &mut Object, wall: &Plane, glass: &Plane, centre: Vec2, outline: &[Vec2]) {
    let depth = (glass.origin - wall.origin).length();
    let mut along = 0.0;
    for k in 0..outline.len() {
        let (a, b) = (outline[k], outline[(k + 1) % outline.len()]);
        let edge = b - a;
        let to_centre = centre - (a + b) * 0.5;
        let n2 = to_centre - edge * (to_centre.dot(edge) / edge.length_squared());
        let n = (wall.s * n2.x + wall.t * n2.y).normalize();
        let (u0, u1) = (along / WALL_TILE.x, (along + edge.length()) / WALL_TILE.x);
        along += edge.length();
        let v1 = depth / WALL_TILE.y;
        let ids = [
            obj.vertex(wall.at(a), n, Vec2::new(u0, 0.0)),
            obj.vertex(wall.at(b), n, Vec2::new(u1, 0.0)),
            obj.vertex(glass.at(b), n, Vec2::new(u1, v1)),
            obj.vertex(glass.at(a), n, Vec2::new(u0, v1)),
        ];
        obj.triangle(ids[0], ids[1], ids[2], n);
        obj.triangle(ids[0], ids[2], ids[3], n);
    }
}

/// Covers the wall between an arch and the level `top` above it. Each half of the arch is
/// convex towards its upper corner of the bay, so a fan from that corner sees all of it; the
/// apex then fans to the top edge, through `top_points` (the next window's bottom corners),
/// which keeps the top edge free of T-junctions.
#[allow(clippy::too_many_arguments)]
fn arch_spandrels(
    obj: &mut Object,
    plane: &Plane,
    outline: &[Vec2],
    far: f32,
    near: f32,
    top: f32,
    top_points: &[Vec2],
    uv: &dyn Fn(Vec2) -> Vec2,
) {
    let n = outline.len();
    let apex_index = 2 + ARCH_SEGMENTS;
    let apex = outline[apex_index];
    let spring_y = outline[2].y;
    // Left: from the bay edge at springing height, along the left arc up to the apex.
    let mut left = vec![Vec2::new(far, spring_y), outline[n - 1]];
    left.extend((apex_index..n - 1).rev().map(|i| outline[i]));
    let corner = Vec2::new(far, top);
    for w in left.windows(2) {
        tri2(obj, plane, [corner, w[0], w[1]], uv);
    }
    let mut right: Vec<Vec2> = (2..=apex_index).map(|i| outline[i]).collect();
    right.insert(0, Vec2::new(near, spring_y));
    let corner_r = Vec2::new(near, top);
    for w in right.windows(2) {
        tri2(obj, plane, [corner_r, w[0], w[1]], uv);
    }
    let mut top_edge = vec![corner];
    top_edge.extend(top_points.iter().copied());
    top_edge.push(corner_r);
    for w in top_edge.windows(2) {
        tri2(obj, plane, [apex, w[0], w[1]], uv);
    }
}

/// Triangulates the ring between `inner` and `outer` (both counter-clockwise and star-shaped
/// about `centre`) by merging their vertices in angular order, so every vertex of both
/// boundaries is used and the wall meets the rose and the shell edge for edge.
fn zip_rings(
    obj: &mut Object,
    plane: &Plane,
    centre: Vec2,
    inner: &[Vec2],
    outer: &[Vec2],
    uv: &dyn Fn(Vec2) -> Vec2,
) {
    let unwrap = |pts: &[Vec2]| -> (Vec<Vec2>, Vec<f64>) {
        let ang: Vec<f64> = pts
            .iter()
            .map(|p| dmath::angle((p.y - centre.y) as f64, (p.x - centre.x) as f64))
            .collect();
        let start = (0..pts.len())
            .min_by(|&a, &b| ang[a].total_cmp(&ang[b]))
            .expect("rings are not empty");
        let mut p = Vec::with_capacity(pts.len() + 1);
        let mut a = Vec::with_capacity(pts.len() + 1);
        for k in 0..=pts.len() {
            let i = (start + k) % pts.len();
            let mut x = ang[i];
            if k > 0 && x <= a[k - 1] {
                x += dmath::TAU;
            }
            p.push(pts[i]);
            a.push(x);
        }
        (p, a)
    };
    let (ip, ia) = unwrap(inner);
    let (op, oa) = unwrap(outer);
    let (mut i, mut o) = (0, 0);
    while i < inner.len() || o < outer.len() {
        let take_outer = i == inner.len() || (o < outer.len() && oa[o + 1] < ia[i + 1]);
        if take_outer {
            tri2(obj, plane, [ip[i], op[o], op[o + 1]], uv);
            o += 1;
        } else {
            tri2(obj, plane, [ip[i], op[o], ip[i + 1]], uv);
            i += 1;
        }
    }
}

/// Engaged piers between the bays on both walls and the transverse ribs that carry them over
/// the vault: the rhythm that makes the corridor read as gothic.
fn piers_and_ribs(l: &Layout) -> Object {
    let mut obj = Object::new("piers", "wall_pier", Class::Wall);
    let (d, hw, half) = (l.pier_depth, l.half_width, l.pier_width / 2.0);
    let outer = l.vault_arc(l.vault_radius);
    let inner = l.vault_arc(l.vault_radius - d);
    for b in 1..l.bays {
        let zc = -(b as f32) * l.bay;
        let (z0, z1) = (zc - half, zc + half);
        for side in [1.0f32, -1.0] {
            let x_wall = side * hw;
            let x_face = side * (hw - d);
            let inward = Vec3::new(-side, 0.0, 0.0);
            let h = l.wall_height;
            let v = |y: f32| y / WALL_TILE.y;
            // Front face and the two sides of the pier.
            quad3(
                &mut obj,
                [
                    Vec3::new(x_face, 0.0, z0),
                    Vec3::new(x_face, 0.0, z1),
                    Vec3::new(x_face, h, z1),
                    Vec3::new(x_face, h, z0),
                ],
                inward,
                [
                    Vec2::new(0.0, 0.0),
                    Vec2::new(0.2, 0.0),
                    Vec2::new(0.2, v(h)),
                    Vec2::new(0.0, v(h)),
                ],
            );
            for (z, n) in [(z0, Vec3::NEG_Z), (z1, Vec3::Z)] {
                quad3(
                    &mut obj,
                    [
                        Vec3::new(x_wall, 0.0, z),
                        Vec3::new(x_face, 0.0, z),
                        Vec3::new(x_face, h, z),
                        Vec3::new(x_wall, h, z),
                    ],
                    n,
                    [
                        Vec2::new(0.0, 0.0),
                        Vec2::new(0.125, 0.0),
                        Vec2::new(0.125, v(h)),
                        Vec2::new(0.0, v(h)),
                    ],
                );
            }
            // The rib: its soffit follows the vault at radius - depth, its sides close the gap.
            for k in 0..VAULT_SEGMENTS {
                let (pa, _) = outer[k];
                let (pb, _) = outer[k + 1];
                let (qa, na) = inner[k];
                let (qb, nb) = inner[k + 1];
                let m = |p: Vec2| Vec3::new(side * p.x, p.y, 0.0);
                let mn = |n: Vec2| Vec3::new(side * n.x, n.y, 0.0);
                let (ua, ub) = (k as f32 * 0.25, (k + 1) as f32 * 0.25);
                let ids = [
                    obj.vertex(m(qa).with_z(z0), mn(na), Vec2::new(ua, 0.0)),
                    obj.vertex(m(qb).with_z(z0), mn(nb), Vec2::new(ub, 0.0)),
                    obj.vertex(m(qb).with_z(z1), mn(nb), Vec2::new(ub, 0.2)),
                    obj.vertex(m(qa).with_z(z1), mn(na), Vec2::new(ua, 0.2)),
                ];
                let facing = mn(na + nb);
                obj.triangle(ids[0], ids[1], ids[2], facing);
                obj.triangle(ids[0], ids[2], ids[3], facing);
                for (z, n) in [(z0, Vec3::NEG_Z), (z1, Vec3::Z)] {
                    quad3(
                        &mut obj,
                        [
                            m(pa).with_z(z),
                            m(pb).with_z(z),
                            m(qb).with_z(z),
                            m(qa).with_z(z),
                        ],
                        n,
                        [
                            Vec2::new(ua, 0.0),
                            Vec2::new(ub, 0.0),
                            Vec2::new(ub, 0.125),
                            Vec2::new(ua, 0.125),
                        ],
                    );
                }
            }
        }
    }
    obj
}

/// A planar quad with one normal, wound to face `n`.
fn quad3(obj: &mut Object, pts: [Vec3; 4], n: Vec3, uvs: [Vec2; 4]) {
    let ids = [0, 1, 2, 3].map(|i| obj.vertex(pts[i], n, uvs[i]));
    obj.triangle(ids[0], ids[1], ids[2], n);
    obj.triangle(ids[0], ids[2], ids[3], n);
}

/// The world outside: a cylinder textured with sky and mountains, a cap at the zenith and a
/// ground disc just below the floor. All of it faces the corridor, which sits at its centre.
fn sky(l: &Layout) -> Object {
    let centre = Vec3::new(0.0, 0.0, -l.length() / 2.0);
    let (r, y0, y1) = (l.sky_radius, l.ground_y, l.sky_top);
    // Half a texel in from the edges, so bilinear filtering never wraps to the other edge.
    let (v0, v1) = (
        0.5 / crate::textures::SKY_HEIGHT as f32,
        1.0 - 0.5 / crate::textures::SKY_HEIGHT as f32,
    );
    let ring: Vec<(Vec3, f32)> = (0..=SKY_SEGMENTS)
        .map(|k| {
            let a = dmath::TAU * k as f64 / SKY_SEGMENTS as f64;
            let (s, c) = dmath::sin_cos(a);
            // Azimuth measured from -z (straight down the corridor) turning towards +x.
            (
                Vec3::new((s * r as f64) as f32, 0.0, (-c * r as f64) as f32),
                k as f32 / SKY_SEGMENTS as f32,
            )
        })
        .collect();
    let mut obj = Object::new("sky", "sky", Class::Background);
    for k in 0..SKY_SEGMENTS {
        let (a, ua) = ring[k];
        let (b, ub) = ring[k + 1];
        let n = |p: Vec3| -p.normalize();
        let ids = [
            obj.vertex(centre + a.with_y(y0), n(a), Vec2::new(ua, v0)),
            obj.vertex(centre + b.with_y(y0), n(b), Vec2::new(ub, v0)),
            obj.vertex(centre + b.with_y(y1), n(b), Vec2::new(ub, v1)),
            obj.vertex(centre + a.with_y(y1), n(a), Vec2::new(ua, v1)),
        ];
        let facing = n(a + b);
        obj.triangle(ids[0], ids[1], ids[2], facing);
        obj.triangle(ids[0], ids[2], ids[3], facing);
    }
    // The cap shows the texture's top row (zenith blue), the ground its bottom row (meadow).
    for (y, v, facing) in [(y1, v1, Vec3::NEG_Y), (y0, v0, Vec3::Y)] {
        let mid = obj.vertex(centre.with_y(y), facing, Vec2::new(0.5, v));
        for k in 0..SKY_SEGMENTS {
            let (a, ua) = ring[k];
            let (b, ub) = ring[k + 1];
            let ia = obj.vertex(centre + a.with_y(y), facing, Vec2::new(ua, v));
            let ib = obj.vertex(centre + b.with_y(y), facing, Vec2::new(ub, v));
            obj.triangle(mid, ia, ib, facing);
        }
    }
    obj
}
