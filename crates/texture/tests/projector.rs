#![allow(clippy::needless_range_loop)]
mod common;

use common::{design, rgba_image};
use texture::blur::srgb8_to_premultiplied_f64;
use texture::{
    BlurMethod, ProjectorOptions, error_lsb, level_count, projector, reference_blur,
    sigma_from_light,
};

#[test]
fn sun_through_a_window_gives_the_documented_sigma() {
    // Sun 0.53°, floor 4 m behind the window, design 256 texels per metre:
    // penumbra θ·d = 3.7 cm, σ = θ·d/4 in texels = 2.37.
    let s = sigma_from_light(0.53f32.to_radians(), 4.0, 256.0);
    assert!(
        (s - 0.53f32.to_radians() * 4.0 / 4.0 * 256.0).abs() < 1e-6 && (s - 2.368).abs() < 0.01,
        "{s}"
    );
    assert!(
        projector(
            &rgba_image(1, 1, vec![0; 4]),
            &ProjectorOptions::new(sigma_from_light(f32::NAN, 1.0, 1.0))
        )
        .is_err()
    );
}

#[test]
fn projector_level_zero_is_the_blur_and_mips_are_complete() {
    let (w, h) = (60, 44);
    let bytes = design(w, h, 8);
    let (chain, report) = projector(
        &rgba_image(w, h, bytes.clone()),
        &ProjectorOptions::new(3.0),
    )
    .unwrap();
    assert_eq!((chain.width, chain.height), (60, 44));
    assert_eq!(chain.levels.len(), level_count(60, 44));
    assert_eq!(report.dropped_levels, 0);
    assert_eq!(report.max_error_lsb, None);
    let reference = reference_blur(&srgb8_to_premultiplied_f64(&bytes), w, h, 3.0);
    let e = error_lsb(&chain.levels[0], &reference);
    assert!(e.max <= 0.55, "{e:?}");
}

#[test]
fn heavy_blur_is_stored_smaller_only_within_the_budget() {
    let (w, h) = (128, 96);
    let img = rgba_image(w, h, design(w, h, 6));
    let opts = |budget| ProjectorOptions {
        sigma_texels: 24.0.into(),
        max_error_lsb: budget,
        max_size: None,
        cap_whole_level: false,
        method: BlurMethod::Auto,
        block_pad: false,
        margin: [0, 0],
        linear: false,
    };
    let (full, _) = projector(&img, &opts(None)).unwrap();
    // The zero border's falloff is the steepest detail left, and limits how far it can go.
    let (small, report) = projector(&img, &opts(Some(3.0))).unwrap();
    assert!(report.dropped_levels >= 1, "{report}");
    assert!(report.max_error_lsb.unwrap() <= 3.0, "{report}");
    assert_eq!(
        small.levels[..],
        full.levels[report.dropped_levels as usize..]
    );
    assert!(report.to_string().contains("dropped"), "{report}");
    // A budget at the rounding floor keeps the design's resolution.
    let (exact, report) = projector(&img, &opts(Some(0.5))).unwrap();
    assert_eq!(report.dropped_levels, 0, "{report}");
    assert_eq!(exact, full);
    // A sharp projector never drops levels, whatever the budget.
    let (_, report) = projector(
        &img,
        &ProjectorOptions {
            sigma_texels: 1.0.into(),
            max_error_lsb: Some(3.0),
            max_size: None,
            cap_whole_level: false,
            method: BlurMethod::Auto,
            block_pad: false,
            margin: [0, 0],
            linear: false,
        },
    )
    .unwrap();
    assert_eq!(report.dropped_levels, 0);
}

#[test]
fn a_size_cap_stores_the_first_level_that_fits_it_and_says_what_it_costs() {
    let (w, h) = (100, 40);
    let img = rgba_image(w, h, design(w, h, 6));
    let mut opts = ProjectorOptions::new(3.0);
    let (full, _) = projector(&img, &opts).unwrap();
    opts.max_size = Some(30);
    let (capped, report) = projector(&img, &opts).unwrap();
    // Across 100 -> 50, then 25 would undershoot the cap, as 20 down would: 50x40 resampled
    // to 30x30, which keeps more of the blur than halving to 25x20.
    assert_eq!((capped.width, capped.height), (30, 30), "{report}");
    assert_eq!(
        (report.dropped_levels, report.halved, report.resampled_from),
        (0, [1, 0], Some((50, 40))),
        "{report}"
    );
    assert!(report.max_error_lsb.is_some_and(|e| e > 0.5), "{report}");
    let halved_error = {
        let mut o = opts;
        o.max_size = Some(25);
        projector(&img, &o).unwrap().1.max_error_lsb.unwrap()
    };
    assert!(report.max_error_lsb.unwrap() < halved_error, "{report}");
    opts.max_size = Some(16);
    let (capped, report) = projector(&img, &opts).unwrap();
    assert_eq!(
        (capped.width, capped.height, report.resampled_from),
        (16, 16, Some((25, 20))),
        "{report}"
    );
    let square = rgba_image(64, 64, design(64, 64, 6));
    let (square_full, _) = projector(&square, &ProjectorOptions::new(3.0)).unwrap();
    let (capped, report) = projector(&square, &opts).unwrap();
    assert_eq!(
        (report.dropped_levels, report.halved),
        (2, [0, 0]),
        "{report}"
    );
    assert_eq!(capped.levels[..], square_full.levels[2..]);
    // A cap the design already fits changes nothing.
    opts.max_size = Some(100);
    let (same, report) = projector(&img, &opts).unwrap();
    assert_eq!(same, full);
    assert_eq!(report.dropped_levels, 0);
}

