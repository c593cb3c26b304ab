//! Wavefront OBJ import.
//!
//! The geometry parser is our own rather than tobj's: errors must name the line (tobj reports
//! an out-of-range index without one), tagging needs `g`, `o` and `usemtl` names kept apart
//! (tobj folds groups and objects into one model name), n-gons must be ear-clipped rather than
//! fanned, and line and point elements must be skipped with a warning. MTL files are still read
//! with tobj's MTL parser.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::{Corner, ImageRef, Imported, NONE, Names, Part, SourceMaterial, Warning};
use crate::CookError;
use crate::triangulate::triangulate;

pub fn import(path: &Path) -> Result<Imported, CookError> {
    let bytes = std::fs::read(path).map_err(|source| CookError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    // UTF-16 (what some Windows tools save) would parse as a stream of unknown statements and
    // cook to nothing; say what it is instead.
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) || bytes.contains(&0) {
        return Err(bad(
            path,
            1,
            "the file is UTF-16 or binary, not an ASCII/UTF-8 OBJ: save it as UTF-8",
        ));
    }
    parse(path, &bytes)
}

fn bad(path: &Path, line: usize, message: impl Into<String>) -> CookError {
    CookError::Source {
        path: path.to_path_buf(),
        line: Some(line),
        message: message.into(),
    }
}

fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

fn text(t: &[u8]) -> String {
    String::from_utf8_lossy(t).into_owned()
}

fn parse_f32(t: &[u8]) -> Option<f32> {
    std::str::from_utf8(t).ok()?.parse().ok()
}

/// The same integers `str::parse::<i64>` accepts (optional sign, decimal digits, no
/// overflow), read straight from the bytes: face indices are most of an OBJ's tokens.
fn parse_i64(t: &[u8]) -> Option<i64> {
    let (negative, digits) = match t {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        _ => (false, t),
    };
    if digits.is_empty() {
        return None;
    }
    let mut v: i64 = 0;
    for &b in digits {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        // Accumulate negatively so i64::MIN parses too.
        v = v.checked_mul(10)?.checked_sub(d as i64)?;
    }
    if negative { Some(v) } else { v.checked_neg() }
}

fn trim(mut s: &[u8]) -> &[u8] {
    while let [first, rest @ ..] = s {
        if first.is_ascii_whitespace() {
            s = rest
        } else {
            break;
        }
    }
    while let [rest @ .., last] = s {
        if last.is_ascii_whitespace() {
            s = rest
        } else {
            break;
        }
    }
    s
}

/// (material, group, object) names of a part.
type PartKey = (Option<String>, Option<String>, Option<String>);

/// Parser state: the source names in effect and the part they map to.
#[derive(Default)]
struct State {
    material: Option<String>,
    group: Option<String>,
    object: Option<String>,
    part: Option<u32>,
    parts: HashMap<PartKey, u32>,
}

