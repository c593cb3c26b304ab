//! The incremental cook cache: an unchanged scene is reused whole, a changed setting or window
//! design re-cooks only what depends on it, and damaged entries are re-cooked, never used.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn cook(scene: &Path, out: &Path, cache: &Path) -> Output {
    cook_with(scene, out, cache, &[], "2")
}

fn cook_with(scene: &Path, out: &Path, cache: &Path, args: &[&str], threads: &str) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args(["cook", "-v"])
        .arg(scene)
        .arg("-o")
        .arg(out)
        .arg("--cache-dir")
        .arg(cache)
        .args(args)
        .env("RAYON_NUM_THREADS", threads)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn lines_starting<'a>(text: &'a str, word: &str) -> Vec<&'a str> {
    text.lines()
        .filter(|l| l.trim_start().starts_with(word))
        .collect()
}

#[test]
fn unchanged_scene_reused_changed_design_recooked_alone_damage_detected() {
    let dir = tempfile::tempdir().unwrap();
    let scene_dir = dir.path().join("scene");
    common::copy_dir(&root().join("assets-src"), &scene_dir);
    let scene = scene_dir.join("scene.toml");
    let cache = dir.path().join("cache");
    let out = dir.path().join("out.pack");

    let first = cook(&scene, &out, &cache);
    assert!(
        stdout(&first).contains("0 textures reused"),
        "{}",
        stdout(&first)
    );
    let clean = std::fs::read(&out).unwrap();

    // Unchanged: nothing is cooked, the output is left as it is (the thread count is not a
    // setting: it never changes the pack).
    let second = cook_with(&scene, &out, &cache, &[], "1");
    assert!(
        stdout(&second).contains("is up to date"),
        "{}",
        stdout(&second)
    );
    // Output removed: the cached pack is written back.
    std::fs::remove_file(&out).unwrap();
    let third = cook(&scene, &out, &cache);
    assert!(
        stdout(&third).contains("reused the cached pack"),
        "{}",
        stdout(&third)
    );
    assert!(std::fs::read(&out).unwrap() == clean);

    // A mesh setting changes the scene's key but no texture's: the pack is cooked again, every
    // texture reused.
    let fifo = stdout(&cook_with(&scene, &out, &cache, &["--fifo"], "2"));
    assert!(
        !fifo.contains("up to date") && fifo.contains("textures reused, 0 cooked"),
        "{fifo}"
    );

    // One design changes: only the textures made from it are cooked again. Mid-window: a
    // texel beyond the lancet's outline is masked away, and changes nothing cooked.
    let design = scene_dir.join("windows/lancet.png");
    let mut img = image::open(&design).unwrap().to_rgba8();
    let (w, h) = img.dimensions();
    img.get_pixel_mut(w / 2, h / 2).0 = [255, 0, 255, 255];
    img.save(&design).unwrap();
    let fourth = stdout(&cook(&scene, &out, &cache));
    let cooked = lines_starting(&fourth, "cooked ");
    let reused = lines_starting(&fourth, "reused ");
    assert!(!cooked.is_empty() && !reused.is_empty(), "{fourth}");
    assert!(
        cooked.iter().all(|l| l.contains("lancet")),
        "only lancet textures re-cooked: {cooked:?}"
    );
    assert!(reused.iter().all(|l| !l.contains("lancet")), "{reused:?}");
    let changed = std::fs::read(&out).unwrap();
    assert!(changed != clean);

    // The cached pack alone damaged: a warning, as for a damaged texture entry (it was said
    // only under -v), and the pack re-cooked as it was.
    let mut blobs = 0;
    for e in std::fs::read_dir(&cache).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "blob") {
            let mut b = std::fs::read(&p).unwrap();
            let n = b.len();
            b[n - 1] ^= 0x01;
            std::fs::write(&p, b).unwrap();
            blobs += 1;
        }
    }
    assert!(blobs > 0, "no cached pack in {}", cache.display());
    std::fs::remove_file(&out).unwrap();
    let o = cook(&scene, &out, &cache);
    assert!(
        stderr(&o).contains("warning: cache: damaged cached pack, re-cooking: "),
        "{}",
        stderr(&o)
    );
    assert!(std::fs::read(&out).unwrap() == changed);

    // Every cache entry damaged: all are detected, re-cooked, and the pack comes out identical
    // to a cook without a cache.
    let mut damaged = 0;
    for e in std::fs::read_dir(&cache).unwrap() {
        let p = e.unwrap().path();
        // Entries only: the cache also keeps its eviction lock and bookkeeping beside them.
        if p.extension().is_none_or(|x| x != "entry") {
            continue;
        }
        let mut b = std::fs::read(&p).unwrap();
        let n = b.len();
        b[n - 1] ^= 0x01;
        std::fs::write(&p, b).unwrap();
        damaged += 1;
    }
    assert!(damaged > 0, "no cache entries found in {}", cache.display());
    let fresh = dir.path().join("fresh.pack");
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("cook")
        .arg(&scene)
        .arg("-o")
        .arg(&fresh)
        .arg("--no-cache")
        .output()
        .unwrap();
    assert!(o.status.success());
    std::fs::remove_file(&out).unwrap();
    let fifth = cook(&scene, &out, &cache);
    let err = String::from_utf8_lossy(&fifth.stderr);
    assert!(err.contains("re-cooked"), "{err}");
    assert!(
        stdout(&fifth).contains("0 textures reused"),
        "{}",
        stdout(&fifth)
    );
    assert!(std::fs::read(&out).unwrap() == std::fs::read(&fresh).unwrap());
    assert!(std::fs::read(&out).unwrap() == changed);
}

