//#include fullscreen.wgsl
// Copies a projector texture (whatever levels are resident) into its layer of the projector
// array, resampled to the array's size; each array level reads the source level of about its
// size, so the array's mips are the cooker's (filtered in linear light), not a re-filtering.

struct Blit {
    // x: the source level to read, relative to the source view (fractional: trilinear);
    // yz: the share of the stored source the image covers (below 1 when padded to blocks).
    lod: vec4<f32>,
}

@group(0) @binding(0) var source: texture_2d<f32>;
@group(0) @binding(1) var source_sampler: sampler;
@group(0) @binding(2) var<uniform> blit: Blit;

@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    return textureSampleLevel(source, source_sampler, in.uv * blit.lod.yz, blit.lod.x);
}
