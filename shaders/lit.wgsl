//#include common.wgsl
// Pass 3: the lit scene with the windows black. Phong shading; inside the building light only
// arrives through the windows, coloured by each window's pre-blurred projector texture.

// True when `p` lies within some building with windows and on the inner side of every window
// plane (or of the uncut wall a window's glass sits on) of the buildings it lies within: such
// points see the light only through the windows. A plane bounds its own building's inside
// only: another building of the scene lies outside it.
fn is_inside(p: vec3<f32>) -> bool {
    if (frame.counts.y == 0u) {
        return false;
    }
    let reach = 2.0 * frame.lengths.x + frame.lengths.y;
    var within = false;
    // A plane per wall, not per window: windows along a wall share one.
    for (var i = 0u; i < frame.counts.w; i = i + 1u) {
        let plane = planes[i];
        if (any(p < plane.lo.xyz - reach) || any(p > plane.hi.xyz + reach)) {
            continue;
        }
        within = true;
        if (dot(p - plane.origin.xyz, plane.normal.xyz) < -frame.lengths.y - plane.origin.w) {
            return false;
        }
    }
    return within;
}

// Taps of the blocker search, and of the filter (only in penumbrae: lit and fully shadowed
// points stop after the search).
const SHADOW_TAPS: u32 = 16u;
const FILTER_TAPS: u32 = 32u;
// The blocker search never spans more texels than this (the cost stays bounded; a wider
// penumbra is still filtered at its width, from the blockers found).
const MAX_SEARCH_TEXELS: f32 = 24.0;
// The fewest search and filter taps through the glass that `shadow_visibility` takes a ratio
// over.
const MIN_SEEN: f32 = 4.0;
const MIN_COUNTED: f32 = 8.0;
const GOLDEN_ANGLE: f32 = 2.39996323;

// ℓ (depth along the light, see `render::shadows`) of a stored depth.
fn shadow_linear(w: WindowProjector, z: f32) -> f32 {
    let n = w.shadow_depth.x;
    let f = w.shadow_depth.y;
    if (w.shadow_depth.z > 0.0) {
        return f * n / (f - z * (f - n));
    }
    return n + z * (f - n);
}

// The stored depth of ℓ.
fn shadow_stored(w: WindowProjector, l: f32) -> f32 {
    let n = w.shadow_depth.x;
    let f = w.shadow_depth.y;
    if (w.shadow_depth.z > 0.0) {
        return f * (l - n) / ((f - n) * max(l, 1e-6));
    }
    return (l - n) / (f - n);
}

// Interleaved gradient noise: turns the tap pattern per pixel, so a few taps give fine noise
// instead of visible copies of the pattern.
fn pixel_noise(frag: vec2<f32>) -> f32 {
    return fract(52.9829189 * fract(dot(frag, vec2<f32>(0.06711056, 0.00583715))));
}