#[test]
fn concurrent_cooks_into_one_cache_and_output_are_safe() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let out = dir.path().join("out.pack");
    let scene = root().join("assets-src/scene.toml");
    let children: Vec<_> = (0..2)
        .map(|_| {
            Command::new(env!("CARGO_BIN_EXE_cooker"))
                .arg("cook")
                .arg(&scene)
                .arg("-o")
                .arg(&out)
                .arg("--cache-dir")
                .arg(&cache)
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for c in children {
        let o = c.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    pack::Pack::open(&out).expect("the output is one complete pack");
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn error_budget_choice_is_reported_and_a_too_tight_budget_warns() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.pack");
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("cook")
        .arg(root().join("assets-src/scene.toml"))
        .arg("-o")
        .arg(&out)
        .args(["--no-cache", "--max-error-lsb", "0.1", "-v"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("chosen by the error budget"), "{err}");
    // A budget no method reaches is a warning that names the method used (and no note).
    assert!(
        err.lines()
            .any(|l| l.starts_with("warning: ") && l.contains("tighter than any")),
        "{err}"
    );
    // Choices are notes, not warnings.
    for line in err
        .lines()
        .filter(|l| l.contains("chosen by the error budget"))
    {
        assert!(line.starts_with("note: "), "{line}");
    }
    pack::Pack::open(&out).unwrap();
    // Without -v the choices (three lines a window) are one line saying how many; the
    // warning stays. A cache hit replays it alike.
    let cache = dir.path().join("cache");
    for run in ["cooked", "reused"] {
        let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
            .arg("cook")
            .arg(root().join("assets-src/scene.toml"))
            .arg("-o")
            .arg(&out)
            .args(["--max-error-lsb", "0.1", "--cache-dir"])
            .arg(&cache)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{run}: {err}");
        assert!(!err.contains("chosen by the error budget"), "{run}: {err}");
        assert!(err.contains("tighter than any"), "{run}: {err}");
        let summary: Vec<&str> = err
            .lines()
            .filter(|l| l.contains("-v prints them"))
            .collect();
        assert!(
            summary.len() == 1 && summary[0].starts_with("note: the error budget chose"),
            "{run}: {err}"
        );
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The lines a cook says about the scene (not about the cache or the output): warnings and
/// notes on stderr, `skipped:` lines, and with `-v` the statistics.
fn what_the_cook_said(o: &Output) -> (String, Vec<String>) {
    let out = stdout(o);
    let said = out
        .lines()
        .filter(|l| {
            !(l.starts_with("cache:")
                || l.starts_with("  reused ")
                || l.starts_with("  cooked ")
                || l.starts_with("wrote ")
                || l.contains(" is up to date"))
        })
        .map(str::to_string)
        .collect();
    (stderr(o), said)
}

#[test]
fn a_verbose_hit_on_a_quiet_cook_says_acmr_was_not_measured() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::small_scene(&dir.path().join("a"));
    let cache = dir.path().join("cache");
    let out = dir.path().join("out.pack");
    // ACMR is measured only with -v; a hit replaying a quiet cook's statistics said 0.000.
    let quiet = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("cook")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .arg("--cache-dir")
        .arg(&cache)
        .output()
        .unwrap();
    assert!(quiet.status.success(), "{}", stderr(&quiet));
    let hit = cook(&scene, &out, &cache);
    let said = stdout(&hit);
    assert!(said.contains("is up to date"), "{said}");
    assert!(!said.contains("acmr_in="), "{said}");
    assert!(
        said.contains("acmr not measured (the cook ran without -v)"),
        "{said}"
    );
}

#[test]
fn a_cache_directory_that_cannot_be_made_leaves_the_cook_uncached() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::small_scene(&dir.path().join("a"));
    let file = dir.path().join("a-file");
    std::fs::write(&file, "not a directory").unwrap();
    let out = dir.path().join("out.pack");
    let o = cook(&scene, &out, &file);
    let err = stderr(&o);
    assert!(
        err.contains(&format!(
            "warning: cache directory {}: a file, not a directory; cooking without a cache",
            file.display()
        )),
        "{err}"
    );
    assert!(out.is_file());
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a directory");

    // `cooker cache stats` is about the cache: a typo is not made into an empty one.
    let typo = dir.path().join("typo");
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args(["cache", "stats", "--cache-dir"])
        .arg(&typo)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no such directory"), "{}", stderr(&o));
    assert!(!typo.exists());
    // A remote that cannot be reached is an I/O failure of `cache stats` (it exited 3).
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args([
            "cache",
            "stats",
            "--cache-timeout",
            "5",
            "--cache-url",
            "redis://127.0.0.1:1/0",
            "--cache-dir",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("error: remote cache redis://127.0.0.1:1/0"),
        "{}",
        stderr(&o)
    );
    // The same typo in $STAINED_GLASS_CACHE said "0 entries" and exited 0.
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args(["cache", "stats"])
        .env("STAINED_GLASS_CACHE", &typo)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(&format!(
            "$STAINED_GLASS_CACHE {}: no such directory",
            typo.display()
        )),
        "{}",
        stderr(&o)
    );
    assert!(!typo.exists());
    // And a file in its place is the same mistake: bad usage, as the typo is.
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args(["cache", "stats", "--cache-dir"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("is a file, not a cache directory"),
        "{}",
        stderr(&o)
    );
    // Remote-cache options without a remote were taken without a word.
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args(["cache", "stats", "--cache-read-only", "--cache-dir"])
        .arg(dir.path())
        .env_remove("STAINED_GLASS_CACHE_URL")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--cache-url"), "{}", stderr(&o));
}

#[test]
fn a_hit_replays_what_the_cook_said_marked_as_reused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::small_scene(&dir.path().join("a"));
    let cache = dir.path().join("cache");
    let out = dir.path().join("out.pack");
    let budget = ["--max-error-lsb", "0.3"];

    let cold = cook_with(&scene, &out, &cache, &budget, "2");
    let (err, said) = what_the_cook_said(&cold);
    assert!(err.contains("0.5 LSB is the 8-bit rounding floor"), "{err}");
    assert!(
        said.iter()
            .any(|l| l.starts_with("skipped: window \"dark\"")),
        "{said:?}"
    );
    assert!(said.iter().any(|l| l.contains("acmr_out=")), "{said:?}");
    assert!(stdout(&cold).contains("0 textures reused"));

    // The output is left alone: the same messages, and it says the pack was reused.
    let up_to_date = cook_with(&scene, &out, &cache, &budget, "2");
    assert!(stdout(&up_to_date).contains("is up to date"));
    assert_eq!(what_the_cook_said(&up_to_date), (err.clone(), said.clone()));
    assert!(stdout(&up_to_date).contains("textures reused, 0 cooked"));
    assert!(
        stdout(&up_to_date).contains("(reused,"),
        "{}",
        stdout(&up_to_date)
    );

    // The output is gone: written back, and again the same messages.
    let bytes = std::fs::read(&out).unwrap();
    std::fs::remove_file(&out).unwrap();
    let written = cook_with(&scene, &out, &cache, &budget, "1");
    assert!(stdout(&written).contains("reused the cached pack"));
    assert_eq!(what_the_cook_said(&written), (err.clone(), said.clone()));
    assert!(std::fs::read(&out).unwrap() == bytes);

    // Without -v, a hit says no statistics, as a cook without -v does; the messages stay.
    let quiet = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("cook")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .arg("--cache-dir")
        .arg(&cache)
        .args(budget)
        .output()
        .unwrap();
    assert!(quiet.status.success());
    assert!(!stdout(&quiet).contains("acmr_out"), "{}", stdout(&quiet));
    // The same warnings and notes, in order, less the budget's choices (`-v` details), which
    // one line counts.
    let quiet_err = stderr(&quiet);
    let (summary, rest): (Vec<&str>, Vec<&str>) = quiet_err
        .lines()
        .partition(|l| l.contains("-v prints them"));
    assert_eq!(summary.len(), 1, "{quiet_err}");
    let mut left_out = err.lines().filter(|l| !rest.contains(l));
    assert!(left_out.all(|l| l.starts_with("note: ")), "{quiet_err}");
    let kept: Vec<&str> = err.lines().filter(|l| rest.contains(l)).collect();
    assert_eq!(kept, rest, "{quiet_err}");
    assert!(
        rest.iter().any(|l| l.starts_with("warning: ")),
        "{quiet_err}"
    );

    // Another checkout of the scene, named from another folder, reuses the same entries and
    // its messages name its own files.
    let other = dir.path().join("elsewhere/b");
    common::copy_dir(&dir.path().join("a"), &other);
    let moved = cook_with(&other.join("scene.toml"), &out, &cache, &budget, "2");
    assert!(
        stdout(&moved).contains("is up to date"),
        "{}",
        stdout(&moved)
    );
    let (moved_err, moved_said) = what_the_cook_said(&moved);
    let a = dir.path().join("a").display().to_string();
    let b = other.display().to_string();
    assert_eq!(moved_err, err.replace(&a, &b));
    assert!(!moved_err.contains(&a), "{moved_err}");
    assert_eq!(moved_said.join("\n"), said.join("\n").replace(&a, &b));
}

/// The bytes of the cache's entries and blobs (what the cap counts).
fn dir_size(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "entry" || e == "blob"))
        .map(|p| p.metadata().unwrap().len())
        .sum()
}

#[test]
fn the_local_cache_keeps_under_its_cap_evicting_the_least_recently_used() {
    let dir = tempfile::tempdir().unwrap();
    let a = common::small_scene(&dir.path().join("a"));
    let b_dir = dir.path().join("b");
    let b = common::small_scene(&b_dir);
    common::design(&b_dir.join("lit.png"), 7);
    let cache = dir.path().join("cache");
    let out = dir.path().join("out.pack");

    // How much one scene's cook keeps.
    cook(&a, &out, &cache);
    let one = dir_size(&cache);
    let cap = (one * 3 / 2).to_string();
    let capped = ["--cache-max-size", cap.as_str()];

    // A second scene does not fit beside the first: the first's entries go, the second's stay.
    let o = cook_with(&b, &out, &cache, &capped, "2");
    assert!(stdout(&o).contains("entries evicted"), "{}", stdout(&o));
    assert!(dir_size(&cache) <= one * 3 / 2);
    let again = cook_with(&b, &out, &cache, &capped, "2");
    assert!(
        stdout(&again).contains("is up to date"),
        "{}",
        stdout(&again)
    );
    std::fs::remove_file(&out).unwrap();
    let evicted = cook_with(&a, &out, &cache, &capped, "2");
    assert!(
        !stdout(&evicted).contains("reused the cached pack"),
        "{}",
        stdout(&evicted)
    );
    let fresh = dir.path().join("fresh.pack");
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("cook")
        .arg(&a)
        .arg("-o")
        .arg(&fresh)
        .arg("--no-cache")
        .output()
        .unwrap();
    assert!(o.status.success());
    assert!(std::fs::read(&out).unwrap() == std::fs::read(&fresh).unwrap());

    // Four cooks of two scenes racing on one directory under a cap that holds neither: each
    // succeeds with its complete pack, and no temp file is left.
    let children: Vec<_> = (0..4)
        .map(|i| {
            let scene = if i % 2 == 0 { &a } else { &b };
            let c = Command::new(env!("CARGO_BIN_EXE_cooker"))
                .arg("cook")
                .arg(scene)
                .arg("-o")
                .arg(dir.path().join(format!("race{i}.pack")))
                .arg("--cache-dir")
                .arg(&cache)
                .args(["--cache-max-size", "1K"])
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap();
            (scene.clone(), i, c)
        })
        .collect();
    for (scene, i, c) in children {
        let o = c.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let race = std::fs::read(dir.path().join(format!("race{i}.pack"))).unwrap();
        let want = dir.path().join("want.pack");
        let w = Command::new(env!("CARGO_BIN_EXE_cooker"))
            .arg("cook")
            .arg(&scene)
            .arg("-o")
            .arg(&want)
            .arg("--no-cache")
            .output()
            .unwrap();
        assert!(w.status.success());
        assert!(
            race == std::fs::read(&want).unwrap(),
            "race{i}.pack differs"
        );
    }
    let temps: Vec<_> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(temps.is_empty(), "{temps:?}");
}

/// Keys leave the scene's folder out, so a second checkout shares the first one's entries;
/// a design changed there is named, from the first checkout's record.
#[test]
fn explain_in_a_second_checkout_names_the_input_that_changed() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::small_scene(&dir.path().join("a"));
    let cache = dir.path().join("cache");
    cook(&scene, &dir.path().join("out.pack"), &cache);
    common::copy_dir(&dir.path().join("a"), &dir.path().join("b"));
    common::design(&dir.path().join("b/lit.png"), 1);
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args(["cache", "explain"])
        .arg(dir.path().join("b/scene.toml"))
        .arg("--cache-dir")
        .arg(&cache)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let said = stdout(&o);
    assert!(
        said.contains(
            "a cook would cook it; since the last cook of the same manifest and \
                       settings recorded here, in another checkout:"
        ) && said.contains("b/lit.png changed"),
        "{said}"
    );
    assert!(!said.contains("no earlier cook"), "{said}");
    // The manifest edited there too: the first checkout's record of the same scene, found by
    // its files, says so.
    let manifest = dir.path().join("b/scene.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    std::fs::write(&manifest, format!("{text}\n# edited\n")).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args(["cache", "explain"])
        .arg(&manifest)
        .arg("--cache-dir")
        .arg(&cache)
        .output()
        .unwrap();
    let said = stdout(&o);
    assert!(
        said.contains("b/scene.toml changed") && said.contains("b/lit.png changed"),
        "{said}"
    );
}

#[test]
fn explain_names_the_setting_or_input_that_changed() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::small_scene(&dir.path().join("a"));
    let cache = dir.path().join("cache");
    let out = dir.path().join("out.pack");
    cook(&scene, &out, &cache);
    let explain = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
            .args(["cache", "explain"])
            .arg(&scene)
            .arg("--cache-dir")
            .arg(&cache)
            .args(args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        stdout(&o)
    };
    let same = explain(&[]);
    assert!(
        same.contains("a cook would reuse the cached pack"),
        "{same}"
    );
    let fifo = explain(&["--fifo", "--max-error-lsb", "2"]);
    assert!(fifo.contains("a cook would cook it"), "{fifo}");
    assert!(
        fifo.contains("setting mesh.cache: \"Full\" -> \"Fifo\""),
        "{fifo}"
    );
    assert!(
        fifo.contains("setting textures.max_error_lsb: null -> 2.0"),
        "{fifo}"
    );
    assert!(!fifo.contains("lit.png"), "{fifo}");
    common::design(&dir.path().join("a/lit.png"), 1);
    let edited = explain(&[]);
    assert!(edited.contains("a cook would cook it"), "{edited}");
    assert!(edited.contains("lit.png changed"), "{edited}");
    assert!(!edited.contains("setting "), "{edited}");
    // A --window entry's settings hold f32s, recorded through JSON: read back, the last digit
    // differed and explain listed "setting window_overrides" as changed.
    common::design(&dir.path().join("a/ov.png"), 2);
    let window = format!("lit={}", dir.path().join("a/ov.png").display());
    cook_with(&scene, &out, &cache, &["--window", &window], "2");
    common::design(&dir.path().join("a/ov.png"), 3);
    let overridden = explain(&["--window", &window]);
    assert!(overridden.contains("ov.png changed"), "{overridden}");
    assert!(!overridden.contains("setting "), "{overridden}");
    // The manifest edited: one line for it (it is among the recorded inputs too).
    let manifest = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(&scene, format!("{manifest}\n# edited\n")).unwrap();
    let edited = explain(&[]);
    assert_eq!(edited.matches("scene.toml changed").count(), 1, "{edited}");

    // The result entry kept, its pack removed as damaged by `cache verify`: explain said a
    // cook would reuse it while the cook said "cached pack was evicted".
    std::fs::write(&scene, &manifest).unwrap();
    cook(&scene, &out, &cache);
    assert!(explain(&[]).contains("a cook would reuse the cached pack"));
    for e in std::fs::read_dir(&cache).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "blob") {
            let mut bytes = std::fs::read(&p).unwrap();
            bytes.push(0);
            std::fs::write(&p, bytes).unwrap();
        }
    }
    // Damaged, before verify removes it: the cook re-cooks it, and explain says so.
    let damaged = explain(&[]);
    assert!(
        damaged.contains("a cook would cook it: the result's pack ")
            && damaged.contains(" is damaged (`cooker cache verify` removes it)"),
        "{damaged}"
    );
    let verify = cache_verify(&cache);
    assert_eq!(verify.status.code(), Some(1), "{}", said(&verify));
    // Each damaged file named once (the reason named it again).
    let verified = stdout(&verify);
    for line in verified.lines().filter(|l| l.starts_with("damaged: ")) {
        assert_eq!(line.matches(".blob").count(), 1, "{verified}");
    }
    let gone = explain(&[]);
    assert!(
        gone.contains("a cook would cook it: the result's pack ")
            && gone.contains(" is gone (evicted, or removed as damaged by `cooker cache verify`)"),
        "{gone}"
    );
    assert!(!gone.contains("reuse"), "{gone}");
    let again = cook(&scene, &out, &cache);
    assert!(
        stdout(&again).contains("cache: cooking because cached pack was evicted"),
        "{}",
        stdout(&again)
    );

    // A garbled record of the last cook is damage, not "no earlier cook is recorded": explain
    // says so, and verify finds and removes it.
    std::fs::write(&scene, format!("{manifest}\n# edited again\n")).unwrap();
    let mut records = 0;
    for e in std::fs::read_dir(cache.join("scenes")).unwrap() {
        std::fs::write(e.unwrap().path(), b"{ not a record").unwrap();
        records += 1;
    }
    assert!(records > 0);
    let garbled = explain(&[]);
    assert!(
        garbled.contains("a cook would cook it: the record of the last cook of ")
            && garbled.contains("is damaged (`cooker cache verify` removes it)"),
        "{garbled}"
    );
    let verify = cache_verify(&cache);
    assert_eq!(verify.status.code(), Some(1), "{}", said(&verify));
    let verified = stdout(&verify);
    assert_eq!(
        verified
            .lines()
            .filter(|l| l.starts_with("damaged: ")
                && l.contains(".json: not a record of a cook: ")
                && l.ends_with("(removed)"))
            .count(),
        records,
        "{verified}"
    );
    assert_eq!(std::fs::read_dir(cache.join("scenes")).unwrap().count(), 0);
}

