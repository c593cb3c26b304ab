// The background's panorama (an equirectangular image) where no surface covers the view: drawn
// after passes 0 and 3, at the far plane, so only pixels their geometry left empty take it.
// Its centre column faces -z; +x is to its right, seen from inside; its top row is straight up.

struct Sky {
    // Clip space to a camera-relative point on the pixel's ray: the inverse of `Frame.view_proj`.
    clip_to_ray: mat4x4<f32>,
    // rgb: what the panorama's linear texels are multiplied by (the background colour).
    scale: vec4<f32>,
}

@group(0) @binding(0) var<uniform> sky: Sky;
@group(0) @binding(1) var panorama: texture_2d<f32>;
@group(0) @binding(2) var panorama_sampler: sampler;

const PI: f32 = 3.141592653589793;

struct SkyOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) ndc: vec2<f32>,
}

// One triangle over the screen, at the far plane (z = w): the depth test keeps what is nearer.
@vertex
fn vs_sky(@builtin(vertex_index) index: u32) -> SkyOut {
    let x = f32((index << 1u) & 2u) * 2.0 - 1.0;
    let y = 1.0 - f32(index & 2u) * 2.0;
    var out: SkyOut;
    out.clip = vec4<f32>(x, y, 1.0, 1.0);
    out.ndc = vec2<f32>(x, y);
    return out;
}

@fragment
fn fs_main(in: SkyOut) -> @location(0) vec4<f32> {
    let p = sky.clip_to_ray * vec4<f32>(in.ndc, 0.5, 1.0);
    let d = normalize(p.xyz / p.w);
    let u = 0.5 + atan2(d.x, -d.z) / (2.0 * PI);
    let v = acos(clamp(d.y, -1.0, 1.0)) / PI;
    // Behind the view (+z) u jumps from 1 to 0 between neighbouring pixels; their gradient
    // would pick the smallest mip there, a seam. The same u shifted half a turn is continuous
    // there, so the gradient is taken from whichever of the two changes less.
    let shifted = fract(u + 0.5);
    var du = vec2<f32>(dpdx(u), dpdy(u));
    let ds = vec2<f32>(dpdx(shifted), dpdy(shifted));
    if (dot(ds, ds) < dot(du, du)) {
        du = ds;
    }
    let dv = vec2<f32>(dpdx(v), dpdy(v));
    let texel = textureSampleGrad(panorama, panorama_sampler, vec2<f32>(u, v),
        vec2<f32>(du.x, dv.x), vec2<f32>(du.y, dv.y));
    return vec4<f32>(texel.rgb * sky.scale.rgb, 1.0);
}
