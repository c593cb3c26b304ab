//! A CPU ray tracer of the lit pass (pass 3), the reference the GPU's shadow maps and
//! projectors are judged against. Its rules are written down in `docs/reference-tracer.md`;
//! in short: the same materials, light and camera as the pack gives the renderer, but light
//! is traced, not projected. A shadow ray towards a sample of the light's disc is stopped by
//! any opaque triangle and coloured by every pane of glass it crosses (the design's colour
//! times its coverage at the crossing), and the light's disc is integrated with many samples,
//! so the blur of the glass pattern and the penumbrae of stone come out of the geometry rather
//! than from the projector textures or the shadow maps.

use glam::{Vec2, Vec3, Vec4};
use pack::{MaterialClass, SectionRole, StandardVertex};

use crate::view::{LightGeometry, View};

/// Sampling of the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceSettings {
    /// Camera rays per pixel along each axis (stratified): `n²` per pixel.
    pub pixel_samples: u32,
    /// Shadow rays per camera ray, spread over the light's disc (stratified, rounded to a
    /// square number).
    pub light_samples: u32,
    /// Linear RGB ambient light, as [`crate::Settings::ambient`].
    pub ambient: [f32; 3],
}

impl Default for ReferenceSettings {
    fn default() -> Self {
        Self {
            pixel_samples: 4,
            light_samples: 4,
            ambient: crate::Settings::default().ambient,
        }
    }
}

/// A texture's level 0 (block formats decoded), as linear floats.
struct Image {
    width: usize,
    height: usize,
    texels: Vec<Vec4>,
}

impl Image {
    /// Bilinear with repeat addressing, texel centres at half-integers (the GPU's sampler
    /// without mips: supersampling the pixel stands in for the mip filter).
    fn sample(&self, uv: Vec2) -> Vec4 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |xi: f32, yi: f32| {
            let xi = (xi as i64).rem_euclid(self.width as i64) as usize;
            let yi = (yi as i64).rem_euclid(self.height as i64) as usize;
            self.texels[yi * self.width + xi]
        };
        let top = at(x0, y0).lerp(at(x0 + 1.0, y0), fx);
        let bottom = at(x0, y0 + 1.0).lerp(at(x0 + 1.0, y0 + 1.0), fx);
        top.lerp(bottom, fy)
    }
}

struct Material {
    class: MaterialClass,
    diffuse: Vec3,
    specular: Vec3,
    shininess: f32,
    emissive: Vec3,
    texture: Option<usize>,
    normal_map: Option<usize>,
}

#[derive(Clone, Copy)]
struct Triangle {
    p: [Vec3; 3],
    n: [Vec3; 3],
    uv: [Vec2; 3],
    tangent: [Vec4; 3],
    /// Linear vertex colours, interpolated as the GPU interpolates them (decoded per vertex).
    colour: [Vec3; 3],
    material: u16,
    /// Glass: the windows (bit per window, TOC order) it is the glass of. Opaque: the backed
    /// windows whose uncut wall it is part of ([`crate::occlusion::Backings`]), which it lets
    /// through a ray that crossed their glass.
    windows: u64,
}

struct Hit {
    t: f32,
    tri: u32,
    /// Barycentrics of the second and third corners.
    b: Vec2,
}

/// The scene as the tracer sees it.
pub struct Reference {
    triangles: Vec<Triangle>,
    bvh: geom::Bvh,
    materials: Vec<Material>,
    images: Vec<Option<Image>>,
    light: Option<pack::Light>,
    background: Vec3,
}

/// The exact decode (f64, rounded once to f32): the texture crate's table, which the cook's
/// mips and colours are measured against too.
fn srgb_to_linear(b: u8) -> f32 {
    texture::srgb::decode8()[b as usize]
}