/// An edit cooked, then reverted with another file changed: explain compares with the cook
/// of the manifest as it is now, not with the edited one, which named a design the manifest
/// no longer does ("scene.toml changed", "lit2.png cannot be read").
#[test]
fn explain_after_a_reverted_edit_compares_with_the_cook_of_the_manifest_as_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::small_scene(&dir.path().join("a"));
    let folder = dir.path().join("a");
    let cache = dir.path().join("cache");
    let out = dir.path().join("out.pack");
    cook(&scene, &out, &cache);
    let manifest = std::fs::read_to_string(&scene).unwrap();
    std::fs::rename(folder.join("lit.png"), folder.join("lit2.png")).unwrap();
    std::fs::write(&scene, manifest.replace("lit.png", "lit2.png")).unwrap();
    cook(&scene, &out, &cache);
    std::fs::rename(folder.join("lit2.png"), folder.join("lit.png")).unwrap();
    std::fs::write(&scene, &manifest).unwrap();
    common::design(&folder.join("dark.png"), 91);
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args(["cache", "explain"])
        .arg(&scene)
        .arg("--cache-dir")
        .arg(&cache)
        .output()
        .unwrap();
    let said = stdout(&o);
    assert!(o.status.success(), "{said}");
    assert!(
        said.contains("since the last cook of this manifest and these settings")
            && said.contains("dark.png changed"),
        "{said}"
    );
    assert!(
        !said.contains("scene.toml changed") && !said.contains("cannot be read"),
        "{said}"
    );
}

