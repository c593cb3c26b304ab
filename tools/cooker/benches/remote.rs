//! The remote cook cache on real servers on 127.0.0.1, through the `cooker` binary, for the
//! default scene and each backend (a folder, Redis, nginx WebDAV, SeaweedFS S3):
//! - cold: a cook with an empty local cache and no remote;
//! - remote miss: the same with an empty remote (read-only: lookups only), whose overhead
//!   over cold is the cost of having a remote that does not help (goal ≤ 5 %);
//! - cold + upload: the same, writing to the remote (what CI pays);
//! - warm from remote: an empty local cache, the remote filled (goal ≤ 0.2× cold);
//! - warm local: the cached pack written back from the local cache (output removed);
//! - the pack's transfer at loopback speed (a plain HTTP GET of it from nginx), so the warm
//!   remote cook can be set against "a warm local hit plus the transfer".
//!
//! Medians of `--runs N` (default 5), interleaved per run so the VM's drift hits all alike.
//! Needs the servers `scripts/install-test-deps.sh` installs.
//!
//! `cargo bench -p cooker --bench remote -- --runs 5 --out docs/bench/remote-cache.md`
//!
//! Under `cargo test` (no `--bench` argument) it runs once over a folder remote, as a check
//! that it still works.

#[path = "../tests/common/mod.rs"]
mod common;
#[path = "../tests/servers/mod.rs"]
mod servers;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

/// A backend: how to name a fresh, empty remote for run `i`, and the cooker's extra
/// arguments and variables.
struct Backend {
    name: &'static str,
    url: Box<dyn Fn(&str) -> String>,
    args: Vec<String>,
    env: Vec<(String, String)>,
    /// Empties the remote where a fresh name is not enough.
    reset: Box<dyn Fn()>,
}

/// Runs the cooker; returns the wall time and checks it succeeded.
fn cook(
    scene: &Path,
    out: &Path,
    cache: &Path,
    remote: Option<(&Backend, &str)>,
    write: bool,
) -> (Duration, String) {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cooker"));
    c.arg("cook")
        .arg(scene)
        .arg("-o")
        .arg(out)
        .arg("--cache-dir")
        .arg(cache)
        .env_remove("CI")
        .env_remove("STAINED_GLASS_CACHE_URL");
    if let Some((b, name)) = remote {
        c.args(["--cache-url", &(b.url)(name)]).args(&b.args);
        for (k, v) in &b.env {
            c.env(k, v);
        }
        if write {
            c.arg("--cache-write");
        }
    }
    let start = Instant::now();
    let o = c.output().unwrap();
    let t = start.elapsed();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "{text}");
    assert!(!text.contains("warning: remote cache"), "{text}");
    (t, text)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

#[derive(Default)]
struct Row {
    cold: Vec<f64>,
    miss: Vec<f64>,
    upload: Vec<f64>,
    warm_remote: Vec<f64>,
    warm_local: Vec<f64>,
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let benching = args.iter().any(|a| a == "--bench");
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let runs: usize = value("--runs").map_or(if benching { 5 } else { 1 }, |r| r.parse().unwrap());
    // Relative to the workspace's root, as the command line is typed there (a bench runs in
    // its package's folder).
    let out_arg = value("--out");
    let out_file = out_arg
        .as_ref()
        .map(|p| Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(p));

    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let scene = if benching {
        common::copy_dir(&root.join("assets-src"), &d.join("scene"));
        d.join("scene/scene.toml")
    } else {
        common::small_scene(&d.join("scene"))
    };

    let share = d.join("share");
    let mut backends = vec![Backend {
        name: "file:// (a folder)",
        url: Box::new({
            let share = share.clone();
            // A share must exist before a cook uses it (one missing is a share not mounted).
            move |run| {
                let folder = share.join(run);
                let _ = std::fs::create_dir_all(&folder);
                format!("file://{}", folder.display())
            }
        }),
        args: Vec::new(),
        env: Vec::new(),
        reset: Box::new(|| {}),
    }];
    let mut keep = Vec::new();
    let mut nginx_port = None;
    if benching {
        let password = "bench-pw";
        let (redis, port) = servers::redis(&d.join("redis"), password);
        keep.push(redis);
        backends.push(Backend {
            name: "redis://",
            url: Box::new(move |_| format!("redis://:{password}@127.0.0.1:{port}/0")),
            args: Vec::new(),
            env: Vec::new(),
            reset: Box::new(move || {
                let o = Command::new("redis-cli")
                    .args([
                        "-p",
                        &port.to_string(),
                        "-a",
                        password,
                        "--no-auth-warning",
                        "FLUSHALL",
                    ])
                    .output()
                    .unwrap();
                assert!(o.status.success());
            }),
        });
        let (nginx, port) = servers::nginx(&d.join("nginx"));
        keep.push(nginx);
        nginx_port = Some(port);
        backends.push(Backend {
            name: "http:// (nginx WebDAV)",
            url: Box::new(move |run| format!("http://127.0.0.1:{port}/{run}/")),
            args: Vec::new(),
            env: Vec::new(),
            reset: Box::new(|| {}),
        });
        let (weed, port) = servers::seaweed(&d.join("weed"));
        keep.push(weed);
        backends.push(Backend {
            name: "s3:// (SeaweedFS)",
            url: Box::new(|run| format!("s3://cache/{run}")),
            args: vec![
                "--cache-endpoint".into(),
                format!("http://127.0.0.1:{port}"),
            ],
            env: vec![
                ("AWS_ACCESS_KEY_ID".into(), "ci".into()),
                ("AWS_SECRET_ACCESS_KEY".into(), "ci-secret-5d1e".into()),
                ("AWS_REGION".into(), "us-east-1".into()),
            ],
            reset: Box::new(|| {}),
        });
    }