/// Parses OBJ text. `path` names the file in errors and locates `mtllib` files.
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Imported, CookError> {
    let mut out = Imported {
        path: path.to_path_buf(),
        ..Default::default()
    };
    let mut state = State::default();
    let mut material_ids: HashMap<String, u32> = HashMap::new();
    let mut missing_textures: Vec<(String, Warning)> = Vec::new();
    let mut unknown_materials: Vec<(String, usize)> = Vec::new();
    let mut skipped_lines = (0usize, 0usize, 0usize); // (line elements, points, first line)
    let mut short_faces: Vec<usize> = Vec::new();
    let mut unknown_keywords: Vec<(String, usize)> = Vec::new();
    let mut empty_groups: Vec<String> = Vec::new();
    let mut group_faces: Option<(String, usize)> = None;
    let mut face: Vec<Corner> = Vec::new();
    let mut poly: Vec<[f32; 3]> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();

    for (index, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line_no = index + 1;
        let line = trim(raw);
        if line.is_empty() || line[0] == b'#' {
            continue;
        }
        let mut it = tokens(line);
        let keyword = it.next().unwrap_or_default();
        let rest = trim(&line[keyword.len()..]);
        match keyword {
            b"v" => {
                let mut p = [0.0f32; 3];
                for (k, c) in p.iter_mut().enumerate() {
                    let t = it.next().ok_or_else(|| {
                        bad(
                            path,
                            line_no,
                            format!("vertex has {k} coordinates, needs 3"),
                        )
                    })?;
                    *c = parse_f32(t).ok_or_else(|| {
                        bad(
                            path,
                            line_no,
                            format!("vertex coordinate {:?} is not a number", text(t)),
                        )
                    })?;
                    if !c.is_finite() {
                        return Err(bad(
                            path,
                            line_no,
                            format!("vertex coordinate {:?} is not finite", text(t)),
                        ));
                    }
                }
                out.positions.push(p);
            }
            b"vt" => {
                let mut uv = [0.0f32; 2];
                for (k, c) in uv.iter_mut().enumerate() {
                    match it.next() {
                        Some(t) => {
                            *c = parse_f32(t).filter(|v| v.is_finite()).ok_or_else(|| {
                                bad(
                                    path,
                                    line_no,
                                    format!(
                                        "texture coordinate {:?} is not a finite number",
                                        text(t)
                                    ),
                                )
                            })?
                        }
                        None if k == 0 => {
                            return Err(bad(path, line_no, "texture coordinate has no values"));
                        }
                        None => {}
                    }
                }
                // OBJ puts v = 0 at the bottom of an image; the pack, glTF and the GPU put it
                // at the top row.
                out.uvs.push([uv[0], 1.0 - uv[1]]);
            }
            b"vn" => {
                let mut n = [0.0f32; 3];
                for (k, c) in n.iter_mut().enumerate() {
                    let t = it.next().ok_or_else(|| {
                        bad(path, line_no, format!("normal has {k} components, needs 3"))
                    })?;
                    *c = parse_f32(t).filter(|v| v.is_finite()).ok_or_else(|| {
                        bad(
                            path,
                            line_no,
                            format!("normal component {:?} is not a finite number", text(t)),
                        )
                    })?;
                }
                out.normals.push(n);
            }
            b"f" => {
                face.clear();
                for t in it {
                    face.push(parse_corner(path, line_no, t, &out)?);
                }
                if face.len() < 3 {
                    short_faces.push(line_no);
                    continue;
                }
                if let Some((_, n)) = &mut group_faces {
                    *n += 1;
                }
                let part = current_part(&mut state, &mut out, &material_ids);
                if face.len() == 3 {
                    out.corners.extend_from_slice(&face);
                    out.tri_part.push(part);
                } else {
                    out.polygons += 1;
                    poly.clear();
                    poly.extend(face.iter().map(|c| out.positions[c.p as usize]));
                    tris.clear();
                    triangulate(&poly, &mut tris);
                    for t in &tris {
                        out.corners.extend(t.iter().map(|&i| face[i as usize]));
                        out.tri_part.push(part);
                    }
                }
            }
            b"l" | b"p" => {
                if skipped_lines.0 + skipped_lines.1 == 0 {
                    skipped_lines.2 = line_no;
                }
                if keyword == b"l" {
                    skipped_lines.0 += 1
                } else {
                    skipped_lines.1 += 1
                }
            }
            b"g" => {
                if let Some((name, 0)) = group_faces.take() {
                    empty_groups.push(name);
                }
                let name = (!rest.is_empty()).then(|| text(rest));
                group_faces = name.clone().map(|n| (n, 0));
                state.group = name;
                state.part = None;
            }
            b"o" => {
                state.object = (!rest.is_empty()).then(|| text(rest));
                state.part = None;
            }
            b"usemtl" => {
                let name = text(rest);
                if !name.is_empty()
                    && !material_ids.contains_key(&name)
                    && !unknown_materials.iter().any(|(n, _)| *n == name)
                {
                    unknown_materials.push((name.clone(), line_no));
                }
                state.material = (!name.is_empty()).then_some(name);
                state.part = None;
            }
            b"mtllib" => load_mtllib(
                path,
                line_no,
                rest,
                &mut out,
                &mut material_ids,
                &mut missing_textures,
            )?,
            // Smoothing groups, free-form geometry and display attributes: normals are
            // generated with a crease angle instead, and the rest has no meaning here.
            b"s" | b"vp" | b"cstype" | b"deg" | b"bmat" | b"step" | b"curv" | b"curv2"
            | b"surf" | b"parm" | b"trim" | b"hole" | b"scrv" | b"sp" | b"end" | b"con" | b"mg"
            | b"lod" | b"bevel" | b"c_interp" | b"d_interp" | b"usemap" | b"maplib"
            | b"shadow_obj" | b"trace_obj" | b"ctech" | b"stech" => {}
            other => {
                let k = text(other);
                if !unknown_keywords.iter().any(|(n, _)| *n == k) {
                    unknown_keywords.push((k, line_no));
                }
            }
        }
    }
    if let Some((name, 0)) = group_faces.take() {
        empty_groups.push(name);
    }

    // Unknown `usemtl` names stay names for tagging; only shading falls back to a default.
    unknown_materials.retain(|(n, _)| !material_ids.contains_key(n));
    for (name, line) in unknown_materials {
        out.warnings.push(Warning::new(
            path,
            Some(line),
            format!("material {name:?} is not defined in any mtllib; using default shading"),
        ));
    }
    if skipped_lines.0 + skipped_lines.1 > 0 {
        out.warnings.push(Warning::new(
            path,
            Some(skipped_lines.2),
            format!(
                "{} line and {} point elements ignored: only faces are cooked",
                skipped_lines.0, skipped_lines.1
            ),
        ));
    }
    if let Some(&first) = short_faces.first() {
        out.warnings.push(Warning::new(
            path,
            Some(first),
            format!(
                "{} faces with fewer than 3 vertices ignored",
                short_faces.len()
            ),
        ));
    }
    if !empty_groups.is_empty() {
        out.warnings.push(Warning::new(
            path,
            None,
            format!("groups without faces: {}", empty_groups.join(", ")),
        ));
    }
    for (k, line) in unknown_keywords {
        out.warnings.push(Warning::new(
            path,
            Some(line),
            format!("unknown statement {k:?} ignored"),
        ));
    }
    if out.tri_part.is_empty() {
        out.warnings
            .push(Warning::new(path, None, "no faces: nothing to cook"));
    }
    // A missing texture matters only to a material some face uses.
    let mut used = vec![false; out.materials.len()];
    for &p in &out.tri_part {
        if let Some(m) = out.parts[p as usize].material {
            used[m as usize] = true;
        }
    }
    for (name, w) in missing_textures {
        if material_ids.get(&name).is_some_and(|&i| used[i as usize]) {
            out.warnings.push(w);
        }
    }
    Ok(out)
}

