//! The whole pipeline, top to bottom: [`cook`] calls each stage in order, and [`prepare`]
//! runs its front (import → tag → windows), which `cooker validate` and `cooker init` share.

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::manifest::{Manifest, WindowDesign};
use crate::report::{HeuristicNote, MeshReport, Report};
use crate::{CookError, Settings, Warning, guess, import, mesh, prune, tag, textures};
use crate::{window_plan, windows};

/// A cooked scene: write it with [`CookOutput::write`] (atomically).
#[derive(Clone, Debug)]
pub struct CookOutput {
    pub toc: pack::Toc,
    pub data: pack::PackData,
    pub report: Report,
}

impl CookOutput {
    pub fn write(&self, path: &Path) -> Result<(), CookError> {
        pack::write_pack(path, self.toc.clone(), &self.data)?;
        Ok(())
    }
}

/// The whole pipeline: sources in, a pack's TOC and data out. A file the manifest names that
/// cannot be used is reported at its line.
pub fn cook(manifest: &Manifest, settings: &Settings) -> Result<CookOutput, CookError> {
    cook_steps(manifest, settings).map_err(|e| at_its_source(manifest, settings, e))
}

fn cook_steps(manifest: &Manifest, settings: &Settings) -> Result<CookOutput, CookError> {
    let mut report = Report::default();

    // 1–3. Import every source into a triangle soup (errors name file and line); tag source
    // names to pack materials with a class; find the windows in the geometry.
    let mut prepared = prepare(manifest, settings, &mut report)?;
    // A pack of no triangles shows nothing: a gate on the cook's exit status must not pass it
    // (`cooker validate` reports the same as its `no-triangles` finding).
    if let Some(e) = no_faces(manifest, &prepared) {
        return Err(e);
    }
    // From here on the manifest's cameras and light are in the scene's shifted frame.
    let framed = manifest.shifted(prepared.shift);
    let manifest = &*framed;
    report.heuristics = heuristic_notes(
        &prepared.imported,
        &prepared.tagging,
        &prepared.tri_material,
    );
    for src in &mut prepared.imported {
        src.release_parts();
    }
    let mut clock = Lap::start();

    // 4. Mesh processing, one source per task, beside a bare model's guessed light and cameras
    // (which read the same prepared geometry); materials left without triangles are dropped.
    let mesh_needs = material_needs(&prepared.tagging);
    // The meshes' source normals become their vertices' normal tables in place; nothing else
    // reads them. Texture coordinates no material samples are not read again either (their
    // values and indices were 3.3 and 9.8 MB of the 819k-triangle grid's cook's peak).
    let normals: Vec<mesh::SourceNormals> = (prepared.imported.iter_mut())
        .map(mesh::SourceNormals::take)
        .collect();
    if !mesh_needs.iter().any(|n| n.uvs || n.tangents) {
        for src in &mut prepared.imported {
            src.uvs = Vec::new();
            src.corners.drop_uv_indices();
        }
    }
    let (guessed, deduplicated) = rayon::join(
        || {
            needs_guess(manifest).then(|| {
                let start = Instant::now();
                (guess::guess(&prepared), start.elapsed())
            })
        },
        || {
            (prepared.imported.par_iter())
                .zip(normals)
                .zip(&prepared.tri_material)
                .map(|((src, n), tm)| mesh::deduplicate(src, n, tm, &mesh_needs, &settings.mesh))
                .collect::<Vec<_>>()
        },
    );
    report.guess_time = guessed.as_ref().map(|g| g.1);
    let manifest = with_guesses(manifest, guessed.map(|g| g.0), &mut report);
    let Prepared {
        mut imported,
        import_times,
        mut tagging,
        tri_material,
        windows: found,
        images,
        shift: _,
    } = prepared;
    // Nothing reads the imported triangles again: let them go, and the attributes once the
    // vertices are gathered, before the vertex cache step, which would otherwise be the peak
    // of a large mesh's cook (a 1M-triangle OBJ's corners are 12 MB, 36 MB with texture
    // coordinates and normals).
    drop(tri_material);
    for src in &mut imported {
        src.release_corners();
    }
    let deduplicated: Vec<mesh::Deduplicated> = deduplicated
        .into_par_iter()
        .zip(imported.par_iter())
        .map(|(d, src)| d.gather(src))
        .collect();
    for src in &mut imported {
        src.release_geometry();
    }
    let mut processed: Vec<mesh::Processed> = deduplicated
        .into_par_iter()
        .zip(imported.par_iter())
        .map(|(d, src)| mesh::optimize(d, src, &mesh_needs, &settings.mesh))
        .collect();
    record_sources(&manifest, &imported, &mut report);
    prune::unused_materials(
        &manifest,
        &found.replaced,
        &mut tagging,
        &mut processed,
        &mut report,
    );
    prune::unused_source_materials(&imported, &tagging, &mut report);
    let needs = material_needs(&tagging);
    clock.lap(&mut report, "mesh");
    // Faces that all had zero area (a collinear triangle, a mesh scaled by 1e-30) left an
    // empty pack and exit 0, as the check above once let points and lines through.
    if processed.iter().all(|p| p.indices.is_empty()) {
        return Err(nothing_to_cook(&manifest, |n| match n {
            1 => "every face has zero area (as placed)".into(),
            n => format!("every face of the scene's {n} meshes has zero area (as placed)"),
        }));
    }

    // 5. Windows: frames from the geometry, and which of them light a receiving surface.
    let (window_frames, lit_windows) = frame_windows(&manifest, &tagging, &processed, &mut report);
    let sky_geometry =
        (tagging.materials.iter()).any(|m| m.material.class == pack::MaterialClass::Background);
    if !window_frames.is_empty()
        && !manifest.background.colour_given
        && manifest.background.panorama.is_none()
        && !sky_geometry
    {
        report.warnings.push(Warning::new(
            &manifest.path,
            None,
            "the windows show black behind their glass: the manifest gives no [background] \
             colour, nor a panorama, and no geometry is tagged background; `[background] \
             colour = [0.5, 0.6, 0.75]` is a daylight sky (`cooker init` writes one)",
        ));
    }
    clock.lap(&mut report, "light reach");

    // 6. Textures: material maps, window designs, normal maps and projectors, background.
    let floor_y = floor_height(&tagging, &processed);
    let (textures, texture_data, panorama) = textures::cook_textures(
        &manifest,
        &mut tagging,
        &window_frames,
        &lit_windows,
        floor_y,
        settings,
        &images,
        &mut report,
    )
    .map_err(|e| at_its_material(&imported, e))?;
    drop(images);
    report.inputs.sort();
    report.inputs.dedup();
    clock.lap(&mut report, "textures");

    // 7. Encode the meshes; assemble the TOC and bulk data.
    let (meshes, mesh_data) = encode_meshes(
        processed,
        &imported,
        import_times,
        &manifest,
        &needs,
        settings,
        &mut report,
    );
    let toc = pack::Toc {
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
            // A panorama's texels are multiplied by the colour: white unless one is given.
            colour: if panorama.is_some() && !manifest.background.colour_given {
                [1.0; 3]
            } else {
                manifest.background.colour
            },
            panorama,
        },
        meshes,
    };
    let data = pack::PackData {
        meshes: mesh_data,
        textures: texture_data,
    };
    clock.lap(&mut report, "assemble");
    Ok(CookOutput { toc, data, report })
}

