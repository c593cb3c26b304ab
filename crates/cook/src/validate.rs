//! `cooker validate`: numbered findings with the values involved, and a table per material.
//!
//! A scene is checked at the source (tagging, degenerate and duplicate triangles as modelled)
//! and after mesh processing (windows, material agreement); a pack is checked as it is.

use std::collections::{HashMap, HashSet};

use pack::{MaterialClass, Semantic};
use serde_json::json;

use crate::manifest::Manifest;
use crate::{CookError, Settings, mesh, tag, windows};

/// One problem. `code` is stable (scripts match on it); `message` carries the values.
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    pub code: &'static str,
    pub message: String,
}

impl Finding {
    /// Whether its code is one of `allowed` (`cooker validate --allow`).
    pub fn is_allowed(&self, allowed: &[String]) -> bool {
        allowed.iter().any(|a| a == self.code)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct MaterialRow {
    pub name: String,
    pub class: MaterialClass,
    pub triangles: u64,
    pub area: f64,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
}

/// Every code a finding may carry, with what it means: `cooker validate --allow` takes these.
pub const FINDING_CODES: &[(&str, &str)] = &[
    (
        "untagged",
        "triangles tagged by heuristics: no rule of the scene matched them",
    ),
    ("ambiguous-name", "a name more than one rule matches"),
    ("unused-rule", "a rule that matches no triangle"),
    (
        "unused-material",
        "a material the model defines and no triangle uses",
    ),
    (
        "no-triangles",
        "a model file with no faces (points or lines only), or none of non-zero area",
    ),
    ("degenerate-triangles", "triangles of zero area"),
    (
        "duplicate-triangles",
        "triangles with the same three corners as another",
    ),
    (
        "window-entry-shadowed",
        "a window entry every window of which an earlier entry describes: never used",
    ),
    (
        "window-not-window-class",
        "a window entry whose glass is not tagged as a window",
    ),
    (
        "window-unknown-material",
        "a window entry naming no material of the model",
    ),
    (
        "window-unknown-name",
        "a window entry whose name matches no window the cook found",
    ),
    (
        "z-up",
        "a bare model that looks Z-up read Y-up: its floor stands on its edge",
    ),
    (
        "window-curved",
        "glass that bends too much for one projector",
    ),
    (
        "window-not-planar",
        "glass whose triangles do not lie in one plane",
    ),
    ("window-no-area", "glass with no area"),
    (
        "window-no-design",
        "a window with no design image and no texture to use",
    ),
    ("window-no-uvs", "glass without texture coordinates"),
    (
        "window-uv-range",
        "glass whose texture coordinates leave [0, 1]",
    ),
    (
        "no-light",
        "a scene with windows and no light, so no window throws any",
    ),
    (
        "unused-texture",
        "a texture of a pack that no material uses",
    ),
    (
        "material-mismatch",
        "a pack whose vertices and draw ranges disagree on materials",
    ),
];

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Validation {
    pub findings: Vec<Finding>,
    pub materials: Vec<MaterialRow>,
}

impl Validation {
    pub fn is_clean(&self) -> bool {
        self.findings.is_empty()
    }

    /// No findings but those with a code in `allowed`.
    pub fn is_clean_allowing(&self, allowed: &[String]) -> bool {
        self.findings.iter().all(|f| f.is_allowed(allowed))
    }

    fn add(&mut self, code: &'static str, message: impl Into<String>) {
        debug_assert!(
            FINDING_CODES.iter().any(|(c, _)| *c == code),
            "finding code {code:?} missing from FINDING_CODES"
        );
        self.findings.push(Finding {
            code,
            message: message.into(),
        });
    }

    /// `allowed`: codes that do not count as problems, marked as such.
    pub fn to_json(&self, allowed: &[String]) -> serde_json::Value {
        json!({
            "findings": self.findings.iter().map(|f| json!({
                "code": f.code,
                "message": f.message,
                "allowed": f.is_allowed(allowed),
            })).collect::<Vec<_>>(),
            "materials": self.materials.iter().map(|m| json!({
                "name": m.name,
                "class": m.class.name(),
                "triangles": m.triangles,
                "area": m.area,
                "bounds_min": m.bounds_min,
                "bounds_max": m.bounds_max,
            })).collect::<Vec<_>>(),
        })
    }

    /// Numbered findings (those with a code in `allowed` marked so), then the material table.
    pub fn to_text(&self, allowed: &[String]) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        if self.findings.is_empty() {
            s.push_str("no findings\n");
        }
        for (i, f) in self.findings.iter().enumerate() {
            let mark = if f.is_allowed(allowed) {
                " (allowed)"
            } else {
                ""
            };
            let _ = writeln!(s, "{:>3}. [{}]{mark} {}", i + 1, f.code, f.message);
        }
        let _ = writeln!(
            s,
            "\n{:<24} {:<13} {:>10} {:>12}  bounding box",
            "material", "class", "triangles", "area"
        );
        for m in &self.materials {
            let f = |v: [f32; 3]| format!("({:.3}, {:.3}, {:.3})", v[0], v[1], v[2]);
            let _ = writeln!(
                s,
                "{} {:<13} {:>10} {:>12.4}  {} .. {}",
                crate::padded(&m.name, 24),
                m.class.name(),
                m.triangles,
                m.area,
                f(m.bounds_min),
                f(m.bounds_max)
            );
        }
        s
    }
}

/// Geometry as the checks see it, decoded from processed meshes or from a pack.
pub struct MeshView {
    pub name: String,
    pub positions: Vec<[f32; 3]>,
    pub uvs: Vec<[f32; 2]>,
    pub materials: Vec<u16>,
    pub indices: Vec<u32>,
    pub ranges: Vec<pack::DrawRange>,
}

fn tri_key(p: [[f32; 3]; 3]) -> [[u32; 3]; 3] {
    let mut k = p.map(|v| v.map(|c| (c + 0.0).to_bits()));
    k.sort_unstable();
    k
}

/// Counts degenerate and duplicate triangles (same three positions, in any order).
fn degenerate_and_duplicates(tris: impl Iterator<Item = [[f32; 3]; 3]>) -> (usize, usize) {
    let mut seen = HashSet::new();
    let (mut degenerate, mut duplicate) = (0, 0);
    for t in tris {
        if mesh::is_degenerate(t[0], t[1], t[2]) {
            degenerate += 1;
        } else if !seen.insert(tri_key(t)) {
            duplicate += 1;
        }
    }
    (degenerate, duplicate)
}

/// Checks a scene: imports and tags it, processes the geometry, and checks the result. `up`:
/// a bare model's up axis (`--up`, [`crate::Settings::up`]).
pub fn validate_scene(manifest: &Manifest, up: crate::UpAxis) -> Result<Validation, CookError> {
    let settings = Settings {
        up,
        ..Settings::new(manifest)
    };
    validate_scene_with(manifest, &settings)
}

/// [`validate_scene`] with the settings the import reads (`up`, `text_encoding`).
pub fn validate_scene_with(
    manifest: &Manifest,
    settings: &Settings,
) -> Result<Validation, CookError> {
    let mut v = Validation::default();
    let mut report = crate::Report::default();
    let prepared = crate::prepare(manifest, settings, &mut report)?;
    // The images the manifest names decode as the cook decodes them: a panorama or a normal
    // map that could not be read validated clean, and the cook then failed.
    {
        use rayon::prelude::*;
        manifest
            .named_files
            .par_iter()
            .filter(|n| n.is_image())
            .try_for_each(|n| {
                crate::textures::decode(&crate::import::ImageRef::File(n.path.clone())).map(drop)
            })
            .map_err(|e| manifest.at_its_line(e))?;
    }
    // A bare model's cook says so in its notes; `validate` is where a user looks first, and
    // a Z-up cathedral read Y-up validated clean while its floor caught no sun.
    if crate::pipeline::needs_guess(manifest) && crate::guess::guess(&prepared).looks_z_up {
        v.add("z-up", crate::guess::Z_UP_NOTE.to_string());
    }
    let crate::Prepared {
        imported: sources,
        tagging,
        tri_material,
        windows: found,
        shift,
        ..
    } = prepared;
    let framed = manifest.shifted(shift);
    let manifest = &*framed;

    // Tagging.
    let untagged = crate::pipeline::heuristic_notes(&sources, &tagging, &tri_material);
    let untagged_tris: usize = untagged.iter().map(|n| n.triangles).sum();
    let untagged_names: Vec<String> = crate::report::group_heuristics(&untagged)
        .iter()
        .map(|g| {
            let n = g[0];
            format!(
                "{} ({} → {})",
                crate::report::group_names(g),
                n.reason,
                n.classes()
            )
        })
        .collect();
    if untagged_tris > 0 {
        v.add(
            "untagged",
            format!(
                "{untagged_tris} triangles in {} source name sets matched no rule: {}",
                untagged.len(),
                untagged_names
                    .iter()
                    .take(8)
                    .cloned()
                    .collect::<Vec<_>>()
                    .join("; ")
                    + if untagged_names.len() > 8 {
                        "; …"
                    } else {
                        ""
                    }
            ),
        );
    }
    for a in &tagging.ambiguities {
        v.add(
            "ambiguous-name",
            format!(
                "{} name {:?} is matched by {} rules (manifest lines {}); the first wins",
                a.kind.name(),
                a.name,
                a.rule_lines.len(),
                a.rule_lines
                    .iter()
                    .map(|l| l.to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        );
    }
    let used_rules: HashSet<usize> = tagging
        .decisions
        .iter()
        .flatten()
        .filter_map(|d| match d {
            tag::Decision::Rule(r) => Some(*r),
            _ => None,
        })
        .collect();
    for (i, r) in manifest.rules.iter().enumerate() {
        if !used_rules.contains(&i) {
            v.add(
                "unused-rule",
                format!(
                    "rule {:?} at manifest line {} matches no triangle",
                    r.pattern, r.line.0
                ),
            );
        }
    }
    for (si, name) in &tagging.unused_source_materials {
        v.add(
            "unused-material",
            format!(
                "material {name:?} of {} is defined but no triangle uses it",
                sources[*si].path.display()
            ),
        );
    }

    // Degenerate and duplicate triangles as modelled (mesh processing drops degenerate ones).
    for src in &sources {
        if src.triangle_count() == 0 {
            v.add(
                "no-triangles",
                format!(
                    "{}: no faces (points or lines only): nothing of it is cooked",
                    src.path.display()
                ),
            );
        }
        let tris = src
            .corners
            .positions()
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]].map(|p| src.positions[p as usize]));
        let (degenerate, duplicate) = degenerate_and_duplicates(tris);
        if degenerate > 0 && degenerate == src.triangle_count() {
            v.add(
                "no-triangles",
                format!(
                    "{}: every face has zero area (as placed): nothing of it is cooked",
                    src.path.display()
                ),
            );
        }
        if degenerate > 0 {
            v.add(
                "degenerate-triangles",
                format!(
                    "{}: {degenerate} of {} triangles have zero area (dropped when cooking)",
                    src.path.display(),
                    src.triangle_count()
                ),
            );
        }
        if duplicate > 0 {
            v.add(
                "duplicate-triangles",
                format!(
                    "{}: {duplicate} triangles repeat the positions of an earlier triangle",
                    src.path.display()
                ),
            );
        }
    }