fn current_part(state: &mut State, out: &mut Imported, material_ids: &HashMap<String, u32>) -> u32 {
    if let Some(p) = state.part {
        return p;
    }
    let key = (
        state.material.clone(),
        state.group.clone(),
        state.object.clone(),
    );
    let next = out.parts.len() as u32;
    let id = *state.parts.entry(key).or_insert_with(|| {
        out.parts.push(Part {
            names: Names {
                material: state.material.clone(),
                group: state.group.clone(),
                object: state.object.clone(),
                mesh: None,
                node: None,
            },
            material: state
                .material
                .as_ref()
                .and_then(|m| material_ids.get(m).copied()),
        });
        next
    });
    state.part = Some(id);
    id
}

fn resolve(
    path: &Path,
    line: usize,
    raw: &[u8],
    count: usize,
    what: &str,
) -> Result<u32, CookError> {
    let i = parse_i64(raw).ok_or_else(|| {
        bad(
            path,
            line,
            format!("{what} index {:?} is not an integer", text(raw)),
        )
    })?;
    let resolved = if i > 0 {
        i - 1
    } else if i < 0 {
        count as i64 + i
    } else {
        return Err(bad(
            path,
            line,
            format!("{what} index 0 is invalid: OBJ indices start at 1"),
        ));
    };
    if resolved < 0 || resolved >= count as i64 || resolved >= NONE as i64 {
        return Err(bad(
            path,
            line,
            format!(
                "{what} index {i} is out of range: {count} {} defined before this line",
                plural(what, count)
            ),
        ));
    }
    Ok(resolved as u32)
}

fn plural(what: &str, n: usize) -> String {
    match (what, n) {
        ("vertex", 1) => "vertex is".to_string(),
        ("vertex", _) => "vertices are".to_string(),
        (w, 1) => format!("{w} is"),
        (w, _) => format!("{w}s are"),
    }
}

