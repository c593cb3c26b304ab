//! God-ray settings from an error budget (`--max-flip`) and the measured error of a setting,
//! both from the table `render::budget` embeds (measured by `bench` on the default scene
//! against a 4096-sample reference).

use anyhow::{Result, bail};
use render::GodRaySettings;
use render::budget::{GodRayChoice, GodRayEntry, choose_god_rays, table};

/// Parses a `--max-flip` value: a FLIP mean, in [0, 1].
pub fn parse_flip_mean(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if !(0.0..=1.0).contains(&v) {
        return Err(format!("{v} is not a FLIP mean (0 = identical, 1 = worst)"));
    }
    Ok(v)
}

/// Parses a `--ray-scale` value: the god-ray target's size relative to the frame.
pub fn parse_scale(s: &str) -> Result<f32, String> {
    let v: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if !(0.125..=1.0).contains(&v) {
        return Err(format!(
            "{v} is outside 0.125..=1 (1 full, 0.5 half, 0.25 quarter)"
        ));
    }
    Ok(v)
}

/// The measured row of exactly this sample count, scale and jitter, if the table has one.
pub fn measured(g: &GodRaySettings) -> Option<&'static GodRayEntry> {
    table().measured(g)
}

/// "128 samples, half resolution, no jitter".
pub fn describe(g: &GodRaySettings) -> String {
    let scale = match g.resolution_scale {
        1.0 => "full resolution".to_string(),
        0.5 => "half resolution".to_string(),
        0.25 => "quarter resolution".to_string(),
        s => format!("resolution scale {s}"),
    };
    format!(
        "{} sample{}, {scale}, {}",
        g.samples,
        if g.samples == 1 { "" } else { "s" },
        if g.jitter { "jitter" } else { "no jitter" }
    )
}

/// What the measured table says about `g`, for printing and the panel.
pub fn measured_note(g: &GodRaySettings) -> String {
    match measured(g) {
        Some(e) => {
            let cost = match table().cost_vs_64_full(e) {
                Some(c) => format!(", cost {c:.3}× 64 samples at full resolution"),
                None => String::new(),
            };
            format!(
                "measured FLIP mean {:.4} (p99 {:.4}){cost}",
                e.flip_mean, e.flip_p99
            )
        }
        None => "not a measured setting".to_string(),
    }
}

/// Applies the cheapest measured setting within `max_flip_mean` to `g` (sample count,
/// resolution scale, jitter; the look parameters stay) and returns the choice.
pub fn apply_budget(max_flip_mean: f32, g: &mut GodRaySettings) -> Result<GodRayChoice> {
    let Some(choice) = choose_god_rays(max_flip_mean) else {
        bail!("--max-flip: the committed god-ray table has no measurements");
    };
    g.samples = choice.samples;
    g.resolution_scale = choice.resolution_scale;
    g.jitter = choice.jitter;
    Ok(choice)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_is_measured_and_on_the_pareto_front() {
        let d = GodRaySettings::default();
        let e = measured(&d).expect("the default setting is in the error table");
        let dominated_by: Vec<_> = table()
            .god_rays
            .iter()
            .filter(|o| {
                o.relative_cost <= e.relative_cost
                    && o.flip_mean <= e.flip_mean
                    && (o.relative_cost < e.relative_cost || o.flip_mean < e.flip_mean)
            })
            .collect();
        assert!(
            dominated_by.is_empty(),
            "default {e:?} is dominated by {dominated_by:?}"
        );
    }

    #[test]
    fn budget_sets_samples_scale_and_jitter_and_keeps_the_look() {
        let mut g = GodRaySettings {
            exposure: 0.7,
            ..GodRaySettings::default()
        };
        let c = apply_budget(1.0, &mut g).unwrap();
        // A budget anything meets: the cheapest row of the table.
        let cheapest = table()
            .god_rays
            .iter()
            .map(|e| e.relative_cost)
            .fold(f32::INFINITY, f32::min);
        assert_eq!(c.relative_cost, cheapest);
        assert_eq!(
            (g.samples, g.resolution_scale, g.jitter),
            (c.samples, c.resolution_scale, c.jitter)
        );
        assert_eq!(g.exposure, 0.7);
        assert!(c.warning.is_none());
        assert_eq!(
            measured(&g).map(|e| e.flip_mean),
            Some(c.expected_flip_mean)
        );

        let c = apply_budget(0.0, &mut g).unwrap();
        assert!(c.warning.is_some());
        let best = table()
            .god_rays
            .iter()
            .map(|e| e.flip_mean)
            .fold(f32::INFINITY, f32::min);
        assert_eq!(c.expected_flip_mean, best);
    }

    #[test]
    fn parsers_reject_what_is_not_a_budget_or_scale() {
        assert_eq!(parse_flip_mean("0.02"), Ok(0.02));
        for bad in ["-0.1", "2", "NaN", "inf", "x", ""] {
            assert!(parse_flip_mean(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_scale("0.5"), Ok(0.5));
        for bad in ["0", "0.1", "1.5", "NaN", "half"] {
            assert!(parse_scale(bad).is_err(), "{bad}");
        }
        assert_eq!(
            describe(&GodRaySettings {
                samples: 128,
                resolution_scale: 0.5,
                jitter: false,
                ..GodRaySettings::default()
            }),
            "128 samples, half resolution, no jitter"
        );
    }
}