/// A `--window` image in the scene's folder is the same setting however it is named: from
/// the folder above (`a/mine.png`), from the scene's own (`mine.png`), or in a second checkout
/// (`b/mine.png`). As typed, each was another key, and the pack was assembled again.
#[test]
fn a_window_image_in_the_scene_s_folder_is_one_setting_however_it_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let (scene_a, scene_b) = (common::small_scene(&a), common::small_scene(&b));
    common::design(&a.join("mine.png"), 17);
    common::design(&b.join("mine.png"), 17);
    let cache = dir.path().join("cache");
    let run = |cwd: &Path, scene: &Path, image: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
            .args(["cook", "-v"])
            .arg(scene)
            .arg("-o")
            .arg(dir.path().join("out.pack"))
            .arg("--cache-dir")
            .arg(&cache)
            .args(["--window", &format!("lit={image}")])
            .current_dir(cwd)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        stdout(&o)
    };
    let first = run(dir.path(), &scene_a, "a/mine.png");
    assert!(!first.contains("reused the cached pack"), "{first}");
    std::fs::remove_file(dir.path().join("out.pack")).unwrap();
    let inside = run(&a, Path::new("scene.toml"), "mine.png");
    assert!(inside.contains("reused the cached pack"), "{inside}");
    std::fs::remove_file(dir.path().join("out.pack")).unwrap();
    let checkout = run(dir.path(), &scene_b, "b/mine.png");
    assert!(checkout.contains("reused the cached pack"), "{checkout}");
}

