//#include fullscreen.wgsl
// Copies a projector texture (whatever levels are resident) into its layer of the projector
// array, resampled to the array's size; each array level reads the source level of about its
// size along the source's short side, so the array's mips are the cooker's (filtered in
// linear light), not a re-filtering, but for the long side's box filter below.

struct Blit {
    // xy: the source levels (relative to the source view, fractional) whose texels are one
    // array texel across and down; z: one array texel in texture coordinates.
    lod: vec4<f32>,
    // xy: the share of the stored source the image covers (below 1 when padded to blocks).
    scale: vec4<f32>,
}

@group(0) @binding(0) var source: texture_2d<f32>;
@group(0) @binding(1) var source_sampler: sampler;
@group(0) @binding(2) var<uniform> blit: Blit;

// The level of the less minified axis, sampled along the more minified one as many times as
// it has texels under one array texel (a box filter, in linear light): a source of another
// shape than the square layer keeps its detail along its short side, where a level chosen by
// its long side had a column or two left of a narrow design.
@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    let lod = max(min(blit.lod.x, blit.lod.y), 0.0);
    let over = exp2(max(blit.lod.x, blit.lod.y) - lod);
    let n = u32(clamp(ceil(over - 1e-3), 1.0, 64.0));
    let axis = select(vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 0.0), blit.lod.x > blit.lod.y);
    var sum = vec4<f32>(0.0);
    for (var i = 0u; i < n; i = i + 1u) {
        let offset = ((f32(i) + 0.5) / f32(n) - 0.5) * blit.lod.z;
        let uv = (in.uv + axis * offset) * blit.scale.xy;
        sum = sum + textureSampleLevel(source, source_sampler, uv, lod);
    }
    return sum / f32(n);
}