fn parse_corner(path: &Path, line: usize, tok: &[u8], out: &Imported) -> Result<Corner, CookError> {
    let mut fields = tok.split(|&b| b == b'/');
    let p = fields.next().unwrap_or_default();
    let p = resolve(path, line, p, out.positions.len(), "vertex")?;
    let t = match fields.next() {
        Some(f) if !f.is_empty() => resolve(path, line, f, out.uvs.len(), "texture coordinate")?,
        _ => NONE,
    };
    let n = match fields.next() {
        Some(f) if !f.is_empty() => resolve(path, line, f, out.normals.len(), "normal")?,
        _ => NONE,
    };
    if fields.next().is_some() {
        return Err(bad(
            path,
            line,
            format!("face corner {:?} has more than 3 fields", text(tok)),
        ));
    }
    Ok(Corner { p, t, n })
}

/// Finds a file named in an MTL or `mtllib` statement: the whole rest of the line first (names
/// may contain spaces), then each word (several files, or options before the name).
fn find_file(dir: &Path, rest: &[u8]) -> (Vec<PathBuf>, Vec<String>) {
    let whole = text(rest);
    let candidate = dir.join(&whole);
    if candidate.is_file() {
        return (vec![candidate], Vec::new());
    }
    let mut found = Vec::new();
    let mut missing = Vec::new();
    for w in tokens(rest) {
        let p = dir.join(text(w));
        if p.is_file() {
            found.push(p)
        } else {
            missing.push(text(w))
        }
    }
    (found, missing)
}

/// `Tf`, `d`/`Tr` and `illum` of an MTL entry; unparsable values count as absent.
fn mtl_transmission(m: &tobj::Material) -> super::Transmission {
    let floats = |key: &str| -> Option<Vec<f32>> {
        let v: Vec<f32> = m
            .unknown_param
            .get(key)?
            .split_whitespace()
            .map_while(|t| t.parse::<f32>().ok())
            .filter(|f| f.is_finite())
            .collect();
        (!v.is_empty()).then_some(v)
    };
    // `Tf` may be written as one grey value or as `Tf xyz …`/`Tf spectral …`, which have no
    // RGB and are ignored.
    let filter = floats("Tf").map(|v| match v.len() {
        1 | 2 => [v[0]; 3],
        _ => [v[0], v[1], v[2]],
    });
    let opacity = m
        .dissolve
        .filter(|d| d.is_finite())
        // `Tr 1` alone is how some exporters write "opaque" (the inverted convention), so a
        // fully transparent `Tr` without `d` is not believed.
        .or_else(|| {
            floats("Tr")
                .map(|t| t[0])
                .filter(|&t| t < 0.999)
                .map(|t| 1.0 - t)
        })
        .map(|d| d.clamp(0.0, 1.0));
    super::Transmission {
        filter: filter.map(|f| f.map(|c| c.clamp(0.0, 1.0))),
        opacity,
        illum: m.illumination_model,
        factor: None,
        blend: false,
    }
}