/// `cooker cache verify` of the local cache `cache`.
fn cache_verify(cache: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args(["cache", "verify", "--cache-dir"])
        .arg(cache)
        .output()
        .unwrap()
}

/// A command's stdout, then its stderr.
fn said(o: &Output) -> String {
    format!("{}{}", stdout(o), stderr(o))
}

/// Asserts that what `o` printed contains `text`, naming `model` where it does not.
fn says(model: &str, o: &Output, text: &str) {
    assert!(said(o).contains(text), "{model}: {}", said(o));
}

/// Files of `folder` under tests/data/third_party, by name and content.
fn third_party_files<'a>(folder: &str, names: &[&'a str]) -> Vec<(&'a str, Vec<u8>)> {
    let dir = root().join("tests/data/third_party").join(folder);
    names
        .iter()
        .map(|&f| (f, std::fs::read(dir.join(f)).unwrap()))
        .collect()
}

/// `files` written into a folder of their own under `parent`, named after `model`; the
/// model's path there.
fn model_folder(parent: &Path, model: &str, files: &[(&str, Vec<u8>)]) -> PathBuf {
    let here = parent.join(model.replace('.', "_"));
    std::fs::create_dir_all(&here).unwrap();
    for (f, bytes) in files {
        std::fs::write(here.join(f), bytes).unwrap();
    }
    here.join(model)
}

