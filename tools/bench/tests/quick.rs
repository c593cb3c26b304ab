//! The whole bench in its small form, so the report tool cannot rot: every sweep runs, every
//! report file appears, and the numbers are sane. No timing is asserted.

use std::path::Path;
use std::process::Command;

use serde_json::Value;

fn run_quick(out: &Path, table: &Path) {
    let status = Command::new(env!("CARGO_BIN_EXE_bench"))
        // The native gltfpack anchor is for benchmark runs only, never for tests.
        .env("GLTFPACK_NATIVE", "/nonexistent/gltfpack")
        .args(["--quick", "--out"])
        .arg(out)
        .arg("--emit-table")
        .arg(table)
        .arg("--emit-god-ray-table")
        .arg(table.with_file_name("god_ray_table.json"))
        .env(
            "VK_DRIVER_FILES",
            std::env::var_os("VK_DRIVER_FILES")
                .unwrap_or_else(|| "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json".into()),
        )
        .status()
        .expect("bench runs");
    assert!(status.success(), "bench --quick failed: {status}");
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn quick_bench_writes_a_sane_report_and_error_table() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let table_path = dir.path().join("error_table.json");
    run_quick(&out, &table_path);

    for name in [
        "README.md",
        "results.json",
        "mips.svg",
        "godrays.svg",
        "meshes-0.svg",
        "blur-sigma-8.svg",
    ] {
        let p = out.join(name);
        let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        assert!(!text.trim().is_empty(), "{name} is empty");
        if name.ends_with(".svg") {
            assert!(
                text.starts_with("<svg") && text.trim_end().ends_with("</svg>"),
                "{name}"
            );
        }
    }
    let readme = std::fs::read_to_string(out.join("README.md")).unwrap();
    for heading in [
        "## Summary",
        "## Blur",
        "## Mip chains",
        "## Meshes",
        "## God rays",
        "## Shadows",
    ] {
        assert!(readme.contains(heading), "README lacks {heading}");
    }
    assert!(readme.contains("Pareto front"));

    let r: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert!(!r["machine"]["cpu"].as_str().unwrap().is_empty());

    // Shadows: every camera of both scenes compared, its images written, the shadow pass timed.
    let shadows = &r["shadows"]["Ok"];
    let cameras = shadows["cameras"].as_array().unwrap();
    assert!(cameras.len() >= 6, "{cameras:?}");
    for c in cameras {
        assert!((0.0..1.0).contains(&f(&c["flip_mean"])), "{c}");
        for key in ["reference_image", "gpu_image"] {
            let p = out.join(c[key].as_str().unwrap());
            assert!(p.is_file(), "{}", p.display());
        }
    }
    assert!(
        shadows["timings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|t| t["map_size"].as_u64() > Some(0) && t["shadow_ms"].is_number()),
        "{shadows}"
    );

    // Blur: our exact methods are exact to the texture issue's bar everywhere, the
    // approximations measurably worse but bounded; every anchor that ran has a finite error no
    // better than the rounding floor allows.
    let blur = r["blur"].as_array().unwrap();
    for m in ["decimated", "decimated-coarse", "box3"] {
        let m = format!("ours: {m}");
        assert!(blur.iter().any(|b| b["method"] == m.as_str()), "{m}");
    }
    for b in blur {
        if b["ours"] == true {
            let max = f(&b["max_lsb"]);
            if b["note"] == "approximation" {
                assert!(max > 0.55 && max < 40.0, "{b}");
            } else {
                assert!((0.45..=0.55).contains(&max), "{b}");
            }
            assert!(f(&b["rms_lsb"]) <= max && f(&b["time_ms"]) > 0.0, "{b}");
        } else if !b["max_lsb"].is_null() {
            // 8-bit output cannot be closer than the rounding floor (0.5 LSB) to an
            // unrounded reference on a non-trivial image; less means the error was not
            // measured against the reference.
            assert!(
                f(&b["max_lsb"]).is_finite() && f(&b["max_lsb"]) >= 0.45,
                "{b}"
            );
        }
    }
    for anchor in ["libblur exact u8", "image::imageops::blur"] {
        assert!(
            blur.iter()
                .any(|b| b["method"] == anchor && !b["max_lsb"].is_null()),
            "{anchor}"
        );
    }

    // Mips: linear light within 0.6 LSB of its f64 chain at every level; gamma space far off
    // (the reason the cooker filters in linear light).
    for m in r["mips"].as_array().unwrap() {
        let levels = m["levels"].as_array().unwrap();
        assert_eq!(levels.len(), 8, "256 → 1 has 8 levels below level 0: {m}");
        let worst = levels.iter().map(|l| f(&l["max_lsb"])).fold(0.0, f64::max);
        match (m["ours"].as_bool().unwrap(), m["space"].as_str().unwrap()) {
            (true, "linear") => assert!(worst <= 0.6, "{m}"),
            // fast_image_resize's gamma-correct chain: linear light through u16 levels.
            (false, "linear") => assert!(worst < 2.0, "{m}"),
            (_, "gamma") => assert!(worst > 5.0, "{m}"),
            _ => unreachable!("{m}"),
        }
    }

    // Meshes: optimizing the vertex cache never makes ACMR worse than the source order, and
    // 16-bit positions stay within half a quantization step of the extent.
    let tangents = r["tangents"].as_array().unwrap();
    assert_eq!(tangents.len(), 2, "Spot and the height field: {tangents:?}");
    for t in tangents {
        assert!(t["max_difference"].as_f64().unwrap() <= 1e-5, "{t}");
        assert_eq!(t["signs_agree"], true, "{t}");
    }
    let meshes = r["meshes"].as_array().unwrap();
    for mesh in ["generated 100x100 height field", "Stanford bunny"] {
        let row = |cache: &str, bits: u64| {
            meshes
                .iter()
                .find(|m| m["mesh"] == mesh && m["cache"] == cache && m["position_bits"] == bits)
                .unwrap_or_else(|| panic!("{mesh} {cache} {bits}"))
        };
        let none = f(&row("none", 16)["acmr"]);
        for cache in ["full", "fifo"] {
            let acmr = f(&row(cache, 16)["acmr"]);
            assert!(
                acmr > 0.4 && acmr <= none,
                "{mesh} {cache}: {acmr} vs {none}"
            );
            assert!(f(&row(cache, 16)["overfetch"]) >= 1.0);
        }
        let rel16 = f(&row("full", 16)["relative_position_error"]);
        assert!(
            rel16 > 0.0 && rel16 <= 0.5 / 65535.0 * 1.01,
            "{mesh}: {rel16}"
        );
        let rel8 = f(&row("full", 8)["relative_position_error"]);
        assert!(rel8 > rel16 && rel8 <= 0.5 / 255.0 * 1.01, "{mesh}: {rel8}");
        assert!(
            f(&row("full", 16)["bytes_per_triangle"]) < f(&row("full", 32)["bytes_per_triangle"])
        );
    }

    // God rays: measured (lavapipe suffices), the reference composite matches the GPU's, and
    // more samples at full resolution without jitter get closer to the reference.
    // Compression: every role measured, BC7's very-fast at least as accurate as ultra-fast on
    // the design, errors finite and positive, BC5 on the normal map in degrees.
    let rows = r["compression"]["rows"].as_array().unwrap();
    let roles: std::collections::BTreeSet<&str> = rows
        .iter()
        .map(|row| row["role"].as_str().unwrap())
        .collect();
    assert_eq!(roles.len(), 4, "{roles:?}");
    for row in rows {
        let e = row["error"].as_f64().unwrap();
        assert!(e.is_finite() && e > 0.0, "{row}");
        assert!(row["time_ms"].as_f64().unwrap() > 0.0, "{row}");
    }
    let design = |codec: &str| {
        rows.iter()
            .find(|row| row["role"] == "stained-glass design" && row["codec"] == codec)
            .unwrap()["error"]
            .as_f64()
            .unwrap()
    };
    assert!(design("bc7 very-fast") <= design("bc7 ultra-fast") * 1.05);
    assert!(rows.iter().any(|row| row["codec"] == "bc5"));
    let g = &r["god_rays"]["Ok"];
    assert!(g.is_object(), "god rays not measured: {}", r["god_rays"]);
    assert!(f(&g["composite_check_lsb"]) <= 1.0, "{g}");
    let rows = g["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 12);
    for x in rows {
        for k in ["flip_mean", "flip_p99", "rmse_linear"] {
            let v = f(&x[k]);
            assert!(v.is_finite() && (0.0..=1.0).contains(&v), "{k}: {x}");
        }
        assert!(f(&x["flip_p99"]) >= f(&x["flip_mean"]), "{x}");
    }
    let at = |samples: u64| {
        rows.iter()
            .find(|x| {
                x["samples"] == samples && x["resolution_scale"] == 1.0 && x["jitter"] == false
            })
            .unwrap()
    };
    assert!(f(&at(64)["rmse_linear"]) < f(&at(16)["rmse_linear"]));

    // The error table round-trips into the cooker's budget.
    let table: cook::budget::ErrorTable =
        serde_json::from_str(&std::fs::read_to_string(&table_path).unwrap()).unwrap();
    assert_eq!(table.image_size, 256);
    let c = cook::budget::choose_blur_in(&table, 0.55, 8.0).unwrap();
    assert!(c.warning.is_none() && c.expected_error <= 0.55, "{c:?}");
    let c = cook::budget::choose_mip_in(&table, 0.6, Some("box")).unwrap();
    assert!(c.linear_light, "{c:?}");
    // And the god-ray table into the renderer's.
    let rays: render::budget::GodRayTable = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("god_ray_table.json")).unwrap(),
    )
    .unwrap();
    assert!(!rays.god_rays.is_empty());
    let c = render::budget::choose_god_rays_in(&rays, 1.0).unwrap();
    assert!(c.warning.is_none(), "{c:?}");

    // Re-measuring one sweep keeps the others' rows from the report already there, and says so.
    let status = Command::new(env!("CARGO_BIN_EXE_bench"))
        .args([
            "--quick",
            "--only",
            "blur",
            "--keep-others",
            "--sigmas",
            "4",
        ])
        .arg("--out")
        .arg(&out)
        .arg("--emit-table")
        .arg(&table_path)
        .status()
        .expect("bench runs");
    assert!(status.success(), "bench --only blur --keep-others failed");
    let again: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert_eq!(again["mips"], r["mips"]);
    assert_eq!(again["meshes"], r["meshes"]);
    assert_eq!(again["god_rays"], r["god_rays"]);
    assert_eq!(again["shadows"], r["shadows"]);
    assert_eq!(again["compression"], r["compression"]);
    assert_eq!(again["tangents"], r["tangents"]);
    assert!(
        again["blur"]
            .as_array()
            .unwrap()
            .iter()
            .all(|b| b["sigma"] == 4.0)
    );
    let kept: Vec<&str> = again["kept"]
        .as_array()
        .unwrap()
        .iter()
        .map(|k| k["sweep"].as_str().unwrap())
        .collect();
    assert_eq!(
        kept,
        [
            "mips",
            "meshes",
            "god-rays",
            "shadows",
            "first-frame",
            "tangents",
            "compression"
        ]
    );
    let readme = std::fs::read_to_string(out.join("README.md")).unwrap();
    assert!(readme.contains("The mips sweep is kept from an earlier run"));
    let table: cook::budget::ErrorTable =
        serde_json::from_str(&std::fs::read_to_string(&table_path).unwrap()).unwrap();
    assert!(!table.mip.is_empty() && table.blur.iter().all(|b| b.sigma == 4.0));
}
