//! Cooks scene sources (OBJ, glTF, window images) into a pack.
//!
//! [`cook`] is the whole pipeline, top to bottom: import → tag → mesh → windows → textures →
//! TOC. Each stage is a plain function over plain data, so `cooker validate` can run the
//! first stages and inspect what they produced.

pub mod budget;
pub mod cache;
pub mod design;
pub mod guess;
pub mod import;
pub mod instances;
pub mod manifest;
pub mod mesh;
pub mod tag;
#[doc(hidden)]
pub mod testing;
mod textures;
pub mod triangulate;
pub mod validate;
pub mod window_plan;
pub mod windows;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rayon::prelude::*;

pub use import::Warning;
pub use manifest::Manifest;
pub use mesh::{CacheMode, MeshSettings, MeshStats};

/// An error while cooking, naming the file (and line where there is one). Wrapped errors are
/// the `source`, not repeated in the message.
#[derive(Debug, thiserror::Error)]
pub enum CookError {
    #[error("{}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Pack(#[from] pack::PackError),
    /// An image could not be read or cooked; the message names the file.
    #[error(transparent)]
    Texture(#[from] texture::TextureError),
    /// The manifest is malformed: syntax, unknown key, wrong type, bad value, missing file.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Manifest {
        path: PathBuf,
        line: Option<usize>,
        message: String,
    },
    /// `--window NAME=…` names no window of the scene.
    #[error("--window {pattern:?} matches no window; the scene's windows are: {}", if known.is_empty() { "(none)".to_string() } else { known.join(", ") })]
    UnknownWindow { pattern: String, known: Vec<String> },
    /// A source file (mesh, material library, image) is malformed.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Source {
        path: PathBuf,
        line: Option<usize>,
        message: String,
    },
}

impl CookError {
    /// True when the operating system failed (permission, disk full, missing directory), as
    /// opposed to invalid input.
    pub fn is_io(&self) -> bool {
        match self {
            CookError::Io { .. } => true,
            CookError::Pack(p) => p.is_io(),
            CookError::Texture(t) => t.is_io(),
            CookError::Manifest { .. }
            | CookError::Source { .. }
            | CookError::UnknownWindow { .. } => false,
        }
    }

    /// The file the error is about.
    pub fn path(&self) -> Option<&Path> {
        match self {
            CookError::Io { path, .. }
            | CookError::Manifest { path, .. }
            | CookError::Source { path, .. } => Some(path),
            CookError::Texture(t) => t.path(),
            CookError::Pack(_) | CookError::UnknownWindow { .. } => None,
        }
    }
}

/// How to cook.
#[derive(Clone, Debug)]
pub struct Settings {
    pub mesh: MeshSettings,
    /// Quantize vertices (positions to `position_bits`, octahedral normals, 16-bit UVs).
    pub quantize: bool,
    pub position_bits: mesh::PositionBits,
    /// Cook textures; off for geometry-only checks such as `cooker validate`.
    pub textures: bool,
    /// Reuse cooked textures from this cache, and store new ones in it.
    pub cache: Option<cache::Cache>,
    /// `--window NAME=IMAGE` designs, taking precedence over the manifest's `[[window]]`s.
    pub window_overrides: Vec<manifest::WindowDesign>,
    /// `--texture-format`: stores every texture so, over the manifest's `[textures] format`
    /// and every window's `texture_format`.
    pub texture_format: Option<manifest::TextureFormatChoice>,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            mesh: MeshSettings::default(),
            quantize: false,
            position_bits: mesh::PositionBits::B16,
            textures: true,
            cache: None,
            window_overrides: Vec::new(),
            texture_format: None,
        }
    }
}

/// Numbers about one cooked mesh.
#[derive(Clone, Debug)]
pub struct MeshReport {
    pub name: String,
    pub source: PathBuf,
    pub import_time: Duration,
    /// n-gons split into triangles by the importer.
    pub polygons: usize,
    pub stats: MeshStats,
    pub vertex_bytes: usize,
    pub index_bytes: usize,
    pub quantization: Option<QuantizationError>,
    /// Vertex attributes left out because no material of the mesh uses them.
    pub dropped_attributes: Vec<&'static str>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuantizationError {
    pub position: f32,
    pub normal_deg: f32,
    pub uv: f32,
}

