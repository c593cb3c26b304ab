//#include fullscreen.wgsl
// Copies a projector texture (whatever levels are resident) into its layer of the projector
// array, resampled to the array's size.

@group(0) @binding(0) var source: texture_2d<f32>;
@group(0) @binding(1) var source_sampler: sampler;

@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    return textureSampleLevel(source, source_sampler, in.uv, 0.0);
}