/// Asserts that `cooked` is what a cook of `scene` without the cache writes.
fn is_the_uncached_cook(model: &str, scene: &Path, cooked: &[u8]) {
    let fresh = scene.with_file_name("fresh.pack");
    let o = common::cooker(&[&"cook", &"--no-cache", &scene, &"-o", &fresh]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(cooked, std::fs::read(&fresh).unwrap(), "{model}");
}

/// A file a model names that is missing (an image beside a glTF, an OBJ's material library, a
/// PLY's texture) is part of what a cached cook depends on: once it is there, the scene is
/// cooked with it, not reused as it was cooked without.
#[test]
fn a_missing_file_that_appears_is_cooked_in_not_reused_without() {
    let third = root().join("tests/data/third_party");
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let ply = std::fs::read_to_string(third.join("ply/cube_uv.ply"))
        .unwrap()
        .replacen(
            "format ascii 1.0\n",
            "format ascii 1.0\ncomment TextureFile cube.png\n",
            1,
        );
    // The model's files by name and content.
    type Files<'a> = Vec<(&'a str, Vec<u8>)>;
    // (the model, its files, the missing one's source, the name it is missing under)
    let cases: [(&str, Files, PathBuf, &str); 3] = [
        (
            "BoxTextured.gltf",
            third_party_files(
                "gltf/BoxTextured",
                &["BoxTextured.gltf", "BoxTextured0.bin"],
            ),
            third.join("gltf/BoxTextured/CesiumLogoFlat.png"),
            "CesiumLogoFlat.png",
        ),
        (
            "cornell_box.obj",
            third_party_files("cornell_box", &["cornell_box.obj"]),
            third.join("cornell_box/cornell_box.mtl"),
            "cornell_box.mtl",
        ),
        (
            // Found as the import finds it: in another letter case.
            "cube_uv.ply",
            vec![("cube_uv.ply", ply.into_bytes())],
            third.join("gltf/BoxTextured/CesiumLogoFlat.png"),
            "cube.PNG",
        ),
    ];
    for (model, files, missing, name) in cases {
        let scene = model_folder(dir.path(), model, &files);
        let here = scene.parent().unwrap();
        let out = here.join("out.pack");
        let says = |o: &Output, text: &str| says(model, o, text);
        let first = cook(&scene, &out, &cache);
        says(&first, "not found");
        let again = cook(&scene, &out, &cache);
        says(&again, "up to date");
        let without = std::fs::read(&out).unwrap();

        std::fs::copy(&missing, here.join(name)).unwrap();
        let with = cook(&scene, &out, &cache);
        says(&with, "was not found by the last cook and is there now");
        assert!(
            !said(&with).contains("not found;"),
            "{model}: {}",
            said(&with)
        );
        let cooked = std::fs::read(&out).unwrap();
        assert_ne!(cooked, without, "{model}: the file changed nothing");
        is_the_uncached_cook(model, &scene, &cooked);
        let last = cook(&scene, &out, &cache);
        says(&last, "up to date");

        // Gone again: the cook without it is the one cached before.
        std::fs::remove_file(here.join(name)).unwrap();
        cook(&scene, &out, &cache);
        assert_eq!(std::fs::read(&out).unwrap(), without, "{model}");
    }
}