/// Encodes each processed mesh with the attributes its materials need; a mesh left without
/// triangles is reported and left out.
fn encode_meshes(
    processed: Vec<mesh::Processed>,
    imported: &[import::Imported],
    import_times: Vec<Duration>,
    manifest: &Manifest,
    needs: &[mesh::MaterialNeeds],
    settings: &Settings,
    report: &mut Report,
) -> (Vec<pack::Mesh>, Vec<pack::MeshData>) {
    let (mut meshes, mut data) = (Vec::new(), Vec::new());
    let quantize = settings.quantize.then_some(settings.position_bits);
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
        } else {
            let packed = mesh::pack_mesh(&m.name, p, needs, quantize);
            mesh_report.dropped_attributes = packed.dropped_attributes;
            mesh_report.quantization = packed.quantization;
            mesh_report.vertex_bytes = packed.data.vertices.len();
            mesh_report.index_bytes = packed.data.indices.len();
            meshes.push(packed.mesh);
            data.push(packed.data);
        }
        report.meshes.push(mesh_report);
    }
    (meshes, data)
}

/// Stage times for the report.
struct Lap(Instant);

impl Lap {
    fn start() -> Self {
        Self(Instant::now())
    }

    fn lap(&mut self, report: &mut Report, name: &'static str) {
        let now = Instant::now();
        report.stage(name, now - self.0);
        self.0 = now;
    }
}

