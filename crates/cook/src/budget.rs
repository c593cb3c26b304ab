//! The error budget: which blur and mip method to cook with for a maximum error a user asks for.
//!
//! The choice comes from a committed table of measured errors and relative costs
//! (`error_table.json`, written by `bench --emit-table` from a 4096x4096 sweep, see
//! `docs/bench/`), never from timings taken during a cook, so the same manifest always cooks
//! the same pack. Errors are in LSB of the 8-bit sRGB output against an f64 linear-light
//! reference (0.5 is the rounding floor); costs are relative to one unit measured in the same
//! run, so only their ratios mean anything.
//!
//! Method names are those of `texture::BlurMethod::name` (exact: `direct`, `decimated`;
//! approximations with a larger measured error: `decimated-coarse`, `box3`) and
//! `texture::MipFilter::name` (`box`, `kaiser`, `lanczos3`). An approximation is chosen only when
//! the budget allows its measured error and it is the cheapest method that fits.

use std::sync::OnceLock;

use serde::Deserialize;

/// The committed measurements.
pub const ERROR_TABLE_JSON: &str = include_str!("error_table.json");

#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct BlurEntry {
    pub method: String,
    pub sigma: f32,
    pub max_error_lsb: f32,
    pub rms_error_lsb: f32,
    pub relative_cost: f32,
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct MipEntry {
    pub filter: String,
    /// Filtered in linear light (true) or on the stored gamma-encoded values (false).
    pub linear_light: bool,
    /// Largest error over all levels, against the f64 linear-light chain of the same filter.
    pub max_error_lsb: f32,
    pub relative_cost: f32,
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct ErrorTable {
    pub generated_by: String,
    pub machine: String,
    pub image_size: u32,
    pub blur: Vec<BlurEntry>,
    pub mip: Vec<MipEntry>,
}

/// Block compression's default budget for colour textures without `--max-error-lsb`: RMS over
/// every channel of every level, LSB of the stored sRGB values. On the default scene it takes
/// ultra-fast for stone and sky and very-fast for the stained-glass designs (docs/bench).
pub const DEFAULT_COLOUR_ERROR_LSB: f32 = 4.0;
/// The same for projector textures, over red, green and blue (renderers never sample their
/// alpha). Stored at most `pack::PROJECTOR_MAX_SIZE` on a side, RGBA8 costs what BC7 at the
/// design's full size did, so a projector BC7 cannot keep within this stays RGBA8 (docs/bench).
pub const DEFAULT_PROJECTOR_ERROR_LSB: f32 = 1.0;
/// The same for normal maps: mean angle in degrees (`[textures] max_normal_error_deg`).
pub const DEFAULT_NORMAL_ERROR_DEG: f32 = 1.5;
/// The same for window designs (`[textures] max_design_error_lsb`). The designs are what the
/// viewer shows brightest, and they feed the god rays and the refraction. Measured on the
/// default scene at 1280x720 (FLIP mean of the final renders against the RGBA8 pack's, goal
/// 0.01): designs in BC7 very-fast (1.2-2.0 LSB RMS) 0.016-0.031; the same texels with the
/// unpadded mip geometry 0.011-0.016; only level 0 in BC7 0.004-0.013; designs exact
/// 0.007-0.009. No BC7 setting is below 1 LSB on them, so by default they stay RGBA8 (with
/// zstd smaller than BC7: docs/bench/README.md, "Block compression").
pub const DEFAULT_DESIGN_ERROR_LSB: f32 = 1.0;

/// The budget a block-compressed texture of `role` (`design`: a window's design) must fit:
/// mean angle in degrees for normal maps, RMS LSB otherwise. The scene's `max_error` (LSB)
/// replaces the colour defaults; `design_lsb` replaces it for designs.
pub fn compression_budget(
    (role, design): (pack::TextureRole, bool),
    max_error: Option<f32>,
    design_lsb: Option<f32>,
    normal_deg: f32,
) -> f32 {
    match role {
        pack::TextureRole::Normal => normal_deg,
        pack::TextureRole::Colour if design => {
            design_lsb.or(max_error).unwrap_or(DEFAULT_DESIGN_ERROR_LSB)
        }
        pack::TextureRole::Colour => max_error.unwrap_or(DEFAULT_COLOUR_ERROR_LSB),
        pack::TextureRole::Projector => max_error.unwrap_or(DEFAULT_PROJECTOR_ERROR_LSB),
    }
}

/// Encoder settings to try for a role, cheapest first (the order the bench's compression
/// sweep measured; docs/bench). BC7's basic and slow settings cost 5 to 20 times very-fast
/// for a fraction of a dB there, so the cook stops at very-fast; normal maps have BC5 only.
pub fn compression_candidates(role: pack::TextureRole) -> Vec<texture::bc::Codec> {
    use texture::bc::{Bc7Profile, Codec};
    match role {
        pack::TextureRole::Normal => vec![Codec::Bc5],
        pack::TextureRole::Colour | pack::TextureRole::Projector => vec![
            Codec::Bc7(Bc7Profile::UltraFast),
            Codec::Bc7(Bc7Profile::VeryFast),
        ],
    }
}

/// The embedded table. A unit test parses it, so a malformed table never ships.
pub fn table() -> &'static ErrorTable {
    static TABLE: OnceLock<ErrorTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        serde_json::from_str(ERROR_TABLE_JSON).expect("error_table.json is checked by a unit test")
    })
}

