//#include fullscreen.wgsl
// A shadow-map layer as a grey image for the pass views: white near the light, black at the
// far plane; texels that hold nothing (cleared to the far plane) show black.

struct ShadowView {
    // x: layer, y: layer size in texels.
    params: vec4<u32>,
}

@group(0) @binding(0) var<uniform> view: ShadowView;
@group(0) @binding(1) var maps: texture_depth_2d_array;

@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    let size = i32(view.params.y);
    let texel = clamp(vec2<i32>(in.uv * f32(size)), vec2<i32>(0), vec2<i32>(size - 1));
    let z = textureLoad(maps, texel, i32(view.params.x), 0);
    let grey = 1.0 - z;
    return vec4<f32>(grey, grey, grey, 1.0);
}