/// A file the import found under another spelling (another letter case, as a model from
/// Windows names it) is taken under its own name once that is there: the cache notices and
/// cooks again, rather than reuse the cook of the other file, whose bytes did not change.
#[test]
fn a_file_found_in_another_case_gives_way_to_its_own_name_and_the_cache_sees_it() {
    let third = root().join("tests/data/third_party");
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let mtl = std::fs::read_to_string(third.join("cornell_box/cornell_box.mtl")).unwrap();
    // (the model and its files, the name the model gives, the spelling first there, the
    // bytes under each)
    type Case<'a> = (
        &'a str,
        Vec<(&'a str, Vec<u8>)>,
        &'a str,
        &'a str,
        Vec<u8>,
        Vec<u8>,
    );
    let cases: [Case; 2] = [
        (
            "BoxTextured.gltf",
            third_party_files(
                "gltf/BoxTextured",
                &["BoxTextured.gltf", "BoxTextured0.bin"],
            ),
            "CesiumLogoFlat.png",
            "cesiumlogoflat.PNG",
            std::fs::read(third.join("gltf/BoxTextured/CesiumLogoFlat.png")).unwrap(),
            std::fs::read(third.join("gltf/TextureCoordinateTest/TextureCoordinateTemplate.png"))
                .unwrap(),
        ),
        (
            "cornell_box.obj",
            third_party_files("cornell_box", &["cornell_box.obj"]),
            "cornell_box.mtl",
            "Cornell_Box.MTL",
            mtl.clone().into_bytes(),
            mtl.replacen("Kd 0 1 0", "Kd 0.2 0.3 0.7", 1).into_bytes(),
        ),
    ];
    for (model, files, name, other_case, first_bytes, own_bytes) in cases {
        assert_ne!(
            first_bytes, own_bytes,
            "{model}: the two files are the same"
        );
        let scene = model_folder(dir.path(), model, &files);
        let here = scene.parent().unwrap();
        std::fs::write(here.join(other_case), &first_bytes).unwrap();
        let out = here.join("out.pack");
        let says = |o: &Output, text: &str| says(model, o, text);
        let first = cook(&scene, &out, &cache);
        assert!(
            !said(&first).contains("not found"),
            "{model}: {}",
            said(&first)
        );
        says(&cook(&scene, &out, &cache), "up to date");
        let before = std::fs::read(&out).unwrap();

        std::fs::write(here.join(name), &own_bytes).unwrap();
        let with = cook(&scene, &out, &cache);
        says(
            &with,
            &format!("{name} was found as {other_case} by the last cook and is {name} now"),
        );
        let cooked = std::fs::read(&out).unwrap();
        assert_ne!(cooked, before, "{model}: its own file changed nothing");
        is_the_uncached_cook(model, &scene, &cooked);
        says(&cook(&scene, &out, &cache), "up to date");

        // Its own name gone again: the other spelling's cook, as cached before.
        std::fs::remove_file(here.join(name)).unwrap();
        cook(&scene, &out, &cache);
        assert_eq!(std::fs::read(&out).unwrap(), before, "{model}");
    }
}

