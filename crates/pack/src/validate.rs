//! Semantic validation of a decoded TOC against the section table, and of bulk data against
//! the TOC. Everything a consumer indexes with is checked here, before use.

use crate::error::{Fail, Problem};
use crate::format::{MAX_TEXTURE_SIZE, SectionEntry, SectionKind};
use crate::toc::{AttributeFormat, IndexFormat, Mesh, Semantic, Supercompression, Texture, Toc};

/// What a bulk section holds, as the TOC assigns it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SectionRole {
    Toc,
    Vertices { mesh: u32 },
    Indices { mesh: u32 },
    Mip { texture: u32, level: u32 },
}

fn finite(v: &[f32]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Bincode encoding of the TOC (standard config: little endian, varints).
pub(crate) fn toc_config() -> bincode::config::Configuration<
    bincode::config::LittleEndian,
    bincode::config::Varint,
    bincode::config::Limit<{ crate::format::MAX_TOC_BYTES as usize }>,
> {
    bincode::config::standard().with_limit::<{ crate::format::MAX_TOC_BYTES as usize }>()
}

pub fn encode_toc(toc: &Toc) -> Vec<u8> {
    bincode::serde::encode_to_vec(toc, toc_config()).expect("TOC encoding cannot fail")
}

/// What went wrong decoding the table of contents, in words: bincode's own `Display` is its
/// `Debug` (`Utf8 { inner: Utf8Error { valid_up_to: 5, .. } }`).
fn toc_decode_message(e: &bincode::error::DecodeError) -> String {
    use bincode::error::DecodeError as D;
    match e {
        D::UnexpectedEnd { additional } => {
            format!("it ends {additional} bytes or more before its last field")
        }
        D::LimitExceeded => format!(
            "it would take more than {} bytes",
            crate::format::MAX_TOC_BYTES
        ),
        D::Utf8 { inner } => format!("a name is not UTF-8 ({inner})"),
        D::InvalidBooleanValue(v) => format!("a flag holds {v}, neither 0 nor 1"),
        D::InvalidCharEncoding(b) => format!("a character is not valid ({b:?})"),
        D::OutsideUsizeRange(v) => format!("a length of {v} is out of range"),
        // Serde's messages: "invalid value: integer `21`, expected variant index 0 <= i < 3".
        D::OtherString(s) => s.clone(),
        D::Other(s) => (*s).to_string(),
        other => format!("{other:?}"),
    }
}

pub(crate) fn decode_toc(bytes: &[u8], offset: u64) -> Result<Toc, Fail> {
    let (toc, used): (Toc, usize) = bincode::serde::decode_from_slice(bytes, toc_config())
        .map_err(|e| {
            Fail::at(
                offset,
                crate::error::Problem::TocDecode(toc_decode_message(&e)),
            )
        })?;
    if used != bytes.len() {
        return Err(Fail::at(
            offset + used as u64,
            crate::error::Problem::TocDecode(format!(
                "{} unused bytes after the table of contents",
                bytes.len() - used
            )),
        ));
    }
    Ok(toc)
}

fn expect_section(
    table: &[SectionEntry],
    roles: &mut [Option<SectionRole>],
    index: u32,
    kind: SectionKind,
    role: SectionRole,
    length: Option<u64>,
    what: &str,
) -> Result<(), Fail> {
    let entry = table.get(index as usize).ok_or_else(|| {
        Fail::toc(format!(
            "{what} refers to section {index}, but there are {}",
            table.len()
        ))
    })?;
    if entry.kind != kind {
        return Err(Fail::toc(format!(
            "{what} refers to section {index}, which is {} not {}",
            entry.kind.name(),
            kind.name()
        )));
    }
    // A supercompressed level's section is as long as its frame; its content is checked
    // against the level's size when it is decoded (`decode_content`).
    if let Some(length) = length
        && entry.length != length
    {
        return Err(Fail::toc(format!(
            "{what}: section {index} is {} bytes but must be {length}",
            entry.length
        )));
    }
    let slot = &mut roles[index as usize];
    if slot.is_some() {
        return Err(Fail::toc(format!(
            "section {index} is referenced twice ({what})"
        )));
    }
    *slot = Some(role);
    Ok(())
}

fn validate_layout(mesh: &Mesh, what: &str) -> Result<(), Fail> {
    let l = &mesh.layout;
    if l.stride == 0 || l.stride > 256 || !l.stride.is_multiple_of(4) {
        return Err(Fail::toc(format!(
            "{what}: vertex stride {} is invalid (1..=256, multiple of 4)",
            l.stride
        )));
    }
    for (i, a) in l.attributes.iter().enumerate() {
        if !a.offset.is_multiple_of(4) || a.offset as u64 + a.format.size() as u64 > l.stride as u64
        {
            return Err(Fail::toc(format!(
                "{what}: attribute {i} ({:?}) at offset {} does not fit stride {}",
                a.semantic, a.offset, l.stride
            )));
        }
        if l.attributes[..i].iter().any(|b| b.semantic == a.semantic) {
            return Err(Fail::toc(format!(
                "{what}: attribute {:?} appears twice",
                a.semantic
            )));
        }
    }
    let pos = l
        .attribute(Semantic::Position)
        .ok_or_else(|| Fail::toc(format!("{what}: no position attribute")))?;
    if pos.format != AttributeFormat::Float32x3 && pos.format.position_bits().is_none() {
        return Err(Fail::toc(format!(
            "{what}: position format {:?} is not supported",
            pos.format
        )));
    }
    let mat = l
        .attribute(Semantic::MaterialId)
        .ok_or_else(|| Fail::toc(format!("{what}: no material ID attribute")))?;
    if mat.format != AttributeFormat::Uint16x2 {
        return Err(Fail::toc(format!(
            "{what}: material ID format {:?} must be Uint16x2",
            mat.format
        )));
    }
    if let Some(c) = l.attribute(Semantic::Colour)
        && c.format != AttributeFormat::Unorm8x4
    {
        return Err(Fail::toc(format!(
            "{what}: colour format {:?} must be Unorm8x4",
            c.format
        )));
    }
    if !finite(&l.position_offset) || !finite(&l.position_scale) {
        return Err(Fail::toc(format!(
            "{what}: non-finite position dequantization"
        )));
    }
    Ok(())
}

fn validate_texture(t: &Texture, what: &str) -> Result<(), Fail> {
    if t.width == 0 || t.height == 0 || t.width > MAX_TEXTURE_SIZE || t.height > MAX_TEXTURE_SIZE {
        return Err(Fail::toc(format!(
            "{what}: size {}x{} is outside 1..={MAX_TEXTURE_SIZE}",
            t.width, t.height
        )));
    }
    let full = 32 - t.width.max(t.height).leading_zeros();
    if t.mips.is_empty() || t.mips.len() as u32 > full {
        return Err(Fail::toc(format!(
            "{what}: mip count {} must be 1..={full} for {}x{}",
            t.mips.len(),
            t.width,
            t.height
        )));
    }
    if !t.format.allows(t.colour_space) {
        return Err(Fail::toc(format!(
            "{what}: format {} cannot hold {} colour",
            t.format,
            t.colour_space.name()
        )));
    }
    let (mut w, mut h) = (t.width, t.height);
    for (level, m) in t.mips.iter().enumerate() {
        if m.width != w || m.height != h {
            return Err(Fail::toc(format!(
                "{what}: mip {level} is {}x{} but must be {w}x{h}",
                m.width, m.height
            )));
        }
        w = (w / 2).max(1);
        h = (h / 2).max(1);
    }
    Ok(())
}

/// Checks the TOC against the section table; returns the role of every section.
pub fn validate_toc(toc: &Toc, table: &[SectionEntry]) -> Result<Vec<SectionRole>, Fail> {
    let mut roles: Vec<Option<SectionRole>> = vec![None; table.len()];
    roles[0] = Some(SectionRole::Toc);
    let nmat = toc.materials.len();
    let ntex = toc.textures.len();
    if nmat > u16::MAX as usize + 1 {
        return Err(Fail::toc(format!(
            "{nmat} materials, at most 65536 allowed"
        )));
    }
    let tex_ok = |t: Option<u32>, what: &str| -> Result<(), Fail> {
        match t {
            Some(i) if i as usize >= ntex => Err(Fail::toc(format!(
                "{what} refers to texture {i}, but there are {ntex}"
            ))),
            _ => Ok(()),
        }
    };

    for (mi, mesh) in toc.meshes.iter().enumerate() {
        let what = format!("mesh {mi} ({:?})", mesh.name);
        validate_layout(mesh, &what)?;
        if !mesh.index_count.is_multiple_of(3) {
            return Err(Fail::toc(format!(
                "{what}: index count {} is not a multiple of 3",
                mesh.index_count
            )));
        }
        if mesh.index_format == IndexFormat::U16 && mesh.vertex_count > u16::MAX as u32 + 1 {
            return Err(Fail::toc(format!(
                "{what}: {} vertices do not fit 16-bit indices",
                mesh.vertex_count
            )));
        }
        if !finite(&mesh.bounds_min)
            || !finite(&mesh.bounds_max)
            || (0..3).any(|k| mesh.bounds_min[k] > mesh.bounds_max[k])
        {
            return Err(Fail::toc(format!(
                "{what}: bounds {:?}..{:?} are not a finite box",
                mesh.bounds_min, mesh.bounds_max
            )));
        }
        let mut next = 0u64;
        for (ri, r) in mesh.ranges.iter().enumerate() {
            if r.material as usize >= nmat {
                return Err(Fail::toc(format!(
                    "{what}: range {ri} uses material {} but there are {nmat}",
                    r.material
                )));
            }
            if r.first_index as u64 != next
                || !r.index_count.is_multiple_of(3)
                || r.index_count == 0
            {
                return Err(Fail::toc(format!(
                    "{what}: range {ri} covers indices {}..+{}, expected to start at {next} with a non-zero multiple of 3",
                    r.first_index, r.index_count
                )));
            }
            next += r.index_count as u64;
        }
        if next != mesh.index_count as u64 {
            return Err(Fail::toc(format!(
                "{what}: draw ranges cover {next} of {} indices",
                mesh.index_count
            )));
        }
        expect_section(
            table,
            &mut roles,
            mesh.vertex_section,
            SectionKind::Vertices,
            SectionRole::Vertices { mesh: mi as u32 },
            Some(mesh.vertex_count as u64 * mesh.layout.stride as u64),
            &format!("{what} vertices"),
        )?;
        expect_section(
            table,
            &mut roles,
            mesh.index_section,
            SectionKind::Indices,
            SectionRole::Indices { mesh: mi as u32 },
            Some(mesh.index_count as u64 * mesh.index_format.size()),
            &format!("{what} indices"),
        )?;
    }

    for (i, m) in toc.materials.iter().enumerate() {
        let what = format!("material {i} ({:?})", m.name);
        if !finite(&m.diffuse)
            || !finite(&m.specular)
            || !finite(&m.emissive)
            || !m.shininess.is_finite()
        {
            return Err(Fail::toc(format!("{what}: non-finite shading parameter")));
        }
        tex_ok(m.diffuse_texture, &what)?;
        tex_ok(m.normal_texture, &what)?;
        tex_ok(m.projector_texture, &what)?;
        let margin_ok = |v: f32| (0.0..=crate::toc::MAX_PROJECTOR_MARGIN).contains(&v);
        if !m.projector_margin.iter().all(|&v| margin_ok(v))
            || (m.projector_texture.is_none() && m.projector_margin != [0.0; 2])
        {
            return Err(Fail::toc(format!(
                "{what}: projector margin {:?} is not in 0..={} or has no projector texture",
                m.projector_margin,
                crate::toc::MAX_PROJECTOR_MARGIN
            )));
        }
    }

    for (ti, t) in toc.textures.iter().enumerate() {
        let what = format!("texture {ti} ({:?})", t.name);
        if t.name.is_empty() || toc.textures[..ti].iter().any(|o| o.name == t.name) {
            return Err(Fail::toc(format!("{what}: name is empty or not unique")));
        }
        validate_texture(t, &what)?;
        for (level, m) in t.mips.iter().enumerate() {
            expect_section(
                table,
                &mut roles,
                m.section,
                SectionKind::TextureMip,
                SectionRole::Mip {
                    texture: ti as u32,
                    level: level as u32,
                },
                (t.supercompression == Supercompression::None).then(|| t.level_bytes(level)),
                &format!("{what} mip {level}"),
            )?;
        }
    }

    for (i, w) in toc.windows.iter().enumerate() {
        if w.material as usize >= nmat {
            return Err(Fail::toc(format!(
                "window {i} uses material {} but there are {nmat}",
                w.material
            )));
        }
        if !finite(&w.origin) || !finite(&w.u_axis) || !finite(&w.v_axis) || !finite(&w.normal) {
            return Err(Fail::toc(format!("window {i}: non-finite frame")));
        }
    }
    if let Some(light) = &toc.light {
        use crate::toc::LightKind;
        // Written as positive tests so NaN fails them; each failure names its parameter.
        let mut bad: Vec<&str> = Vec::new();
        let mut need = |ok: bool, what: &'static str| {
            if !ok {
                bad.push(what)
            }
        };
        need(finite(&light.colour), "colour not finite");
        need(
            light.intensity.is_finite() && light.intensity >= 0.0,
            "intensity not finite and 0 or more",
        );
        if let Some((position, radius)) = light.kind.lamp() {
            need(finite(&position), "position not finite");
            need(
                radius.is_finite() && radius > 0.0,
                "radius not finite and above 0",
            );
        }
        let direction_ok = |d: &[f32; 3]| finite(d) && d.iter().any(|&c| c != 0.0);
        match &light.kind {
            LightKind::Point { .. } => {}
            LightKind::Directional {
                direction,
                angular_size,
            } => {
                need(direction_ok(direction), "direction zero or not finite");
                need(
                    angular_size.is_finite() && *angular_size >= 0.0,
                    "angular size not finite and 0 or more",
                );
            }
            LightKind::Spot {
                direction,
                inner,
                outer,
                ..
            } => {
                need(direction_ok(direction), "direction zero or not finite");
                need(
                    *inner >= 0.0
                        && inner <= outer
                        && *outer > 0.0
                        && *outer <= std::f32::consts::FRAC_PI_2,
                    "cone angles not 0 <= inner <= outer <= 90 degrees with outer above 0",
                );
            }
        }
        if !bad.is_empty() {
            return Err(Fail::toc(format!(
                "the {} light has invalid parameters: {}",
                light.kind.name(),
                bad.join(", ")
            )));
        }
    }
    for c in &toc.cameras {
        // Written as positive tests so NaN fails them; each failure names its parameter.
        let checks = [
            (
                finite(&c.position) && finite(&c.target) && finite(&c.up),
                "position, target or up not finite",
            ),
            (c.position != c.target, "position equal to target"),
            (
                c.fov_y > 0.0 && c.fov_y < 180.0,
                "vertical field of view not between 0 and 180 degrees",
            ),
            (
                c.near > 0.0 && c.far > c.near && c.far.is_finite(),
                "clip planes not 0 < near < far, finite",
            ),
        ];
        let bad: Vec<&str> = checks.iter().filter(|c| !c.0).map(|c| c.1).collect();
        if !bad.is_empty() {
            return Err(Fail::toc(format!(
                "camera {:?} has invalid parameters: {}",
                c.name,
                bad.join(", ")
            )));
        }
    }
    if !finite(&toc.background.colour) {
        return Err(Fail::toc("background colour is not finite"));
    }
    tex_ok(toc.background.panorama, "background")?;

    // Streaming order: geometry before any mip, and each texture's levels smallest first.
    let mut seen_mip = false;
    for (i, r) in roles.iter().enumerate() {
        match r {
            None => {
                return Err(Fail::toc(format!(
                    "section {i} is not referenced by the TOC"
                )));
            }
            Some(SectionRole::Mip { .. }) => seen_mip = true,
            Some(SectionRole::Vertices { .. } | SectionRole::Indices { .. }) if seen_mip => {
                return Err(Fail::toc(format!(
                    "section {i} holds geometry after texture data: not in streaming order"
                )));
            }
            _ => {}
        }
    }
    for (ti, t) in toc.textures.iter().enumerate() {
        if t.mips.windows(2).any(|w| w[1].section >= w[0].section) {
            return Err(Fail::toc(format!(
                "texture {ti} ({:?}): mip levels are not stored smallest first",
                t.name
            )));
        }
    }
    Ok(roles.into_iter().map(|r| r.unwrap()).collect())
}

