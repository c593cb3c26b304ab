// The shadow-map depth pass: opaque geometry seen from the light (one layer per draw). Depth
// only; the lit pass (`lit.wgsl`) reads the maps.
//
// Vertices are made relative to the layer's origin first (a window or the sun's footprint),
// so far from the world's origin the products stay small, as in `common.wgsl`.

struct ShadowPass {
    // Position minus `origin` to the layer's clip space.
    view_proj: mat4x4<f32>,
    origin: vec4<f32>,
}

@group(0) @binding(0) var<uniform> shadow_pass: ShadowPass;

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return shadow_pass.view_proj * vec4<f32>(position - shadow_pass.origin.xyz, 1.0);
}
