//! The window stage before mesh processing: finds the window instances, gives each its own
//! pack material, writes planar texture coordinates where the glass has none, and decides
//! each window's design (an image, the material's own texture, or one rasterized from the
//! panes' colours), masked by the window's outline.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;
use pack::MaterialClass;
use rayon::prelude::*;

use crate::design::{self, Pane, Tint, UvTriangle};
use crate::import::{ImageRef, Imported, NONE};
use crate::instances::{self, Instance};
use crate::manifest::{Fit, Manifest, UvMode, WindowDesign};
use crate::tag::{Decision, Tagging};
use crate::{CookError, Report, Warning};
use texture::{GreenAxis, NormalEncoding};

/// Where a window's design came from, for reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DesignSource {
    /// A `[[window]]` design or `--window` image.
    Image,
    /// The glass material's own colour texture.
    Texture,
    /// Rasterized from the panes' transmitted colours, with lead cames.
    Mesh,
}

/// What the texture stage cooks for one window.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowPlan {
    pub design: ImageRef,
    pub source: DesignSource,
    pub colour_space: pack::ColourSpace,
    /// A given normal map; `None` derives one from the design.
    pub normal: Option<(ImageRef, NormalEncoding, GreenAxis)>,
    /// The `[[window]]`'s `normal_strength`, over the glass's own.
    pub normal_strength: Option<f32>,
    pub blur_sigma: Option<f32>,
    /// The window's `texture_format`, overriding `[textures] format`.
    pub texture_format: Option<crate::manifest::TextureFormatChoice>,
    /// Size of the design in texels (the projector's blur and margin are in texels).
    pub design_size: (u32, u32),
    /// Unit normal into the building.
    pub inside: [f32; 3],
    /// The source materials of the window's glass.
    pub materials: Vec<String>,
    /// Where the texture stage's notes on this window's textures point: the manifest's
    /// `[[window]]` entry and its line, or for a `--window` image the image itself. A design
    /// cut to its window's outline is made by the cook, and its notes lost the line.
    pub said_at: Option<(PathBuf, Option<usize>)>,
}

/// What the window stage found, for `validate`, `info` and reports.
#[derive(Clone, Debug, Default)]
pub struct Windows {
    pub instances: Vec<Instance>,
    /// Pack material of each instance.
    pub material: Vec<u16>,
    /// Materials whose triangles all moved to per-window materials: not reported as unused.
    pub replaced: Vec<u16>,
}

/// A decoded design's texels as RGBA8: borrowed, since the cook holds 8-bit images as RGBA8
/// already (`textures::DecodedImages`), and converted only for 16-bit and float ones. Each
/// window showing a design read it, and copied it whole, even where nothing was masked.
fn rgba(img: &image::DynamicImage) -> std::borrow::Cow<'_, image::RgbaImage> {
    match img.as_rgba8() {
        Some(pixels) => std::borrow::Cow::Borrowed(pixels),
        None => std::borrow::Cow::Owned(img.to_rgba8()),
    }
}

/// The instance's triangles in texture space, each with its pane (index into `panes`); the
/// panes: one per source material, in its transmitted colour; and, where the design is
/// `tinted` by them (drawn from the mesh, or the glass's own texture), the vertex colours at
/// each triangle's corners.
fn uv_triangles(
    src: &Imported,
    inst: &Instance,
    tri_material: &[u16],
    tagging: &Tagging,
    si: usize,
    tinted: bool,
) -> (Vec<UvTriangle>, Vec<Pane>, Option<Vec<Tint>>) {
    let mut panes: Vec<(Option<u32>, Pane)> = Vec::new();
    let mut tris = Vec::with_capacity(inst.triangles.len());
    for &t in &inst.triangles {
        let part = src.tri_part[t as usize] as usize;
        let source_material = src.parts[part].material;
        let pane = match source_material.and_then(|m| src.materials.get(m as usize)) {
            Some(m) => {
                let (colour, amount) = m.transmission.transmitted(m.diffuse);
                Pane { colour, amount }
            }
            None => {
                let m = &tagging.materials[tri_material[t as usize] as usize].material;
                Pane {
                    colour: m.diffuse,
                    amount: 1.0,
                }
            }
        };
        // Panes are told apart by source material (tagged material when there is none).
        let key = source_material.or(Some(u32::MAX - tagging.part_material[si][part] as u32));
        let id = match panes.iter().position(|p| p.0 == key) {
            Some(i) => i,
            None => {
                panes.push((key, pane));
                panes.len() - 1
            }
        };
        let uv = src.corners.triangle(t as usize).map(|k| {
            if k.t == NONE {
                [0.0; 2]
            } else {
                src.uvs[k.t as usize]
            }
        });
        tris.push((uv, id as u16));
    }
    // Vertex colours tint the panes of a design drawn from the mesh, and the glass's own
    // texture; a window whose corners are all white (or a model without them) is made as it
    // always was. A design given in the manifest or with `--window` is taken as it is.
    let tints: Option<Vec<Tint>> = (tinted && !src.colours.is_empty()).then(|| {
        inst.triangles
            .iter()
            .map(|&t| {
                src.corners
                    .triangle_positions(t as usize)
                    .map(|k| src.colours[k as usize])
            })
            .collect()
    });
    let tints = tints.filter(|t| t.iter().flatten().any(|c| *c != [1.0; 4]));
    (tris, panes.into_iter().map(|p| p.1).collect(), tints)
}

fn raster(name: String, image: image::RgbaImage) -> ImageRef {
    ImageRef::Raster {
        name,
        image: Arc::new(image),
    }
}

/// The lowest floor and highest wall corner of the tagged geometry (infinite where there is
/// none).
fn floor_and_wall_top(
    sources: &[Imported],
    tri_material: &[Vec<u16>],
    classes: &[MaterialClass],
) -> (f64, f64) {
    let (mut floor, mut wall_top) = (f64::INFINITY, f64::NEG_INFINITY);
    for (src, mats) in sources.iter().zip(tri_material) {
        for (t, &m) in mats.iter().enumerate() {
            let class = classes[m as usize];
            for k in 0..3 {
                let y = src.positions[src.corners.p(t * 3 + k) as usize][1] as f64;
                match class {
                    MaterialClass::Floor => floor = floor.min(y),
                    MaterialClass::Wall => wall_top = wall_top.max(y),
                    _ => {}
                }
            }
        }
    }
    (floor, wall_top)
}