/// A source as imported, and how long its import took.
pub type ImportedSource = (import::Imported, Duration);

/// Imports every mesh source in parallel and applies its manifest transform; a bare model's
/// is the turn that stands it up (`settings.up`).
///
/// A model in survey coordinates (see `Imported::origin`) is moved near the origin: the scene
/// is shifted by the returned vector (subtracted from every position, the manifest's cameras
/// and light too), the first such mesh's origin placed by its transform and rounded to whole
/// units, so that meshes of one survey keep their places to each other. Zero for any other
/// scene, whose positions are transformed as they always were.
pub fn import_sources(
    manifest: &Manifest,
    settings: &Settings,
) -> Result<(Vec<ImportedSource>, [f64; 3]), CookError> {
    let up = settings.up;
    let results: Vec<Result<ImportedSource, CookError>> = manifest
        .meshes
        .par_iter()
        .map(|m| {
            let start = Instant::now();
            let imported = import::import_with(&m.source, settings.text_encoding)?;
            Ok((imported, start.elapsed()))
        })
        .collect();
    // The first error in manifest order, so the message does not depend on thread timing.
    let mut sources: Vec<ImportedSource> = results.into_iter().collect::<Result<_, _>>()?;
    let transform = |m: &crate::manifest::MeshSource| {
        if manifest.bare {
            up.to_y_up()
        } else {
            m.transform()
        }
    };
    let shift = manifest
        .meshes
        .iter()
        .zip(&sources)
        .find(|(_, (src, _))| src.origin != [0.0; 3])
        .map_or([0.0; 3], |(m, (src, _))| {
            let placed = transform(m)
                .as_dmat4()
                .transform_point3(glam::DVec3::from(src.origin));
            placed.round().to_array()
        });
    sources
        .par_iter_mut()
        .zip(&manifest.meshes)
        .for_each(|((src, started), m)| {
            let start = Instant::now();
            let matrix = transform(m);
            if shift == [0.0; 3] && src.origin == [0.0; 3] {
                src.transform(matrix);
            } else {
                // Where the file's origin lands, less the shift: in f64, so that only the
                // model's own extent is ever rounded to f32.
                let t = matrix
                    .as_dmat4()
                    .transform_point3(glam::DVec3::from(src.origin))
                    - glam::DVec3::from(shift);
                let mut moved = matrix;
                moved.w_axis = t.as_vec3().extend(1.0);
                src.transform(moved);
            }
            *started += start.elapsed();
        });
    // A scale of 1e38 passes the manifest's finite check and sends the positions past f32's
    // range: the triangles were dropped as degenerate and the pack came out empty, exit 0.
    for ((src, _), m) in sources.iter().zip(&manifest.meshes) {
        if !manifest.bare
            && m.transform() != glam::Mat4::IDENTITY
            && src.positions.iter().flatten().any(|c| !c.is_finite())
        {
            return Err(CookError::Manifest {
                path: manifest.path.clone(),
                line: Some(m.line.0),
                message: format!(
                    "[[mesh]] {:?}: its transform (translate {:?}, rotate_deg {:?}, scale {:?}) \
                     takes positions of {} past the range of 32-bit floats",
                    m.name,
                    m.translate,
                    m.rotate_deg,
                    m.scale,
                    m.source.display()
                ),
            });
        }
    }
    Ok((sources, shift))
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
                colours: !window,
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
    /// Image files the window stage decoded, for the texture jobs to reuse.
    pub images: textures::DecodedImages,
    /// Subtracted from the model's positions, and from the manifest's cameras and light: see
    /// [`import_sources`].
    pub shift: [f64; 3],
}

/// Runs import → tag → windows; see [`Prepared`]. Errors as [`cook`]'s.
pub fn prepare(
    manifest: &Manifest,
    settings: &Settings,
    report: &mut Report,
) -> Result<Prepared, CookError> {
    prepare_steps(manifest, settings, report).map_err(|e| at_its_source(manifest, settings, e))
}

