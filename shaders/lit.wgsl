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

// Light transmitted through the windows towards `p` (1 = unfiltered light). `dpx`/`dpy` are
// the screen derivatives of `p`; the texture-coordinate derivatives follow from them exactly,
// so this runs only where the surface faces the light (no uniform control flow needed).
fn transmitted(p: vec3<f32>, dpx: vec3<f32>, dpy: vec3<f32>) -> vec3<f32> {
    var total = vec3<f32>(0.0);
    let count = min(frame.counts.x, MAX_WINDOWS);
    for (var i = 0u; i < count; i = i + 1u) {
        let w = windows.items[i];
        if (w.params.y == 0u || dot(p - w.origin.xyz, w.normal.xyz) <= 0.0) {
            continue; // no light through this window, or p is on the light's side of it
        }
        let clip = w.projector * vec4<f32>(p, 1.0);
        if (clip.w <= 0.0) {
            continue; // behind the light
        }
        // Divide per fragment: u/w interpolated linearly would be wrong.
        let uv = clip.xy / clip.w;
        if (uv.x < 0.0 || uv.x > 1.0 || uv.y < 0.0 || uv.y > 1.0) {
            continue;
        }
        let cx = w.projector * vec4<f32>(dpx, 0.0);
        let cy = w.projector * vec4<f32>(dpy, 0.0);
        let ddx = (cx.xy - uv * cx.w) / clip.w;
        let ddy = (cy.xy - uv * cy.w) / clip.w;
        total = total + textureSampleGrad(projectors, linear_clamp, uv, w.params.x, ddx, ddy).rgb * w.tint.rgb;
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
    let v = safe_normalize(-in.rel, n);

    var l: vec3<f32>;
    var radiance: vec3<f32>;
    if (frame.light_pos.w > 0.5) {
        let d = frame.light_pos.xyz - in.rel;
        let d2 = dot(d, d);
        l = safe_normalize(d, n);
        let r = frame.light_colour.w;
        radiance = frame.light_colour.rgb / max(d2, r * r);
    } else {
        l = safe_normalize(frame.light_pos.xyz, n);
        radiance = frame.light_colour.rgb;
    }

    // Before any per-fragment branch: derivatives need uniform control flow.
    let dpx = dpdx(in.rel);
    let dpy = dpdy(in.rel);
    var colour = albedo * frame.ambient.rgb + material.emissive.rgb;
    let n_dot_l = dot(n, l);
    // The geometric test stops light reaching faces turned away from it through a normal map.
    if (n_dot_l > 0.0 && dot(geometric, l) > 0.0) {
        // Surfaces lying in a window's plane (the wall around it) are judged by the side they
        // face: a small step along the camera-facing normal puts the outer face outside.
        var light_filter = vec3<f32>(1.0);
        if (is_inside(in.rel + geometric * 0.01)) {
            light_filter = transmitted(in.rel, dpx, dpy);
        }
        let r = reflect(-l, n);
        let shininess = max(material.specular.w, 1.0);
        let spec = material.specular.rgb * pow(max(dot(r, v), 0.0), shininess);
        colour = colour + (albedo * n_dot_l + spec) * radiance * light_filter;
    }
    return vec4<f32>(colour, 1.0);
}
