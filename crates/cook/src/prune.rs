//! What the scene defines but nothing uses is not cooked: materials left without triangles
//! and source materials no triangle names, each reported on a `skipped:` line with the
//! textures that were therefore not cooked.

use crate::manifest::Manifest;
use crate::report::Report;
use crate::{import, mesh, tag};

/// Removes materials that no processed triangle uses from the material table, renumbers the
/// material IDs in vertices and draw ranges (order-preserving, so ranges stay sorted and
/// windows last), and reports each one with the textures it would have needed.
pub(crate) fn unused_materials(
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
/// the table and renumbers material IDs, as [`unused_materials`] does for the cook.
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
        for m in &mut p.vertices.materials {
            *m = remap[*m as usize];
        }
        p.ranges.retain(|r| r.index_count > 0);
        for r in &mut p.ranges {
            r.material = remap[r.material as usize];
        }
    }
}

fn nor_textures(textures: &[String]) -> String {
    if textures.is_empty() {
        String::new()
    } else {
        format!(", nor its textures ({})", textures.join(", "))
    }
}

/// Source materials (an MTL entry, a glTF material) that no triangle uses never become pack
/// materials; say so, with the textures that were therefore not cooked: a line each, or, where
/// one source has more than [`crate::report::NAMED`] (a shared MTL library), one line for them.
pub(crate) fn unused_source_materials(
    sources: &[import::Imported],
    tagging: &tag::Tagging,
    report: &mut Report,
) {
    let textures_of = |src: &import::Imported, name: &str| -> Vec<String> {
        src.materials
            .iter()
            .filter(|m| m.name == name)
            .flat_map(|m| [&m.diffuse_texture, &m.normal_texture])
            .flatten()
            .map(|t| t.name())
            .collect()
    };
    for (si, src) in sources.iter().enumerate() {
        let names: Vec<&str> = tagging
            .unused_source_materials
            .iter()
            .filter(|(s, _)| *s == si)
            .map(|(_, n)| n.as_str())
            .collect();
        if names.len() <= crate::report::NAMED {
            for name in names {
                report.skipped.push(format!(
                    "material {name:?} of {}: defined but no triangle uses it, not cooked{}",
                    src.path.display(),
                    nor_textures(&textures_of(src, name))
                ));
            }
            continue;
        }
        let textures: Vec<String> = names.iter().flat_map(|n| textures_of(src, n)).collect();
        let nor = if textures.is_empty() {
            String::new()
        } else {
            format!(
                ", nor their {} textures ({})",
                textures.len(),
                crate::report::few_names(&textures)
            )
        };
        report.skipped.push(format!(
            "{} materials of {} ({}): defined but no triangle uses them, not cooked{nor}",
            names.len(),
            src.path.display(),
            crate::report::few_names(&names)
        ));
    }
}