fn load_mtllib(
    path: &Path,
    line: usize,
    rest: &[u8],
    out: &mut Imported,
    ids: &mut HashMap<String, u32>,
    missing_textures: &mut Vec<(String, Warning)>,
) -> Result<(), CookError> {
    let dir = path.parent().unwrap_or(Path::new(""));
    let (mut found, missing) = find_file(dir, rest);
    if found.is_empty() {
        // Exporters often name a library that was never shipped (`untitled.mtl`) while the
        // real one sits beside the OBJ under the OBJ's own name.
        let beside = path.with_extension("mtl");
        let already = out.files.contains(&beside);
        if beside.is_file() && !already {
            out.warnings.push(Warning::new(
                path,
                Some(line),
                format!(
                    "material library {:?} not found; using {} beside the OBJ instead",
                    text(rest),
                    beside.display()
                ),
            ));
            found.push(beside);
        } else {
            out.warnings.push(Warning::new(
                path,
                Some(line),
                format!("material library {:?} not found; materials keep their names but get default shading", text(rest)),
            ));
            return Ok(());
        }
    }
    if !missing.is_empty() && found.len() > 1 {
        out.warnings.push(Warning::new(
            path,
            Some(line),
            format!("material libraries not found: {}", missing.join(", ")),
        ));
    }
    for mtl in found {
        out.files.push(mtl.clone());
        let (materials, _) = tobj::load_mtl(&mtl).map_err(|e| CookError::Source {
            path: mtl.clone(),
            line: None,
            message: format!("material library cannot be parsed: {e}"),
        })?;
        let mtl_dir = mtl.parent().unwrap_or(Path::new("")).to_path_buf();
        for m in materials {
            let mut texture = |name: &Option<String>, what: &str| -> Option<ImageRef> {
                let name = name.as_deref()?.trim();
                if name.is_empty() {
                    return None;
                }
                let (files, _) = find_file(&mtl_dir, name.as_bytes());
                match files.last() {
                    Some(f) => Some(ImageRef::File(f.clone())),
                    None => {
                        let w = Warning::new(
                            &mtl,
                            None,
                            format!(
                                "{what} {name:?} of material {:?} not found; ignored",
                                m.name
                            ),
                        );
                        missing_textures.push((m.name.clone(), w));
                        None
                    }
                }
            };
            let diffuse_texture = texture(&m.diffuse_texture, "diffuse texture");
            let normal_name = m
                .normal_texture
                .clone()
                .or_else(|| m.unknown_param.get("norm").cloned());
            let normal_texture = texture(&normal_name, "normal map");
            let sm = SourceMaterial {
                name: m.name.clone(),
                diffuse: m.diffuse.unwrap_or([0.8; 3]),
                specular: m.specular.unwrap_or([0.0; 3]),
                shininess: m.shininess.unwrap_or(1.0),
                emissive: m.emissive.unwrap_or([0.0; 3]),
                diffuse_texture,
                normal_texture,
                transmission: mtl_transmission(&m),
            };
            let finite = sm
                .diffuse
                .iter()
                .chain(&sm.specular)
                .chain(&sm.emissive)
                .all(|v| v.is_finite())
                && sm.shininess.is_finite();
            if !finite {
                return Err(CookError::Source {
                    path: mtl.clone(),
                    line: None,
                    message: format!("material {:?} has a non-finite colour or shininess", m.name),
                });
            }
            // A later definition of the same name wins, as in every OBJ reader.
            match ids.get(&m.name) {
                Some(&i) => out.materials[i as usize] = sm,
                None => {
                    ids.insert(m.name.clone(), out.materials.len() as u32);
                    out.materials.push(sm);
                }
            }
        }
    }
    // Parts created before this mtllib could not resolve their material.
    for part in &mut out.parts {
        if part.material.is_none() {
            part.material = part
                .names
                .material
                .as_ref()
                .and_then(|n| ids.get(n).copied());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn integers_parse_as_std_does(s in "[-+]?[0-9]{0,21}|[-+0-9a ]{0,4}", n in any::<i64>()) {
            prop_assert_eq!(parse_i64(s.as_bytes()), s.parse::<i64>().ok());
            let t = n.to_string();
            prop_assert_eq!(parse_i64(t.as_bytes()), Some(n));
        }
    }

    fn parse_str(s: &str) -> Result<Imported, CookError> {
        parse(Path::new("test.obj"), s.as_bytes())
    }

    #[test]
    fn names_and_relative_indices() {
        let m = parse_str(
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\no box\ng front\nusemtl red\nf -4 -3 -2 -1\n",
        )
        .unwrap();
        assert_eq!(m.triangle_count(), 2);
        assert_eq!(m.polygons, 1);
        assert_eq!(m.parts.len(), 1);
        let n = &m.parts[0].names;
        assert_eq!(
            (
                n.object.as_deref(),
                n.group.as_deref(),
                n.material.as_deref()
            ),
            (Some("box"), Some("front"), Some("red"))
        );
        assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings); // red is not defined
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse_str("v 0 0 0\nv 1 0 0\n\nf 1 2 3\n").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("test.obj:4: vertex index 3 is out of range"),
            "{e}"
        );
        let e = parse_str("v 0 0 0\nv nan 0 0\n").unwrap_err();
        assert!(e.to_string().starts_with("test.obj:2:"), "{e}");
        let e = parse_str("v 0 0 inf\n").unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
        let e = parse_str("v 0 0 0\nf 0 1 1\n").unwrap_err();
        assert!(
            e.to_string().starts_with("test.obj:2: vertex index 0"),
            "{e}"
        );
    }

    #[test]
    fn lines_points_and_short_faces_warn() {
        let m = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\np 3\nf 1 2\nf 1 2 3\n").unwrap();
        assert_eq!(m.triangle_count(), 1);
        assert_eq!(m.warnings.len(), 2, "{:?}", m.warnings);
    }
}