/// Runs the window stage: see the module documentation. `overrides` are `--window` entries,
/// which come before the manifest's. `tri_material` (per source, per triangle) is updated to
/// the per-window materials.
pub fn plan(
    manifest: &Manifest,
    settings: &crate::settings::Settings,
    sources: &mut [Imported],
    tagging: &mut Tagging,
    tri_material: &mut [Vec<u16>],
    images: &crate::textures::DecodedImages,
    report: &mut Report,
) -> Result<Windows, CookError> {
    let overrides = &settings.window_overrides[..];
    // `--window NAME=IMAGE` replaces the design of the manifest's entry for that window and
    // keeps the rest of it (normal map, fit, colour space, blur...): one merged entry per pair,
    // few enough to make them all.
    let merged: Vec<Vec<WindowDesign>> = overrides
        .iter()
        .map(|o| {
            manifest
                .windows
                .iter()
                .map(|e| WindowDesign {
                    design: o.design.clone(),
                    ..e.clone()
                })
                .collect()
        })
        .collect();
    let classes: Vec<MaterialClass> = tagging.materials.iter().map(|m| m.material.class).collect();
    let names: Vec<String> = tagging
        .materials
        .iter()
        .map(|m| m.material.name.clone())
        .collect();
    let material_names =
        |mats: &[u16]| -> Vec<String> { mats.iter().map(|&m| names[m as usize].clone()).collect() };
    // A window's materials as entries glob them: its glass's source or tagged materials, and
    // the pack material named after the window that it takes where it is not all of one
    // material of its own (`Glass#3`); `material` globs over pack names too (as `cooker
    // validate` and `cooker info` list them).
    let window_materials = |name: &str, mats: &[u16]| -> Vec<String> {
        let mut mn = material_names(mats);
        if !mn.iter().any(|m| m == name) {
            mn.push(name.to_string());
        }
        mn
    };
    let entry_for = |name: &str, mats: &[u16]| -> Option<&WindowDesign> {
        let mn = window_materials(name, mats);
        let hit = |e: &WindowDesign| e.matches(name, mn.iter().map(String::as_str));
        let entry = manifest.windows.iter().position(hit);
        // The last `--window` wins, as a later option does on a command line: with `'*=a.png'
        // then 'rose=b.png'`, the rose gets b.png (the first won, and b.png was dropped).
        match (overrides.iter().rposition(hit), entry) {
            (Some(o), Some(e)) => Some(&merged[o][e]),
            (Some(o), None) => Some(&overrides[o]),
            (None, e) => e.map(|e| &manifest.windows[e]),
        }
    };
    let light = manifest.light.as_ref().map(|l| &l.kind);
    let found = instances::find(
        sources,
        tri_material,
        &classes,
        &names,
        light,
        &|name, mats| entry_for(name, mats).and_then(|e| e.inside),
    );

    // Whether an entry or `--window` names window `k` found, by its name or its materials'.
    let found_materials: Vec<Vec<String>> = found
        .iter()
        .map(|i| {
            window_materials(
                &i.name,
                &i.materials.iter().map(|m| m.0).collect::<Vec<_>>(),
            )
        })
        .collect();
    let names_window = |e: &WindowDesign, k: usize| {
        e.matches(
            &found[k].name,
            found_materials[k].iter().map(String::as_str),
        )
    };
    // `--window NAME=image` must name something: a typo would silently cook the old design.
    for o in overrides {
        if !(0..found.len()).any(|k| names_window(o, k)) {
            return Err(CookError::UnknownWindow {
                pattern: o.name.as_deref().unwrap_or_default().to_string(),
                known: found.iter().map(|i| i.name.clone()).collect(),
            });
        }
    }
    // One that later ones override on every window it matches does nothing: say so.
    let winners: Vec<Option<usize>> = (0..found.len())
        .map(|k| overrides.iter().rposition(|o| names_window(o, k)))
        .collect();
    for (k, o) in overrides.iter().enumerate() {
        if !winners.contains(&Some(k)) {
            report.warnings.push(Warning::new(
                &manifest.path,
                None,
                format!(
                    "--window {}={}: a later --window gives every window it matches another \
                     design, so it is not used",
                    o.name.as_deref().unwrap_or_default(),
                    o.design
                        .as_deref()
                        .unwrap_or(std::path::Path::new(""))
                        .display()
                ),
            ));
        }
    }
    // The windows each entry names, and per window the entry that takes it (the first).
    let named: Vec<Vec<usize>> = manifest
        .windows
        .iter()
        .map(|e| (0..found.len()).filter(|&k| names_window(e, k)).collect())
        .collect();
    let first_entry: Vec<Option<usize>> = (0..found.len())
        .map(|k| named.iter().position(|ks| ks.contains(&k)))
        .collect();
    for (e, ks) in manifest.windows.iter().zip(&named) {
        if ks.is_empty() {
            report.warnings.push(Warning::new(
                &manifest.path,
                Some(e.line.0),
                format!(
                    "[[window]] names {}, which matches no window (windows: {}{}); its design \
                     is not cooked",
                    e.describe(),
                    if found.is_empty() {
                        "none".to_string()
                    } else {
                        found
                            .iter()
                            .map(|i| i.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    },
                    // An entry by material is told the materials it can match.
                    if e.name.is_none() && !found.is_empty() {
                        let mut all: Vec<&str> = Vec::new();
                        for n in found_materials.iter().flatten() {
                            if !all.contains(&n.as_str()) {
                                all.push(n);
                            }
                        }
                        format!("; their materials: {}", all.join(", "))
                    } else {
                        String::new()
                    }
                ),
            ));
        }
    }

    // An entry every window of which an earlier entry takes (the first match wins) is never
    // used: `name = "lancet_*"` before `name = "lancet_4"`. It was taken without a word.
    for (i, (e, ks)) in manifest.windows.iter().zip(&named).enumerate() {
        if let Some(&k) = ks.first()
            && ks.iter().all(|&k| first_entry[k] != Some(i))
            && let Some(earlier) = first_entry[k]
        {
            report.warnings.push(Warning::new(
                &manifest.path,
                Some(e.line.0),
                format!(
                    "[[window]] for {} is never used: every window it matches takes an earlier \
                     [[window]] (the first that matches wins), such as the one at line {}",
                    e.describe(),
                    manifest.windows[earlier].line.0
                ),
            ));
        }
    }

    // Heights for upper/lower, a pass over every triangle that a model without windows skips.
    let (floor, wall_top) = if found.is_empty() {
        (f64::INFINITY, f64::NEG_INFINITY)
    } else {
        floor_and_wall_top(sources, tri_material, &classes)
    };
    // A material placed by an explicit rule keeps its class; heuristics and `class =
    // "window"` rules defer to the sill.
    let mut by_rule = vec![false; tagging.materials.len()];
    for (si, decisions) in tagging.decisions.iter().enumerate() {
        for (pi, d) in decisions.iter().enumerate() {
            if matches!(d, Decision::Rule(r) if !manifest.rules[*r].by_sill) {
                by_rule[tagging.part_material[si][pi] as usize] = true;
            }
        }
    }
    let mut instance_count = vec![0usize; tagging.materials.len()];
    for i in &found {
        for m in &i.materials {
            instance_count[m.0 as usize] += 1;
        }
    }

    // Designs rasterized from the mesh are sized in texels per metre; the model's unit comes
    // from its windows' sizes.
    let mut sides: Vec<f64> = found.iter().map(|i| i.width().max(i.height())).collect();
    sides.sort_by(f64::total_cmp);
    let unit = design::unit_from_windows(sides.iter().copied());
    let default_texels =
        crate::manifest::DEFAULT_TEXELS_PER_METRE * unit.map_or(1.0, |u| u.0) as f32;
    let mut unit_used = false;
    let mut out = Windows::default();
    let mut pending: Vec<Pending> = Vec::new();
    // (texture, fit, window) where a material's texture is fitted to a window without
    // coordinates.
    let mut fitted_textures: Vec<(String, Fit, String)> = Vec::new();
    // Per [[window]] line: the keys set there that no window it matches could use.
    let mut idle_keys: std::collections::BTreeMap<usize, (Vec<&str>, DesignSource, Vec<String>)> =
        std::collections::BTreeMap::new();
    for inst in &found {
        let dominant = inst.materials[0].0;
        let sill = inst
            .triangles
            .iter()
            .flat_map(|&t| {
                let s = &sources[inst.source];
                (s.corners.triangle_positions(t as usize))
                    .map(|k| s.positions[k as usize][1] as f64)
            })
            .fold(f64::INFINITY, f64::min);
        let class = if by_rule[dominant as usize] || !floor.is_finite() {
            classes[dominant as usize]
        } else if wall_top.is_finite() {
            instances::class_by_sill(sill, floor, wall_top)
        } else {
            classes[dominant as usize]
        };
        // A window that is all of one material, and the only window of it, keeps the
        // material; otherwise it gets its own, named after the window.
        let own = inst.materials.len() == 1 && instance_count[dominant as usize] == 1;
        let material = if own {
            tagging.materials[dominant as usize].material.class = class;
            dominant
        } else {
            let mut plan = tagging.materials[dominant as usize].clone();
            plan.material.name = inst.name.clone();
            plan.material.class = class;
            tagging.materials.push(plan);
            for m in &inst.materials {
                if !out.replaced.contains(&m.0) {
                    out.replaced.push(m.0);
                }
            }
            (tagging.materials.len() - 1) as u16
        };
        if tagging.materials.len() > u16::MAX as usize + 1 {
            return Err(CookError::Source {
                path: sources[inst.source].path.clone(),
                line: None,
                message: "more than 65536 materials and windows: material IDs are 16-bit".into(),
            });
        }
        for &t in &inst.triangles {
            tri_material[inst.source][t as usize] = material;
        }

        let entry = entry_for(
            &inst.name,
            &inst.materials.iter().map(|m| m.0).collect::<Vec<_>>(),
        );
        if let Some(e) = entry
            && let Some(v) = e.inside
            && instances::lies_in_plane(v, inst.inside)
        {
            report.warnings.push(Warning::new(
                &manifest.path,
                Some(e.line.0),
                format!(
                    "inside = {v:?} lies in the plane of window {:?} (its normal is [{:.2}, \
                     {:.2}, {:.2}]), so it cannot say which side is inside; the side was \
                     guessed ({})",
                    inst.name,
                    // + 0.0: no "-0.00".
                    inst.inside.x + 0.0,
                    inst.inside.y + 0.0,
                    inst.inside.z + 0.0,
                    inst.inside_reason
                ),
            ));
        }
        if let Some(e) = entry
            && let Some(v) = e.inside
            && inst.inside_reason == instances::INSIDE_AGAINST_ENCLOSURE
        {
            report.warnings.push(Warning::new(
                &manifest.path,
                Some(e.line.0),
                format!(
                    "inside = {v:?} of window {:?} points out of the model: seen from that \
                     side there is sky, from the other the model closes round the window. \
                     Followed; but whatever lies on its outer side is lit as outdoors (direct \
                     sun through every opening), so check it",
                    inst.name,
                ),
            ));
        }
        let mut planar = !inst.has_uvs || entry.is_some_and(|e| e.uv == UvMode::Planar);
        // Texture coordinates past the texture's square (tiled glass, or metres as SketchUp
        // writes them) place the design on the glass, but a projector covers that square
        // only: the light fell on a quarter of a 2 x 2 tiling's patch, or came from a phantom
        // window in the wall where the square lay. The design is drawn as the glass shows
        // it onto planar coordinates, and glass and light both use that.
        let mut baked_from = None;
        if !planar && inst.planar {
            let (own, _, _) = uv_triangles(
                &sources[inst.source],
                inst,
                &tri_material[inst.source],
                tagging,
                inst.source,
                false,
            );
            if let Some(b) = design::beyond_unit_square(&own) {
                planar = true;
                baked_from = Some((own, b));
            }
        }
        // `fit` places a design on planar UVs only; on the model's own it was ignored without
        // a word, and a user who asked for `contain` saw the design cropped.
        if let Some(e) = entry
            && !planar
            && e.fit != crate::manifest::Fit::Cover
            && e.design.is_some()
        {
            report.warnings.push(Warning::new(
                &manifest.path,
                Some(e.line.0),
                format!(
                    "fit = \"{}\" has no effect on window {:?}: its glass has texture \
                     coordinates, which place the design; set uv = \"planar\" to fit the design \
                     to the window instead",
                    e.fit.name(),
                    inst.name
                ),
            ));
        }
        if planar {
            instances::write_planar_uvs(&mut sources[inst.source], inst);
        }
        let plan_textures = tagging.materials[material as usize].diffuse_texture.clone();
        let image = match entry.and_then(|e| e.design.clone()) {
            Some(p) => Some((ImageRef::File(p), DesignSource::Image)),
            // Glass without texture coordinates that names a colour texture (an MTL's
            // `map_Kd`): the image is the design, fitted to the window as a `--window` image
            // is. It was dropped for the mesh's colours without a word before.
            None => plan_textures.map(|t| {
                if !inst.has_uvs {
                    let shown = match &t {
                        ImageRef::File(f) => f.file_name().map_or(t.name(), |n| {
                            crate::import::text::file_name_for_display(
                                n,
                                sources[inst.source].text_encoding,
                            )
                        }),
                        other => other.name(),
                    };
                    let fit = entry.map_or(Fit::Cover, |e| e.fit);
                    fitted_textures.push((shown, fit, inst.name.clone()));
                }
                (t, DesignSource::Texture)
            }),
        };
        // `came_width` and `texels_per_metre` shape a design drawn from the panes; over an
        // image they did nothing, without a word (`uv = "planar"` on glass with a `map_Kd`).
        if let (Some(e), Some((_, source))) = (entry, &image) {
            let keys: Vec<&'static str> = [
                (
                    e.came_width != crate::manifest::DEFAULT_CAME_WIDTH,
                    "came_width",
                ),
                (e.texels_per_metre.is_some(), "texels_per_metre"),
            ]
            .into_iter()
            .filter_map(|(set, key)| set.then_some(key))
            .collect();
            if !keys.is_empty() {
                idle_keys
                    .entry(e.line.0)
                    .or_insert_with(|| (keys, *source, Vec::new()))
                    .2
                    .push(inst.name.clone());
            }
        }
        if let Some((_, b)) = &baked_from {
            let path = &sources[inst.source].path;
            // As the file writes them: an OBJ's v runs up, and is held flipped (images' rows
            // run down); the note said [-9, -6] of `vt` lines reading 7 to 10.
            let obj = path
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
            let (v0, v1) = if obj {
                (1.0 - b[3], 1.0 - b[1])
            } else {
                (b[1], b[3])
            };
            report.notes.push(Warning::new(
                path,
                None,
                format!(
                    "window {:?}: its glass's texture coordinates span [{:.3}, {:.3}] x \
                     [{:.3}, {:.3}], past the texture's square (a tiled design, or coordinates \
                     in metres), where a projector covers that square only; {}",
                    inst.name,
                    b[0],
                    b[2],
                    v0,
                    v1,
                    if image.is_some() {
                        "its design is drawn as the glass shows it onto planar coordinates \
                         (uv = \"planar\" fits it to the window once instead)"
                    } else {
                        "its design is placed by planar coordinates"
                    }
                ),
            ));
        }
        let baked_from = baked_from.filter(|_| image.is_some());
        let tinted = image
            .as_ref()
            .is_none_or(|(_, source)| *source == DesignSource::Texture);
        let triangles_of = |sources: &[Imported], tagging: &Tagging| {
            uv_triangles(
                &sources[inst.source],
                inst,
                &tri_material[inst.source],
                tagging,
                inst.source,
                tinted,
            )
        };
        let (mut tris, mut panes, mut tints) = triangles_of(sources, tagging);
        // A design drawn from the panes' colours is drawn where their texture coordinates put
        // them. Exporters often map every pane to the whole square (per-face or reset UVs): in
        // those coordinates the panes lie on one another and the last drawn covers the rest,
        // so a blue, red and gold window came out all gold. No image is placed by them, so
        // planar ones hold the same design, each pane where it is on the glass.
        let uv_mode = entry.map_or(UvMode::Auto, |e| e.uv);
        if !planar
            && image.is_none()
            && uv_mode == UvMode::Auto
            && inst.planar
            && panes.len() > 1
            && design::panes_overlap(&tris)
        {
            planar = true;
            instances::write_planar_uvs(&mut sources[inst.source], inst);
            (tris, panes, tints) = triangles_of(sources, tagging);
            report.notes.push(Warning::new(
                &sources[inst.source].path,
                None,
                format!(
                    "window {:?}: its panes' texture coordinates lie on one another, so the \
                     design drawn from their colours is placed by planar coordinates \
                     (uv = \"planar\" says so in a manifest)",
                    inst.name
                ),
            ));
        }
        // Glass without texture coordinates whose one pane names a texture: the texture is
        // fitted to the whole window, over the panes of other glass, whose colours are lost.
        if image
            .as_ref()
            .is_some_and(|(_, source)| *source == DesignSource::Texture)
            && !inst.has_uvs
            && panes.len() > 1
        {
            report.notes.push(Warning::new(
                &sources[inst.source].path,
                None,
                format!(
                    "window {:?}: the colour texture of its glass covers the whole window, over \
                     its {} other panes' own colours; a [[window]] entry with a design, or \
                     texture coordinates on the glass, place it otherwise",
                    inst.name,
                    panes.len() - 1
                ),
            ));
        }
        // A design decoded here for its mask may reach the texture stage only as pixels; the
        // file is still an input of the cook (and of its cache entry).
        if let Some((ImageRef::File(p), _)) = &image {
            report.inputs.push(p.clone());
        }
        let texels = match entry.and_then(|e| e.texels_per_metre) {
            Some(t) => t,
            None => {
                unit_used |= image.is_none();
                default_texels
            }
        };
        pending.push(Pending {
            material,
            name: inst.name.clone(),
            image,
            tris,
            panes,
            tints,
            srgb: entry.is_none_or(|e| e.colour_space == pack::ColourSpace::Srgb),
            planar,
            baked_from,
            extent: (inst.width(), inst.height()),
            fit: entry.map_or(Fit::Cover, |e| e.fit),
            aspect: inst.width() / inst.height().max(1e-12),
            size: design::design_size(inst.width(), inst.height(), texels),
            came_width: entry.map_or(crate::manifest::DEFAULT_CAME_WIDTH, |e| e.came_width),
            text_encoding: sources[inst.source].text_encoding,
        });
        let src_names: Vec<String> = {
            let src = &sources[inst.source];
            let mut v: Vec<String> = Vec::new();
            for &t in &inst.triangles {
                let part = &src.parts[src.tri_part[t as usize] as usize];
                let n = part
                    .material
                    .and_then(|m| src.materials.get(m as usize))
                    .map(|m| m.name.clone())
                    .or_else(|| part.names.material.clone())
                    .unwrap_or_else(|| {
                        names[tagging.part_material[inst.source][src.tri_part[t as usize] as usize]
                            as usize]
                            .clone()
                    });
                if !v.contains(&n) {
                    v.push(n);
                }
            }
            v
        };
        tagging.materials[material as usize].window = Some(Box::new(WindowPlan {
            // Made below, in parallel over the windows.
            design: ImageRef::Raster {
                name: String::new(),
                image: Arc::new(image::RgbaImage::new(0, 0)),
            },
            source: DesignSource::Mesh,
            colour_space: entry.map_or(pack::ColourSpace::Srgb, |e| e.colour_space),
            normal: entry.and_then(|e| {
                e.normal_map
                    .clone()
                    .map(|n| (ImageRef::File(n), e.normal_encoding, e.green))
            }),
            normal_strength: entry.and_then(|e| e.normal_strength),
            blur_sigma: entry.and_then(|e| e.blur_sigma),
            texture_format: entry.and_then(|e| e.texture_format),
            design_size: (0, 0),
            inside: [
                inst.inside.x as f32,
                inst.inside.y as f32,
                inst.inside.z as f32,
            ],
            materials: src_names,
            // A design a `--window` gave (merged into the manifest's entry, it has that
            // entry's line) is said of as that image, which the manifest does not name.
            said_at: entry.and_then(|e| {
                let given = e
                    .design
                    .as_ref()
                    .filter(|d| overrides.iter().any(|o| o.design.as_ref() == Some(*d)));
                match (given, e.line.0) {
                    (Some(design), _) => Some((design.clone(), None)),
                    (None, 0) => None,
                    (None, line) => Some((manifest.path.clone(), Some(line))),
                }
            }),
        }));
        out.material.push(material);
        if !inst.planar {
            report.warnings.push(Warning::new(
                &sources[inst.source].path,
                None,
                format!(
                    "window {:?} is curved: a vertex lies {:.4} from its plane ({:.1}% of its \
                     size); its projector assumes the fitted plane",
                    inst.name,
                    inst.max_deviation,
                    inst.max_deviation / (inst.width().hypot(inst.height())).max(1e-12) * 100.0
                ),
            ));
        }
    }
    for (line, (keys, source, windows)) in idle_keys {
        let shown = crate::report::few_names(&windows);
        let from = match source {
            DesignSource::Image => "the entry's design image",
            _ => "its glass's colour texture",
        };
        report.warnings.push(Warning::new(
            &manifest.path,
            Some(line),
            format!(
                "{} shape{} only a design drawn from the panes' colours; the design of {shown} \
                 is {from}, so {} no effect",
                keys.join(" and "),
                if keys.len() == 1 { "s" } else { "" },
                if keys.len() == 1 {
                    "it has"
                } else {
                    "they have"
                }
            ),
        ));
    }
    fitted_textures.sort_by(|a, b| (&a.0, a.1.name(), &a.2).cmp(&(&b.0, b.1.name(), &b.2)));
    for group in fitted_textures.chunk_by(|a, b| (&a.0, a.1) == (&b.0, b.1)) {
        let windows: Vec<&str> = group.iter().map(|(_, _, w)| w.as_str()).collect();
        let shown = if windows.len() > crate::report::shown_of(windows.len()) {
            format!("{} and {} more", windows[..3].join(", "), windows.len() - 3)
        } else {
            windows.join(", ")
        };
        report.notes.push(Warning::new(
            &manifest.path,
            None,
            format!(
                "texture {} is on glass without texture coordinates ({shown}): it is fitted \
                 to each window (fit {}); a [[window]] entry with its own design or fit \
                 chooses otherwise",
                group[0].0,
                group[0].1.name()
            ),
        ));
    }
    if let (true, Some((_, name))) = (unit_used, unit) {
        report.notes.push(Warning::new(
            &manifest.path,
            None,
            format!(
                "the windows are {}–{} units long (median {}): taken as {name}, so designs \
                 drawn from the mesh get {default_texels} texels per unit ({} per metre); set \
                 texels_per_metre on a [[window]] to choose",
                crate::report::length(sides[0]),
                crate::report::length(sides[sides.len() - 1]),
                crate::report::length(sides[sides.len() / 2]),
                crate::manifest::DEFAULT_TEXELS_PER_METRE,
            ),
        ));
    }
    // Windows made from the very same inputs (repeated lancets, one image on windows of one
    // shape) are made once: an 8000x6000 photo masked for each of 13 windows held 13 copies.
    let mut first_of: std::collections::HashMap<Vec<u32>, usize> = Default::default();
    let mut image_ids: Vec<&ImageRef> = Vec::new();
    let same_as: Vec<usize> = pending
        .iter()
        .enumerate()
        .map(|(i, p)| match p.inputs(&mut image_ids) {
            Some(key) => *first_of.entry(key).or_insert(i),
            None => i,
        })
        .collect();
    // A `--window` design in the colour space of the entries it merged with: its profile
    // applied where a window reads it as sRGB (declared linear, it was converted anyway).
    let mut settled: Vec<&Path> = Vec::new();
    for path in overrides.iter().filter_map(|o| o.design.as_deref()) {
        let named = |w: &WindowDesign| w.design.as_deref() == Some(path);
        if settled.contains(&path) || manifest.windows.iter().any(named) {
            continue;
        }
        settled.push(path);
        let uses: Vec<bool> = (pending.iter())
            .filter(|p| matches!(&p.image, Some((ImageRef::File(f), _)) if f == path))
            .map(|p| p.srgb)
            .collect();
        let srgb = uses.is_empty() || uses.contains(&true);
        if srgb {
            images.manage_colour(path);
        }
        crate::pipeline::say_profile(path, !srgb, report);
    }
    let capped = CappedDesigns::new(&pending, images, &settings.textures)?;
    let made: Vec<Option<Result<Design, CookError>>> = pending
        .par_iter()
        .enumerate()
        .map(|(i, p)| (same_as[i] == i).then(|| make_design(p, images, &capped)))
        .collect();
    // Said of an image where some window's design was made from its level within the cap;
    // one used as it is is reduced by the texture stage, which says so itself. Once per
    // image, read as sRGB or not (the note is the same).
    let mut noted: Vec<&ImageRef> = Vec::new();
    for r in &capped.reduced {
        let (image, srgb) = (&r.image, &r.srgb);
        if noted.contains(&image) {
            continue;
        }
        let used = pending.iter().zip(&made).any(|(p, d)| {
            p.image.as_ref().is_some_and(|(i, _)| i == image)
                && p.srgb == *srgb
                && matches!(d, Some(Ok((ImageRef::Raster { .. }, _, _))))
        });
        if used {
            noted.push(image);
            report.notes.push(Warning::new(
                &manifest.path,
                match image {
                    ImageRef::File(p) => {
                        manifest.naming(p, Some("window design")).map(|n| n.line.0)
                    }
                    _ => None,
                },
                format!("{}: {}", image.name(), capped.note(r)),
            ));
        }
    }
    drop(capped);
    let mut designs: Vec<Option<Design>> = Vec::with_capacity(made.len());
    for (i, d) in made.into_iter().enumerate() {
        designs.push(match d {
            Some(d) => Some(d?),
            None => designs[same_as[i]].clone(),
        });
    }
    let designs = one_copy_each(share_identical(designs.into_iter().flatten().collect()));
    // A design whose every texel is transparent lets no light through (its alpha is coverage:
    // lead and stone): the window is black and throws nothing. Said once per image.
    let mut said_dark: Vec<String> = Vec::new();
    for (design, source, _) in &designs {
        if *source == DesignSource::Mesh || said_dark.contains(&design.name()) {
            continue;
        }
        let img = images.get(design)?;
        // Stops at the first texel with any coverage, which most designs have at once.
        let transparent = img.color().has_alpha()
            && match img.as_rgba8() {
                Some(rgba) => rgba.pixels().all(|p| p[3] == 0),
                None => image::GenericImageView::pixels(&*img).all(|(_, _, p)| p[3] == 0),
            };
        if transparent {
            said_dark.push(design.name());
            let line = match design {
                ImageRef::File(p) => manifest.naming(p, Some("window design")).map(|n| n.line.0),
                _ => None,
            };
            report.warnings.push(Warning::new(
                &manifest.path,
                line,
                format!(
                    "design {} is transparent in every texel: a design's alpha is how much of \
                     it is glass, so its window is black and throws no light (clear glass is \
                     white and opaque)",
                    design.name()
                ),
            ));
        }
    }
    // Windows whose glass's diffuse colour was dropped, by that colour: one note each.
    let mut kd_dropped: Vec<(String, Vec<String>)> = Vec::new();
    for (p, (design, source, size)) in pending.iter().zip(designs) {
        let material = &mut tagging.materials[p.material as usize];
        // The window pass shows the design times the material's diffuse colour. A design
        // drawn from the panes already holds their transmitted colours, and real glass is
        // often `Kd 0 0 0` (its colour in `Tf`): times that, every window showed black. A
        // design given in the manifest or with `--window` is the glass as it is: times a red
        // `Kd`, its blue showed navy on the glass and in the god rays while the floor, lit by
        // the projector (the design alone), showed blue.
        // The glass's own texture likewise: the projector throws the texture alone, so times
        // a dark `Kd` (3ds Max glass: `Kd 0.2`, its colour in `Tf`) the glass showed dark brown
        // while the floor under it was lit bright orange. Kd is the light the glass reflects,
        // not what it lets through.
        let diffuse = &mut material.material.diffuse;
        if source == DesignSource::Texture && diffuse.iter().any(|&c| c < 254.5 / 255.0) {
            let kd = format!("[{:.2}, {:.2}, {:.2}]", diffuse[0], diffuse[1], diffuse[2]);
            match kd_dropped.iter_mut().find(|(k, _)| *k == kd) {
                Some((_, windows)) => windows.push(material.material.name.clone()),
                None => kd_dropped.push((kd, vec![material.material.name.clone()])),
            }
        }
        *diffuse = [1.0; 3];
        let plan = material.window.as_mut().expect("planned above");
        plan.design_size = size;
        plan.design = design;
        plan.source = source;
    }
    for (kd, windows) in kd_dropped {
        report.notes.push(Warning::new(
            &manifest.path,
            None,
            format!(
                "{} {}: the glass's texture is shown as the light it throws, not times the \
                 glass's diffuse colour {kd} (the light it reflects)",
                if windows.len() == 1 {
                    "window"
                } else {
                    "windows"
                },
                crate::report::few_names(&windows)
            ),
        ));
    }
    out.instances = found;
    Ok(out)
}

