// Shared by every geometry pass (0-3): the frame and material bindings and the vertex shader.
// Struct layouts are mirrored by `render::uniforms`; a test checks the sizes with naga.
//
// Positions past the vertex shader are camera-relative (world minus `frame.camera_pos`): the
// CPU builds the matrices, light and window positions in that frame, so no uniform carries
// the scene's distance from the origin and nothing cancels large f32 products. The one large
// subtraction, vertex minus camera, rounds once.

// The most windows a fragment tests (see `render::uniforms::MAX_WINDOWS`).
const MAX_WINDOWS: u32 = 1024u;

struct Frame {
    // Camera-relative position to clip space (no translation).
    view_proj: mat4x4<f32>,
    // The view's rotation: world directions to view space.
    view: mat4x4<f32>,
    // The camera's world position; subtracted from every vertex.
    camera_pos: vec4<f32>,
    // xyz: camera-relative position (point light) or the direction towards the light
    // (directional); w: 1 or 0.
    light_pos: vec4<f32>,
    // rgb: colour times intensity; w: the point light's radius (falloff clamp).
    light_colour: vec4<f32>,
    ambient: vec4<f32>,
    // x: window count, y: 1 when the scene has windows (interior lit only through them), z:
    // how many windows pass light (they come first in `windows.items`), w: how many distinct
    // planes the windows lie in (`planes`).
    counts: vec4<u32>,
    // x: shadow bias (in texels of slope), y: smallest filter σ (texels), z: shadow-map
    // layer size (texels), w: 1 when the window light is occluded by shadow maps.
    shadow: vec4<f32>,
    // A spot light's cone: clamp(dot(spot.xyz, d) + spot.w, 0, 1)², d the unit direction from
    // the light, is the share of its light leaving along d; (0, 0, 0, 1) for other lights.
    spot: vec4<f32>,
    // In the scene's units: x how far off a surface `is_inside` is asked, y its slack behind
    // a window's plane (0.01 and 0.001 in a scene 10 units across or more, less in a smaller).
    lengths: vec4<f32>,
}

struct WindowProjector {
    // Maps a camera-relative position to (u*w, v*w, 0, w) on the window's design.
    projector: mat4x4<f32>,
    // xyz: a point of the window plane (camera-relative); w: how far behind the glass the
    // wall it sits on lies, when that wall was never cut open (0 otherwise).
    origin: vec4<f32>,
    // xyz: unit normal pointing into the building.
    normal: vec4<f32>,
    // rgb: colour the light is multiplied by (the glass colour for a window without a
    // projector texture, white otherwise).
    tint: vec4<f32>,
    // x: projector array layer, y: 1 when this window passes light, z: shadow-map layer,
    // w: 1 when the window has a shadow map.
    params: vec4<u32>,
    // Camera-relative position to the window's shadow map: (u·w, v·w, z·w, w), with (u, v)
    // texture coordinates and z the stored depth (see `render::shadows`).
    shadow: mat4x4<f32>,
    // xyz: unit world direction in which the map's u grows; w: world size of a texel along
    // it (for a lamp at ℓ = 1, the window's plane).
    shadow_x: vec4<f32>,
    // The same for v.
    shadow_y: vec4<f32>,
    // x, y: near and far ℓ; z: a lamp's distance to the window's plane (0 for the sun);
    // w: the light's size (the sun's angular diameter in radians, a lamp's diameter).
    shadow_depth: vec4<f32>,
    // xyz: the sun's travel direction, or the window's inward normal for a lamp.
    shadow_dir: vec4<f32>,
    // Where the light line through a shadow-map position (u, v, any z, 1) crosses the window's
    // plane, in the projector's coordinates as `projector` gives them (see
    // `render::shadows::Aperture`).
    aperture: mat4x4<f32>,
    // The glass in those coordinates, less a texel of the map on each side: (min, max).
    aperture_box: vec4<f32>,
}

// A storage buffer, sized to the scene's windows: a uniform block would bound them to what
// 64 KiB holds (192).
struct Windows {
    // The light's map over all the opaque geometry (shadow fields only; params.w = 1 when
    // present): whether a point outside a window's plane sees the light (see `fs_main`).
    direct: WindowProjector,
    // `frame.counts.x` of them.
    items: array<WindowProjector>,
}

// A plane of the building's edge, shared by the windows in it (`render::uniforms::WindowPlane`).
struct WindowPlane {
    // xyz: a point of it (camera-relative); w: how far behind it the uncut wall lies.
    origin: vec4<f32>,
    // xyz: unit normal into the building.
    normal: vec4<f32>,
    // xyz: the corners of the buildings whose windows lie in it: tested only within them.
    lo: vec4<f32>,
    hi: vec4<f32>,
}

struct Material {
    // rgb: diffuse albedo (linear), w: 1 with a diffuse texture.
    diffuse: vec4<f32>,
    // rgb: specular colour, w: shininess.
    specular: vec4<f32>,
    // rgb: emission; w: for a window, the share of the light it passes (0 where the light does
    // not come in through it, a spot's fall-off across it), which weighs its god rays.
    emissive: vec4<f32>,
    // x: class (see `render::uniforms::class_id`), y: 1 with a normal map (2: a two-channel
    // one, Z rebuilt from X and Y), z: 1 for windows.
    flags: vec4<u32>,
    // xy: the diffuse texture's share of its stored (block-padded) size, zw: the normal map's.
    uv_scale: vec4<f32>,
}