/// What to cook with, and what error to expect.
#[derive(Clone, Debug, PartialEq)]
pub struct Choice {
    /// `texture::BlurMethod::name` or `texture::MipFilter::name`.
    pub method: String,
    /// Mips: filter in linear light. Always true for blur, which is only done in linear light.
    pub linear_light: bool,
    /// Measured max error, LSB.
    pub expected_error: f32,
    /// Relative cost from the table (comparable between choices of the same kind only).
    pub relative_cost: f32,
    /// Set when no method meets the budget and the most accurate one was chosen.
    pub warning: Option<String>,
}

impl Choice {
    /// The blur method to cook with, for `texture::ProjectorOptions::method`; `None` when the
    /// name is not a blur method (a mip choice).
    pub fn blur_method(&self) -> Option<texture::BlurMethod> {
        texture::BlurMethod::ALL
            .into_iter()
            .find(|m| m.name() == self.method)
    }

    /// The mip filter to cook with, for `texture::ColourOptions::filter`; `None` when the name
    /// is not a mip filter (a blur choice). Filter in linear light when
    /// [`Choice::linear_light`] (`ColourOptions::srgb` for an sRGB texture).
    pub fn mip_filter(&self) -> Option<texture::MipFilter> {
        [
            texture::MipFilter::Box,
            texture::MipFilter::Kaiser,
            texture::MipFilter::Lanczos3,
        ]
        .into_iter()
        .find(|f| f.name() == self.method)
    }
}

struct Candidate {
    method: String,
    linear_light: bool,
    error: f32,
    cost: f32,
}

/// The cheapest candidate within `budget`, or the most accurate one with a warning.
fn pick(candidates: Vec<Candidate>, budget: f32, what: &str) -> Option<Choice> {
    let within = candidates
        .iter()
        .filter(|c| c.error <= budget)
        .min_by(|a, b| a.cost.total_cmp(&b.cost).then(a.error.total_cmp(&b.error)));
    let (c, warning) = match within {
        Some(c) => (c, None),
        None => {
            let best = candidates
                .iter()
                .min_by(|a, b| a.error.total_cmp(&b.error).then(a.cost.total_cmp(&b.cost)))?;
            let warning = format!(
                "error budget {budget} LSB is tighter than any {what} reaches (best: {} at \
                 {:.3} LSB; 0.5 LSB is the 8-bit rounding floor); using {}",
                best.method, best.error, best.method
            );
            (best, Some(warning))
        }
    };
    Some(Choice {
        method: c.method.clone(),
        linear_light: c.linear_light,
        expected_error: c.error,
        relative_cost: c.cost,
        warning,
    })
}

/// The measured σ values bracketing `sigma` (both the nearest one at the ends of the table).
fn bracket(sigmas: &[f32], sigma: f32) -> Option<(f32, f32)> {
    let lo = sigmas
        .iter()
        .copied()
        .filter(|&s| s <= sigma)
        .reduce(f32::max);
    let hi = sigmas
        .iter()
        .copied()
        .filter(|&s| s >= sigma)
        .reduce(f32::min);
    match (lo, hi) {
        (Some(l), Some(h)) => Some((l, h)),
        (Some(l), None) => Some((l, l)),
        (None, Some(h)) => Some((h, h)),
        (None, None) => None,
    }
}

