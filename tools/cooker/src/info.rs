//! `cooker info <pack> [--json]`

use std::path::PathBuf;

use pack::{Pack, SectionRole};
use serde_json::json;

use crate::exit::{OK, Outcome};

#[derive(clap::Args)]
pub struct Args {
    /// The pack to describe.
    pack: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

fn role_name(pack: &Pack, role: SectionRole) -> String {
    let toc = pack.toc();
    match role {
        SectionRole::Toc => "toc".into(),
        SectionRole::Vertices { mesh } => {
            format!("vertices of {:?}", toc.meshes[mesh as usize].name)
        }
        SectionRole::Indices { mesh } => format!("indices of {:?}", toc.meshes[mesh as usize].name),
        SectionRole::Mip { texture, level } => {
            format!("mip {level} of {:?}", toc.textures[texture as usize].name)
        }
    }
}

/// Where a window's design came from, by the name the cook gave it (see [`windows`]).
fn design_source(design: Option<&str>) -> &'static str {
    // Without the `.2` that tells apart two textures of one name: the design drawn from the
    // panes for the windows of the opposite wall (`Glas_rot.design.2`) was called "image".
    let base = design.map(|d| {
        d.rsplit_once('.')
            .filter(|(_, n)| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
            .map_or(d, |(b, _)| b)
    });
    match base {
        None => "none",
        Some(d) if d.ends_with(".design") => "mesh colours",
        Some(d) if d.ends_with(".fitted") => "image, fitted to the window",
        Some(d) if d.ends_with(".masked") => "image, cut to the window's outline",
        Some(_) => "image",
    }
}

/// Each window: its material, size and placement in the scene's units (a pack does not
/// record them: metres for the default scene, whatever a bare model was drawn in), and its
/// textures. A design made by the cook is named `<window>.design` (rasterized from the mesh's
/// pane colours), `<image>.fitted` (an image fitted to planar texture coordinates) or
/// `<image>.masked` (an image cut to the window's outline).
fn windows(toc: &pack::Toc, tris: &[u64]) -> Vec<serde_json::Value> {
    let tex = |i: Option<u32>| i.map(|i| toc.textures[i as usize].name.clone());
    toc.windows
        .iter()
        .map(|w| {
            let m = &toc.materials[w.material as usize];
            let v = |a: [f32; 3]| glam::Vec3::from(a);
            let centre = v(w.origin) + 0.5 * (v(w.u_axis) + v(w.v_axis));
            let design = tex(m.diffuse_texture);
            let source = design_source(design.as_deref());
            json!({
                "name": m.name,
                "material": w.material,
                "source_materials": w.source_materials,
                "class": m.class.name(),
                "triangles": tris.get(w.material as usize).copied().unwrap_or(0),
                "centre": centre.to_array(),
                "normal": w.normal,
                "width": v(w.u_axis).length(),
                "height": v(w.v_axis).length(),
                "design": design,
                "design_source": source,
                "normal_texture": tex(m.normal_texture),
                "projector_texture": tex(m.projector_texture),
                "projector_margin": m.projector_margin,
            })
        })
        .collect()
}

/// A texture's bytes, all levels: in the pack's file (after supercompression), in its format
/// (what a GPU holds), and as uncompressed RGBA8 of its logical size.
struct TextureBytes {
    stored: u64,
    format: u64,
    rgba8: u64,
}

fn texture_bytes(pack: &Pack, t: &pack::Texture) -> TextureBytes {
    let sections = pack.sections();
    (0..t.mips.len()).fold(
        TextureBytes {
            stored: 0,
            format: 0,
            rgba8: 0,
        },
        |b, k| TextureBytes {
            stored: b.stored + sections[t.mips[k].section as usize].length,
            format: b.format + t.level_bytes(k),
            rgba8: b.rgba8 + t.level_rgba8_bytes(k),
        },
    )
}

/// `bc7`, or `bc7+zstd` for a supercompressed texture.
fn storage_name(t: &pack::Texture) -> String {
    match t.supercompression {
        pack::Supercompression::None => t.format.name().to_string(),
        s => format!("{}+{}", t.format.name(), s.name()),
    }
}

/// The JSON description of a pack; also what golden regression data is made of.
pub fn describe(pack: &Pack) -> serde_json::Value {
    let toc = pack.toc();
    let tris = toc.triangles_per_material();
    let sections: Vec<_> = pack
        .sections()
        .iter()
        .zip(pack.roles())
        .map(|(s, &r)| {
            json!({
                "kind": s.kind.name(),
                "offset": s.offset,
                "length": s.length,
                "align": s.align,
                "crc32": format!("{:08x}", s.crc),
                "checksum_ok": true,
                "holds": role_name(pack, r),
            })
        })
        .collect();
    let materials: Vec<_> = toc
        .materials
        .iter()
        .zip(&tris)
        .map(|(m, &t)| {
            let tex = |i: Option<u32>| i.map(|i| toc.textures[i as usize].name.clone());
            json!({
                "name": m.name,
                "class": m.class.name(),
                "triangles": t,
                "diffuse": m.diffuse,
                "specular": m.specular,
                "shininess": m.shininess,
                "emissive": m.emissive,
                "diffuse_texture": tex(m.diffuse_texture),
                "normal_texture": tex(m.normal_texture),
                "projector_texture": tex(m.projector_texture),
                "projector_margin": m.projector_margin,
            })
        })
        .collect();
    let textures: Vec<_> = toc
        .textures
        .iter()
        .map(|t| {
            let bytes = texture_bytes(pack, t);
            json!({
                "name": t.name,
                "role": t.role.name(),
                "colour_space": t.colour_space.name(),
                "format": t.format.name(),
                "supercompression": t.supercompression.name(),
                "width": t.width,
                "height": t.height,
                "mips": t.mips.len(),
                "stored_bytes": bytes.stored,
                "format_bytes": bytes.format,
                "uncompressed_bytes": bytes.rgba8,
            })
        })
        .collect();
    let meshes: Vec<_> = toc
        .meshes
        .iter()
        .map(|m| {
            json!({
                "name": m.name,
                "vertices": m.vertex_count,
                "triangles": m.index_count / 3,
                "stride": m.layout.stride,
                "attributes": m
                    .layout
                    .attributes
                    .iter()
                    .map(|a| json!({"semantic": format!("{:?}", a.semantic), "format": format!("{:?}", a.format), "offset": a.offset}))
                    .collect::<Vec<_>>(),
                "bounds_min": m.bounds_min,
                "bounds_max": m.bounds_max,
                "ranges": m.ranges.len(),
            })
        })
        .collect();
    let light = toc.light.as_ref().map(|l| match &l.kind {
        pack::LightKind::Point { position, radius } => json!({
            "type": "point", "position": position, "radius": radius,
            "colour": l.colour, "intensity": l.intensity,
        }),
        pack::LightKind::Directional {
            direction,
            angular_size,
        } => json!({
            // Radians, as the pack stores them; the manifest's and text output's degrees
            // beside them, named so.
            "type": "directional", "direction": direction, "angular_size": angular_size,
            "angular_size_deg": angular_size.to_degrees(),
            "colour": l.colour, "intensity": l.intensity,
        }),
        pack::LightKind::Spot {
            position,
            radius,
            direction,
            inner,
            outer,
        } => json!({
            "type": "spot", "position": position, "radius": radius, "direction": direction,
            "inner_cone": inner, "outer_cone": outer,
            "inner_cone_deg": inner.to_degrees(), "outer_cone_deg": outer.to_degrees(),
            "colour": l.colour, "intensity": l.intensity,
        }),
    });
    json!({
        "format_version": pack.header().version,
        "file_length": pack.header().file_length,
        "sections": sections,
        "meshes": meshes,
        "triangles": tris.iter().sum::<u64>(),
        "materials": materials,
        "textures": textures,
        "windows": windows(toc, &tris),
        "light": light,
        "cameras": toc.cameras.iter().map(|c| c.name.clone()).collect::<Vec<_>>(),
        // Each camera whole; `cameras` keeps the names alone, as scripts read them.
        "views": toc.cameras.iter().map(|c| json!({
            "name": c.name, "position": c.position, "target": c.target, "up": c.up,
            "fov_y_deg": c.fov_y, "near": c.near, "far": c.far,
        })).collect::<Vec<_>>(),
        "background": {
            "colour": toc.background.colour,
            "panorama": panorama_name(toc),
        },
    })
}

/// The name of the background's panorama texture, if it has one.
fn panorama_name(toc: &pack::Toc) -> Option<&str> {
    let i = toc.background.panorama?;
    toc.textures.get(i as usize).map(|t| t.name.as_str())
}

pub fn run(args: Args) -> Outcome {
    let pack = Pack::open(&args.pack)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&describe(&pack))?);
        return Ok(OK);
    }
    let toc = pack.toc();
    println!(
        "{}: pack format version {}, {} bytes",
        args.pack.display(),
        pack.header().version,
        pack.header().file_length
    );
    println!("sections ({}), all checksums OK:", pack.sections().len());
    println!(
        "  {:>4}  {:<12} {:>12} {:>12}  {:<8}  holds",
        "#", "kind", "offset", "size", "crc32"
    );
    for (i, (s, &r)) in pack.sections().iter().zip(pack.roles()).enumerate() {
        println!(
            "  {i:>4}  {:<12} {:>12} {:>12}  {:08x}  {}",
            s.kind.name(),
            s.offset,
            s.length,
            s.crc,
            role_name(&pack, r)
        );
    }
    let tris = toc.triangles_per_material();
    println!("meshes ({}):", toc.meshes.len());
    for m in &toc.meshes {
        let colours = m.layout.attribute(pack::Semantic::Colour).is_some();
        println!(
            "  {} {:>9} vertices {:>9} triangles  stride {:>3}  {} ranges{}",
            cook::padded(&m.name, 24),
            m.vertex_count,
            m.index_count / 3,
            m.layout.stride,
            m.ranges.len(),
            if colours { ", vertex colours" } else { "" }
        );
    }
    println!("materials ({}):", toc.materials.len());
    for class in pack::MaterialClass::ALL {
        let (n, t) = toc
            .materials
            .iter()
            .zip(&tris)
            .filter(|(m, _)| m.class == class)
            .fold((0, 0), |(n, t), (_, &c)| (n + 1, t + c));
        if n > 0 {
            println!("  {:<13} {n:>4} materials {t:>10} triangles", class.name());
        }
    }
    for (m, t) in toc.materials.iter().zip(&tris) {
        println!(
            "    {} {:<13} {t:>10} triangles",
            cook::padded(&m.name, 28),
            m.class.name()
        );
    }
    println!("textures ({}):", toc.textures.len());
    let (mut all_stored, mut all_format, mut all_rgba8) = (0, 0, 0);
    for t in &toc.textures {
        let b = texture_bytes(&pack, t);
        all_stored += b.stored;
        all_format += b.format;
        all_rgba8 += b.rgba8;
        println!(
            "  {} {:<9} {:<6} {:<10} {:>5}x{:<5} {:>2} mips {:>10} bytes ({:>10} in {}, {:>10} as RGBA8)",
            cook::padded(&t.name, 32),
            t.role.name(),
            t.colour_space.name(),
            storage_name(t),
            t.width,
            t.height,
            t.mips.len(),
            b.stored,
            b.format,
            t.format.name(),
            b.rgba8
        );
    }
    println!("  texture bytes: {all_stored} stored, {all_format} on the GPU, {all_rgba8} as RGBA8");
    let cameras: Vec<String> = toc
        .cameras
        .iter()
        .map(|c| cook::shown(&c.name).into_owned())
        .collect();
    println!(
        "windows: {}, cameras: {}",
        toc.windows.len(),
        if cameras.is_empty() {
            "none (the viewer makes a default view)".to_string()
        } else {
            cameras.join(", ")
        }
    );
    for w in &toc.windows {
        let m = &toc.materials[w.material as usize];
        let len = |a: [f32; 3]| glam::Vec3::from(a).length();
        // Which design each window shows: windows that share one share its texture.
        let design = m.diffuse_texture.map_or(String::new(), |t| {
            format!("  design: {}", cook::shown(&toc.textures[t as usize].name))
        });
        println!(
            "  {} {:<12} {:>6} x {:<6} units  glass: {}{design}",
            cook::padded(&m.name, 32),
            m.class.name(),
            cook::length(len(w.u_axis) as f64),
            cook::length(len(w.v_axis) as f64),
            cook::shown(&w.source_materials.join(", "))
        );
    }
    println!("light: {}", crate::diff::describe_light(toc.light.as_ref()));
    let [r, g, b] = toc.background.colour;
    let panorama = panorama_name(toc).map_or(String::new(), |name| {
        format!(", panorama {}", cook::shown(name))
    });
    println!("background: colour [{r:.3}, {g:.3}, {b:.3}] (linear){panorama}");
    Ok(OK)
}

#[cfg(test)]
mod tests {
    /// A design drawn from the panes for a second set of windows (`.design.2`) is still
    /// "mesh colours", not "image".
    #[test]
    fn a_numbered_design_keeps_its_source() {
        use super::design_source;
        assert_eq!(design_source(Some("Glas_rot.design")), "mesh colours");
        assert_eq!(design_source(Some("Glas_rot.design.2")), "mesh colours");
        assert_eq!(
            design_source(Some("mosaic.fitted.12")),
            "image, fitted to the window"
        );
        assert_eq!(
            design_source(Some("rose.masked.3")),
            "image, cut to the window's outline"
        );
        assert_eq!(design_source(Some("v1.2")), "image");
        assert_eq!(design_source(Some("lancet")), "image");
        assert_eq!(design_source(None), "none");
    }
}