fn prepare_steps(
    manifest: &Manifest,
    settings: &Settings,
    report: &mut Report,
) -> Result<Prepared, CookError> {
    settings.check(manifest)?;
    let start = Instant::now();
    let (sources, shift) = import_sources(manifest, settings)?;
    if shift != [0.0; 3] {
        report.notes.push(crate::Warning::new(
            &manifest.path,
            None,
            format!(
                "the model lies far from the origin (survey coordinates): the scene is moved by \
                 [{}, {}, {}] so that its 32-bit positions keep their precision (at 5,000,000 \
                 units they are half a unit apart); the manifest's cameras and light move with it",
                0.0 - shift[0],
                0.0 - shift[1],
                0.0 - shift[2]
            ),
        ));
    }
    let (mut imported, import_times): (Vec<import::Imported>, Vec<Duration>) =
        sources.into_iter().unzip();
    let tagged = Instant::now();
    report.stage("import", tagged - start);
    let mut tagging = tag::tag(manifest, &mut imported)?;
    let mut tri_material: Vec<Vec<u16>> = imported
        .iter()
        .zip(&tagging.part_material)
        .map(|(src, parts)| tri_materials(src, parts))
        .collect();
    let found = Instant::now();
    report.stage("tag", found - tagged);
    let images = textures::DecodedImages::with_colour_managed(colour_managed(manifest, report));
    let framed = manifest.shifted(shift);
    let windows = window_plan::plan(
        &framed,
        settings,
        &mut imported,
        &mut tagging,
        &mut tri_material,
        &images,
        report,
    )
    .map_err(|e| at_its_material(&imported, e))?;
    report.stage("windows", found.elapsed());
    Ok(Prepared {
        imported,
        import_times,
        tagging,
        tri_material,
        windows,
        images,
        shift,
    })
}

/// The image files the user named as colour: window designs (the manifest's and `--window`'s),
/// rules' textures and the background's panorama. Their embedded colour profiles are applied
/// (`texture::profile`), wherever the scene uses the file (one file is one set of colours);
/// what each does is said here, on every cook, cache hit or not. A design declared
/// `colour_space = "linear"` holds data in linear light, which a profile does not describe:
/// it is read as declared, and a profile it carries is said to be left out. A file that cannot
/// be read is left to its decode, which names it.
///
/// A `--window` design takes the colour space of the entry it merges with, which only the
/// window stage knows: it is settled there ([`say_profile`]).
fn colour_managed(manifest: &Manifest, report: &mut Report) -> Vec<PathBuf> {
    let linear = |w: &WindowDesign| w.colour_space == pack::ColourSpace::Linear;
    let designs = manifest.windows.iter();
    let mut files: Vec<PathBuf> = (designs.clone())
        .filter(|w| !linear(w))
        .filter_map(|w| w.design.clone())
        .chain(manifest.rules.iter().filter_map(|r| r.texture.clone()))
        .chain(manifest.background.panorama.clone())
        .collect();
    files.sort();
    files.dedup();
    for f in &files {
        say_profile(f, false, report);
    }
    let mut linear_designs: Vec<&PathBuf> = designs
        .filter(|w| linear(w))
        .filter_map(|w| w.design.as_ref())
        .filter(|d| !files.contains(d))
        .collect();
    linear_designs.sort();
    linear_designs.dedup();
    for f in linear_designs {
        say_profile(f, true, report);
    }
    files
}

/// Says what becomes of `f`'s embedded colour profile: applied (a note), not applicable (a
/// warning), or, where the file is read as linear light (`linear`), not applied.
pub(crate) fn say_profile(f: &Path, linear: bool, report: &mut Report) {
    match texture::profile_use(f) {
        Ok(used @ texture::ProfileUse::Converted { .. }) if !linear => {
            let said = used.said().unwrap_or_default();
            report.notes.push(Warning::new(f, None, said));
        }
        Ok(used @ texture::ProfileUse::Ignored { .. }) if !linear => {
            let said = used.said().unwrap_or_default();
            report.warnings.push(Warning::new(f, None, said));
        }
        Ok(texture::ProfileUse::Converted { name } | texture::ProfileUse::Ignored { name, .. }) => {
            let name = if name.is_empty() {
                String::new()
            } else {
                format!(" \"{name}\"")
            };
            report.warnings.push(Warning::new(
                f,
                None,
                format!(
                    "its ICC profile{name} is not applied: the design is declared \
                     colour_space = \"linear\", so its texels are read as linear light"
                ),
            ));
        }
        Ok(texture::ProfileUse::Srgb) | Err(_) => {}
    }
}

