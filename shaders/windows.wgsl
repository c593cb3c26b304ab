//#include common.wgsl
// Pass 1: windows with their colour, everything else (occluders included) black with zero
// coverage. Alpha is the window coverage the composite masks refraction with. Window ranges
// are drawn with `fs_main`, all others with `fs_occluder`, in the scene's order.

struct MaskOut {
    @location(0) mask: vec4<f32>,
    // What the god rays blur: the colour times the share of the light the window passes
    // (`Material::emissive.w`), so a window the light does not come through casts no shaft.
    @location(1) rays: vec4<f32>,
}

@fragment
fn fs_main(in: VertexOut) -> MaskOut {
    let c = base_colour(in);
    let glass = c.rgb * c.a;
    return MaskOut(vec4<f32>(glass, 1.0), vec4<f32>(glass * material.emissive.w, 1.0));
}

// Depth alone: the cleared target already holds the black, zero-coverage value. A shader of
// its own rather than a branch on the material: lavapipe runs both sides of such a branch, so
// every occluder paid for the windows' texture sample.
@fragment
fn fs_occluder(in: VertexOut) -> MaskOut {
    return MaskOut(vec4<f32>(0.0), vec4<f32>(0.0));
}
