//! Tangents: the cooker's MikkTSpace (`cook::mesh::tangents`) against the `mikktspace` crate,
//! the reference a user would otherwise pick, on the same corners: a real model with UV seams
//! and a generated height field with normals and UVs, both as the cooker's mesh stage leaves
//! them (generated normals, deduplicated vertices, cache-optimized order).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use cook::mesh::tangents::{CornerArrays, generate};
use cook::mesh::{MaterialNeeds, MeshSettings, process};
use serde::{Deserialize, Serialize};

use crate::common::median_ms;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TangentRow {
    pub mesh: String,
    pub triangles: usize,
    pub runs: usize,
    /// The `mikktspace` crate (one thread: it has no parallel path).
    pub reference_ms: f64,
    /// Ours on every core of this machine.
    pub ours_ms: f64,
    /// Ours on one thread.
    pub ours_one_thread_ms: f64,
    /// Largest difference of a tangent component from the reference's, and whether every sign
    /// agrees.
    pub max_difference: f64,
    pub signs_agree: bool,
}

pub struct TangentConfig {
    /// Side of the generated height field in quads (2·n² triangles).
    pub grid: usize,
    pub runs: usize,
    /// Keenan Crane's Spot from the test data, when there.
    pub model: Option<PathBuf>,
}

/// Spot from the project's test data, when it is there.
pub fn spot_path() -> Option<PathBuf> {
    let p =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/third_party/classic/spot.obj");
    p.is_file().then_some(p)
}

struct Corners {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
}

impl Corners {
    fn arrays(&self) -> CornerArrays<'_> {
        CornerArrays {
            positions: &self.positions,
            normals: &self.normals,
            uvs: &self.uvs,
        }
    }
}

fn cooked_corners(src: &cook::import::Imported) -> Corners {
    let needs = [MaterialNeeds {
        tangents: true,
        ..MaterialNeeds::OPAQUE
    }];
    let p = process(
        src,
        &vec![0; src.triangle_count()],
        &needs,
        &MeshSettings {
            analyze: false,
            ..MeshSettings::default()
        },
    );
    let v = |i: &u32| p.vertices.get(*i as usize);
    Corners {
        positions: p.indices.iter().map(|i| v(i).position).collect(),
        normals: p.indices.iter().map(|i| v(i).normal).collect(),
        uvs: p.indices.iter().map(|i| v(i).uv).collect(),
    }
}

fn measure(name: &str, c: &Corners, runs: usize) -> Result<TangentRow> {
    let (reference_ms, theirs) = median_ms(runs, || cook::mesh::tangents::reference(&c.arrays()));
    let theirs = theirs.with_context(|| format!("the mikktspace crate failed on {name}"))?;
    let (ours_ms, ours) = median_ms(runs, || generate(&c.arrays()));
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .context("a one-thread pool")?;
    let (ours_one_thread_ms, _) = median_ms(runs, || one.install(|| generate(&c.arrays())));
    let mut max_difference = 0.0f64;
    let mut signs_agree = true;
    for (a, b) in ours.iter().zip(&theirs) {
        for k in 0..3 {
            max_difference = max_difference.max((a[k] - b[k]).abs() as f64);
        }
        signs_agree &= a[3] == b[3];
    }
    Ok(TangentRow {
        mesh: name.to_string(),
        triangles: c.positions.len() / 3,
        runs,
        reference_ms,
        ours_ms,
        ours_one_thread_ms,
        max_difference,
        signs_agree,
    })
}

pub fn sweep(cfg: &TangentConfig, progress: &mut dyn FnMut(&str)) -> Result<Vec<TangentRow>> {
    let mut rows = Vec::new();
    if let Some(path) = &cfg.model {
        let src =
            cook::import::import(path).with_context(|| format!("importing {}", path.display()))?;
        progress("tangents: Spot");
        rows.push(measure("Spot (UV seams)", &cooked_corners(&src), cfg.runs)?);
    }
    let n = cfg.grid;
    let text = cook::testing::height_field_obj_with_normals_and_uvs(n);
    let src = cook::import::obj::parse(Path::new("height-field.obj"), text.as_bytes())
        .context("parsing the generated height field")?;
    drop(text);
    progress(&format!("tangents: {n}x{n} height field"));
    rows.push(measure(
        &format!("generated {n}x{n} height field with normals and UVs"),
        &cooked_corners(&src),
        cfg.runs,
    )?);
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_sweep_agrees_with_the_reference() {
        let rows = sweep(
            &TangentConfig {
                grid: 20,
                runs: 1,
                model: spot_path(),
            },
            &mut |_| {},
        )
        .unwrap();
        assert_eq!(rows.len(), 2, "Spot is in the test data");
        for r in rows {
            assert!(r.max_difference <= 1e-5 && r.signs_agree, "{r:?}");
            assert!(r.reference_ms > 0.0 && r.ours_ms > 0.0);
        }
    }
}