/// A raster's size and a hash of its texels: designs to compare texel by texel.
fn pixels_key(image: &image::RgbaImage) -> (u32, u32, u64) {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    image.as_raw().hash(&mut h);
    (image.width(), image.height(), h.finish())
}

/// Designs an image makes alike for several windows (one design masked to windows of one
/// shape) share one copy of their pixels. The texture stage cooks one texture of them (jobs
/// compare names and pixels), but each window's copy was held to its end: 24 MB of the
/// default scene's 64 MB heap peak, four textures' worth held as eleven.
fn one_copy_each(mut designs: Vec<Design>) -> Vec<Design> {
    let mut firsts: std::collections::HashMap<(String, u32, u32, u64), Vec<Arc<image::RgbaImage>>> =
        Default::default();
    for (design, _, _) in &mut designs {
        let ImageRef::Raster { name, image } = design else {
            continue;
        };
        let (w, h, hash) = pixels_key(image);
        let seen = firsts.entry((name.clone(), w, h, hash)).or_default();
        match seen.iter().find(|f| f.as_raw() == image.as_raw()) {
            Some(first) => *image = Arc::clone(first),
            None => seen.push(Arc::clone(image)),
        }
    }
    designs
}

/// Windows whose rasterized designs are texel for texel the same (thirty lancets of one glass)
/// get one image under one name, so the texture stage cooks and stores it once. The name drops
/// the windows' `#k` numbers when they all share the prefix.
fn share_identical(mut designs: Vec<Design>) -> Vec<Design> {
    use std::collections::HashMap;
    let mut groups: HashMap<(u32, u32, u64), Vec<Vec<usize>>> = HashMap::new();
    for (i, (design, source, _)) in designs.iter().enumerate() {
        let ImageRef::Raster { image, .. } = design else {
            continue;
        };
        if *source != DesignSource::Mesh {
            continue;
        }
        let buckets = groups.entry(pixels_key(image)).or_default();
        let same = |g: &Vec<usize>| match &designs[g[0]].0 {
            ImageRef::Raster { image: first, .. } => first.as_raw() == image.as_raw(),
            _ => false,
        };
        match buckets.iter_mut().find(|g| same(g)) {
            Some(g) => g.push(i),
            None => buckets.push(vec![i]),
        }
    }
    let mut shared: Vec<Vec<usize>> = groups
        .into_values()
        .flatten()
        .filter(|g| g.len() > 1)
        .collect();
    shared.sort();
    for g in shared {
        let ImageRef::Raster { name, image } = designs[g[0]].0.clone() else {
            continue;
        };
        let window = |n: &str| n.strip_suffix(".design").unwrap_or(n).to_string();
        let prefix = |n: &str| {
            let w = window(n);
            w.rsplit_once('#').map_or(w.clone(), |(p, _)| p.to_string())
        };
        // Named after every window it serves, not the first alone: `Glass_blue#1` listing
        // `design: Glass_red#1.design` read as a mistake.
        let mut stems: Vec<String> = Vec::new();
        for &i in &g {
            let p = prefix(&designs[i].0.name());
            if !stems.contains(&p) {
                stems.push(p);
            }
        }
        let name = match stems.len() {
            0 => name,
            1..=3 => format!("{}.design", stems.join("+")),
            n => format!("{}+{}+{}-more.design", stems[0], stems[1], n - 2),
        };
        for &i in &g {
            designs[i].0 = ImageRef::Raster {
                name: name.clone(),
                image: image.clone(),
            };
        }
    }
    designs
}

