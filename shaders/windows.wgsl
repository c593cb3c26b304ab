//#include common.wgsl
// Pass 1: windows with their colour, everything else (occluders included) black with zero
// coverage. Alpha is the window coverage the composite masks refraction with.

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    if (!is_window()) {
        return vec4<f32>(0.0);
    }
    let c = base_colour(in);
    return vec4<f32>(c.rgb * c.a, 1.0);
}