    let out = d.join("out.pack");
    let mut rows: Vec<Row> = backends.iter().map(|_| Row::default()).collect();
    let mut pack_len = 0u64;
    for run in 0..runs {
        for (i, (b, row)) in backends.iter().zip(rows.iter_mut()).enumerate() {
            let fresh = |what: &str| d.join(format!("cache-{run}-{what}-{i}"));
            let name = format!("run{run}");
            let (t, _) = cook(&scene, &out, &fresh("cold"), None, false);
            row.cold.push(t.as_secs_f64());
            (b.reset)();
            let (t, text) = cook(&scene, &out, &fresh("miss"), Some((b, &name)), false);
            assert!(text.contains(" 0 hits, "), "{text}");
            row.miss.push(t.as_secs_f64());
            let (t, _) = cook(&scene, &out, &fresh("upload"), Some((b, &name)), true);
            row.upload.push(t.as_secs_f64());
            std::fs::remove_file(&out).unwrap();
            let warm = fresh("warm");
            let (t, text) = cook(&scene, &out, &warm, Some((b, &name)), false);
            assert!(text.contains("reused the cached pack"), "{text}");
            row.warm_remote.push(t.as_secs_f64());
            pack_len = std::fs::metadata(&out).unwrap().len();
            std::fs::remove_file(&out).unwrap();
            let (t, text) = cook(&scene, &out, &warm, None, false);
            assert!(text.contains("reused the cached pack"), "{text}");
            row.warm_local.push(t.as_secs_f64());
            // Only the last run's caches are kept: the disk is not the thing measured.
            for what in ["cold", "miss", "upload", "warm"] {
                let _ = std::fs::remove_dir_all(fresh(what));
            }
        }
    }

    // The pack's bytes over loopback HTTP, as a plain GET of a file from nginx.
    let transfer = nginx_port.map(|port| {
        std::fs::copy(&out, d.join("nginx/dav/pack.bin")).unwrap();
        let mut times: Vec<f64> = (0..runs.max(3))
            .map(|_| {
                let o = Command::new("curl")
                    .args(["-s", "-o", "/dev/null", "-w", "%{time_total}"])
                    .arg(format!("http://127.0.0.1:{port}/pack.bin"))
                    .output()
                    .unwrap();
                String::from_utf8_lossy(&o.stdout)
                    .trim()
                    .parse::<f64>()
                    .unwrap()
            })
            .collect();
        median(&mut times)
    });

    let ms = |s: f64| format!("{:.0} ms", s * 1e3);
    let mut table = String::new();
    table.push_str(&format!(
        "{} ({:.1} MB pack), `cooker` in the {} profile, median of {runs} runs each; ratios \
         are of medians taken in the same run.\n\n",
        if benching {
            "Default scene"
        } else {
            "A small scene"
        },
        pack_len as f64 / 1e6,
        if benching { "bench" } else { "test" }
    ));
    table.push_str(
        "| backend | cold, no remote | cold, remote miss | miss overhead (paired) | cold + upload | warm from remote, empty local cache | warm / cold | warm local hit |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for (b, row) in backends.iter().zip(rows.iter_mut()) {
        // The miss costs milliseconds where the VM drifts by tens: the median of each run's
        // difference (the two cooks ran back to back), over the median cold cook.
        let mut extra: Vec<f64> = row.miss.iter().zip(&row.cold).map(|(m, c)| m - c).collect();
        let extra = median(&mut extra);
        let cold = median(&mut row.cold);
        let miss = median(&mut row.miss);
        let upload = median(&mut row.upload);
        let warm = median(&mut row.warm_remote);
        let local = median(&mut row.warm_local);
        table.push_str(&format!(
            "| {} | {} | {} | {:+.0} ms, {:+.1} % | {} | {} | {:.2} | {} |\n",
            b.name,
            ms(cold),
            ms(miss),
            extra * 1e3,
            extra / cold * 100.0,
            ms(upload),
            ms(warm),
            warm / cold,
            ms(local),
        ));
    }
    if let Some(t) = transfer {
        table.push_str(&format!(
            "\nThe pack over loopback HTTP (curl GET from the same nginx): {} ({:.0} MB/s).\n",
            ms(t),
            pack_len as f64 / 1e6 / t
        ));
    }
    print!("{table}");
    if let Some(path) = out_file {
        let header = format!(
            "# Remote cook cache\n\n\
             Written by `cargo bench -p cooker --bench remote -- --runs {runs} --out {}` \
             (tools/cooker/benches/remote.rs), against real servers on 127.0.0.1: a folder \
             (`file://`), Redis 7, nginx 1.22 with WebDAV, SeaweedFS's S3 API.\n\n\
             - cold, no remote: an empty local cache, no remote;\n\
             - cold, remote miss: the same with an empty remote, read-only (lookups only): \
             what a remote that does not help costs (goal ≤ 5 %);\n\
             - cold + upload: the same, writing everything to the remote (what CI pays);\n\
             - warm from remote: an empty local cache, the remote filled, the output absent \
             (goal ≤ 0.2× cold);\n\
             - warm local hit: the cached pack written back from the local cache.\n\n",
            out_arg.as_deref().unwrap_or_default()
        );
        std::fs::write(&path, format!("{header}{table}")).unwrap();
    }
}