/// Checks a vertex section: material IDs within the material table, positions finite and
/// within the mesh's bounds (what the viewer fits its views and shadow maps to).
pub fn validate_vertices(toc: &Toc, mesh: u32, bytes: &[u8]) -> Result<(), Fail> {
    let m = &toc.meshes[mesh as usize];
    let stride = m.layout.stride as usize;
    let nmat = toc.materials.len();
    // Quantized positions decode a rounding away from the corners they were fitted to.
    let largest = m
        .bounds_min
        .iter()
        .chain(&m.bounds_max)
        .fold(0.0f32, |a, &c| a.max(c.abs()));
    let slack: [f32; 3] = std::array::from_fn(|k| {
        1e-4 * (m.bounds_max[k] - m.bounds_min[k]) + 8.0 * f32::EPSILON * largest
    });
    let inside = |p: &[f32; 3]| {
        (0..3).all(|k| p[k] >= m.bounds_min[k] - slack[k] && p[k] <= m.bounds_max[k] + slack[k])
    };
    for (v, chunk) in bytes.chunks_exact(stride).enumerate() {
        let [id, zero, ..] = m
            .layout
            .read(chunk, Semantic::MaterialId)
            .expect("validated layout");
        if id as usize >= nmat || zero != 0.0 {
            return Err(Fail::geometry(format!(
                "mesh {mesh} vertex {v} has material ID {id}, but there are {nmat} materials"
            )));
        }
        let p = m.layout.position(chunk).expect("validated layout");
        if !finite(&p) {
            return Err(Fail::geometry(format!(
                "mesh {mesh} vertex {v} has a non-finite position"
            )));
        }
        if !inside(&p) {
            return Err(Fail::geometry(format!(
                "mesh {mesh} vertex {v} at {p:?} lies outside the mesh's bounds {:?}..{:?}",
                m.bounds_min, m.bounds_max
            )));
        }
    }
    Ok(())
}