    // Window designs named in the manifest.
    let materials: Vec<pack::Material> = tagging
        .materials
        .iter()
        .map(|m| m.material.clone())
        .collect();
    let entry_matches = |w: &crate::manifest::WindowDesign, k: usize| {
        let (i, m) = (&found.instances[k], found.material[k] as usize);
        let plan = tagging.materials[m].window.as_deref();
        let mats = plan.map(|p| p.materials.clone()).unwrap_or_default();
        // And the names the cook matches entries with: the glass's tagged materials (a rule's
        // `material` renames them), before the window took a material of its own.
        let tagged = i
            .materials
            .iter()
            .filter_map(|&(id, ..)| tagging.materials.get(id as usize))
            .map(|t| t.material.name.as_str());
        w.matches(
            &i.name,
            mats.iter()
                .map(String::as_str)
                .chain([materials[m].name.as_str()])
                .chain(tagged),
        )
    };
    // Per window, the entry that describes it: the first that matches.
    let first_entry: Vec<Option<usize>> = (0..found.instances.len())
        .map(|k| manifest.windows.iter().position(|w| entry_matches(w, k)))
        .collect();
    for (wi, w) in manifest.windows.iter().enumerate() {
        let matched: Vec<usize> = (0..found.instances.len())
            .filter(|&k| entry_matches(w, k))
            .collect();
        if let Some(&k) = matched.first() {
            // Every window it matches taken by an earlier entry: never used, as the cook
            // warns (validate said nothing).
            if matched.iter().all(|&k| first_entry[k] != Some(wi))
                && let Some(earlier) = first_entry[k]
            {
                v.add(
                    "window-entry-shadowed",
                    format!(
                        "[[window]] at manifest line {} names {}, but every window it matches \
                         takes the earlier [[window]] at line {} (the first that matches wins)",
                        w.line.0,
                        w.describe(),
                        manifest.windows[earlier].line.0
                    ),
                );
            }
            continue;
        }
        match materials
            .iter()
            .find(|m| w.matches(&m.name, std::iter::once(m.name.as_str())))
        {
            Some(m) if !m.class.is_window() => v.add(
                "window-not-window-class",
                format!(
                    "[[window]] at manifest line {} names {}, tagged {}",
                    w.line.0,
                    w.describe(),
                    m.class
                ),
            ),
            // By its name the entry picks out a window the cook finds, not a material: a
            // typo there is not the same finding (`--allow` one and not the other).
            _ if w.material.is_none() => v.add(
                "window-unknown-name",
                format!(
                    "[[window]] at manifest line {} names {}, which matches no window",
                    w.line.0,
                    w.describe()
                ),
            ),
            _ => v.add(
                "window-unknown-material",
                format!(
                    "[[window]] at manifest line {} names {}, which matches no window",
                    w.line.0,
                    w.describe()
                ),
            ),
        }
    }
    // Materials of curved glass: said here, with what the cook does about it, so not again
    // as not planar below.
    let mut curved: Vec<usize> = Vec::new();
    for (k, i) in found
        .instances
        .iter()
        .enumerate()
        .filter(|(_, i)| !i.planar)
    {
        curved.push(found.material[k] as usize);
        v.add(
            "window-curved",
            format!(
                "window {:?} is curved: a vertex lies {:.4} from its plane ({:.1}% of its size, \
                 more than {}%), and it is not made of a few planes to split it into",
                i.name,
                i.max_deviation,
                i.max_deviation / i.width().hypot(i.height()).max(1e-12) * 100.0,
                crate::instances::PLANAR_TOLERANCE * 100.0
            ),
        );
    }