/// A tagging decision made by heuristics rather than a rule.
#[derive(Clone, Debug, PartialEq)]
pub struct HeuristicNote {
    pub source: PathBuf,
    pub names: String,
    pub material: String,
    pub class: pack::MaterialClass,
    /// The name keyword that decided, if a name did.
    pub keyword: Option<&'static str>,
    /// Why: the keyword, the material property or the geometry that decided, or that nothing
    /// matched.
    pub reason: String,
    pub triangles: usize,
}

/// What happened while cooking, for the CLI.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Every file the cook read (sorted, without duplicates): what a cache entry depends on.
    pub inputs: Vec<PathBuf>,
    /// Per cooked artifact (texture), whether it was cooked or reused from the cache.
    pub artifacts: Vec<(String, ArtifactSource)>,
    pub warnings: Vec<Warning>,
    pub meshes: Vec<MeshReport>,
    pub heuristics: Vec<HeuristicNote>,
    /// What the scene defines but nothing uses, so it was not cooked: one line each.
    pub skipped: Vec<String>,
    pub stages: Vec<(&'static str, Duration)>,
}

/// Where a cooked artifact came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ArtifactSource {
    Cooked,
    Reused,
    /// The cache entry was damaged; it was cooked again.
    Recooked(String),
}

/// A cooked scene: write it with [`CookOutput::write`] (atomically).
#[derive(Clone, Debug)]
pub struct CookOutput {
    pub toc: pack::Toc,
    pub data: pack::PackData,
    pub report: Report,
}

impl CookOutput {
    pub fn write(&self, path: &Path) -> Result<(), CookError> {
        Ok(pack::write_pack(path, self.toc.clone(), &self.data)?)
    }
}

/// Imports every mesh source in parallel and applies its manifest transform.
pub fn import_sources(manifest: &Manifest) -> Result<Vec<(import::Imported, Duration)>, CookError> {
    let results: Vec<Result<(import::Imported, Duration), CookError>> = manifest
        .meshes
        .par_iter()
        .map(|m| {
            let start = Instant::now();
            let mut imported = import::import(&m.source)?;
            imported.transform(m.transform());
            Ok((imported, start.elapsed()))
        })
        .collect();
    // The first error in manifest order, so the message does not depend on thread timing.
    results.into_iter().collect()
}

/// Which materials are windows and which vertex attributes each needs. A window with a
/// `[[window]]` design always gets a normal map (given, or derived from the design in the
/// texture stage), so it needs tangents even though no source material names one. Texture
/// coordinates matter only to textured materials, normals to everything but the unlit
/// backdrop.
pub fn material_needs(tagging: &tag::Tagging) -> Vec<mesh::MaterialNeeds> {
    tagging
        .materials
        .iter()
        .map(|m| {
            let window = m.material.class.is_window();
            let designed = window && m.window.is_some();
            let tangents = m.normal_texture.is_some() || designed;
            mesh::MaterialNeeds {
                window,
                tangents,
                uvs: tangents || m.diffuse_texture.is_some(),
                normals: tangents || m.material.class != pack::MaterialClass::Background,
            }
        })
        .collect()
}

/// The front of the pipeline, shared with `cooker validate`: import, tag, then the window
/// stage (instances, per-window materials, planar UVs, designs).
pub struct Prepared {
    pub imported: Vec<import::Imported>,
    pub import_times: Vec<Duration>,
    pub tagging: tag::Tagging,
    /// Per source, per triangle: the pack material.
    pub tri_material: Vec<Vec<u16>>,
    pub windows: window_plan::Windows,
}