/// Checks an index section: every index within the mesh's vertex count.
pub fn validate_indices(toc: &Toc, mesh: u32, bytes: &[u8]) -> Result<(), Fail> {
    let m = &toc.meshes[mesh as usize];
    let n = m.vertex_count;
    let bad = match m.index_format {
        IndexFormat::U32 => bytes
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .enumerate()
            .find(|&(_, i)| i >= n),
        IndexFormat::U16 => bytes
            .chunks_exact(2)
            .map(|c| u16::from_le_bytes(c.try_into().unwrap()) as u32)
            .enumerate()
            .find(|&(_, i)| i >= n),
    };
    if let Some((at, i)) = bad {
        return Err(Fail::geometry(format!(
            "mesh {mesh} index {at} is {i}, but the mesh has {n} vertices"
        )));
    }
    Ok(())
}

/// Checks a bulk section's content according to its role, and undoes a texture level's
/// supercompression: `Some` holds the level's bytes when the section does not.
pub(crate) fn decode_content(
    toc: &Toc,
    role: SectionRole,
    bytes: &[u8],
) -> Result<Option<crate::AlignedBytes>, Fail> {
    match role {
        SectionRole::Vertices { mesh } => validate_vertices(toc, mesh, bytes).map(|()| None),
        SectionRole::Indices { mesh } => validate_indices(toc, mesh, bytes).map(|()| None),
        SectionRole::Toc => Ok(None),
        SectionRole::Mip { texture, level } => {
            let t = &toc.textures[texture as usize];
            if t.supercompression == Supercompression::None {
                return Ok(None);
            }
            let fail = |reason| {
                Fail::from(Problem::Supercompression {
                    what: format!("texture {texture} ({:?}) mip {level}", t.name),
                    reason,
                })
            };
            let expected = t.level_bytes(level as usize);
            t.supercompression
                .check_declared(bytes, expected)
                .map_err(fail)?;
            let mut out = crate::AlignedBytes::zeroed(expected as usize);
            t.supercompression
                .decompress_into(bytes, out.as_mut_slice())
                .map_err(fail)?;
            Ok(Some(out))
        }
    }
}