/// A window's design image, where it came from, and its size in texels.
type Design = (ImageRef, DesignSource, (u32, u32));

/// A window design still to make: what [`make_design`] needs, gathered sequentially.
struct Pending {
    material: u16,
    name: String,
    image: Option<(ImageRef, DesignSource)>,
    tris: Vec<UvTriangle>,
    panes: Vec<Pane>,
    /// The triangles' vertex colours, where the model has any other than white.
    tints: Option<Vec<Tint>>,
    /// The design's texels are sRGB (else linear), for tinting them.
    srgb: bool,
    planar: bool,
    /// The glass's own texture coordinates (in the order of `tris`, which are planar) where
    /// they reach past the texture's square, and their bounds: the design is baked through
    /// them.
    baked_from: Option<(Vec<UvTriangle>, [f32; 4])>,
    /// The window's width and height in scene units.
    extent: (f64, f64),
    fit: Fit,
    aspect: f64,
    size: (u32, u32),
    came_width: f32,
    /// The encoding of the model's names, for an image named on disk in it.
    text_encoding: Option<crate::import::text::TextEncoding>,
}

impl Pending {
    /// Everything [`make_design`] reads to make this design, exactly (as bits): two windows
    /// with equal inputs get equal designs. An image is keyed by its index in `image_ids`
    /// (images seen so far, compared by value). `None` for an image drawn through the glass's
    /// own coordinates, whose design is not only the image's.
    fn inputs<'a>(&'a self, image_ids: &mut Vec<&'a ImageRef>) -> Option<Vec<u32>> {
        let Some((img, source)) = &self.image else {
            return self.mesh_inputs();
        };
        if self.baked_from.is_some() {
            return None;
        }
        let id = match image_ids.iter().position(|&r| r == img) {
            Some(id) => id,
            None => {
                image_ids.push(img);
                image_ids.len() - 1
            }
        };
        let mut key = vec![
            u32::MAX - 1,
            id as u32,
            *source as u32,
            self.srgb as u32,
            self.planar as u32,
            self.fit as u32,
        ];
        for e in [self.aspect, self.extent.0, self.extent.1] {
            let b = e.to_bits();
            key.extend([b as u32, (b >> 32) as u32]);
        }
        key.extend([self.size.0, self.size.1]);
        // The design's name, from the file's, reads its bytes in this encoding.
        let encoding = self.text_encoding.map_or("", |e| e.name());
        key.push(encoding.len() as u32);
        key.extend(encoding.bytes().map(u32::from));
        self.push_outline(&mut key);
        Some(key)
    }

    /// The triangles in texture space and their tints, as bits, onto `key`.
    fn push_outline(&self, key: &mut Vec<u32>) {
        for (uv, pane) in &self.tris {
            key.extend(uv.iter().flat_map(|c| c.map(f32::to_bits)));
            key.push(*pane as u32);
        }
        if let Some(tints) = &self.tints {
            key.push(u32::MAX);
            key.extend(tints.iter().flatten().flatten().map(|c| c.to_bits()));
        }
    }

    /// Everything a design rasterized from the mesh depends on, exactly (as bits).
    fn mesh_inputs(&self) -> Option<Vec<u32>> {
        let mut key = vec![self.size.0, self.size.1, self.came_width.to_bits()];
        for p in &self.panes {
            key.extend(p.colour.map(f32::to_bits));
            key.push(p.amount.to_bits());
        }
        key.push(u32::MAX);
        self.push_outline(&mut key);
        Some(key)
    }
}