    // Processed geometry, with every attribute the source has: validation looks at UVs and
    // normals even where no material would sample them.
    let needs: Vec<mesh::MaterialNeeds> = crate::material_needs(&tagging)
        .into_iter()
        .map(|n| mesh::MaterialNeeds {
            uvs: true,
            normals: true,
            ..n
        })
        .collect();
    let settings = mesh::MeshSettings::default();
    let mut processed: Vec<mesh::Processed> = sources
        .iter()
        .zip(&tri_material)
        .map(|(src, tm)| mesh::process(src, tm, &needs, &settings))
        .collect();
    // Materials whose triangles all went to per-window materials are gone, as in the cook;
    // materials without triangles for other reasons stay, so they are reported below.
    let mut tagging = tagging;
    crate::prune::drop_replaced(&found.replaced, &mut tagging, &mut processed);
    let materials: Vec<pack::Material> = tagging
        .materials
        .iter()
        .map(|m| m.material.clone())
        .collect();
    let views: Vec<MeshView> = processed
        .into_iter()
        .zip(&manifest.meshes)
        .map(|(p, m)| MeshView {
            name: m.name.clone(),
            uvs: p.vertices.iter().map(|v| v.uv).collect(),
            positions: p.vertices.positions,
            materials: p.vertices.materials,
            indices: p.indices,
            ranges: p.ranges,
        })
        .collect();
    let has_design: Vec<bool> = tagging
        .materials
        .iter()
        .map(|m| m.window.is_some())
        .collect();
    // A bare model gets a guessed sun; a manifest without [light] cooks every window dark.
    let windows = has_design.iter().filter(|&&d| d).count();
    if manifest.light.is_none() && !crate::pipeline::needs_guess(manifest) && windows > 0 {
        v.add("no-light", no_light(windows));
    }
    check_geometry(
        &views,
        &materials,
        &has_design,
        manifest.light.as_ref().map(|l| &l.kind),
        false,
        &curved,
        &mut v,
    );
    Ok(v)
}