const CLASS_FLOOR: u32 = 0u;
const CLASS_WALL: u32 = 1u;
const CLASS_WINDOW_UPPER: u32 = 2u;
const CLASS_WINDOW_LOWER: u32 = 3u;
const CLASS_BACKGROUND: u32 = 4u;
const CLASS_OTHER: u32 = 5u;

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var<storage, read> windows: Windows;
// One layer per distinct projector texture; the window's params.x picks it.
@group(0) @binding(2) var projectors: texture_2d_array<f32>;
@group(0) @binding(3) var linear_clamp: sampler;
// One layer per shadow map: the sun's, or one per window for a lamp.
@group(0) @binding(4) var shadow_maps: texture_depth_2d_array;
@group(0) @binding(5) var shadow_cmp: sampler_comparison;
// `frame.counts.w` of them.
@group(0) @binding(6) var<storage, read> planes: array<WindowPlane>;

@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var diffuse_tex: texture_2d<f32>;
@group(1) @binding(2) var normal_tex: texture_2d<f32>;
@group(1) @binding(3) var material_sampler: sampler;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) tangent: vec4<f32>,
    // sRGB; white where the model has no vertex colours.
    @location(4) colour: vec4<f32>,
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    // Camera-relative position.
    @location(0) rel: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) tangent: vec4<f32>,
    // Linear.
    @location(4) colour: vec3<f32>,
}

// The sRGB decode: per vertex, so exact rather than a power of 2.2.
fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let low = c / 12.92;
    let high = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(high, low, c <= vec3<f32>(0.04045));
}

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    // `invariant`-like behaviour matters: passes 2 and 3 reuse pass 1's depth with an equal test,
    // so every pass computes the clip position with this same expression.
    let rel = v.position - frame.camera_pos.xyz;
    out.clip = frame.view_proj * vec4<f32>(rel, 1.0);
    out.rel = rel;
    out.normal = v.normal;
    out.uv = v.uv;
    out.tangent = v.tangent;
    out.colour = srgb_to_linear(v.colour.rgb);
    return out;
}

fn safe_normalize(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let l = length(v);
    if (l > 1e-12) {
        return v / l;
    }
    return fallback;
}

// Set for the pipelines that draw materials with a texture padded to whole blocks (the
// renderer makes them only for scenes that have one).
override PADDED_TEXTURES: bool = false;

// A material texture at `uv`. A block-compressed texture padded to whole blocks holds the
// image in the `scale` share of it: wrap first, then scale, with the unwrapped derivatives so
// the wrap seam picks no smaller mip. Unpadded textures take implicit derivatives: lavapipe's
// anisotropic sampling with explicit gradients (Mesa 22.3) read a far smaller mip at some
// pixels along triangle edges, which showed as dots of wrong colour down every window's
// diagonal. The choice is a pipeline constant, not a branch: lavapipe runs both sides of a
// branch on a uniform, and a second sample took the default scene's time to full quality at
// 1280x720 from about 1.0 to 1.7 s there.
fn sample_material(t: texture_2d<f32>, uv: vec2<f32>, scale: vec2<f32>) -> vec4<f32> {
    if (PADDED_TEXTURES) {
        let at = select(uv, fract(uv) * scale, any(scale != vec2<f32>(1.0)));
        return textureSampleGrad(t, material_sampler, at, dpdx(uv) * scale, dpdy(uv) * scale);
    }
    return textureSample(t, material_sampler, uv);
}

// The shading normal: the normal map (OpenGL convention, +Y up) in the tangent frame when the
// material has one and the vertex carries a tangent, the geometric normal otherwise.
fn shading_normal(in: VertexOut) -> vec3<f32> {
    let n = safe_normalize(in.normal, vec3<f32>(0.0, 1.0, 0.0));
    if (material.flags.y == 0u || dot(in.tangent.xyz, in.tangent.xyz) < 1e-12) {
        return n;
    }
    let t = safe_normalize(in.tangent.xyz - n * dot(n, in.tangent.xyz), vec3<f32>(1.0, 0.0, 0.0));
    let sign = select(1.0, -1.0, in.tangent.w < 0.0);
    let b = cross(n, t) * sign;
    var m = sample_material(normal_tex, in.uv, material.uv_scale.zw).xyz * 2.0 - 1.0;
    if (material.flags.y == 2u) {
        m.z = sqrt(max(1.0 - dot(m.xy, m.xy), 0.0));
    }
    return safe_normalize(t * m.x + b * m.y + n * m.z, n);
}

fn base_colour(in: VertexOut) -> vec4<f32> {
    var c = vec4<f32>(material.diffuse.rgb * in.colour, 1.0);
    if (material.diffuse.w > 0.5) {
        c = c * sample_material(diffuse_tex, in.uv, material.uv_scale.xy);
    }
    return c;
}

// Background surfaces (sky, distant mountains) are a painted backdrop: shown unlit, as their
// colour plus emission, identically in pass 0 and pass 3.
fn background_radiance(in: VertexOut) -> vec3<f32> {
    return base_colour(in).rgb + material.emissive.rgb;
}

// Surfaces are drawn from both sides; shade the side the camera sees, so light reaching a wall
// from outside does not light its inner face.
fn facing_camera(in: VertexOut) -> VertexOut {
    var out = in;
    if (dot(in.normal, -in.rel) < 0.0) {
        out.normal = -in.normal;
    }
    return out;
}