/// `e` said where its file was named: a `--window` option, else the manifest's line.
fn at_its_source(manifest: &Manifest, settings: &Settings, e: CookError) -> CookError {
    manifest.at_its_line(WindowDesign::at_its_option(&settings.window_overrides, e))
}

/// The error of a scene whose models hold no face, if it is one: said of its first mesh, at
/// the line of the first statement its import skipped (faces of fewer than three corners,
/// lines, points), with what the import said of them, which a failed cook does not print.
pub fn no_faces(manifest: &Manifest, prepared: &Prepared) -> Option<CookError> {
    if !prepared.imported.iter().all(|s| s.triangle_count() == 0) {
        return None;
    }
    let first = prepared.imported.first();
    let skipped: Vec<&Warning> = first
        .into_iter()
        .flat_map(|s| &s.warnings)
        .filter(|w| w.line.is_some() || w.skipped_geometry)
        .collect();
    let mut e = nothing_to_cook(manifest, |n| match (n, skipped.as_slice()) {
        (1, []) => "no faces (the model holds no geometry, or only vertices)".into(),
        (1, [one]) => format!("no faces ({})", one.message),
        (1, said) => format!(
            "no faces ({})",
            said.iter()
                .map(|w| match w.line {
                    Some(l) => format!("line {l}: {}", w.message),
                    None => w.message.clone(),
                })
                .collect::<Vec<_>>()
                .join("; ")
        ),
        (n, _) => format!("no faces in this or any other of the scene's {n} meshes"),
    });
    if let (CookError::Source { line, .. }, Some(w)) = (&mut e, skipped.first()) {
        *line = w.line;
    }
    Some(e)
}

/// A scene that would cook to a pack of no triangles, said of its first mesh: `why` of its
/// number of meshes. An empty pack would pass a gate on the cook's exit status.
fn nothing_to_cook(manifest: &Manifest, why: impl Fn(usize) -> String) -> CookError {
    CookError::Source {
        path: manifest
            .meshes
            .first()
            .map_or_else(|| manifest.path.clone(), |m| m.source.clone()),
        line: None,
        message: format!("{}: nothing to cook", why(manifest.meshes.len())),
    }
}

/// An image a model's material names that cannot be used, said with the material and model
/// (`bad.png: cannot decode image` left the user to search the MTL files for it).
fn at_its_material(sources: &[import::Imported], e: CookError) -> CookError {
    if e.is_io() || !matches!(e, CookError::Texture(_)) {
        return e;
    }
    let Some(path) = e.path().map(Path::to_path_buf) else {
        return e;
    };
    let is =
        |t: &Option<import::ImageRef>| matches!(t, Some(import::ImageRef::File(f)) if *f == path);
    let named = sources.iter().find_map(|src| {
        src.materials.iter().find_map(|m| {
            let what = if is(&m.diffuse_texture) {
                "diffuse texture"
            } else if is(&m.normal_texture) {
                "normal map"
            } else {
                return None;
            };
            Some((src.path.clone(), m.name.clone(), what))
        })
    });
    match named {
        Some((model, material, what)) => CookError::MaterialImage {
            model,
            material,
            what,
            source: Box::new(e),
        },
        None => e,
    }
}

fn tri_materials(src: &import::Imported, part_material: &[u16]) -> Vec<u16> {
    src.tri_part
        .iter()
        .map(|&p| part_material[p as usize])
        .collect()
}

/// A bare model says nothing of light or cameras: it gets the guesses `cooker init` writes.
pub(crate) fn needs_guess(manifest: &Manifest) -> bool {
    manifest.bare && manifest.light.is_none()
}

