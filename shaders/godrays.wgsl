//#include fullscreen.wgsl
// God rays: a radial blur of the window mask (pass 1) towards the light's screen position.
//
// The light is kept homogeneous: in aspect-corrected screen space (x in [-aspect, aspect],
// y in [-1, 1], y up) the direction from pixel p to the light L is L.xy - p * L.w, which stays
// finite when L.w -> 0 (view perpendicular to the light) and for a directional light (w = 0).
// The march covers `density` times the distance to the light, clamped to `max_length`; decay
// and weight are per unit of that march, so the sample count changes accuracy, not the look.

struct GodRays {
    // (L.x * aspect, L.y, 0, L.w): the light in clip space, aspect-corrected.
    light: vec4<f32>,
    // rgb: light colour * intensity * exposure * view fade.
    colour: vec4<f32>,
    density: f32,
    // Per unit of march, like `weight`.
    ln_decay: f32,
    weight: f32,
    max_length: f32,
    // width / height.
    aspect: f32,
    // 0 or 1.
    jitter: f32,
    max_output: f32,
    pad0: f32,
    samples: u32,
    seed: u32,
    pad1: vec2<u32>,
}

@group(0) @binding(0) var<uniform> rays: GodRays;
@group(0) @binding(1) var mask_tex: texture_2d<f32>;
@group(0) @binding(2) var mask_sampler: sampler;

fn hash(p: vec2<u32>, seed: u32) -> f32 {
    var h = p.x * 1664525u + p.y * 1013904223u + seed * 2654435761u;
    h = (h ^ (h >> 16u)) * 2246822519u;
    h = (h ^ (h >> 13u)) * 3266489917u;
    h = h ^ (h >> 16u);
    return f32(h >> 8u) / 16777216.0;
}

@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    let lw = rays.light.w;
    // Behind the camera: exactly nothing, never a mirrored phantom.
    if (!(lw > 0.0)) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let aspect = rays.aspect;
    let p = vec2<f32>((in.uv.x * 2.0 - 1.0) * aspect, 1.0 - in.uv.y * 2.0);
    let d = rays.light.xy - p * lw;
    let dl = length(d);
    let density = rays.density;
    let max_length = rays.max_length;
    var march = 0.0;
    var dir = vec2<f32>(0.0);
    if (dl > 0.0) {
        dir = d / dl;
        // min(density * dl / lw, max_length) without dividing by a small w.
        march = select(density * dl / lw, max_length, density * dl >= max_length * lw);
    }
    let samples = max(rays.samples, 1u);
    let n = f32(samples);
    var offset = 0.5;
    if (rays.jitter > 0.0) {
        offset = hash(vec2<u32>(in.clip.xy), rays.seed);
    }
    let ln_decay = rays.ln_decay;
    let weight = rays.weight / n;
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < samples; i = i + 1u) {
        let t = (f32(i) + offset) / n;
        let s = p + dir * (march * t);
        let uv = vec2<f32>((s.x / aspect) * 0.5 + 0.5, 0.5 - s.y * 0.5);
        // Samples off screen count as black: clamping would smear edge texels into streaks.
        if (uv.x >= 0.0 && uv.x <= 1.0 && uv.y >= 0.0 && uv.y <= 1.0) {
            let m = textureSampleLevel(mask_tex, mask_sampler, uv, 0.0).rgb;
            sum = sum + m * (weight * exp(ln_decay * t));
        }
    }
    let out = clamp(sum * rays.colour.rgb, vec3<f32>(0.0), vec3<f32>(rays.max_output));
    return vec4<f32>(out, 1.0);
}