#[cfg(test)]
mod decode_message_tests {
    use super::toc_decode_message;
    use bincode::error::DecodeError as D;

    #[test]
    fn toc_decode_errors_are_said_in_words_not_bincode_s_debug_text() {
        // Built at run time: the compiler rejects a literal it can see is not UTF-8.
        let bytes: Vec<u8> = "a".bytes().chain([0xFF]).collect();
        let bad = std::str::from_utf8(&bytes).unwrap_err();
        let said = toc_decode_message(&D::Utf8 { inner: bad });
        assert!(said.starts_with("a name is not UTF-8 ("), "{said}");
        assert!(!said.contains("Utf8Error"), "{said}");
        let serde = "invalid value: integer `21`, expected variant index 0 <= i < 3";
        assert_eq!(toc_decode_message(&D::OtherString(serde.into())), serde);
        let said = toc_decode_message(&D::UnexpectedEnd { additional: 3 });
        assert_eq!(said, "it ends 3 bytes or more before its last field");
    }

    /// An index past the mesh's vertices is the geometry's fault, not the table of contents'
    /// (it was said "table of contents is invalid" at the index section's offset).
    #[test]
    fn a_bad_index_is_said_to_be_the_geometry_s() {
        let (toc, _) = crate::testing::sample();
        let n = toc.meshes[0].vertex_count;
        let bytes: Vec<u8> = match toc.meshes[0].index_format {
            crate::IndexFormat::U32 => [0, 1, n].iter().flat_map(|i| i.to_le_bytes()).collect(),
            crate::IndexFormat::U16 => [0, 1, n as u16]
                .iter()
                .flat_map(|i| i.to_le_bytes())
                .collect(),
        };
        let f = super::validate_indices(&toc, 0, &bytes).unwrap_err();
        assert_eq!(
            f.problem.to_string(),
            format!("geometry is invalid: mesh 0 index 2 is {n}, but the mesh has {n} vertices")
        );
    }
}
