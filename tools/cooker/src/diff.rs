//! `cooker diff <a.pack> <b.pack> [--json] [--tolerance-lsb LSB] [--max-position-delta D]`
//!
//! Compares two packs section by section and explains the differences: geometry (counts,
//! largest position change, material ID changes) and, per texture and mip level, the largest
//! error in 8-bit steps, PSNR and FLIP mean of the decoded texels (whatever each pack stores
//! them in: RGBA8 or a block format). Exit 0 when within the thresholds (identical by
//! default), 1 otherwise, so a user's CI can gate on it.

use std::collections::BTreeMap;
use std::path::PathBuf;

use pack::{Pack, SectionRole, TextureRole};
use serde_json::{Value, json};

use crate::exit::{FOUND_PROBLEMS, OK, Outcome, UsageError};

#[derive(clap::Args)]
pub struct Args {
    /// The reference pack.
    a: PathBuf,
    /// The pack compared against it.
    b: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Largest texel difference accepted in any texture level, in 8-bit steps (LSB); default:
    /// identical. `--max-error` is the old spelling.
    #[arg(long = "tolerance-lsb", alias = "max-error", value_name = "LSB")]
    tolerance_lsb: Option<f64>,
    /// Largest vertex position change accepted (scene units); default: identical.
    #[arg(long, value_name = "D")]
    max_position_delta: Option<f64>,
}

/// What differs about one texture level.
struct LevelDiff {
    level: usize,
    width: u32,
    height: u32,
    max_error: u32,
    psnr: f64,
    flip_mean: Option<f32>,
}

fn level_diff(role: TextureRole, level: usize, w: u32, h: u32, a: &[u8], b: &[u8]) -> LevelDiff {
    let mut max_error = 0u32;
    let mut sq = 0f64;
    for (x, y) in a.iter().zip(b) {
        let d = x.abs_diff(*y) as u32;
        max_error = max_error.max(d);
        sq += (d * d) as f64;
    }
    let mse = sq / a.len().max(1) as f64;
    let psnr = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    };
    // FLIP models human perception of colour images; it says nothing useful about normal maps,
    // and needs a few texels of neighbourhood.
    let flip_mean = (role != TextureRole::Normal && w >= 8 && h >= 8 && max_error > 0).then(|| {
        let rgb = |src: &[u8]| -> Vec<u8> {
            src.chunks_exact(4)
                .flat_map(|p| [p[0], p[1], p[2]])
                .collect()
        };
        let ra = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(a));
        let rb = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(b));
        let err = nv_flip::flip(ra, rb, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
        nv_flip::FlipPool::from_image(&err).mean()
    });
    let flip_mean = if max_error == 0 { Some(0.0) } else { flip_mean };
    LevelDiff {
        level,
        width: w,
        height: h,
        max_error,
        psnr,
        flip_mean,
    }
}

fn positions(pack: &Pack, mesh: &pack::Mesh) -> Vec<[f32; 3]> {
    let l = &mesh.layout;
    pack.vertex_bytes(mesh)
        .chunks_exact(l.stride as usize)
        .map(|v| l.position(v).expect("validated layout"))
        .collect()
}

fn material_ids(pack: &Pack, mesh: &pack::Mesh) -> Vec<u16> {
    let l = &mesh.layout;
    pack.vertex_bytes(mesh)
        .chunks_exact(l.stride as usize)
        .map(|v| l.material_id(v).expect("validated layout"))
        .collect()
}

fn role_key(pack: &Pack, role: SectionRole) -> String {
    let toc = pack.toc();
    match role {
        SectionRole::Toc => "toc".into(),
        SectionRole::Vertices { mesh } => format!("vertices/{}", toc.meshes[mesh as usize].name),
        SectionRole::Indices { mesh } => format!("indices/{}", toc.meshes[mesh as usize].name),
        SectionRole::Mip { texture, level } => {
            format!("mip/{}/{level}", toc.textures[texture as usize].name)
        }
    }
}