/// The size of a design baked through the glass's own texture coordinates, whose bounds are
/// `b` (`[u_min, v_min, u_max, v_max]`): the design's texels as dense as the glass shows them
/// (its texels times the coordinates' span, per scene unit, the denser axis), at least `least`
/// (the size a design drawn for the window gets, so the outline is resolved where a small
/// design is tiled), at most [`design::MAX_SIDE`].
fn baked_size(
    b: [f32; 4],
    design: &image::RgbaImage,
    (width, height): (f64, f64),
    least: (u32, u32),
) -> (u32, u32) {
    let (su, sv) = ((b[2] - b[0]) as f64, (b[3] - b[1]) as f64);
    let density = (design.width() as f64 * su / width.max(1e-12))
        .max(design.height() as f64 * sv / height.max(1e-12));
    let (mut w, mut h) = (width * density, height * density);
    let long = w.max(h);
    if long > design::MAX_SIDE as f64 {
        (w, h) = (
            w * design::MAX_SIDE as f64 / long,
            h * design::MAX_SIDE as f64 / long,
        );
    }
    let (w, h) = (w.round() as u32, h.round() as u32);
    if w < least.0 || h < least.1 {
        return least;
    }
    (w.clamp(1, design::MAX_SIDE), h.clamp(1, design::MAX_SIDE))
}