/// The cheapest blur method whose measured error at `sigma` stays within `max_error_lsb`;
/// when none does, the most accurate one and a warning.
///
/// Between two measured σ a method's error is taken as the larger of the two (the table's
/// errors barely move with σ, and a budget must not be exceeded by interpolation) and its cost
/// is interpolated in log σ. A method counts at `sigma` only when both bracketing σ measured
/// it (the decimated blur exists only from σ ≈ 3.8). A NaN budget means no budget: the
/// cheapest method.
pub fn choose_blur(max_error_lsb: f32, sigma: f32) -> Choice {
    choose_blur_in(table(), max_error_lsb, sigma).expect("the embedded table has blur entries")
}

pub fn choose_blur_in(table: &ErrorTable, max_error_lsb: f32, sigma: f32) -> Option<Choice> {
    let budget = if max_error_lsb.is_nan() {
        f32::INFINITY
    } else {
        max_error_lsb
    };
    let mut sigmas: Vec<f32> = table.blur.iter().map(|e| e.sigma).collect();
    sigmas.sort_by(f32::total_cmp);
    sigmas.dedup();
    let sigma = if sigma.is_finite() { sigma } else { 0.0 };
    let (lo, hi) = bracket(&sigmas, sigma)?;
    let mut methods: Vec<&str> = table.blur.iter().map(|e| e.method.as_str()).collect();
    methods.dedup();
    let mut seen = Vec::new();
    let mut candidates = Vec::new();
    for m in methods {
        if seen.contains(&m) {
            continue;
        }
        seen.push(m);
        let at = |s: f32| table.blur.iter().find(|e| e.method == m && e.sigma == s);
        let (Some(a), Some(b)) = (at(lo), at(hi)) else {
            continue;
        };
        let t = if hi > lo && sigma > lo {
            ((sigma / lo).ln() / (hi / lo).ln()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let cost = (a.relative_cost.ln() * (1.0 - t) + b.relative_cost.ln() * t).exp();
        candidates.push(Candidate {
            method: m.to_string(),
            linear_light: true,
            error: a.max_error_lsb.max(b.max_error_lsb),
            cost,
        });
    }
    pick(candidates, budget, &format!("blur at sigma {sigma}"))
}

/// The cheapest mip method within `max_error_lsb` (error against the f64 linear-light chain of
/// the same filter, worst level). `filter` restricts the choice to one filter (the manifest's
/// `mip_filter`), so only linear light against gamma space is decided; `None` lets any filter
/// win. When none meets the budget: the most accurate one and a warning.
pub fn choose_mip(max_error_lsb: f32, filter: Option<&str>) -> Choice {
    choose_mip_in(table(), max_error_lsb, filter)
        .or_else(|| choose_mip_in(table(), max_error_lsb, None))
        .expect("the embedded table has mip entries")
}

pub fn choose_mip_in(
    table: &ErrorTable,
    max_error_lsb: f32,
    filter: Option<&str>,
) -> Option<Choice> {
    let budget = if max_error_lsb.is_nan() {
        f32::INFINITY
    } else {
        max_error_lsb
    };
    let candidates = table
        .mip
        .iter()
        .filter(|e| filter.is_none_or(|f| f == e.filter))
        .map(|e| Candidate {
            method: e.filter.clone(),
            linear_light: e.linear_light,
            error: e.max_error_lsb,
            cost: e.relative_cost,
        })
        .collect();
    pick(candidates, budget, "mip filter")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn designs_have_their_own_budget_which_the_specific_setting_overrides() {
        use pack::TextureRole::{Colour, Normal, Projector};
        let b = |role, design, max, design_lsb| {
            compression_budget((role, design), max, design_lsb, 1.5)
        };
        assert_eq!(b(Colour, true, None, None), DEFAULT_DESIGN_ERROR_LSB);
        assert_eq!(b(Colour, false, None, None), DEFAULT_COLOUR_ERROR_LSB);
        assert_eq!(b(Projector, false, None, None), DEFAULT_PROJECTOR_ERROR_LSB);
        assert_eq!(b(Normal, false, Some(9.0), Some(9.0)), 1.5);
        // `[scene] max_error` / `--max-error-lsb` sets every LSB budget...
        assert_eq!(b(Colour, true, Some(3.0), None), 3.0);
        assert_eq!(b(Colour, false, Some(3.0), None), 3.0);
        // ...except where `[textures] max_design_error_lsb` names the designs' own.
        assert_eq!(b(Colour, true, Some(3.0), Some(0.5)), 0.5);
        assert_eq!(b(Colour, false, Some(3.0), Some(0.5)), 3.0);
    }

    fn blur(method: &str, sigma: f32, err: f32, cost: f32) -> BlurEntry {
        BlurEntry {
            method: method.into(),
            sigma,
            max_error_lsb: err,
            rms_error_lsb: err / 2.0,
            relative_cost: cost,
        }
    }

    fn synthetic() -> ErrorTable {
        ErrorTable {
            generated_by: "test".into(),
            machine: "test".into(),
            image_size: 64,
            blur: vec![
                blur("direct", 1.0, 0.50, 1.0),
                blur("direct", 4.0, 0.51, 4.0),
                blur("direct", 16.0, 0.52, 16.0),
                blur("decimated", 4.0, 0.60, 2.0),
                blur("decimated", 16.0, 0.55, 2.0),
            ],
            mip: vec![
                MipEntry {
                    filter: "box".into(),
                    linear_light: true,
                    max_error_lsb: 0.5,
                    relative_cost: 1.0,
                },
                MipEntry {
                    filter: "box".into(),
                    linear_light: false,
                    max_error_lsb: 45.0,
                    relative_cost: 0.5,
                },
                MipEntry {
                    filter: "lanczos3".into(),
                    linear_light: true,
                    max_error_lsb: 0.52,
                    relative_cost: 3.0,
                },
            ],
        }
    }

    #[test]
    fn embedded_table_parses_and_covers_both_kinds() {
        let t = table();
        assert!(!t.blur.is_empty() && !t.mip.is_empty());
        for e in &t.blur {
            assert!(
                e.max_error_lsb.is_finite() && e.max_error_lsb >= 0.0,
                "{e:?}"
            );
            assert!(e.relative_cost > 0.0, "{e:?}");
        }
        for e in &t.mip {
            assert!(
                e.max_error_lsb.is_finite() && e.relative_cost > 0.0,
                "{e:?}"
            );
        }
        // The cooker's blur methods must all be exact to within the texture issue's bar.
        for e in t.blur.iter().filter(|e| e.method == "direct") {
            assert!(e.max_error_lsb <= 0.55, "{e:?}");
        }
    }

    #[test]
    fn every_method_in_the_embedded_table_is_one_the_texture_crate_runs() {
        for e in &table().blur {
            let c = choose_blur(f32::INFINITY, e.sigma);
            assert!(c.blur_method().is_some(), "{c:?}");
            let named = Choice {
                method: e.method.clone(),
                ..c
            };
            assert!(
                named.blur_method().is_some(),
                "unknown blur method {:?}",
                e.method
            );
        }
        for e in &table().mip {
            let c = choose_mip(f32::INFINITY, Some(&e.filter));
            assert_eq!(c.mip_filter().map(|f| f.name()), Some(e.filter.as_str()));
        }
    }

    #[test]
    fn cheapest_within_budget_wins() {
        let t = synthetic();
        let c = choose_blur_in(&t, 1.0, 16.0).unwrap();
        assert_eq!((c.method.as_str(), c.warning), ("decimated", None));
        // A tighter budget rules the decimated blur out at σ = 16.
        let c = choose_blur_in(&t, 0.53, 16.0).unwrap();
        assert_eq!(c.method, "direct");
        assert_eq!(c.expected_error, 0.52);
    }

    #[test]
    fn between_measured_sigmas_error_is_the_worse_and_cost_interpolates() {
        let t = synthetic();
        let c = choose_blur_in(&t, 0.58, 8.0).unwrap();
        // decimated: max(0.60, 0.55) = 0.60 > 0.58, so direct, at a cost between 4 and 16.
        assert_eq!(c.method, "direct");
        assert_eq!(c.expected_error, 0.52);
        assert!((c.relative_cost - 8.0).abs() < 1e-3, "{}", c.relative_cost);
    }

    #[test]
    fn method_missing_at_small_sigma_is_not_offered() {
        let t = synthetic();
        let c = choose_blur_in(&t, 10.0, 2.0).unwrap();
        assert_eq!(c.method, "direct");
        // Beyond the table's ends the nearest measured σ stands in.
        assert_eq!(
            choose_blur_in(&t, 10.0, 1000.0).unwrap().method,
            "decimated"
        );
        assert_eq!(choose_blur_in(&t, 10.0, 0.0).unwrap().method, "direct");
    }

    #[test]
    fn too_tight_a_budget_uses_the_most_accurate_and_warns() {
        let t = synthetic();
        let c = choose_blur_in(&t, 0.1, 16.0).unwrap();
        assert_eq!(c.method, "direct");
        let w = c.warning.expect("warning");
        assert!(w.contains("0.1") && w.contains("direct"), "{w}");
        let m = choose_mip_in(&t, 0.2, None).unwrap();
        assert_eq!((m.method.as_str(), m.linear_light), ("box", true));
        assert!(m.warning.is_some());
    }

    #[test]
    fn mips_reject_gamma_space_unless_the_budget_allows_it() {
        let t = synthetic();
        let m = choose_mip_in(&t, 1.0, Some("box")).unwrap();
        assert_eq!(
            (m.method.as_str(), m.linear_light, m.warning),
            ("box", true, None)
        );
        let m = choose_mip_in(&t, 100.0, Some("box")).unwrap();
        assert!(!m.linear_light);
        let m = choose_mip_in(&t, 0.53, Some("lanczos3")).unwrap();
        assert_eq!(m.method, "lanczos3");
        assert!(choose_mip_in(&t, 1.0, Some("kaiser")).is_none());
        // NaN means no budget at all: the cheapest.
        assert!(!choose_mip_in(&t, f32::NAN, None).unwrap().linear_light);
    }

    #[test]
    fn a_loose_budget_picks_an_approximation_and_a_tight_one_never_does() {
        let t = table();
        let cheapest = |sigma: f32, approx: bool| {
            t.blur
                .iter()
                .filter(|e| e.sigma == sigma)
                .filter(|e| {
                    let m = texture::BlurMethod::ALL
                        .into_iter()
                        .find(|m| m.name() == e.method);
                    m.expect("known method").is_approximation() == approx
                })
                .map(|e| e.relative_cost)
                .reduce(f32::min)
        };
        let mut sigmas: Vec<f32> = t.blur.iter().map(|e| e.sigma).collect();
        sigmas.dedup();
        // Where an approximation was measured cheaper than every exact method, a user who
        // allows its error gets it; the table must show that for most σ, or the approximations
        // are not worth offering.
        let mut faster = 0;
        for &sigma in &sigmas {
            let exact = choose_blur(0.55, sigma);
            assert!(
                !exact.blur_method().unwrap().is_approximation(),
                "sigma {sigma}: {exact:?}"
            );
            let (Some(a), Some(e)) = (cheapest(sigma, true), cheapest(sigma, false)) else {
                continue;
            };
            if a < e {
                faster += 1;
                let c = choose_blur(30.0, sigma);
                let m = c.blur_method().expect("a blur method");
                assert!(m.is_approximation(), "sigma {sigma}: {c:?}");
                assert!(c.expected_error > 0.55 && c.expected_error <= 30.0, "{c:?}");
                assert_eq!(c.warning, None);
                assert!(c.relative_cost < exact.relative_cost, "{c:?} {exact:?}");
            }
        }
        assert!(faster >= 3, "approximations faster at only {faster} σ");
    }

    #[test]
    fn approximations_compete_on_cost_within_the_budget() {
        let mut t = synthetic();
        t.blur.extend([
            blur("decimated-coarse", 4.0, 3.0, 1.0),
            blur("decimated-coarse", 16.0, 3.5, 1.0),
            blur("box3", 4.0, 12.0, 1.5),
            blur("box3", 16.0, 8.0, 0.5),
        ]);
        // Budget 4: box3 (cheaper at σ = 16) is over it, so the coarse grid.
        let c = choose_blur_in(&t, 4.0, 16.0).unwrap();
        assert_eq!(c.method, "decimated-coarse");
        assert_eq!(c.blur_method(), Some(texture::BlurMethod::DecimatedCoarse));
        // Budget 10: box3 fits and is cheapest; between σ 4 and 16 its error is the worse of
        // the two (12), so at σ = 8 it does not fit a budget of 10.
        assert_eq!(choose_blur_in(&t, 10.0, 16.0).unwrap().method, "box3");
        assert_eq!(
            choose_blur_in(&t, 10.0, 8.0).unwrap().method,
            "decimated-coarse"
        );
        assert_eq!(
            choose_blur_in(&t, 10.0, 16.0).unwrap().blur_method(),
            Some(texture::BlurMethod::Box3)
        );
        // An exact budget ignores them.
        assert_eq!(choose_blur_in(&t, 0.55, 16.0).unwrap().method, "decimated");
        assert_eq!(choose_blur_in(&t, 0.52, 16.0).unwrap().method, "direct");
    }

    #[test]
    fn real_table_answers_for_every_sigma() {
        for s in [0.0, 0.5, 1.0, 3.0, 7.0, 50.0, 1e4, f32::NAN] {
            let c = choose_blur(0.55, s);
            assert!(c.expected_error.is_finite(), "{s}: {c:?}");
        }
        let c = choose_mip(0.6, Some("box"));
        assert!(c.linear_light, "{c:?}");
    }
}
