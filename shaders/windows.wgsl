//#include common.wgsl
// Pass 1: windows with their colour, everything else (occluders included) black with zero
// coverage. Alpha is the window coverage the composite masks refraction with. Window ranges
// are drawn with `fs_main`, all others with `fs_occluder`, in the scene's order.

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    let c = base_colour(in);
    return vec4<f32>(c.rgb * c.a, 1.0);
}

// Depth alone: the cleared target already holds the black, zero-coverage value. A shader of
// its own rather than a branch on the material: lavapipe runs both sides of such a branch, so
// every occluder paid for the windows' texture sample.
@fragment
fn fs_occluder(in: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(0.0);
}