/// Design images over the size cap (`[textures] max_size`), each replaced by its first mip
/// level within the cap before it is fitted, masked or baked, as the texture stage would
/// replace the image given: masking the whole of an 8000x6000 photo for each of five windows
/// and reducing each result took 3.2 GB and 18 s where the cap kept 2000x1500 of it. Reduced
/// once per image, with the mip filter in the design's colour space.
struct CappedDesigns {
    cap: u32,
    reduced: Vec<Reduced>,
    /// Each design as windows read it, the colour under its fully transparent texels bled
    /// from its panes (`texture::pixels::bleed_under_transparent`), made once per image and
    /// colour space: fitting and outlining filter it as stored, so what an image editor left
    /// under the lead (white, often) haloed the panes.
    bled: std::sync::Mutex<Vec<(ImageRef, bool, Arc<image::DynamicImage>)>>,
}

/// A design image over the cap, in one colour space: its level within the cap.
struct Reduced {
    image: ImageRef,
    srgb: bool,
    level: Arc<image::DynamicImage>,
    /// The level's number.
    k: usize,
    /// The image's own size.
    size: (u32, u32),
}

impl CappedDesigns {
    fn new(
        pending: &[Pending],
        images: &crate::textures::DecodedImages,
        textures: &crate::settings::TextureSettings,
    ) -> Result<Self, CookError> {
        let Some(cap) = textures.max_size else {
            return Ok(Self {
                cap: 0,
                reduced: Vec::new(),
                bled: Default::default(),
            });
        };
        let mut distinct: Vec<(&ImageRef, bool)> = Vec::new();
        for p in pending {
            if let Some((img, _)) = &p.image
                && !distinct.iter().any(|&(d, s)| d == img && s == p.srgb)
            {
                distinct.push((img, p.srgb));
            }
        }
        // Per image: its level within the cap, the level's number and the image's size.
        type Level = Option<(usize, image::DynamicImage, (u32, u32))>;
        let made: Vec<Result<Level, CookError>> = distinct
            .par_iter()
            .map(|&(img, srgb)| {
                let decoded = images.get(img)?;
                let (opts, _) = crate::textures::colour_options(srgb, textures);
                let level = texture::first_level_within(&decoded, cap, &opts)
                    .map_err(|e| crate::textures::texture_error(Path::new(&img.name()), e))?;
                Ok(level.map(|(k, l)| (k, l, (decoded.width(), decoded.height()))))
            })
            .collect();
        let mut reduced = Vec::new();
        for ((img, srgb), level) in distinct.into_iter().zip(made) {
            if let Some((k, level, size)) = level? {
                reduced.push(Reduced {
                    image: img.clone(),
                    srgb,
                    level: Arc::new(level),
                    k,
                    size,
                });
            }
        }
        Ok(Self {
            cap,
            reduced,
            bled: Default::default(),
        })
    }