impl Reference {
    /// Reads geometry, materials and textures (level 0) from a validated pack.
    pub fn from_pack(pack: &pack::Pack) -> Self {
        let toc = pack.toc();
        let images = toc
            .textures
            .iter()
            .map(|t| {
                let level = t.mips.first()?;
                // Block formats decode to the logical level (padding dropped).
                let bytes = pack::texels::decode_level(t, 0, pack.section_data(level.section));
                let (w, h) = (level.width as usize, level.height as usize);
                if bytes.len() < w * h * 4 {
                    return None;
                }
                let srgb = t.colour_space == pack::ColourSpace::Srgb;
                let texels = bytes[..w * h * 4]
                    .chunks_exact(4)
                    .map(|c| {
                        let f = |b: u8| {
                            if srgb {
                                srgb_to_linear(b)
                            } else {
                                b as f32 / 255.0
                            }
                        };
                        Vec4::new(f(c[0]), f(c[1]), f(c[2]), c[3] as f32 / 255.0)
                    })
                    .collect();
                Some(Image {
                    width: w,
                    height: h,
                    texels,
                })
            })
            .collect();
        let materials: Vec<Material> = toc
            .materials
            .iter()
            .map(|m| Material {
                class: m.class,
                diffuse: Vec3::from(m.diffuse),
                specular: Vec3::from(m.specular),
                shininess: m.shininess.max(1.0),
                emissive: Vec3::from(m.emissive),
                texture: m.diffuse_texture.map(|t| t as usize),
                normal_map: m.normal_texture.map(|t| t as usize),
            })
            .collect();
        let mut triangles = Vec::new();
        for (mi, mesh) in toc.meshes.iter().enumerate() {
            let (mut vsec, mut isec) = (None, None);
            for (i, role) in pack.roles().iter().enumerate() {
                match *role {
                    SectionRole::Vertices { mesh } if mesh as usize == mi => vsec = Some(i),
                    SectionRole::Indices { mesh } if mesh as usize == mi => isec = Some(i),
                    _ => {}
                }
            }
            let (Some(vsec), Some(isec)) = (vsec, isec) else {
                continue;
            };
            let vbytes = pack.section_bytes(vsec as u32);
            let stride = mesh.layout.stride as usize;
            let vertices: Vec<StandardVertex> = vbytes
                .chunks_exact(stride.max(1))
                .take(mesh.vertex_count as usize)
                .map(|v| mesh.layout.decode(v))
                .collect();
            let ibytes = pack.section_bytes(isec as u32);
            let indices: Vec<u32> = match mesh.index_format {
                pack::IndexFormat::U16 => ibytes
                    .chunks_exact(2)
                    .map(|c| u16::from_le_bytes([c[0], c[1]]) as u32)
                    .collect(),
                pack::IndexFormat::U32 => ibytes
                    .chunks_exact(4)
                    .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                    .collect(),
            };
            for r in &mesh.ranges {
                let first = (r.first_index as usize).min(indices.len());
                let end = (first + r.index_count as usize).min(indices.len());
                for t in indices[first..end].chunks_exact(3) {
                    let Some(v) = [t[0], t[1], t[2]]
                        .map(|i| vertices.get(i as usize))
                        .into_iter()
                        .collect::<Option<Vec<_>>>()
                    else {
                        continue;
                    };
                    triangles.push(Triangle {
                        p: [0, 1, 2].map(|k| Vec3::from(v[k].position)),
                        n: [0, 1, 2].map(|k| Vec3::from(v[k].normal)),
                        uv: [0, 1, 2].map(|k| Vec2::from(v[k].uv)),
                        tangent: [0, 1, 2].map(|k| Vec4::from(v[k].tangent)),
                        colour: [0, 1, 2].map(|k| {
                            let [r, g, b, _] = v[k].colour;
                            Vec3::new(srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b))
                        }),
                        material: r.material,
                        windows: 0,
                    });
                }
            }
        }
        let casts =
            |t: &Triangle| crate::passes::casts_shadow(materials[t.material as usize].class);
        let backings = crate::occlusion::Backings::find(
            &toc.windows,
            triangles.iter().filter(|t| casts(t)).map(|t| t.p),
        );
        for t in &mut triangles {
            t.windows = if materials[t.material as usize].class.is_window() {
                toc.windows
                    .iter()
                    .take(64)
                    .enumerate()
                    .filter(|(_, w)| w.material == t.material)
                    .fold(0, |m, (i, _)| m | 1 << i)
            } else if casts(t) {
                backings.mask(t.p)
            } else {
                0
            };
        }
        let bvh = geom::Bvh::build(triangles.len(), |i| triangles[i as usize].p);
        Self {
            triangles,
            bvh,
            materials,
            images,
            light: toc.light.clone(),
            background: Vec3::from(toc.background.colour),
        }
    }

    /// The lit pass of `view` at `width`×`height`: linear RGBA, rows top first, like
    /// [`crate::Renderer::read_target`] of [`crate::TargetId::Lit`].
    pub fn render_lit(
        &self,
        view: &View,
        width: u32,
        height: u32,
        settings: &ReferenceSettings,
    ) -> Vec<[f32; 4]> {
        use rayon::prelude::*;
        let inverse = view.view_proj_relative().inverse();
        let n = settings.pixel_samples.max(1);
        (0..height)
            .into_par_iter()
            .flat_map_iter(|y| {
                let inverse = &inverse;
                (0..width).map(move |x| {
                    let mut sum = Vec3::ZERO;
                    for sy in 0..n {
                        for sx in 0..n {
                            let px = (x as f32 + (sx as f32 + 0.5) / n as f32) / width as f32;
                            let py = (y as f32 + (sy as f32 + 0.5) / n as f32) / height as f32;
                            let ndc = Vec4::new(px * 2.0 - 1.0, 1.0 - py * 2.0, 1.0, 1.0);
                            let far = *inverse * ndc;
                            let dir = (far.truncate() / far.w).normalize();
                            let seed = (y * width + x) * n * n + sy * n + sx;
                            sum += self.radiance(view.position, dir, settings, seed);
                        }
                    }
                    let c = sum / (n * n) as f32;
                    [c.x, c.y, c.z, 1.0]
                })
            })
            .collect()
    }

    fn texture(&self, index: Option<usize>) -> Option<&Image> {
        index.and_then(|i| self.images.get(i)?.as_ref())
    }

    /// Radiance along a camera ray, by the lit pass's rules.
    fn radiance(&self, eye: Vec3, dir: Vec3, settings: &ReferenceSettings, seed: u32) -> Vec3 {
        let Some(hit) = self.closest(eye, dir) else {
            return self.background;
        };
        let tri = &self.triangles[hit.tri as usize];
        let mat = &self.materials[tri.material as usize];
        let w = Vec3::new(1.0 - hit.b.x - hit.b.y, hit.b.x, hit.b.y);
        let uv = tri.uv[0] * w.x + tri.uv[1] * w.y + tri.uv[2] * w.z;
        let colour = tri.colour[0] * w.x + tri.colour[1] * w.y + tri.colour[2] * w.z;
        let mut albedo = mat.diffuse * colour;
        if let Some(img) = self.texture(mat.texture) {
            albedo *= img.sample(uv).truncate();
        }
        if mat.class.is_window() {
            return Vec3::ZERO;
        }
        if mat.class == MaterialClass::Background {
            return albedo + mat.emissive;
        }
        let p = eye + dir * hit.t;
        // Interpolated normal, turned to the camera (both sides of a quad are seen).
        let mut geometric =
            (tri.n[0] * w.x + tri.n[1] * w.y + tri.n[2] * w.z).normalize_or(Vec3::Y);
        if geometric.dot(-dir) < 0.0 {
            geometric = -geometric;
        }
        let mut n = geometric;
        if let Some(img) = self.texture(mat.normal_map) {
            let t4 = tri.tangent[0] * w.x + tri.tangent[1] * w.y + tri.tangent[2] * w.z;
            let t3 = t4.truncate();
            if t3.length_squared() > 1e-12 {
                let t = (t3 - n * n.dot(t3)).normalize_or(Vec3::X);
                let b = n.cross(t) * if t4.w < 0.0 { -1.0 } else { 1.0 };
                let m = img.sample(uv).truncate() * 2.0 - 1.0;
                n = (t * m.x + b * m.y + n * m.z).normalize_or(n);
            }
        }
        let ambient = Vec3::from(settings.ambient);
        let mut colour = albedo * ambient + mat.emissive;
        let Some(light) = &self.light else {
            return colour;
        };
        let geometry = LightGeometry::from_light(light);
        let intensity = Vec3::from(light.colour) * light.intensity;
        let (l, radiance) = match geometry {
            LightGeometry::Point { position, radius } => {
                let d = position - p;
                // A spot's cone, by glTF's definition, from the light's centre.
                let cone = light
                    .kind
                    .cone()
                    .map_or(1.0, |c| c.towards((p - position).as_dvec3().to_array()));
                (
                    d.normalize_or(n),
                    intensity * cone as f32 / d.length_squared().max(radius * radius),
                )
            }
            LightGeometry::Directional { towards } => (towards, intensity),
        };
        let n_dot_l = n.dot(l);
        if n_dot_l <= 0.0 || geometric.dot(l) <= 0.0 {
            return colour;
        }
        let visible = self.transmittance(p + geometric * 1e-4, light, l, settings, seed);
        let r = (-l) - n * 2.0 * n.dot(-l);
        let spec = mat.specular * r.dot(-dir).max(0.0).powf(mat.shininess);
        colour += (albedo * n_dot_l + spec) * radiance * visible;
        colour
    }

    /// Mean light arriving at `p` over the light's disc: each shadow ray is stopped by opaque
    /// geometry and filtered by every pane of glass it crosses.
    fn transmittance(
        &self,
        p: Vec3,
        light: &pack::Light,
        l: Vec3,
        settings: &ReferenceSettings,
        seed: u32,
    ) -> Vec3 {
        let k = (settings.light_samples.max(1) as f32)
            .sqrt()
            .round()
            .max(1.0) as u32;
        // A frame around the direction to the light's centre.
        let a = if l.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
        let e1 = l.cross(a).normalize();
        let e2 = l.cross(e1);
        let mut total = Vec3::ZERO;
        let jitter = hash(seed);
        for i in 0..k {
            for j in 0..k {
                // Stratified over the unit square, mapped to the unit disc by area
                // (concentric rings), turned per pixel so strata do not line up as bands.
                let s = ((i as f32 + fract(jitter + 0.37 * j as f32)) / k as f32).min(0.9999);
                let t = (j as f32 + fract(jitter * 7.0 + 0.61 * i as f32)) / k as f32;
                let r = s.sqrt();
                let phi = std::f32::consts::TAU * (t + jitter);
                let disc = Vec2::new(phi.cos(), phi.sin()) * r;
                let (dir, max_t) = match light.kind {
                    pack::LightKind::Directional { angular_size, .. } => {
                        let tan = (angular_size * 0.5).tan();
                        (
                            (l + (e1 * disc.x + e2 * disc.y) * tan).normalize(),
                            f32::INFINITY,
                        )
                    }
                    pack::LightKind::Point { position, radius }
                    | pack::LightKind::Spot {
                        position, radius, ..
                    } => {
                        let q = Vec3::from(position) + (e1 * disc.x + e2 * disc.y) * radius;
                        let d = q - p;
                        (d.normalize_or(l), d.length())
                    }
                };
                total += self.through(p, dir, max_t);
            }
        }
        total / (k * k) as f32
    }

    /// Light surviving along a shadow ray: zero at an opaque surface, times the glass's
    /// colour and coverage at each pane it crosses (order does not matter for a product).
    /// A backed window's uncut wall stops only the rays that did not cross that window's
    /// glass.
    fn through(&self, origin: Vec3, dir: Vec3, max_t: f32) -> Vec3 {
        let mut light = Vec3::ONE;
        // Windows whose glass the ray crossed, and the walls it met that might let it through.
        let mut crossed = 0u64;
        let mut walls: Vec<u64> = Vec::new();
        let blocked = self.bvh.visit(
            origin,
            dir,
            max_t,
            |i| self.triangles[i as usize].p,
            &mut |tri, _, b| {
                let tri = &self.triangles[tri as usize];
                let mat = &self.materials[tri.material as usize];
                if mat.class == MaterialClass::Background {
                    return max_t;
                }
                if !mat.class.is_window() {
                    if tri.windows == 0 {
                        return -1.0;
                    }
                    walls.push(tri.windows);
                    return max_t;
                }
                crossed |= tri.windows;
                let glass = match self.texture(mat.texture) {
                    Some(img) => {
                        let uv = tri.uv[0] * (1.0 - b.x - b.y) + tri.uv[1] * b.x + tri.uv[2] * b.y;
                        let c = img.sample(uv);
                        c.truncate() * c.w
                    }
                    None => mat.diffuse,
                };
                light *= glass;
                max_t
            },
        );
        if blocked || walls.iter().any(|&w| w & crossed == 0) {
            Vec3::ZERO
        } else {
            light
        }
    }

    fn closest(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        self.bvh.visit(
            origin,
            dir,
            f32::INFINITY,
            |i| self.triangles[i as usize].p,
            &mut |tri, t, b| {
                best = Some(Hit { t, tri, b });
                t
            },
        );
        best
    }
}