fn no_light(windows: usize) -> String {
    format!(
        "the scene has no light, so its {windows} window{} throw{} none onto the floor and no \
         god rays (a [light] section gives one)",
        if windows == 1 { "" } else { "s" },
        if windows == 1 { "s" } else { "" }
    )
}

/// Checks a cooked pack.
pub fn validate_pack(pack: &pack::Pack) -> Validation {
    let mut v = Validation::default();
    let toc = pack.toc();
    let views: Vec<MeshView> = toc.meshes.iter().map(|m| decode(pack, m)).collect();
    let has_design: Vec<bool> = toc
        .materials
        .iter()
        .map(|m| m.projector_texture.is_some() || m.diffuse_texture.is_some())
        .collect();
    let windows = toc.materials.iter().filter(|m| m.class.is_window()).count();
    if toc.light.is_none() && windows > 0 {
        v.add("no-light", no_light(windows));
    }
    check_geometry(
        &views,
        &toc.materials,
        &has_design,
        toc.light.as_ref().map(|l| &l.kind),
        true,
        &[],
        &mut v,
    );
    let mut used = vec![false; toc.textures.len()];
    for m in &toc.materials {
        for t in [m.diffuse_texture, m.normal_texture, m.projector_texture]
            .into_iter()
            .flatten()
        {
            used[t as usize] = true;
        }
    }
    if let Some(t) = toc.background.panorama {
        used[t as usize] = true;
    }
    for (t, u) in toc.textures.iter().zip(used) {
        if !u {
            v.add(
                "unused-texture",
                format!(
                    "texture {:?} ({}, {}x{}) is referenced by nothing",
                    t.name, t.role, t.width, t.height
                ),
            );
        }
    }
    v
}