    /// What the cook says of a reduced image.
    fn note(&self, r: &Reduced) -> String {
        let (w, h) = r.size;
        format!(
            "{w}x{h} is over the size cap of {}: its windows' designs are made from its mip \
             level {}, {}x{}",
            self.cap,
            r.k,
            r.level.width(),
            r.level.height()
        )
    }

    /// `img` decoded, or its level within the cap, in the colour space `srgb` says; bled
    /// under its transparent texels (see `bled`).
    fn get(
        &self,
        img: &ImageRef,
        srgb: bool,
        images: &crate::textures::DecodedImages,
    ) -> Result<Arc<image::DynamicImage>, CookError> {
        let lock = || self.bled.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, _, d)) = lock().iter().find(|(i, s, _)| i == img && *s == srgb) {
            return Ok(Arc::clone(d));
        }
        let decoded = match self.find(img, srgb) {
            Some((level, _)) => Arc::clone(level),
            None => images.get(img)?,
        };
        let design = match texture::pixels::bleed_under_transparent(&decoded) {
            Some(bled) => Arc::new(bled),
            None => decoded,
        };
        let mut bled = lock();
        // Another window may have made it meanwhile: the first one made is kept, so every
        // window reads the same.
        if let Some((_, _, d)) = bled.iter().find(|(i, s, _)| i == img && *s == srgb) {
            return Ok(Arc::clone(d));
        }
        bled.push((img.clone(), srgb, Arc::clone(&design)));
        Ok(design)
    }

    /// `img`'s level within the cap, and the image's own size; `None` where it fits.
    fn find(&self, img: &ImageRef, srgb: bool) -> Option<(&Arc<image::DynamicImage>, (u32, u32))> {
        self.reduced
            .iter()
            .find(|r| r.image == *img && r.srgb == srgb)
            .map(|r| (&r.level, r.size))
    }
}

