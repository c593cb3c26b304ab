//! God-ray quality from an error budget: the committed table of measured god-ray settings
//! (`god_ray_table.json`, written by `bench --emit-god-ray-table`, see `docs/bench/`) and the
//! choice of the cheapest setting within a FLIP budget. It lives with the renderer it
//! describes, so configuring the renderer needs nothing from the cooker.
//!
//! Each row is the final image of the default scene against a 4096-sample reference, FLIP mean
//! and p99, and the god-ray pass time relative to one row of the same run: only ratios between
//! rows mean anything ([`GodRayTable::cost_vs_64_full`] gives the one the viewer prints).

use std::sync::OnceLock;

use serde::Deserialize;

use crate::GodRaySettings;

/// The committed measurements.
pub const GOD_RAY_TABLE_JSON: &str = include_str!("god_ray_table.json");

/// One god-ray configuration, measured on the default scene against a 4096-sample reference.
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct GodRayEntry {
    pub samples: u32,
    /// God-ray target size relative to the frame (1, 0.5, 0.25).
    pub resolution_scale: f32,
    pub jitter: bool,
    /// FLIP mean of the final image (0 = identical).
    pub flip_mean: f32,
    pub flip_p99: f32,
    /// God-ray pass time relative to one row of the same run: 64 samples at full resolution
    /// without jitter in tables the bench writes now, the default setting in the committed
    /// one (measured before that), so compare it only with rows of the same table.
    pub relative_cost: f32,
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct GodRayTable {
    pub generated_by: String,
    pub machine: String,
    /// Empty when the bench had no GPU adapter.
    #[serde(default)]
    pub god_rays: Vec<GodRayEntry>,
}

impl GodRayTable {
    /// The row of exactly this sample count, scale and jitter, if one was measured.
    pub fn row(&self, samples: u32, resolution_scale: f32, jitter: bool) -> Option<&GodRayEntry> {
        self.god_rays.iter().find(|e| {
            e.samples == samples && e.resolution_scale == resolution_scale && e.jitter == jitter
        })
    }

    /// The row of `g`'s sample count, resolution scale and jitter.
    pub fn measured(&self, g: &GodRaySettings) -> Option<&GodRayEntry> {
        self.row(g.samples, g.resolution_scale, g.jitter)
    }

    /// `e`'s cost in units of 64 samples at full resolution without jitter (the renderer's
    /// former default, the unit the README and the viewer quote); `None` without that row.
    pub fn cost_vs_64_full(&self, e: &GodRayEntry) -> Option<f32> {
        let unit = self.row(64, 1.0, false)?.relative_cost;
        (unit > 0.0).then(|| e.relative_cost / unit)
    }
}

/// The embedded table. A unit test parses it, so a malformed table never ships.
pub fn table() -> &'static GodRayTable {
    static TABLE: OnceLock<GodRayTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        serde_json::from_str(GOD_RAY_TABLE_JSON)
            .expect("god_ray_table.json is checked by a unit test")
    })
}

/// A god-ray setting for an error budget, with its measured error.
#[derive(Clone, Debug, PartialEq)]
pub struct GodRayChoice {
    pub samples: u32,
    pub resolution_scale: f32,
    pub jitter: bool,
    pub expected_flip_mean: f32,
    pub relative_cost: f32,
    pub warning: Option<String>,
}

/// The cheapest god-ray setting whose measured FLIP mean (final image against a 4096-sample
/// render) stays within `max_flip_mean`; when none does, the most accurate one and a warning.
/// `None` when the table has no god-ray measurements.
pub fn choose_god_rays(max_flip_mean: f32) -> Option<GodRayChoice> {
    choose_god_rays_in(table(), max_flip_mean)
}

pub fn choose_god_rays_in(table: &GodRayTable, max_flip_mean: f32) -> Option<GodRayChoice> {
    let budget = if max_flip_mean.is_nan() {
        f32::INFINITY
    } else {
        max_flip_mean
    };
    let by_cost = |a: &&GodRayEntry, b: &&GodRayEntry| {
        a.relative_cost
            .total_cmp(&b.relative_cost)
            .then(a.flip_mean.total_cmp(&b.flip_mean))
    };
    let within = table
        .god_rays
        .iter()
        .filter(|e| e.flip_mean <= budget)
        .min_by(by_cost);
    let (e, warning) = match within {
        Some(e) => (e, None),
        None => {
            let best = table.god_rays.iter().min_by(|a, b| {
                a.flip_mean
                    .total_cmp(&b.flip_mean)
                    .then(a.relative_cost.total_cmp(&b.relative_cost))
            })?;
            let w = format!(
                "god-ray error budget {budget} (FLIP mean) is tighter than any measured setting \
                 reaches (best: {} samples at {:.4}); using it",
                best.samples, best.flip_mean
            );
            (best, Some(w))
        }
    };
    Some(GodRayChoice {
        samples: e.samples,
        resolution_scale: e.resolution_scale,
        jitter: e.jitter,
        expected_flip_mean: e.flip_mean,
        relative_cost: e.relative_cost,
        warning,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(
        samples: u32,
        resolution_scale: f32,
        jitter: bool,
        flip: f32,
        cost: f32,
    ) -> GodRayEntry {
        GodRayEntry {
            samples,
            resolution_scale,
            jitter,
            flip_mean: flip,
            flip_p99: flip * 5.0,
            relative_cost: cost,
        }
    }

    fn synthetic() -> GodRayTable {
        GodRayTable {
            generated_by: "test".into(),
            machine: "test".into(),
            god_rays: vec![
                entry(16, 0.5, true, 0.04, 0.2),
                entry(64, 1.0, false, 0.01, 1.0),
            ],
        }
    }

    #[test]
    fn god_rays_cheapest_within_budget_or_most_accurate_with_warning() {
        let t = synthetic();
        let c = choose_god_rays_in(&t, 0.05).unwrap();
        assert_eq!((c.samples, c.resolution_scale, c.warning), (16, 0.5, None));
        let c = choose_god_rays_in(&t, 0.02).unwrap();
        assert_eq!(c.samples, 64);
        let c = choose_god_rays_in(&t, 0.001).unwrap();
        assert_eq!(c.samples, 64);
        assert!(c.warning.is_some());
        let empty = GodRayTable {
            god_rays: Vec::new(),
            ..t
        };
        assert!(choose_god_rays_in(&empty, 1.0).is_none());
    }

    #[test]
    fn embedded_table_parses_and_is_sane() {
        let t = table();
        assert!(!t.god_rays.is_empty());
        for e in &t.god_rays {
            assert!(
                e.flip_mean.is_finite() && e.flip_mean >= 0.0 && e.relative_cost > 0.0,
                "{e:?}"
            );
        }
    }

    /// The cost the viewer prints is against 64 samples at full resolution whatever row the
    /// bench divided by; the default's is the README's "about half".
    #[test]
    fn costs_are_quoted_against_64_samples_at_full_resolution() {
        let t = table();
        let e = t.measured(&GodRaySettings::default()).unwrap();
        let c = t.cost_vs_64_full(e).unwrap();
        assert!((0.4..0.6).contains(&c), "{c}");
        let unit = t.row(64, 1.0, false).unwrap();
        assert_eq!(t.cost_vs_64_full(unit), Some(1.0));
    }
}
