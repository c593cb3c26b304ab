// The interactive viewer's own passes: showing an intermediate target or the finished view
// (`vs_fullscreen` + `fs_show`), and the false-colour material-ID view (`vs_ids` + `fs_ids`).

//#include fullscreen.wgsl

struct Show {
    // 0: pass through, 1: HDR colour (scaled, clamped), 2: window normals, 3: black.
    mode: u32,
    // Gain of modes 1 and 2.
    scale: f32,
    // 1 when the target view is not sRGB, so the shader encodes.
    encode: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> show: Show;
@group(0) @binding(1) var source: texture_2d<f32>;
@group(0) @binding(2) var source_sampler: sampler;

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let low = c / 12.92;
    let high = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(high, low, c <= vec3<f32>(0.04045));
}

fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let low = c * 12.92;
    let high = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(high, low, c <= vec3<f32>(0.0031308));
}

// NaN and infinities show as black rather than as undefined colours.
fn finite_clamped(c: vec3<f32>) -> vec3<f32> {
    let bad = (c != c) | (abs(c) > vec3<f32>(3.0e38));
    return select(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)), vec3<f32>(0.0), bad);
}

@fragment
fn fs_show(in: FullscreenOut) -> @location(0) vec4<f32> {
    let texel = textureSample(source, source_sampler, in.uv);
    let c = texel.rgb;
    var linear: vec3<f32>;
    switch show.mode {
        case 1u: {
            linear = finite_clamped(c * show.scale);
        }
        case 2u: {
            // Pass 2 holds the normal map's view-space perturbation (xy) and the window
            // coverage (a). Shown the way normal maps usually are: a flat window is (0.5, 0.5,
            // 1), a perturbation shifts red and green; outside windows is black. The values
            // are display bytes, so the sRGB encoding of the target is undone first.
            let n = vec3<f32>(c.xy * show.scale * 0.5 + 0.5, 1.0) * step(0.5, texel.a);
            linear = srgb_to_linear(finite_clamped(n));
        }
        case 3u: {
            linear = vec3<f32>(0.0);
        }
        default: {
            linear = finite_clamped(c);
        }
    }
    if show.encode == 1u {
        return vec4<f32>(linear_to_srgb(linear), 1.0);
    }
    return vec4<f32>(linear, 1.0);
}

struct IdCamera {
    // Camera-relative position to clip (no translation, so no precision lost far from the
    // origin; see common.wgsl).
    view_proj: mat4x4<f32>,
    eye: vec4<f32>,
}

struct Swatch {
    // Linear RGB of this material's false colour.
    colour: vec4<f32>,
}

@group(0) @binding(0) var<uniform> id_camera: IdCamera;
@group(1) @binding(0) var<uniform> swatch: Swatch;

struct IdOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    // Camera-relative position.
    @location(1) rel: vec3<f32>,
}

@vertex
fn vs_ids(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>) -> IdOut {
    var out: IdOut;
    let rel = position - id_camera.eye.xyz;
    out.clip = id_camera.view_proj * vec4<f32>(rel, 1.0);
    out.normal = normal;
    out.rel = rel;
    return out;
}

@fragment
fn fs_ids(in: IdOut) -> @location(0) vec4<f32> {
    // Flat colour with a little facing-ratio shading, so shapes stay readable while the
    // hue alone identifies the material.
    var shade = 1.0;
    let n_len = length(in.normal);
    let to_eye = -in.rel;
    if n_len > 1e-6 && length(to_eye) > 1e-6 {
        shade = 0.55 + 0.45 * abs(dot(in.normal / n_len, normalize(to_eye)));
    }
    return vec4<f32>(swatch.colour.rgb * shade, 1.0);
}
