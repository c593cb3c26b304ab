//#include fullscreen.wgsl
// Pass 4: refraction through the windows added to the lit scene, god rays on top, tone mapping.

struct Composite {
    // x: refraction strength (fraction of the screen height per unit of normal perturbation),
    // y: exposure, z: aspect (width / height).
    params: vec4<f32>,
    // x: refraction on, y: god rays on, z: encode sRGB in the shader (non-sRGB output),
    // w: windows drawn (passes 1 and 2 hold this frame's data).
    flags: vec4<u32>,
}

@group(0) @binding(0) var<uniform> comp: Composite;
@group(0) @binding(1) var scene_tex: texture_2d<f32>;
@group(0) @binding(2) var background_tex: texture_2d<f32>;
@group(0) @binding(3) var mask_tex: texture_2d<f32>;
@group(0) @binding(4) var normal_tex: texture_2d<f32>;
@group(0) @binding(5) var rays_tex: texture_2d<f32>;
@group(0) @binding(6) var nearest: sampler;
@group(0) @binding(7) var bilinear: sampler;

fn aces(x: vec3<f32>) -> vec3<f32> {
    // Narkowicz's fit of the ACES filmic curve.
    let a = 2.51;
    let b = 0.03;
    let c = 2.43;
    let d = 0.59;
    let e = 0.14;
    return clamp((x * (a * x + b)) / (x * (c * x + d) + e), vec3<f32>(0.0), vec3<f32>(1.0));
}

fn srgb_encode(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}

fn inside_screen(uv: vec2<f32>) -> bool {
    return uv.x >= 0.0 && uv.x <= 1.0 && uv.y >= 0.0 && uv.y <= 1.0;
}

@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    let uv = in.uv;
    var colour = textureSampleLevel(scene_tex, nearest, uv, 0.0).rgb;
    let here = textureSampleLevel(mask_tex, nearest, uv, 0.0);
    if (comp.flags.w != 0u && here.a > 0.5) {
        var src = uv;
        if (comp.flags.x != 0u) {
            let n = textureSampleLevel(normal_tex, nearest, uv, 0.0).xy;
            let shifted = uv + vec2<f32>(n.x / comp.params.z, -n.y) * comp.params.x;
            // Only take the shifted sample where it still lies on glass: an object in front of
            // the window (zero coverage in pass 1) must not leak into the refraction.
            if (inside_screen(shifted) && textureSampleLevel(mask_tex, nearest, shifted, 0.0).a > 0.5) {
                src = shifted;
            }
        }
        // The design is painted on the glass itself: only what lies behind it is displaced.
        let glass = here.rgb;
        let behind = textureSampleLevel(background_tex, nearest, src, 0.0).rgb;
        colour = colour + behind * glass;
    }
    if (comp.flags.y != 0u) {
        colour = colour + textureSampleLevel(rays_tex, bilinear, uv, 0.0).rgb;
    }
    var out = aces(max(colour, vec3<f32>(0.0)) * comp.params.y);
    if (comp.flags.z != 0u) {
        out = srgb_encode(out);
    }
    return vec4<f32>(out, 1.0);
}
