//#include common.wgsl
// Pass 0: the background (sky, mountains) alone, unoccluded, so refraction can sample what lies
// behind the glass. Only background-class ranges are drawn into this target.

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(background_radiance(in), 1.0);
}