/// The manifest with the guesses (made when [`needs_guess`]) filled in.
fn with_guesses<'a>(
    manifest: &'a Manifest,
    guessed: Option<guess::Guess>,
    report: &mut Report,
) -> Cow<'a, Manifest> {
    let Some(g) = guessed else {
        return Cow::Borrowed(manifest);
    };
    let mut m = manifest.clone();
    m.light = g.light;
    if m.cameras.is_empty() {
        m.cameras = g.cameras;
    }
    // A bare model's background is the default, black, and no panorama.
    if let Some(sky) = g.sky {
        m.background.colour = sky;
        m.background.colour_given = true;
    }
    report.warnings.push(Warning::new(
        &manifest.path,
        None,
        format!(
            "cooking a bare mesh without a scene.toml: materials are tagged by heuristics \
             (material transparency, names, geometry), and the light and cameras are \
             guessed ({}{}); `cooker init` writes these guesses into a scene.toml to edit",
            g.notes.join("; "),
            if g.sky.is_some() {
                "; a daylight sky behind the windows"
            } else {
                ""
            }
        ),
    ));
    Cow::Owned(m)
}

/// Records the files read so far and the importers' warnings.
fn record_sources(manifest: &Manifest, imported: &[import::Imported], report: &mut Report) {
    report.inputs.push(manifest.path.clone());
    for s in imported {
        report.warnings.extend(s.warnings.iter().cloned());
        report.inputs.push(s.path.clone());
        report.inputs.extend(s.files.iter().cloned());
        report.absent.extend(s.absent.iter().cloned());
    }
    report.absent.sort();
    report.absent.dedup();
}

/// Each window's projector frame, facing the side the window stage chose, and per material
/// whether its light lands on a receiving surface (only those get a projector cooked).
fn frame_windows(
    manifest: &Manifest,
    tagging: &tag::Tagging,
    processed: &[mesh::Processed],
    report: &mut Report,
) -> (Vec<pack::Window>, Vec<bool>) {
    let light = manifest.light.as_ref().map(|l| &l.kind);
    let mut frames = Vec::new();
    for (mi, g) in window_geometry(tagging, processed) {
        let name = &tagging.materials[mi as usize].material.name;
        let inside = window_plan::inside_of(tagging, mi);
        match windows::analyze(mi, &g, light, inside) {
            Some(mut a) => {
                a.frame.source_materials = match &tagging.materials[mi as usize].window {
                    Some(plan) => plan.materials.clone(),
                    None => vec![name.clone()],
                };
                frames.push(a.frame)
            }
            None if g.triangles.is_empty() => {}
            None => report.warnings.push(Warning::new(
                &manifest.path,
                None,
                format!("window material {name:?} has no area; no projector frame"),
            )),
        }
    }
    let mut lit = vec![false; tagging.materials.len()];
    // The windows skipped for each reason (singular, plural), in the order first met.
    let mut skipped: Vec<((&str, &str), Vec<&str>)> = Vec::new();
    for f in &frames {
        let name = &tagging.materials[f.material as usize].material.name;
        let reaches = light
            .is_some_and(|l| windows::light_reaches(f, l, receiving_triangles(tagging, processed)));
        lit[f.material as usize] = reaches;
        let designed = tagging.materials[f.material as usize].window.is_some();
        if designed && !reaches {
            let why = match light {
                None => ("the scene has no light", "the scene has no light"),
                Some(l) if windows::light_enters(f, l) => (
                    "its light reaches no floor, wall or other receiving surface",
                    "their light reaches no floor, wall or other receiving surface",
                ),
                Some(l) if windows::faces_light(f, l) => (
                    "the spot light's cone does not reach it",
                    "the spot light's cone does not reach them",
                ),
                Some(pack::LightKind::Directional { .. }) => (
                    "the sunlight does not come in through it (it faces away from the sun)",
                    "the sunlight does not come in through them (they face away from the sun)",
                ),
                Some(pack::LightKind::Point { .. } | pack::LightKind::Spot { .. }) => (
                    "the light does not come in through it (the lamp is on its inner side)",
                    "the light does not come in through them (the lamp is on their inner side)",
                ),
            };
            match skipped.iter_mut().find(|(w, _)| *w == why) {
                Some((_, names)) => names.push(name),
                None => skipped.push((why, vec![name])),
            }
        }
    }
    report.skipped.extend(skipped_windows(&skipped));
    (frames, lit)
}