pub fn run(args: Args) -> Outcome {
    for (name, v) in [
        ("--tolerance-lsb", args.tolerance_lsb),
        ("--max-position-delta", args.max_position_delta),
    ] {
        if let Some(v) = v
            && !(v.is_finite() && v >= 0.0)
        {
            return Err(UsageError(format!("{name} must be a finite number >= 0, got {v}")).into());
        }
    }
    let a = Pack::open(&args.a)?;
    let b = Pack::open(&args.b)?;
    let (ta, tb) = (a.toc(), b.toc());
    let mut problems: Vec<String> = Vec::new();

    // Sections, matched by what they hold rather than by index, and compared by content: a
    // supercompressed level by its decoded bytes.
    let index = |p: &Pack| -> BTreeMap<String, u32> {
        p.roles()
            .iter()
            .zip(p.sections())
            .enumerate()
            .map(|(i, (&r, s))| {
                let data = p.section_data(i as u32);
                let crc = if data.len() as u64 == s.length && data == p.section_bytes(i as u32) {
                    s.crc
                } else {
                    pack::format::crc32(data)
                };
                (role_key(p, r), crc)
            })
            .collect()
    };
    let (sa, sb) = (index(&a), index(&b));
    let mut sections = Vec::new();
    for key in sa.keys().chain(sb.keys().filter(|k| !sa.contains_key(*k))) {
        let state = match (sa.get(key), sb.get(key)) {
            (Some(x), Some(y)) if x == y => "equal",
            (Some(_), Some(_)) => "different",
            (Some(_), None) => "only in a",
            _ => "only in b",
        };
        sections.push(json!({"section": key, "state": state}));
    }
    let identical = a.bytes() == b.bytes();

    // Geometry, meshes matched by name.
    let mut meshes = Vec::new();
    for ma in &ta.meshes {
        let Some(mb) = tb.meshes.iter().find(|m| m.name == ma.name) else {
            problems.push(format!("mesh {:?} is missing from b", ma.name));
            meshes.push(json!({"name": ma.name, "state": "only in a"}));
            continue;
        };
        let mut entry = json!({
            "name": ma.name,
            "vertices": [ma.vertex_count, mb.vertex_count],
            "triangles": [ma.index_count / 3, mb.index_count / 3],
        });
        if ma.vertex_count != mb.vertex_count || ma.index_count != mb.index_count {
            problems.push(format!(
                "mesh {:?}: {} vertices / {} triangles in a, {} / {} in b",
                ma.name,
                ma.vertex_count,
                ma.index_count / 3,
                mb.vertex_count,
                mb.index_count / 3
            ));
        } else {
            let (pa, pb) = (positions(&a, ma), positions(&b, mb));
            let delta = pa
                .iter()
                .zip(&pb)
                .map(|(p, q)| {
                    (0..3)
                        .map(|k| (p[k] - q[k]).abs() as f64)
                        .fold(0.0, f64::max)
                })
                .fold(0.0, f64::max);
            // Material IDs compare by name: the tables of the two packs may be ordered differently.
            let name_a = |i: u16| ta.materials[i as usize].name.as_str();
            let name_b = |i: u16| tb.materials[i as usize].name.as_str();
            let changed = material_ids(&a, ma)
                .iter()
                .zip(material_ids(&b, mb))
                .filter(|&(&x, y)| name_a(x) != name_b(y))
                .count();
            let indices_equal = a.indices(ma) == b.indices(mb);
            if delta > args.max_position_delta.unwrap_or(0.0) {
                problems.push(format!("mesh {:?}: a vertex moved by {delta:.3e}", ma.name));
            }
            if changed > 0 {
                problems.push(format!(
                    "mesh {:?}: {changed} vertices changed material",
                    ma.name
                ));
            }
            if !indices_equal {
                problems.push(format!("mesh {:?}: index buffers differ", ma.name));
            }
            entry["max_position_delta"] = json!(delta);
            entry["material_id_changes"] = json!(changed);
            entry["indices_equal"] = json!(indices_equal);
        }
        meshes.push(entry);
    }
    for mb in &tb.meshes {
        if !ta.meshes.iter().any(|m| m.name == mb.name) {
            problems.push(format!("mesh {:?} is new in b", mb.name));
            meshes.push(json!({"name": mb.name, "state": "only in b"}));
        }
    }

    // Materials, by name.
    let mut materials = Vec::new();
    let (tria, trib) = (ta.triangles_per_material(), tb.triangles_per_material());
    for (i, m) in ta.materials.iter().enumerate() {
        match tb.materials.iter().position(|n| n.name == m.name) {
            None => problems.push(format!("material {:?} is missing from b", m.name)),
            Some(j) => {
                let n = &tb.materials[j];
                if n.class != m.class || tria[i] != trib[j] {
                    problems.push(format!(
                        "material {:?}: {} with {} triangles in a, {} with {} in b",
                        m.name, m.class, tria[i], n.class, trib[j]
                    ));
                }
                materials.push(json!({
                    "name": m.name, "class": [m.class.name(), n.class.name()],
                    "triangles": [tria[i], trib[j]],
                    "shading_equal": m.diffuse == n.diffuse && m.specular == n.specular
                        && m.shininess == n.shininess && m.emissive == n.emissive,
                }));
            }
        }
    }
    for m in &tb.materials {
        if !ta.materials.iter().any(|n| n.name == m.name) {
            problems.push(format!("material {:?} is new in b", m.name));
        }
    }

    // Textures, by name, level by level.
    let tolerance = args.tolerance_lsb.unwrap_or(0.0);
    let mut textures = Vec::new();
    for (i, t) in ta.textures.iter().enumerate() {
        let Some((j, u)) = tb.texture_by_name(&t.name) else {
            problems.push(format!("texture {:?} is missing from b", t.name));
            continue;
        };
        if (t.width, t.height, t.mips.len(), t.role) != (u.width, u.height, u.mips.len(), u.role) {
            problems.push(format!(
                "texture {:?}: {} {}x{} with {} mips in a, {} {}x{} with {} in b",
                t.name,
                t.role,
                t.width,
                t.height,
                t.mips.len(),
                u.role,
                u.width,
                u.height,
                u.mips.len()
            ));
            continue;
        }
        let mut levels = Vec::new();
        for (level, m) in t.mips.iter().enumerate() {
            // Decoded texels, so an RGBA8 pack and a block-compressed one compare.
            let d = level_diff(
                t.role,
                level,
                m.width,
                m.height,
                &pack::texels::decode_level(t, level, a.mip_bytes(i, level)),
                &pack::texels::decode_level(u, level, b.mip_bytes(j, level)),
            );
            if d.max_error as f64 > tolerance {
                problems.push(format!(
                    "texture {:?} mip {level} ({}x{}): max error {} LSB > {tolerance}, PSNR {:.2} dB",
                    t.name, d.width, d.height, d.max_error, d.psnr
                ));
            }
            levels.push(d);
        }
        textures.push((t.name.clone(), levels));
    }
    for t in &tb.textures {
        if ta.texture_by_name(&t.name).is_none() {
            problems.push(format!("texture {:?} is new in b", t.name));
        }
    }
    // Scene parameters outside geometry and textures.
    if ta.light != tb.light {
        problems.push("the light differs".into());
    }
    if ta.cameras != tb.cameras {
        problems.push("the camera presets differ".into());
    }
    if ta.windows != tb.windows {
        problems.push("the window frames differ".into());
    }
    if ta.background != tb.background {
        problems.push("the background differs".into());
    }
    // Identical by default: without thresholds any byte difference (even one no rule above
    // explains, such as reordered sections) is a difference.
    let strict = args.tolerance_lsb.is_none() && args.max_position_delta.is_none();
    if strict && !identical && problems.is_empty() {
        problems.push(
            "the packs differ in bytes (section order, supercompression or TOC encoding)".into(),
        );
    }
    let within = problems.is_empty();

    if args.json {
        let tex_json: Vec<Value> = textures
            .iter()
            .map(|(name, levels)| {
                json!({
                    "name": name,
                    "levels": levels.iter().map(|d| json!({
                        "level": d.level, "width": d.width, "height": d.height,
                        "max_error": d.max_error,
                        "psnr": if d.psnr.is_finite() { json!(d.psnr) } else { json!("inf") },
                        "flip_mean": d.flip_mean,
                    })).collect::<Vec<_>>(),
                })
            })
            .collect();
        println!(
            "{}",
            serde_json::to_string_pretty(&json!({
                "a": args.a, "b": args.b,
                "identical": identical,
                "within_thresholds": within,
                "sections": sections,
                "meshes": meshes,
                "materials": materials,
                "textures": tex_json,
                "problems": problems,
            }))?
        );
    } else {
        println!("a: {}\nb: {}", args.a.display(), args.b.display());
        if identical {
            println!("identical: every byte is equal");
        }
        let differing: Vec<_> = sections.iter().filter(|s| s["state"] != "equal").collect();
        println!(
            "sections: {} compared, {} differ",
            sections.len(),
            differing.len()
        );
        for s in differing {
            println!(
                "  {:<40} {}",
                s["section"].as_str().unwrap_or(""),
                s["state"].as_str().unwrap_or("")
            );
        }
        for (name, levels) in &textures {
            for d in levels.iter().filter(|d| d.max_error > 0) {
                let flip = d
                    .flip_mean
                    .map(|f| format!("{f:.4}"))
                    .unwrap_or_else(|| "-".into());
                println!(
                    "  texture {name:?} mip {} ({}x{}): max error {} LSB, PSNR {:.2} dB, FLIP mean {flip}",
                    d.level, d.width, d.height, d.max_error, d.psnr
                );
            }
        }
        if within {
            println!("result: within thresholds");
        } else {
            println!("result: {} problem(s)", problems.len());
            for (i, p) in problems.iter().enumerate() {
                println!("  {}. {p}", i + 1);
            }
        }
    }
    Ok(if within { OK } else { FOUND_PROBLEMS })
}