/// The design of one window: an image fitted and masked, or cut to the outline where it
/// would let light through stone, or rasterized from the panes; with its size in texels.
fn make_design(
    p: &Pending,
    images: &crate::textures::DecodedImages,
    capped: &CappedDesigns,
) -> Result<Design, CookError> {
    let get = |img: &ImageRef| capped.get(img, p.srgb, images);
    let Some((img, source)) = &p.image else {
        let (w, h) = p.size;
        let came = p.came_width * w.min(h) as f32;
        let img = design::mesh_design(&p.panes, &p.tris, p.tints.as_deref(), w, h, came);
        return Ok((
            raster(format!("{}.design", p.name), img),
            DesignSource::Mesh,
            (w, h),
        ));
    };
    // Named after the image, so windows that mask a design the same way share one texture
    // (jobs compare names and pixels).
    let stem = match img {
        ImageRef::File(f) => f
            .file_stem()
            .map(|s| crate::import::text::file_name_for_display(s, p.text_encoding))
            .unwrap_or_default(),
        other => other.name(),
    };
    let name = format!(
        "{stem}.{}{}",
        match (&p.baked_from, p.planar) {
            (Some(_), _) => "tiled",
            (None, true) => "fitted",
            (None, false) => "masked",
        },
        if p.tints.is_some() { ".tinted" } else { "" }
    );
    if let Some((own, bounds)) = &p.baked_from {
        let decoded = get(img)?;
        let pixels = rgba(&decoded);
        let (w, h) = baked_size(*bounds, &pixels, p.extent, p.size);
        let mut canvas = design::bake(&p.tris, own, &pixels, w, h);
        if let Some(tints) = &p.tints {
            design::tint_image(&mut canvas, &p.tris, tints, p.srgb);
        }
        return Ok((raster(name, canvas), *source, (w, h)));
    }
    if p.planar {
        let canvas = design::fit_design(&rgba(&*get(img)?), p.fit, p.aspect);
        let mut canvas = design::outline_resolved(&canvas, p.extent).unwrap_or(canvas);
        if let Some(tints) = &p.tints {
            design::tint_image(&mut canvas, &p.tris, tints, p.srgb);
        }
        let mask = design::coverage(&p.tris, canvas.width(), canvas.height());
        design::apply_mask(&mut canvas, &mask);
        let size = canvas.dimensions();
        return Ok((raster(name, canvas), *source, size));
    }
    // With the model's own UVs the design is used as it is, unless it would let light
    // through where the window has no glass.
    let decoded = get(img)?;
    let pixels = rgba(&decoded);
    // A design of a few texels (one colour for the whole window) resolves no outline at its
    // size: a 1x1 design's one texel is covered, so the light kept the square's corners
    // beyond a pointed lancet. Filtered up as the renderer samples it, then masked.
    let resolved = design::outline_resolved(&pixels, p.extent)
        .map(|up| {
            let mask = design::coverage(&p.tris, up.width(), up.height());
            (up, mask)
        })
        .filter(|(up, mask)| design::light_outside(up, mask));
    let (pixels, mask) = match resolved {
        Some((up, mask)) => (std::borrow::Cow::Owned(up), mask),
        None => {
            let (w, h) = pixels.dimensions();
            (pixels, design::coverage(&p.tris, w, h))
        }
    };
    let size = pixels.dimensions();
    let pixels = match &p.tints {
        Some(tints) => {
            let mut tinted = pixels.into_owned();
            design::tint_image(&mut tinted, &p.tris, tints, p.srgb);
            std::borrow::Cow::Owned(tinted)
        }
        None => pixels,
    };
    if design::light_outside(&pixels, &mask) {
        let mut pixels = pixels.into_owned();
        design::apply_mask(&mut pixels, &mask);
        Ok((raster(name, pixels), *source, size))
    } else if p.tints.is_some() {
        Ok((raster(name, pixels.into_owned()), *source, size))
    } else {
        // The image as it is, under its own name: a 16-bit design's 8-bit copy above is owned
        // too, and was taken for a tinted one (named `.masked` with nothing masked). Its own
        // size, not its level's within the size cap: the texture stage reads the image, and
        // sizes the projector's blur by it.
        let size = capped.find(img, p.srgb).map_or(size, |(_, own)| own);
        Ok((img.clone(), *source, size))
    }
}

/// The inside normal of a window material, if the window stage planned it.
pub fn inside_of(tagging: &Tagging, material: u16) -> Option<DVec3> {
    let w = tagging.materials.get(material as usize)?.window.as_ref()?;
    Some(DVec3::new(
        w.inside[0] as f64,
        w.inside[1] as f64,
        w.inside[2] as f64,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pending(image: &str, tris: Vec<UvTriangle>) -> Pending {
        Pending {
            material: 0,
            name: "w".into(),
            image: Some((ImageRef::File(image.into()), DesignSource::Image)),
            tris,
            panes: Vec::new(),
            tints: None,
            srgb: true,
            planar: false,
            baked_from: None,
            extent: (1.0, 3.0),
            fit: Fit::Cover,
            aspect: 1.0,
            size: (64, 192),
            came_width: 0.015,
            text_encoding: None,
        }
    }

    /// Windows given one image with the same outline are made once, whatever their names
    /// (an 8000x6000 photo masked for 13 windows held 13 copies); another image, another
    /// outline or another fit are other designs, as is one baked through the glass's own
    /// coordinates.
    #[test]
    fn one_image_on_windows_of_one_outline_is_one_design() {
        let tri = |x: f32| vec![([[x, 0.0], [1.0, 0.0], [0.5, 1.0]], 0)];
        let a = pending("a.png", tri(0.0));
        let mut renamed = pending("a.png", tri(0.0));
        renamed.name = "other".into();
        renamed.material = 3;
        let mut contain = pending("a.png", tri(0.0));
        contain.fit = Fit::Contain;
        let others = [
            pending("b.png", tri(0.0)),
            pending("a.png", tri(0.1)),
            contain,
        ];
        let mut baked = pending("a.png", tri(0.0));
        baked.baked_from = Some((tri(0.0), [0.0, 0.0, 2.0, 2.0]));
        let mut ids = Vec::new();
        assert_eq!(a.inputs(&mut ids), renamed.inputs(&mut ids));
        assert!(a.inputs(&mut ids).is_some());
        for other in &others {
            assert_ne!(a.inputs(&mut ids), other.inputs(&mut ids));
        }
        assert_eq!(baked.inputs(&mut ids), None);
        assert_eq!(ids.len(), 2, "images keyed once each");
    }
}