/// The report's lines for windows cooked without a projector: one per window, or, where more
/// than [`crate::report::NAMED`] share a reason (a hall's whole shaded side), one line naming
/// the first few.
fn skipped_windows(skipped: &[((&str, &str), Vec<&str>)]) -> Vec<String> {
    let mut out = Vec::new();
    for ((one, many), names) in skipped {
        if names.len() <= crate::report::NAMED {
            out.extend(
                names.iter().map(|name| {
                    format!("window {name:?}: {one}, so no projector texture was cooked")
                }),
            );
        } else {
            out.push(format!(
                "{} windows ({}): {many}, so no projector textures were cooked",
                names.len(),
                crate::report::few_names(names)
            ));
        }
    }
    out
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
                            let v = p.vertices.get(i as usize);
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
                    .map(move |t| [t[0], t[1], t[2]].map(|i| p.vertices.positions[i as usize]))
            })
    })
}

/// The height of the floor: the lowest point of any floor-class triangle.
fn floor_height(tagging: &tag::Tagging, processed: &[mesh::Processed]) -> Option<f32> {
    let mut y: Option<f32> = None;
    for p in processed {
        for r in p.ranges.iter().filter(|r| {
            tagging.materials[r.material as usize].material.class == pack::MaterialClass::Floor
        }) {
            for &i in &p.indices[r.first_index as usize..(r.first_index + r.index_count) as usize] {
                let v = p.vertices.positions[i as usize][1];
                y = Some(y.map_or(v, |m: f32| m.min(v)));
            }
        }
    }
    y
}

/// The parts of each source that a heuristic tagged rather than a rule (and that have
/// triangles), with why: the cook's `note:` lines and `cooker validate`'s `untagged` finding.
pub(crate) fn heuristic_notes(
    sources: &[import::Imported],
    tagging: &tag::Tagging,
    tri_material: &[Vec<u16>],
) -> Vec<HeuristicNote> {
    let mut notes = Vec::new();
    for (si, src) in sources.iter().enumerate() {
        let noted: Vec<bool> = tagging.decisions[si].iter().map(|d| !d.is_rule()).collect();
        if !noted.contains(&true) {
            continue;
        }
        // Per part, the pack materials its triangles went to: the window stage moves glass
        // into a material per window.
        let mut went: Vec<std::collections::BTreeSet<u16>> = vec![Default::default(); noted.len()];
        // A part's triangles run in long stretches of one material: the set is asked only
        // where the material changes, not once per triangle of a million-triangle mesh.
        let mut last = vec![u32::MAX; noted.len()];
        for (&p, &m) in src.tri_part.iter().zip(&tri_material[si]) {
            let p = p as usize;
            if noted[p] && last[p] != u32::from(m) {
                last[p] = u32::from(m);
                went[p].insert(m);
            }
        }
        let counts = src.part_triangles();
        for (pi, d) in tagging.decisions[si].iter().enumerate() {
            if !noted[pi] || counts[pi] == 0 {
                continue;
            }
            notes.push(HeuristicNote {
                source: src.path.clone(),
                names: src.parts[pi].names.describe(),
                materials: went[pi]
                    .iter()
                    .map(|&m| {
                        let m = &tagging.materials[m as usize].material;
                        (m.name.clone(), m.class)
                    })
                    .collect(),
                keyword: match d {
                    tag::Decision::Heuristic { keyword, .. } => Some(keyword),
                    _ => None,
                },
                reason: d.reason().unwrap_or_default(),
                triangles: counts[pi],
            });
        }
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn many_windows_skipped_for_one_reason_are_one_line() {
        let away = ("away from it", "away from them");
        let dark = ("in the dark", "in the dark");
        let side: Vec<String> = (1..=225).map(|i| format!("glass_s#{i}")).collect();
        let lines = skipped_windows(&[
            (away, side.iter().map(String::as_str).collect()),
            (dark, vec!["rose", "oculus"]),
        ]);
        assert_eq!(
            lines,
            [
                "225 windows (\"glass_s#1\", \"glass_s#2\", \"glass_s#3\" and 222 more): away \
                 from them, so no projector textures were cooked",
                "window \"rose\": in the dark, so no projector texture was cooked",
                "window \"oculus\": in the dark, so no projector texture was cooked",
            ]
        );
    }
}