/// Runs import → tag → windows; see [`Prepared`].
pub fn prepare(
    manifest: &Manifest,
    settings: &Settings,
    report: &mut Report,
) -> Result<Prepared, CookError> {
    let start = Instant::now();
    let sources = import_sources(manifest)?;
    let (mut imported, import_times): (Vec<import::Imported>, Vec<Duration>) =
        sources.into_iter().unzip();
    let tagged = Instant::now();
    report.stages.push(("import", tagged - start));
    let mut tagging = tag::tag(manifest, &imported)?;
    let mut tri_material: Vec<Vec<u16>> = imported
        .iter()
        .zip(&tagging.part_material)
        .map(|(src, parts)| tri_materials(src, parts))
        .collect();
    let found = Instant::now();
    report.stages.push(("tag", found - tagged));
    let windows = window_plan::plan(
        manifest,
        &settings.window_overrides,
        &mut imported,
        &mut tagging,
        &mut tri_material,
        report,
    )?;
    report.stages.push(("windows", found.elapsed()));
    Ok(Prepared {
        imported,
        import_times,
        tagging,
        tri_material,
        windows,
    })
}

fn tri_materials(src: &import::Imported, part_material: &[u16]) -> Vec<u16> {
    src.tri_part
        .iter()
        .map(|&p| part_material[p as usize])
        .collect()
}

/// Gathers each window material's triangles from the processed meshes.
pub fn window_geometry(
    tagging: &tag::Tagging,
    processed: &[mesh::Processed],
) -> Vec<(u16, windows::WindowGeometry)> {
    let mut out = Vec::new();
    for (mi, m) in tagging.materials.iter().enumerate() {
        if !m.material.class.is_window() {
            continue;
        }
        let mut g = windows::WindowGeometry::default();
        for p in processed {
            for r in p.ranges.iter().filter(|r| r.material as usize == mi) {
                let span =
                    &p.indices[r.first_index as usize..(r.first_index + r.index_count) as usize];
                let mut local = std::collections::HashMap::new();
                for t in span.chunks_exact(3) {
                    let tri = [t[0], t[1], t[2]].map(|i| {
                        *local.entry(i).or_insert_with(|| {
                            let v = &p.vertices[i as usize];
                            g.positions.push(v.position);
                            g.uvs.push(v.uv);
                            g.positions.len() as u32 - 1
                        })
                    });
                    g.triangles.push(tri);
                }
            }
        }
        out.push((mi as u16, g));
    }
    out
}