fn decode(pack: &pack::Pack, m: &pack::Mesh) -> MeshView {
    let l = &m.layout;
    let bytes = pack.vertex_bytes(m);
    let vertices = bytes
        .chunks_exact(l.stride as usize)
        .take(m.vertex_count as usize);
    let (mut positions, mut uvs, mut materials) = (Vec::new(), Vec::new(), Vec::new());
    for b in vertices {
        positions.push(l.position(b).unwrap_or([0.0; 3]));
        let [u, v, ..] = l.read(b, Semantic::TexCoord).unwrap_or([0.0; 4]);
        uvs.push([u, v]);
        materials.push(l.material_id(b).unwrap_or(u16::MAX));
    }
    MeshView {
        name: m.name.clone(),
        positions,
        uvs,
        materials,
        indices: pack.indices(m).into_owned(),
        ranges: m.ranges.clone(),
    }
}

/// Checks shared by scenes and packs: material agreement, windows, the material table (and, for
/// packs, degenerate and duplicate triangles, which a scene reports at the source). `curved`:
/// the materials whose glass a scene's check already said is curved.
pub fn check_geometry(
    views: &[MeshView],
    materials: &[pack::Material],
    has_design: &[bool],
    light: Option<&pack::LightKind>,
    check_triangles: bool,
    curved: &[usize],
    v: &mut Validation,
) {
    let mut rows: Vec<MaterialRow> = materials
        .iter()
        .map(|m| MaterialRow {
            name: m.name.clone(),
            class: m.class,
            triangles: 0,
            area: 0.0,
            bounds_min: [f32::INFINITY; 3],
            bounds_max: [f32::NEG_INFINITY; 3],
        })
        .collect();
    let mut window_geo: HashMap<u16, windows::WindowGeometry> = HashMap::new();
    for view in views {
        let mut mismatched = 0usize;
        let mut example = None;
        for r in &view.ranges {
            let span =
                &view.indices[r.first_index as usize..(r.first_index + r.index_count) as usize];
            let row = &mut rows[r.material as usize];
            let is_window = materials[r.material as usize].class.is_window();
            let mut local = HashMap::new();
            for t in span.chunks_exact(3) {
                let t = [t[0], t[1], t[2]];
                if t.iter().any(|&i| view.materials[i as usize] != r.material) {
                    mismatched += 1;
                    example.get_or_insert((r.material, t.map(|i| view.materials[i as usize])));
                }
                let p = t.map(|i| view.positions[i as usize]);
                let g = glam::Vec3::from(p[1]) - glam::Vec3::from(p[0]);
                let h = glam::Vec3::from(p[2]) - glam::Vec3::from(p[0]);
                row.triangles += 1;
                row.area += 0.5 * g.cross(h).length() as f64;
                for q in p {
                    for (k, c) in q.into_iter().enumerate() {
                        row.bounds_min[k] = row.bounds_min[k].min(c);
                        row.bounds_max[k] = row.bounds_max[k].max(c);
                    }
                }
                if is_window {
                    let wg = window_geo.entry(r.material).or_default();
                    let tri = t.map(|i| {
                        *local.entry(i).or_insert_with(|| {
                            wg.positions.push(view.positions[i as usize]);
                            wg.uvs.push(view.uvs[i as usize]);
                            wg.positions.len() as u32 - 1
                        })
                    });
                    wg.triangles.push(tri);
                }
            }
        }
        if let Some((want, got)) = example {
            v.add(
                "material-mismatch",
                format!("mesh {:?}: {mismatched} triangles have vertices whose material IDs disagree with their draw range (e.g. range material {want}, vertices {got:?})", view.name),
            );
        }
        if check_triangles {
            let tris = view
                .indices
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]].map(|i| view.positions[i as usize]));
            let (degenerate, duplicate) = degenerate_and_duplicates(tris);
            if degenerate > 0 {
                v.add(
                    "degenerate-triangles",
                    format!(
                        "mesh {:?}: {degenerate} triangles have zero area",
                        view.name
                    ),
                );
            }
            if duplicate > 0 {
                v.add("duplicate-triangles", format!("mesh {:?}: {duplicate} triangles repeat the positions of an earlier triangle", view.name));
            }
        }
    }
    for (mi, m) in materials.iter().enumerate() {
        if rows[mi].triangles == 0 {
            v.add(
                "unused-material",
                format!("material {:?} ({}) has no triangles", m.name, m.class),
            );
            rows[mi].bounds_min = [0.0; 3];
            rows[mi].bounds_max = [0.0; 3];
            continue;
        }
        if !m.class.is_window() {
            continue;
        }
        if !has_design[mi] {
            v.add(
                "window-no-design",
                format!(
                    "window material {:?} ({}) has no design image",
                    m.name, m.class
                ),
            );
        }
        let Some(g) = window_geo.get(&(mi as u16)) else {
            continue;
        };
        match windows::analyze(mi as u16, g, light, None) {
            None => v.add(
                "window-no-area",
                format!("window material {:?} has no area", m.name),
            ),
            Some(a) => {
                if a.max_plane_distance > a.plane_tolerance && !curved.contains(&mi) {
                    v.add(
                        "window-not-planar",
                        format!(
                            "window material {:?}: a vertex lies {:.6} from the window's plane, tolerance {:.6}",
                            m.name, a.max_plane_distance, a.plane_tolerance
                        ),
                    );
                }
                if !a.has_uvs {
                    v.add("window-no-uvs", format!("window material {:?} has no texture coordinates: its design cannot be placed", m.name));
                } else if a
                    .uv_min
                    .iter()
                    .chain(&a.uv_max)
                    .any(|&c| !(-1e-4..=1.0 + 1e-4).contains(&c))
                {
                    v.add(
                        "window-uv-range",
                        format!(
                            "window material {:?}: texture coordinates span [{:.4}, {:.4}] x [{:.4}, {:.4}], outside [0, 1]",
                            m.name, a.uv_min[0], a.uv_max[0], a.uv_min[1], a.uv_max[1]
                        ),
                    );
                }
            }
        }
    }
    v.materials = rows;
}

#[cfg(test)]
mod tests {
    use super::FINDING_CODES;

    /// `cooker validate --allow` offers FINDING_CODES: every code this file adds is listed,
    /// and every listed code is one it adds.
    #[test]
    fn finding_codes_are_the_codes_added() {
        let source = include_str!("validate.rs");
        let code = &source[..source.rfind("#[cfg(test)]").unwrap()];
        let mut added: Vec<&str> = code
            .split(".add(")
            .skip(1)
            .filter_map(|rest| {
                let rest = rest.trim_start().strip_prefix('"')?;
                rest.split('"').next()
            })
            .collect();
        added.sort_unstable();
        added.dedup();
        let mut listed: Vec<&str> = FINDING_CODES.iter().map(|(c, _)| *c).collect();
        listed.sort_unstable();
        assert_eq!(added, listed);
    }
}