// How much of the light reaching `p` through window `w` is not blocked (0 to 1): percentage-
// closer soft shadows. A blocker search finds the mean depth of what lies between `p` and the
// light; the penumbra then follows the projector blur's physics, a Gaussian of
// σ = (light size) × (receiver − blocker distance) / 4 (for a lamp, over the blocker's
// distance), which the filter integrates with Gaussian-distributed comparison taps.
// `n` is the geometric normal facing the light; `frag` the fragment's pixel position.
fn shadow_visibility(w: WindowProjector, p: vec3<f32>, n: vec3<f32>, frag: vec2<f32>) -> f32 {
    if (w.params.w == 0u || frame.shadow.w < 0.5) {
        return 1.0;
    }
    let c = w.shadow * vec4<f32>(p, 1.0);
    if (c.w <= 0.0) {
        return 1.0;
    }
    let m = c.xyz / c.w;
    let lamp = w.shadow_depth.z > 0.0;
    let lr = shadow_linear(w, clamp(m.z, 0.0, 1.0));
    // Per world unit along the light, ℓ grows by k; a lamp's texels grow with the distance.
    var t = w.shadow_dir.xyz;
    var k = 1.0;
    var scale = 1.0;
    if (lamp) {
        t = safe_normalize(p - frame.light_pos.xyz, w.shadow_dir.xyz);
        k = dot(w.shadow_dir.xyz, t) / w.shadow_depth.z;
        scale = lr;
    }
    let tx = w.shadow_x.w * scale;
    let ty = w.shadow_y.w * scale;
    // Receiver-plane depth bias: how ℓ changes per texel step across the receiving surface,
    // so taps away from `p` compare against the surface's own depth there, not `p`'s.
    // Grazing surfaces are capped (they get little light anyway).
    let nt = min(dot(n, t), -0.1);
    let gx = -tx * k * dot(n, w.shadow_x.xyz) / nt;
    let gy = -ty * k * dot(n, w.shadow_y.xyz) / nt;
    // Slope-scaled bias: a texel's stored depth is the surface's at the texel centre, up to
    // about a texel from where a tap lands.
    let eps = frame.shadow.x * (abs(gx) + abs(gy) + 0.5 * min(tx, ty) * k);
    let size = frame.shadow.z;
    let layer = i32(w.params.z);
    let light = w.shadow_depth.w;
    let near = w.shadow_depth.x;
    // The widest penumbra possible here: a blocker at the near plane.
    var widest = light * (lr - near) * 0.25;
    if (lamp) {
        widest = widest / max(near, 1e-6);
    }
    let search = clamp(2.7 * widest / min(tx, ty), 1.5, MAX_SEARCH_TEXELS);
    let angle = pixel_noise(frag) * 6.2831853;
    // Only taps whose light line crosses the glass count (`render::shadows::Aperture`): the
    // projector already darkens what the wall around the window stops.
    let at = m.xy * size;
    let glass = w.aperture * vec4<f32>(m.xy, m.z, 1.0);
    let per_u = w.aperture[0] / size;
    let per_v = w.aperture[1] / size;
    // Most fragments' taps all fall well inside the glass: one bound spares the test per tap.
    let reach = search + 1.0;
    let whole = all(at >= vec2<f32>(reach)) && all(at <= vec2<f32>(size - reach))
        && glass_holds_box(w, glass, per_u, per_v, vec2<f32>(reach));
    var seen = 0.0;
    var blockers = 0.0;
    var sum = 0.0;
    for (var i = 0u; i < SHADOW_TAPS; i = i + 1u) {
        let a = f32(i) * GOLDEN_ANGLE + angle;
        let o = vec2<f32>(cos(a), sin(a)) * sqrt((f32(i) + 0.5) / f32(SHADOW_TAPS)) * search;
        let texel = clamp(
            vec2<i32>(floor(at + o)),
            vec2<i32>(0),
            vec2<i32>(i32(size) - 1),
        );
        let d = vec2<f32>(texel) + 0.5 - at;
        if (whole || through_glass(w, glass + per_u * d.x + per_v * d.y)) {
            seen = seen + 1.0;
            let lb = shadow_linear(w, textureLoad(shadow_maps, texel, layer, 0));
            if (lb < lr + gx * o.x + gy * o.y - eps) {
                blockers = blockers + 1.0;
                sum = sum + lb;
            }
        }
    }
    // Of the light through the glass, the fraction the search finds unstopped. With few taps
    // through the glass (the projection's margin, lit by the glass's edge) that ratio is
    // noise, specks on the floor: the light line through the nearest point of the glass
    // fills in.
    let pad = max(MIN_SEEN - seen, 0.0);
    var edge = 1.0;
    if (pad > 0.0) {
        let o = nearest_glass(w, glass, m.z) * size - at;
        let reference = shadow_stored(w, lr + gx * o.x + gy * o.y - eps);
        edge = textureSampleCompareLevel(shadow_maps, shadow_cmp, (at + o) / size, layer, reference);
    }
    let found = (seen - blockers + pad * edge) / (seen + pad);
    if (found == 1.0) {
        return 1.0;
    }
    if (blockers == 0.0) {
        return found;
    }
    let lb = sum / blockers;
    var sigma_world = light * max(lr - lb, 0.0) * 0.25;
    if (lamp) {
        sigma_world = sigma_world / max(lb, 1e-6);
    }
    let sigma = max(vec2<f32>(sigma_world / tx, sigma_world / ty), vec2<f32>(frame.shadow.y));
    if (found == 0.0 && 2.7 * max(sigma.x, sigma.y) <= search) {
        return 0.0;
    }
    var lit = 0.0;
    var counted = 0.0;
    // The filter's taps reach 2.88 σ (its last tap's area fraction, 1 − 1/64).
    let whole_f = glass_holds_box(w, glass, per_u, per_v, 2.9 * sigma);
    for (var i = 0u; i < FILTER_TAPS; i = i + 1u) {
        // A 2D Gaussian's radius for the area fraction q: σ·sqrt(−2 ln(1 − q)).
        let q = (f32(i) + 0.5) / f32(FILTER_TAPS);
        let a = f32(i) * GOLDEN_ANGLE + angle;
        let o = vec2<f32>(cos(a), sin(a)) * sqrt(-2.0 * log(1.0 - q)) * sigma;
        if (whole_f || through_glass(w, glass + per_u * o.x + per_v * o.y)) {
            counted = counted + 1.0;
            let reference = shadow_stored(w, lr + gx * o.x + gy * o.y - eps);
            lit = lit + textureSampleCompareLevel(shadow_maps, shadow_cmp, m.xy + o / size, layer, reference);
        }
    }
    // The same for the filter: too few taps through the glass, and the rest count as the
    // search found (counting them lit drew the outline of a patch that something else stops).
    let fill = max(MIN_COUNTED - counted, 0.0);
    return (lit + fill * found) / (counted + fill);
}