/// The whole pipeline: sources in, a pack's TOC and data out.
pub fn cook(manifest: &Manifest, settings: &Settings) -> Result<CookOutput, CookError> {
    let mut report = Report::default();

    // 1–3. Import every source into a triangle soup (errors name file and line); tag source
    // names to pack materials with a class; find the windows in the geometry.
    let prepared = prepare(manifest, settings, &mut report)?;
    // A bare model says nothing of light or cameras: use the guesses `cooker init` writes.
    let guessed;
    let manifest = if manifest.bare && manifest.light.is_none() {
        let g = guess::guess(&prepared);
        let mut m = manifest.clone();
        m.light = g.light;
        if m.cameras.is_empty() {
            m.cameras = g.cameras;
        }
        report.warnings.push(Warning::new(
            &manifest.path,
            None,
            format!(
                "cooking a bare mesh without a scene.toml: materials are tagged by heuristics \
                 (material transparency, names, geometry), and the light and cameras are \
                 guessed ({}); `cooker init` writes these guesses into a scene.toml to edit",
                g.notes.join("; ")
            ),
        ));
        guessed = m;
        &guessed
    } else {
        manifest
    };
    let Prepared {
        imported,
        import_times,
        mut tagging,
        tri_material,
        windows: found,
    } = prepared;
    report.inputs.push(manifest.path.clone());
    for s in imported.iter() {
        report.warnings.extend(s.warnings.iter().cloned());
        report.inputs.push(s.path.clone());
        report.inputs.extend(s.files.iter().cloned());
    }
    note_heuristics(&imported, &tagging, &mut report);
    let mut clock = Instant::now();
    let mut lap = |report: &mut Report, name: &'static str| {
        let now = Instant::now();
        report.stages.push((name, now - clock));
        clock = now;
    };

    // 4. Mesh processing, one source per task.
    let needs = material_needs(&tagging);
    let mut processed: Vec<mesh::Processed> = imported
        .par_iter()
        .zip(&tri_material)
        .map(|(src, tm)| mesh::process(src, tm, &needs, &settings.mesh))
        .collect();
    // Materials left without triangles (empty groups, only degenerate faces) are not cooked,
    // and neither are their textures.
    prune_materials(
        manifest,
        &found.replaced,
        &mut tagging,
        &mut processed,
        &mut report,
    );
    skip_unused_source_materials(&imported, &tagging, &mut report);
    let needs = material_needs(&tagging);
    lap(&mut report, "mesh");

    // 5. Windows: frames from the geometry, facing the side the window stage chose.
    let light = manifest.light.as_ref().map(|l| &l.kind);
    let mut window_frames = Vec::new();
    for (mi, g) in window_geometry(&tagging, &processed) {
        let name = &tagging.materials[mi as usize].material.name;
        let inside = window_plan::inside_of(&tagging, mi);
        match windows::analyze(mi, &g, light, inside) {
            Some(a) => window_frames.push(a.frame),
            None if g.triangles.is_empty() => {}
            None => report.warnings.push(Warning::new(
                &manifest.path,
                None,
                format!("window material {name:?} has no area; no projector frame"),
            )),
        }
    }
    // A projector is cooked only for windows whose light can land on a receiving surface.
    let mut lit_windows = vec![false; tagging.materials.len()];
    for f in &window_frames {
        let name = &tagging.materials[f.material as usize].material.name;
        let reaches = light.is_some_and(|l| {
            windows::light_reaches(f, l, receiving_triangles(&tagging, &processed))
        });
        lit_windows[f.material as usize] = reaches;
        let designed = tagging.materials[f.material as usize].window.is_some();
        if designed && !reaches {
            report.skipped.push(format!(
                "window {name:?}: {}, so no projector texture was cooked",
                if light.is_some() {
                    "its light reaches no floor, wall or other receiving surface"
                } else {
                    "the scene has no light"
                }
            ));
        }
    }
    lap(&mut report, "windows");

    // 6. Textures: material maps, window designs, normal maps and projectors, background.
    let floor_y = processed_floor(&tagging, &processed);
    let (textures, texture_data, panorama) = textures::cook_textures(
        manifest,
        &mut tagging,
        &window_frames,
        &lit_windows,
        floor_y,
        settings,
        &mut report,
    )?;
    report.inputs.sort();
    report.inputs.dedup();
    lap(&mut report, "textures");

    // 7. Assemble the TOC and bulk data.
    let mut toc = pack::Toc {
        materials: tagging
            .materials
            .iter()
            .map(|m| m.material.clone())
            .collect(),
        textures,
        windows: window_frames,
        light: manifest.light.as_ref().map(|l| pack::Light {
            kind: l.kind.clone(),
            colour: l.colour,
            intensity: l.intensity,
        }),
        cameras: manifest.cameras.clone(),
        background: pack::Background {
            colour: manifest.background.colour,
            panorama,
        },
        meshes: Vec::new(),
    };
    let mut data = pack::PackData {
        meshes: Vec::new(),
        textures: texture_data,
    };
    for ((p, (src, import_time)), m) in processed
        .into_iter()
        .zip(imported.iter().zip(import_times))
        .zip(&manifest.meshes)
    {
        let mut mesh_report = MeshReport {
            name: m.name.clone(),
            source: m.source.clone(),
            import_time,
            polygons: src.polygons,
            stats: p.stats.clone(),
            vertex_bytes: 0,
            index_bytes: 0,
            quantization: None,
            dropped_attributes: Vec::new(),
        };
        if p.indices.is_empty() {
            report.warnings.push(Warning::new(
                &m.source,
                None,
                "no triangles left to cook; mesh skipped",
            ));
            report.meshes.push(mesh_report);
            continue;
        }
        let attrs = mesh::Attributes::for_materials(&needs, p.ranges.iter().map(|r| r.material));
        mesh_report.dropped_attributes = attrs.dropped();
        let e = mesh::encode(
            &p.vertices,
            p.bounds_min,
            p.bounds_max,
            attrs,
            settings.quantize.then_some(settings.position_bits),
        );
        if settings.quantize {
            mesh_report.quantization = Some(QuantizationError {
                position: e.max_position_error,
                normal_deg: e.max_normal_error_deg,
                uv: e.max_uv_error,
            });
        }
        let (layout, vertices) = (e.layout, e.bytes);
        let (index_format, indices) = if p.vertices.len() <= u16::MAX as usize + 1 {
            let v: Vec<u16> = p.indices.iter().map(|&i| i as u16).collect();
            (pack::IndexFormat::U16, bytemuck::cast_slice(&v).to_vec())
        } else {
            (
                pack::IndexFormat::U32,
                bytemuck::cast_slice(&p.indices).to_vec(),
            )
        };
        mesh_report.vertex_bytes = vertices.len();
        mesh_report.index_bytes = indices.len();
        toc.meshes.push(pack::Mesh {
            name: m.name.clone(),
            layout,
            vertex_count: p.vertices.len() as u32,
            index_count: p.indices.len() as u32,
            index_format,
            vertex_section: 0,
            index_section: 0,
            bounds_min: p.bounds_min,
            bounds_max: p.bounds_max,
            ranges: p.ranges,
        });
        data.meshes.push(pack::MeshData { vertices, indices });
        report.meshes.push(mesh_report);
    }
    lap(&mut report, "assemble");
    Ok(CookOutput { toc, data, report })
}

