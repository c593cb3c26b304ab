//#include common.wgsl
// Pass 3: the lit scene with the windows black. Phong shading; inside the building light only
// arrives through the windows, coloured by each window's pre-blurred projector texture.

// True when `p` lies on the inner side of every window plane: such points see the light only
// through the windows.
fn is_inside(p: vec3<f32>) -> bool {
    if (frame.counts.y == 0u) {
        return false;
    }
    let count = min(frame.counts.x, MAX_WINDOWS);
    for (var i = 0u; i < count; i = i + 1u) {
        let w = windows.items[i];
        if (dot(p - w.origin.xyz, w.normal.xyz) < -1e-3) {
            return false;
        }
    }
    return true;
}

// Light transmitted through the windows towards `p` (1 = unfiltered light).
fn transmitted(p: vec3<f32>) -> vec3<f32> {
    var total = vec3<f32>(0.0);
    let count = min(frame.counts.x, MAX_WINDOWS);
    for (var i = 0u; i < count; i = i + 1u) {
        let w = windows.items[i];
        let clip = w.projector * vec4<f32>(p, 1.0);
        let in_front = clip.w > 0.0;
        // Divide per fragment (never interpolate u/w linearly); a safe denominator keeps the
        // derivatives finite where the result is rejected anyway.
        let uv = select(vec2<f32>(0.0), clip.xy / max(clip.w, 1e-6), in_front);
        // Derivatives in uniform control flow, before any per-fragment rejection.
        let ddx = dpdx(uv);
        let ddy = dpdy(uv);
        let enabled = w.params.y != 0u;
        let past_glass = dot(p - w.origin.xyz, w.normal.xyz) > 0.0;
        let in_bounds = uv.x >= 0.0 && uv.x <= 1.0 && uv.y >= 0.0 && uv.y <= 1.0;
        if (enabled && in_front && past_glass && in_bounds) {
            total = total + textureSampleGrad(projectors, linear_clamp, uv, w.params.x, ddx, ddy).rgb * w.tint.rgb;
        }
    }
    return total;
}

@fragment
fn fs_main(vertex: VertexOut) -> @location(0) vec4<f32> {
    let in = facing_camera(vertex);
    if (is_window()) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    if (material.flags.x == CLASS_BACKGROUND) {
        return vec4<f32>(background_radiance(in), 1.0);
    }
    let albedo = base_colour(in).rgb;
    let n = shading_normal(in);
    let geometric = safe_normalize(in.normal, n);
    let v = safe_normalize(frame.camera_pos.xyz - in.world, n);

    var l: vec3<f32>;
    var radiance: vec3<f32>;
    if (frame.light_pos.w > 0.5) {
        let d = frame.light_pos.xyz - in.world;
        let d2 = dot(d, d);
        l = safe_normalize(d, n);
        let r = frame.light_colour.w;
        radiance = frame.light_colour.rgb / max(d2, r * r);
    } else {
        l = safe_normalize(frame.light_pos.xyz, n);
        radiance = frame.light_colour.rgb;
    }

    let through = transmitted(in.world);
    // Surfaces lying in a window's plane (the wall around it) are judged by the side they face:
    // a small step along the camera-facing normal puts the outer face outside.
    let light_filter = select(vec3<f32>(1.0), through, is_inside(in.world + geometric * 0.01));
    var colour = albedo * frame.ambient.rgb + material.emissive.rgb;
    let n_dot_l = dot(n, l);
    // The geometric test stops light reaching faces turned away from it through a normal map.
    if (n_dot_l > 0.0 && dot(geometric, l) > 0.0) {
        let r = reflect(-l, n);
        let shininess = max(material.specular.w, 1.0);
        let spec = material.specular.rgb * pow(max(dot(r, v), 0.0), shininess);
        colour = colour + (albedo * n_dot_l + spec) * radiance * light_filter;
    }
    return vec4<f32>(colour, 1.0);
}