// The shadow-map position (u, v) whose light line crosses the window's plane at the point of
// the glass (less its texel, `aperture_box`) nearest to where the line through `glass` does:
// `glass` is that line's point in the projector's homogeneous coordinates, `z` any depth on
// it. The aperture's (u, v, 1) to (s, t, 1) part at that depth, inverted by its adjugate.
fn nearest_glass(w: WindowProjector, glass: vec4<f32>, z: f32) -> vec2<f32> {
    let st = select(w.aperture_box.xy, glass.xy / glass.w, glass.w > 0.0);
    let g = vec3<f32>(clamp(st, w.aperture_box.xy, w.aperture_box.zw), 1.0);
    let h0 = w.aperture[0].xyw;
    let h1 = w.aperture[1].xyw;
    let h2 = (w.aperture[3] + w.aperture[2] * z).xyw;
    let x = vec3<f32>(dot(cross(h1, h2), g), dot(cross(h2, h0), g), dot(cross(h0, h1), g));
    return x.xy / x.z;
}

// Whether every light line within `r` map texels (per axis) of `glass`'s crosses the glass:
// the edge distances of `glass_edges` are linear in the offset, so their least over the box is
// the centre's less the steps' magnitudes times `r`. `per_u`, `per_v`: one texel's step.
fn glass_holds_box(w: WindowProjector, glass: vec4<f32>, per_u: vec4<f32>, per_v: vec4<f32>, r: vec2<f32>) -> bool {
    let spread = abs(glass_edges(w, per_u)) * r.x + abs(glass_edges(w, per_v)) * r.y;
    return all(glass_edges(w, glass) >= spread);
}

// A light line's signed distances inside the four edges of the glass (`aperture_box`), scaled
// by its point's w (`through_glass`'s point): all four ≥ 0 where it crosses the glass.
fn glass_edges(w: WindowProjector, c: vec4<f32>) -> vec4<f32> {
    let b = w.aperture_box;
    return vec4<f32>(c.x - b.x * c.w, c.y - b.y * c.w, b.z * c.w - c.x, b.w * c.w - c.y);
}

// Whether a light line crosses the window's glass, from its point on the window's plane in
// the projector's homogeneous coordinates (`WindowProjector::aperture`).
fn through_glass(w: WindowProjector, c: vec4<f32>) -> bool {
    if (c.w <= 0.0) {
        return false;
    }
    let st = c.xy / c.w;
    return all(st >= w.aperture_box.xy) && all(st <= w.aperture_box.zw);
}

// How much of the light reaches `p` directly (0 to 1), in its map over all the opaque geometry
// (`windows.direct`): one comparison, filtered over 2 x 2 texels by the sampler, from a point
// lifted off the surface along its normal `n` (facing the light) by a texel and a half, against
// its own depth less a quarter texel. The slope-scaled bias of `shadow_visibility` lit the
// floor along the foot of every wall beyond a window's plane (the wall's depth there is
// within the bias of the floor's); comparing with the receiving plane instead darkened the
// floor along the sunlit foot of a wall. The light's own penumbra is left out: such points are
// a small part of a view from inside.
fn direct_visibility(p: vec3<f32>, n: vec3<f32>) -> f32 {
    let w = windows.direct;
    if (frame.shadow.w < 0.5) {
        return 1.0;
    }
    // A texel's world size at `p`, and ℓ per world unit along the light (as in
    // `shadow_visibility`: a lamp's texels grow with ℓ, and its ℓ is a ratio of distances).
    var texel = min(w.shadow_x.w, w.shadow_y.w);
    var k = 1.0;
    if (w.shadow_depth.z > 0.0) {
        let c0 = w.shadow * vec4<f32>(p, 1.0);
        texel = texel * shadow_linear(w, clamp(c0.z / c0.w, 0.0, 1.0));
        let t = safe_normalize(p - frame.light_pos.xyz, w.shadow_dir.xyz);
        k = dot(w.shadow_dir.xyz, t) / w.shadow_depth.z;
    }
    let c = w.shadow * vec4<f32>(p + n * (1.5 * texel), 1.0);
    let m = c.xyz / c.w;
    let l = shadow_linear(w, clamp(m.z, 0.0, 1.0)) - 0.25 * texel * k;
    return textureSampleCompareLevel(shadow_maps, shadow_cmp, m.xy, i32(w.params.z), shadow_stored(w, l));
}