fn fract(x: f32) -> f32 {
    x - x.floor()
}

/// A number in [0, 1) from a sample index.
fn hash(mut h: u32) -> f32 {
    h = h.wrapping_mul(0x9E37_79B9) ^ (h >> 15);
    h = h.wrapping_mul(0x85EB_CA6B) ^ (h >> 13);
    h = h.wrapping_mul(0xC2B2_AE35) ^ (h >> 16);
    (h >> 8) as f32 / 16_777_216.0
}

/// A linear HDR image (the lit target, or this reference) as the composite would show it
/// without glass or god rays: exposure 1, Narkowicz's ACES fit, sRGB, 8 bits. Tests and the
/// bench compare the GPU and the reference through it.
pub fn tone_mapped(w: u32, h: u32, px: &[[f32; 4]]) -> image::RgbImage {
    image::RgbImage::from_fn(w, h, |x, y| image::Rgb(tone_map(px[(y * w + x) as usize])))
}

/// One linear HDR texel as [`tone_mapped`] shows it.
pub(crate) fn tone_map(p: [f32; 4]) -> [u8; 3] {
    let aces = |x: f32| {
        // NaN and infinities (an unlit texel's garbage) show black, not white.
        let x = if x.is_finite() { x.max(0.0) } else { 0.0 };
        ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
    };
    let srgb = |c: f32| {
        let s = if c <= 0.003_130_8 {
            c * 12.92
        } else {
            1.055 * c.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round().clamp(0.0, 255.0) as u8
    };
    [0, 1, 2].map(|c| srgb(aces(p[c])))
}