/// Removes materials that no processed triangle uses from the material table, renumbers the
/// material IDs in vertices and draw ranges (order-preserving, so ranges stay sorted and
/// windows last), and reports each one with the textures it would have needed.
fn prune_materials(
    manifest: &Manifest,
    replaced: &[u16],
    tagging: &mut tag::Tagging,
    processed: &mut [mesh::Processed],
    report: &mut Report,
) {
    let mut used = vec![false; tagging.materials.len()];
    for p in processed.iter() {
        for r in p.ranges.iter().filter(|r| r.index_count > 0) {
            used[r.material as usize] = true;
        }
    }
    if used.iter().all(|&u| u) {
        return;
    }
    for (i, (plan, &u)) in tagging.materials.iter().zip(&used).enumerate() {
        // Its triangles now belong to per-window materials.
        if u || replaced.contains(&(i as u16)) {
            continue;
        }
        let mut textures: Vec<String> = [&plan.diffuse_texture, &plan.normal_texture]
            .into_iter()
            .flatten()
            .map(|t| t.name())
            .collect();
        for w in manifest.windows.iter().filter(|w| {
            w.matches(
                &plan.material.name,
                std::iter::once(plan.material.name.as_str()),
            )
        }) {
            textures.extend(w.design.iter().map(|d| d.display().to_string()));
            textures.extend(w.normal_map.iter().map(|n| n.display().to_string()));
        }
        report.skipped.push(format!(
            "material {:?} ({}): no triangles, not cooked{}",
            plan.material.name,
            plan.material.class,
            nor_textures(&textures)
        ));
    }
    renumber(&used, tagging, processed);
}

/// Removes the `replaced` materials (their triangles moved to per-window materials) from
/// the table and renumbers material IDs, as [`prune_materials`] does for the cook.
pub(crate) fn drop_replaced(
    replaced: &[u16],
    tagging: &mut tag::Tagging,
    processed: &mut [mesh::Processed],
) {
    let keep: Vec<bool> = (0..tagging.materials.len())
        .map(|i| !replaced.contains(&(i as u16)))
        .collect();
    renumber(&keep, tagging, processed);
}