/// A `--window` image is named from the working directory, but the cache hashed it from the
/// model's folder: with the model in a subfolder it warned that the image "cannot be read", and
/// where a file of that name also lay beside the model, a changed design reused the stale pack.
#[test]
fn a_window_image_named_from_the_working_directory_is_the_one_the_cache_watches() {
    let dir = tempfile::tempdir().unwrap();
    for sub in ["t1/design", "design"] {
        std::fs::create_dir_all(dir.path().join(sub)).unwrap();
    }
    std::fs::write(
        dir.path().join("t1/chapel.obj"),
        "mtllib chapel.mtl\nv -3 0 -6\nv -3 0 6\nv 3 0 6\nv 3 0 -6\nusemtl Boden\nf 1 2 3 4\n\
         v -3 1 -1\nv -3 1 1\nv -3 2.5 1\nv -3 2.5 -1\nusemtl Fenster\nf 5 6 7 8\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("t1/chapel.mtl"),
        "newmtl Boden\nKd 0.5 0.5 0.5\nnewmtl Fenster\nKd 0.7 0.8 0.9\nd 0.3\n",
    )
    .unwrap();
    let png = |path: &str, rgb: [u8; 3]| {
        image::RgbaImage::from_pixel(16, 16, image::Rgba([rgb[0], rgb[1], rgb[2], 255]))
            .save(dir.path().join(path))
            .unwrap()
    };
    // The decoy beside the model, under the name the design is given by.
    png("t1/design/x.png", [128, 128, 128]);
    png("design/x.png", [255, 0, 255]);
    let run = || {
        let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
            .current_dir(dir.path())
            .args([
                "cook",
                "-v",
                "t1/chapel.obj",
                "-o",
                "out.pack",
                "--cache-dir",
                "cache",
            ])
            .args(["--window", "Fenster=design/x.png"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        (
            said(&o),
            std::fs::read(dir.path().join("out.pack")).unwrap(),
        )
    };
    let (first, magenta) = run();
    assert!(!first.contains("cannot be read"), "{first}");
    let (again, same) = run();
    assert!(again.contains("up to date"), "{again}");
    assert_eq!(same, magenta);
    png("design/x.png", [0, 255, 0]);
    let (changed, green) = run();
    assert!(
        changed.contains("an input changed") && !changed.contains("up to date"),
        "{changed}"
    );
    assert_ne!(green, magenta, "the changed design was not cooked in");
}

/// A query about the default cache on a machine that never cooked says there is none and
/// makes nothing (`cache stats` made the directory, empty); a cook then makes it.
#[test]
fn a_query_does_not_make_the_default_cache() {
    let dir = tempfile::tempdir().unwrap();
    let home = dir.path().join("home");
    std::fs::create_dir(&home).unwrap();
    let default = home.join(".cache/stained-glass");
    let run = |args: &[&dyn AsRef<std::ffi::OsStr>]| {
        let mut c = common::command();
        for a in args {
            c.arg(a);
        }
        c.env("HOME", &home)
            .env_remove("XDG_CACHE_HOME")
            .env_remove("STAINED_GLASS_CACHE")
            .env_remove("STAINED_GLASS_CACHE_URL")
            .output()
            .unwrap()
    };
    let scene_dir = dir.path().join("scene");
    common::copy_dir(&root().join("assets-src"), &scene_dir);
    let scene = scene_dir.join("scene.toml");
    for args in [
        vec![&"cache" as &dyn AsRef<std::ffi::OsStr>, &"stats"],
        vec![&"cache", &"verify"],
        vec![&"cache", &"explain", &scene],
    ] {
        let o = run(&args);
        let t = format!("{}{}", stdout(&o), stderr(&o));
        assert_eq!(o.status.code(), Some(0), "{t}");
        assert!(
            t.contains(&format!(
                "local cache {}: no such directory",
                default.display()
            )),
            "{t}"
        );
        assert!(!default.exists(), "{t}");
    }
    let out = dir.path().join("out.pack");
    let o = run(&[&"cook", &scene, &"-o", &out, &"--texture-format", &"rgba8"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(default.is_dir());
}

/// After a bare cook of a model, `explain` of the manifest `init` wrote for it compares it
/// with that cook as what it is (the same files under another manifest), not as "the same
/// manifest, in another checkout" where "scene.toml changed".
#[test]
fn explain_after_a_bare_cook_says_the_manifest_is_another() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(
        root().join("tests/data/third_party/cornell_box/cornell_box.obj"),
        d.join("box.obj"),
    )
    .unwrap();
    std::fs::copy(
        root().join("tests/data/third_party/cornell_box/cornell_box.mtl"),
        d.join("cornell_box.mtl"),
    )
    .unwrap();
    let cache = d.join("cache");
    cook(&d.join("box.obj"), &d.join("box.pack"), &cache);
    let o = common::cooker(&[&"init", &d.join("box.obj")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .args(["cache", "explain"])
        .arg(d.join("scene.toml"))
        .arg("--cache-dir")
        .arg(&cache)
        .output()
        .unwrap();
    let said = stdout(&o);
    assert!(o.status.success(), "{said}{}", stderr(&o));
    assert!(
        said.contains("under another manifest or as a bare model"),
        "{said}"
    );
    assert!(
        said.contains("scene.toml is not that cook's manifest"),
        "{said}"
    );
    assert!(!said.contains("in another checkout"), "{said}");
}

/// A model whose file name is not UTF-8 (unpacked from a Windows archive) is reused as any
/// other: its cache entries failed to serialize ("cache not updated"), and every cook missed.
#[cfg(unix)]
#[test]
fn a_model_named_in_another_encoding_is_reused() {
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = d.join(std::ffi::OsStr::from_bytes(b"\xf5\xf0\xe0\xec.obj"));
    std::fs::copy(
        root().join("tests/data/third_party/cornell_box/cornell_box.obj"),
        &model,
    )
    .unwrap();
    std::fs::copy(
        root().join("tests/data/third_party/cornell_box/cornell_box.mtl"),
        d.join("cornell_box.mtl"),
    )
    .unwrap();
    let cache = d.join("cache");
    let out = d.join("out.pack");
    let first = cook(&model, &out, &cache);
    assert!(
        !stderr(&first).contains("cache not updated"),
        "{}",
        stderr(&first)
    );
    let second = cook(&model, &out, &cache);
    assert!(
        stdout(&second).contains("is up to date"),
        "{}",
        stdout(&second)
    );
}

#[test]
fn a_bad_size_in_the_environment_is_blamed_on_the_variable() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_cooker"))
            .args(["cook", "scene.toml", "-o", "x.pack"])
            .args(args)
            .current_dir(dir.path())
            .env("STAINED_GLASS_CACHE_MAX_SIZE", "abc")
            .output()
            .unwrap()
    };
    let from_env = run(&[]);
    assert_eq!(from_env.status.code(), Some(2), "{}", stderr(&from_env));
    let e = stderr(&from_env);
    assert!(
        e.contains(
            "invalid value 'abc' in $STAINED_GLASS_CACHE_MAX_SIZE (read as --cache-max-size)"
        ),
        "{e}"
    );
    // The flag, where given, is what clap blames, and it is the flag's value that is shown.
    for args in [&["--cache-max-size", "xyz"][..], &["--cache-max-size=xyz"]] {
        let flagged = run(args);
        assert_eq!(flagged.status.code(), Some(2));
        let e = stderr(&flagged);
        assert!(e.contains("'xyz'") && !e.contains("$STAINED_GLASS"), "{e}");
    }
    assert!(!dir.path().join("x.pack").exists());
}

/// A cached scene cooked to a device: whether the output already holds the pack was asked of
/// `/dev/zero` by reading it whole, and the cook grew until it was killed (24 GB). Under a
/// 4 GB address-space limit that was a failed allocation; now it is a write, as uncached.
#[cfg(target_os = "linux")]
#[test]
fn a_cache_hit_written_to_a_device_reads_no_more_of_it_than_a_pack() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::small_scene(&dir.path().join("a"));
    let cache = dir.path().join("cache");
    cook(&scene, &dir.path().join("out.pack"), &cache);
    let o = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 4000000 && exec \"$0\" cook \"$1\" -o /dev/zero --cache-dir \"$2\"")
        .arg(env!("CARGO_BIN_EXE_cooker"))
        .arg(&scene)
        .arg(&cache)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("reused the cached pack"),
        "{}",
        stdout(&o)
    );
}
