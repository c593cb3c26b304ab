//#include common.wgsl
// Pass 2: windows' normal-map perturbation in view space, everything else zero. rg is the
// screen-space refraction direction (x right, y up); a is the window coverage. Only window
// ranges are drawn: the depth pass 1 laid down already hides the windows behind occluders,
// and the target is cleared to the zero everything else gets.

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    let geometric = safe_normalize(in.normal, vec3<f32>(0.0, 1.0, 0.0));
    let mapped = shading_normal(in);
    // Only the perturbation bends the view: a flat window seen at an angle must not shift
    // what lies behind it.
    let view_delta = (frame.view * vec4<f32>(mapped - geometric, 0.0)).xyz;
    return vec4<f32>(view_delta.xy, 0.0, 1.0);
}