/// Keeps the materials marked in `keep`, in order, and renumbers every reference to them.
fn renumber(keep: &[bool], tagging: &mut tag::Tagging, processed: &mut [mesh::Processed]) {
    let mut remap = vec![u16::MAX; keep.len()];
    let mut next = 0u16;
    for (old, &k) in keep.iter().enumerate() {
        if k {
            remap[old] = next;
            next += 1;
        }
    }
    let old = std::mem::take(&mut tagging.materials);
    tagging.materials = old
        .into_iter()
        .zip(keep)
        .filter(|(_, k)| **k)
        .map(|(m, _)| m)
        .collect();
    for parts in &mut tagging.part_material {
        for m in parts.iter_mut() {
            *m = remap[*m as usize];
        }
    }
    for p in processed.iter_mut() {
        for v in &mut p.vertices {
            v.material[0] = remap[v.material[0] as usize];
        }
        p.ranges.retain(|r| r.index_count > 0);
        for r in &mut p.ranges {
            r.material = remap[r.material as usize];
        }
    }
}

/// Every triangle of a surface that can receive light through a window: everything but the
/// windows themselves and the unlit backdrop.
fn receiving_triangles<'a>(
    tagging: &'a tag::Tagging,
    processed: &'a [mesh::Processed],
) -> impl Iterator<Item = [[f32; 3]; 3]> + 'a {
    processed.iter().flat_map(move |p| {
        p.ranges
            .iter()
            .filter(move |r| {
                let class = tagging.materials[r.material as usize].material.class;
                !class.is_window() && class != pack::MaterialClass::Background
            })
            .flat_map(move |r| {
                p.indices[r.first_index as usize..(r.first_index + r.index_count) as usize]
                    .chunks_exact(3)
                    .map(move |t| [t[0], t[1], t[2]].map(|i| p.vertices[i as usize].position))
            })
    })
}

fn nor_textures(textures: &[String]) -> String {
    if textures.is_empty() {
        String::new()
    } else {
        format!(", nor its textures ({})", textures.join(", "))
    }
}

/// Source materials (an MTL entry, a glTF material) that no triangle uses never become pack
/// materials; say so, with the textures that were therefore not cooked.
fn skip_unused_source_materials(
    sources: &[import::Imported],
    tagging: &tag::Tagging,
    report: &mut Report,
) {
    for (si, name) in &tagging.unused_source_materials {
        let src = &sources[*si];
        let textures: Vec<String> = src
            .materials
            .iter()
            .filter(|m| &m.name == name)
            .flat_map(|m| [&m.diffuse_texture, &m.normal_texture])
            .flatten()
            .map(|t| t.name())
            .collect();
        report.skipped.push(format!(
            "material {name:?} of {}: defined but no triangle uses it, not cooked{}",
            src.path.display(),
            nor_textures(&textures)
        ));
    }
}

/// The height of the floor: the lowest point of any floor-class triangle.
fn processed_floor(tagging: &tag::Tagging, processed: &[mesh::Processed]) -> Option<f32> {
    let mut y: Option<f32> = None;
    for p in processed {
        for r in p.ranges.iter().filter(|r| {
            tagging.materials[r.material as usize].material.class == pack::MaterialClass::Floor
        }) {
            for &i in &p.indices[r.first_index as usize..(r.first_index + r.index_count) as usize] {
                let v = p.vertices[i as usize].position[1];
                y = Some(y.map_or(v, |m: f32| m.min(v)));
            }
        }
    }
    y
}

fn note_heuristics(sources: &[import::Imported], tagging: &tag::Tagging, report: &mut Report) {
    for (si, src) in sources.iter().enumerate() {
        let mut counts = vec![0usize; src.parts.len()];
        for &p in &src.tri_part {
            counts[p as usize] += 1;
        }
        for (pi, d) in tagging.decisions[si].iter().enumerate() {
            if d.is_rule() || counts[pi] == 0 {
                continue;
            }
            let m = &tagging.materials[tagging.part_material[si][pi] as usize].material;
            report.heuristics.push(HeuristicNote {
                source: src.path.clone(),
                names: src.parts[pi].names.describe(),
                material: m.name.clone(),
                class: m.class,
                keyword: match d {
                    tag::Decision::Heuristic { keyword, .. } => Some(keyword),
                    _ => None,
                },
                reason: d.reason().unwrap_or_default(),
                triangles: counts[pi],
            });
        }
    }
}