#[test]
fn bad_budget_is_an_error() {
    let img = rgba_image(2, 2, vec![9; 16]);
    for b in [f32::NAN, -1.0] {
        let opts = ProjectorOptions {
            sigma_texels: 1.0.into(),
            max_error_lsb: Some(b),
            max_size: None,
            cap_whole_level: false,
            method: BlurMethod::Auto,
            block_pad: false,
            margin: [0, 0],
            linear: false,
        };
        assert!(
            projector(&img, &opts)
                .unwrap_err()
                .to_string()
                .contains("budget")
        );
    }
}

/// The accuracy bar on a design large enough for the decimated method's grid to matter.
#[test]
fn blur_error_on_a_512_design() {
    let (w, h) = (512, 384);
    let bytes = design(w, h, 12);
    let reference_input = srgb8_to_premultiplied_f64(&bytes);
    for sigma in [8.0f32, 32.0] {
        let ours =
            texture::blur_srgb8(&bytes, w as u32, h as u32, sigma, BlurMethod::Auto).unwrap();
        let e = error_lsb(&ours, &reference_blur(&reference_input, w, h, sigma as f64));
        assert!(e.max <= 0.55, "sigma {sigma}: {e:?}");
    }
}

#[test]
fn block_padded_projector_keeps_the_image_and_mips_the_padded_level() {
    // 61x43 under a cap of 30: stored 30x30 (halved across, resampled down), padded to 32x32
    // with the blur's zero border.
    let (w, h) = (61, 43);
    let img = rgba_image(w, h, design(w, h, 8));
    let mut opts = ProjectorOptions::new(3.0);
    opts.max_size = Some(30);
    let (plain, report) = projector(&img, &opts).unwrap();
    opts.block_pad = true;
    let (padded, padded_report) = projector(&img, &opts).unwrap();
    assert_eq!(report, padded_report);
    assert_eq!((report.width, report.height), (30, 30));
    assert_eq!((padded.width, padded.height), (32, 32));
    for y in 0..32usize {
        for x in 0..32usize {
            let p = &padded.levels[0][(y * 32 + x) * 4..][..4];
            if x < 30 && y < 30 {
                assert_eq!(p, &plain.levels[0][(y * 30 + x) * 4..][..4], "({x}, {y})");
            } else {
                assert_eq!(p, [0; 4], "padding at ({x}, {y})");
            }
        }
    }
    // Level 1 is the padded level 0 halved: 16x16, each texel the box of its four.
    assert_eq!(padded.level_size(1), (16, 16));
    assert_eq!(padded.levels[1].len(), 16 * 16 * 4);
    let corner = &padded.levels[1][(15 * 16 + 15) * 4..][..4];
    assert_eq!(corner, [0; 4], "all four source texels are padding");
}

#[test]
fn the_unpadded_chain_of_a_padded_projector_is_the_plain_projector() {
    for (w, h) in [(61, 43), (64, 44)] {
        let img = rgba_image(w, h, design(w, h, 5));
        let opts = |block_pad| ProjectorOptions {
            block_pad,
            ..ProjectorOptions::new(2.5)
        };
        let (plain, plain_report) = projector(&img, &opts(false)).unwrap();
        let (padded, unpadded, report) =
            texture::projector_with_unpadded(&img, &opts(true)).unwrap();
        assert_eq!(report, plain_report);
        if (w % 4, h % 4) == (0, 0) {
            // Already whole blocks: one chain, and it is the plain one.
            assert_eq!(unpadded, None);
            assert_eq!(padded, plain);
        } else {
            assert_eq!((padded.width, padded.height), (64, 44));
            assert_eq!(unpadded, Some(plain));
        }
    }
}