// Whether `p` lies inside the building from window `i` and within its projection; `i` is one
// of the windows that pass light (`frame.counts.z`). Plain arithmetic: no texture is read.
fn projects_onto(i: u32, p: vec3<f32>) -> bool {
    // Through a pointer, so only the fields used are read (the entry is 336 bytes).
    let w = &windows.items[i];
    if (dot(p - (*w).origin.xyz, (*w).normal.xyz) <= 0.0) {
        return false; // p is on the light's side of the window
    }
    let clip = (*w).projector * vec4<f32>(p, 1.0);
    if (clip.w <= 0.0) {
        return false; // behind the light
    }
    let uv = clip.xy / clip.w;
    return all(uv >= vec2<f32>(0.0)) && all(uv <= vec2<f32>(1.0));
}

// Light transmitted through the windows towards `p` (1 = unfiltered light), shadows included.
// `dpx`/`dpy` are the screen derivatives of `p`; the texture-coordinate derivatives follow from
// them exactly, so this runs only where the surface faces the light (no uniform control flow
// needed). `n` is the geometric normal facing the light, `frag` the pixel position.
//
// The windows whose projection holds `p` are found first, 32 at a time as the bits of a word;
// the projector samples and shadow-map taps then loop over those alone, in window order. A CPU
// rasterizer (lavapipe) runs a loop's body for all its lanes until every lane is done, a
// `continue` included, so one loop over every window read every window's textures at every
// texel. A word at a time needs no array of them: a private array sized for the most windows
// (32 words for 1024) would sit in every fragment's scratch memory on a GPU.
fn transmitted(p: vec3<f32>, dpx: vec3<f32>, dpy: vec3<f32>, n: vec3<f32>, frag: vec2<f32>) -> vec3<f32> {
    // The windows that pass light come first.
    let count = min(frame.counts.z, MAX_WINDOWS);
    var total = vec3<f32>(0.0);
    // Only the words that hold windows: a CPU rasterizer runs every iteration for all lanes,
    // and looping over five took lavapipe's lit pass from 225 to 284 ms (nave, 720p).
    let words = (count + 31u) / 32u;
    for (var word = 0u; word < words; word = word + 1u) {
        let first = word * 32u;
        let last = min(first + 32u, count);
        var bits = 0u;
        for (var i = first; i < last; i = i + 1u) {
            if (projects_onto(i, p)) {
                bits = bits | (1u << (i - first));
            }
        }
        loop {
            if (bits == 0u) {
                break;
            }
            let i = first + firstTrailingBit(bits);
            bits = bits & (bits - 1u);
            let w = windows.items[i];
            // Divide per fragment: u/w interpolated linearly would be wrong.
            let clip = w.projector * vec4<f32>(p, 1.0);
            let uv = clip.xy / clip.w;
            let cx = w.projector * vec4<f32>(dpx, 0.0);
            let cy = w.projector * vec4<f32>(dpy, 0.0);
            let ddx = (cx.xy - uv * cx.w) / clip.w;
            let ddy = (cy.xy - uv * cy.w) / clip.w;
            let glass = textureSampleGrad(projectors, linear_clamp, uv, w.params.x, ddx, ddy).rgb * w.tint.rgb;
            if (any(glass > vec3<f32>(0.0))) {
                total = total + glass * shadow_visibility(w, p, n, frag);
            }
        }
    }
    return total;
}

// Windows are black in this pass (the composite adds what they let through).
@fragment
fn fs_window(vertex: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(0.0, 0.0, 0.0, 1.0);
}

// Background surfaces, unlit as in pass 0.
@fragment
fn fs_background(vertex: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(background_radiance(facing_camera(vertex)), 1.0);
}

// Every other surface. Windows and the background have shaders of their own rather than
// branches on the material: lavapipe runs both sides of such a branch, so every lit texel paid
// for the background's texture sample as well.
@fragment
fn fs_main(vertex: VertexOut) -> @location(0) vec4<f32> {
    let in = facing_camera(vertex);
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
        let cone = clamp(dot(frame.spot.xyz, -l) + frame.spot.w, 0.0, 1.0);
        radiance = frame.light_colour.rgb * (cone * cone) / max(d2, r * r);
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
        // Outside a window's plane, the light's direct map says whether the point is outside
        // the building: the plane runs on through it (a transept's window's plane through the
        // nave), and a roof over the point stops the light.
        var light_filter = vec3<f32>(1.0);
        if (is_inside(in.rel + geometric * frame.lengths.x)) {
            light_filter = transmitted(in.rel, dpx, dpy, geometric, in.clip.xy);
        } else if (windows.direct.params.w != 0u) {
            light_filter = vec3<f32>(direct_visibility(in.rel, geometric));
        }
        let r = reflect(-l, n);
        let shininess = max(material.specular.w, 1.0);
        let spec = material.specular.rgb * pow(max(dot(r, v), 0.0), shininess);
        colour = colour + (albedo * n_dot_l + spec) * radiance * light_filter;
    }
    return vec4<f32>(colour, 1.0);
}
