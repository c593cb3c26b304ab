//! The remote cook cache against real servers on 127.0.0.1, started here and stopped when each
//! test ends: Redis (`redis-server`), nginx with WebDAV, SeaweedFS's S3 API (`weed mini`), and
//! a plain folder (`file://`). `scripts/install-test-deps.sh` installs them; a missing one
//! fails the test (it never skips).
//!
//! For each backend: machine A cooks cold and fills the remote; machine B (an empty cache dir,
//! another checkout) reuses everything with a byte-identical pack; a design changed on A is
//! re-cooked there alone and B then reuses A's result; a design changed on B alone re-cooks only
//! that design's textures. Fault cases: the server stopped mid-cook, a corrupted blob planted,
//! a truncated reply, a read-only token (403), two cooks racing on one key.

mod common;
mod servers;

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::Duration;

/// A remote as the cooker is told about it: the URL, and extra arguments and variables.
#[derive(Clone)]
struct Remote {
    url: String,
    args: Vec<String>,
    env: Vec<(String, String)>,
}

impl Remote {
    fn plain(url: String) -> Remote {
        Remote {
            url,
            args: Vec::new(),
            env: Vec::new(),
        }
    }
}

fn cook_cmd(scene: &Path, out: &Path, cache: &Path, remote: &Remote, args: &[&str]) -> Command {
    let mut c = common::command();
    c.args(["cook", "-v"])
        .arg(scene)
        .arg("-o")
        .arg(out)
        .arg("--cache-dir")
        .arg(cache)
        .args(["--cache-url", &remote.url])
        .args(&remote.args)
        .args(["--cache-timeout", "20"])
        .args(args)
        // Writes are asked for explicitly: the variable CI would turn them on.
        .env_remove("CI")
        .env_remove("STAINED_GLASS_CACHE_URL");
    for (k, v) in &remote.env {
        c.env(k, v);
    }
    c
}

fn cook(scene: &Path, out: &Path, cache: &Path, remote: &Remote, args: &[&str]) -> Output {
    cook_cmd(scene, out, cache, remote, args).output().unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn ok(o: &Output) -> String {
    let t = text(o);
    assert!(o.status.success(), "{t}");
    t
}

/// The remote summary line's counts: (hits, misses, errors).
fn remote_counts(t: &str) -> (u64, u64, u64) {
    let line = t
        .lines()
        .find(|l| l.starts_with("remote cache ") && l.contains(" hits, "))
        .unwrap_or_else(|| panic!("no remote summary in {t}"));
    let n = |word: &str| -> u64 {
        let before = &line[..line.find(word).unwrap()];
        before
            .rsplit(|c: char| !c.is_ascii_digit())
            .find(|s| !s.is_empty())
            .unwrap()
            .parse()
            .unwrap()
    };
    (n(" hits"), n(" misses"), n(" errors"))
}

fn lines_with<'a>(t: &'a str, start: &str) -> Vec<&'a str> {
    t.lines()
        .filter(|l| l.trim_start().starts_with(start))
        .collect()
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// One scene in two checkouts (machine A's and machine B's), with the design to change.
struct Scene {
    a: PathBuf,
    b: PathBuf,
    /// A design file, relative to the scene's folder, and another one for B alone.
    design: &'static str,
    other_design: &'static str,
}

fn default_scene(dir: &Path) -> Scene {
    common::copy_dir(&root().join("assets-src"), &dir.join("a"));
    common::copy_dir(&root().join("assets-src"), &dir.join("machine-b/scene"));
    Scene {
        a: dir.join("a/scene.toml"),
        b: dir.join("machine-b/scene/scene.toml"),
        design: "windows/lancet.png",
        other_design: "windows/border.png",
    }
}

fn small_scene(dir: &Path) -> Scene {
    common::small_scene(&dir.join("a"));
    common::small_scene(&dir.join("machine-b/scene"));
    Scene {
        a: dir.join("a/scene.toml"),
        b: dir.join("machine-b/scene/scene.toml"),
        design: "lit.png",
        other_design: "dark.png",
    }
}

/// Changes one pixel of a design, mid-image: one beyond its window's outline is masked away
/// and changes nothing cooked.
fn edit(design: &Path, colour: [u8; 4]) {
    let mut img = image::open(design).unwrap().to_rgba8();
    let (w, h) = img.dimensions();
    img.get_pixel_mut(w / 2, h / 2).0 = colour;
    img.save(design).unwrap();
}

/// A cook with no cache at all: what every cached cook must equal.
fn reference(scene: &Path, out: &Path) -> Vec<u8> {
    let o = common::command()
        .arg("cook")
        .arg(scene)
        .arg("-o")
        .arg(out)
        .arg("--no-cache")
        .output()
        .unwrap();
    ok(&o);
    std::fs::read(out).unwrap()
}

/// Machine A fills the remote, machine B reuses it; a design changed on A, then on B alone.
fn machines_share(dir: &Path, scene: &Scene, remote: &Remote, forbidden: &[&str]) {
    let out_a = dir.join("a.pack");
    let out_b = dir.join("b.pack");
    let cache_a = dir.join("cache-a");
    let writer = ["--cache-write"];

    // A, cold: everything cooked, everything stored.
    let t = ok(&cook(&scene.a, &out_a, &cache_a, remote, &writer));
    let (hits, misses, errors) = remote_counts(&t);
    assert!(hits == 0 && misses > 0 && errors == 0, "{t}");
    assert!(t.contains("0 textures reused"), "{t}");
    for secret in forbidden {
        assert!(!t.contains(secret), "a secret was printed: {t}");
    }
    let cold = std::fs::read(&out_a).unwrap();

    // B, another checkout with an empty cache, only reading: the whole pack from the remote.
    let t = ok(&cook(&scene.b, &out_b, &dir.join("cache-b"), remote, &[]));
    assert!(t.contains("reused the cached pack"), "{t}");
    let (hits, _, errors) = remote_counts(&t);
    assert!(hits > 0 && errors == 0, "{t}");
    assert!(t.contains("(read-only)"), "{t}");
    assert!(
        std::fs::read(&out_b).unwrap() == cold,
        "B's pack differs from A's"
    );
    // What A's cook said, B's hit says, naming B's files.
    let a_dir = scene.a.parent().unwrap().display().to_string();
    let b_dir = scene.b.parent().unwrap().display().to_string();
    let said = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| l.starts_with("warning: ") && !l.contains("remote cache"))
            .map(str::to_string)
            .collect()
    };
    let a_said = said(&ok(&cook(&scene.a, &out_a, &cache_a, remote, &[])));
    let b_said = said(&t);
    assert_eq!(
        b_said,
        a_said
            .iter()
            .map(|l| l.replace(&a_dir, &b_dir))
            .collect::<Vec<_>>()
    );

    // One design changes on A: only its textures are cooked, the rest reused locally.
    edit(
        &scene.a.parent().unwrap().join(scene.design),
        [255, 0, 255, 255],
    );
    let t = ok(&cook(&scene.a, &out_a, &cache_a, remote, &writer));
    // As a cooked line names it: the file, or the design cut to its outline (`lancet.masked`).
    let file = scene.design.rsplit('/').next().unwrap();
    let stem = file.split('.').next().unwrap();
    let cooked = lines_with(&t, "cooked ");
    assert!(!cooked.is_empty(), "{t}");
    assert!(cooked.iter().all(|l| l.contains(stem)), "{cooked:?}");
    assert!(
        lines_with(&t, "reused ").iter().all(|l| !l.contains(stem)),
        "{t}"
    );
    let changed = std::fs::read(&out_a).unwrap();
    assert!(changed != cold);

    // The same change reaches B: A's result is reused whole, byte for byte.
    edit(
        &scene.b.parent().unwrap().join(scene.design),
        [255, 0, 255, 255],
    );
    let t = ok(&cook(&scene.b, &out_b, &dir.join("cache-b"), remote, &[]));
    assert!(t.contains("reused the cached pack"), "{t}");
    assert!(std::fs::read(&out_b).unwrap() == changed);

    // A change on B alone, with an empty cache: only that design's textures are cooked, every
    // other one comes from the remote.
    edit(
        &scene.b.parent().unwrap().join(scene.other_design),
        [0, 255, 0, 255],
    );
    let t = ok(&cook(&scene.b, &out_b, &dir.join("cache-b2"), remote, &[]));
    let other = scene.other_design.rsplit('/').next().unwrap();
    let other = other.split('.').next().unwrap();
    let cooked = lines_with(&t, "cooked ");
    let reused = lines_with(&t, "reused ");
    assert!(!cooked.is_empty() && !reused.is_empty(), "{t}");
    assert!(cooked.iter().all(|l| l.contains(other)), "{cooked:?}");
    assert!(reused.iter().all(|l| !l.contains(other)), "{reused:?}");
    let (hits, _, errors) = remote_counts(&t);
    assert!(hits as usize >= reused.len() && errors == 0, "{t}");
    let fresh = reference(&scene.b, &dir.join("fresh.pack"));
    assert!(std::fs::read(&out_b).unwrap() == fresh);
}

#[test]
fn file_share_machines_share_and_a_planted_blob_is_caught() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let share = d.join("share");
    let scene = small_scene(&d.join("s"));
    // A share that is not there (not mounted) was made and used as an empty cache, read-only
    // and required alike: now it is a remote failure, exit 4 where required, and not made.
    let unmounted = Remote::plain(format!("file://{}", share.display()));
    let o = cook(
        &scene.b,
        &d.join("u.pack"),
        &d.join("cache-u"),
        &unmounted,
        &["--cache-read-only", "--cache-remote-required"],
    );
    let t = text(&o);
    assert_eq!(o.status.code(), Some(4), "{t}");
    assert!(
        t.contains("is not a folder (a share that is not mounted?)"),
        "{t}"
    );
    assert!(!share.exists());
    // A URL of no known scheme is bad usage (it exited 4 and blamed --cache-remote-required).
    let ftp = Remote::plain("ftp://host/cache".to_string());
    let o = cook(
        &scene.b,
        &d.join("u.pack"),
        &d.join("cache-u"),
        &ftp,
        &["--cache-remote-required"],
    );
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(
        t.contains("unknown scheme \"ftp\"") && !t.contains("(--cache-remote-required)"),
        "{t}"
    );
    std::fs::create_dir(&share).unwrap();
    let remote = Remote::plain(format!("file://{}", share.display()));
    machines_share(d, &scene, &remote, &[]);

    // Every blob on the share replaced by other bytes of the same length: each is caught,
    // reported, and the cook goes on locally to the same pack, storing what it made over the
    // damaged blobs (every writer used to skip a name that was there, so nothing repaired one).
    let damage = || {
        let mut planted = 0;
        for e in std::fs::read_dir(share.join("cas")).unwrap() {
            let p = e.unwrap().path();
            let mut b = std::fs::read(&p).unwrap();
            let n = b.len();
            b[n / 2] ^= 0xff;
            std::fs::write(&p, b).unwrap();
            planted += 1;
        }
        planted
    };
    let verify = |dir: &Path| {
        let v = common::command()
            .args(["cache", "verify", "--cache-write", "--cache-dir"])
            .arg(dir)
            .args(["--cache-url", &remote.url])
            .env_remove("CI")
            .output()
            .unwrap();
        (v.status.code(), text(&v))
    };
    let planted = damage();
    let out = d.join("c.pack");
    let o = cook(
        &scene.b,
        &out,
        &d.join("cache-c"),
        &remote,
        &["--cache-write"],
    );
    let t = ok(&o);
    assert!(t.contains("content hashes to"), "{t}");
    assert!(t.contains("damaged blobs not used"), "{t}");
    let read_damaged = t.matches("damaged blob cas/").count() - t.matches(" replaced").count();
    let replaced = t.matches("damaged blob cas/").count() - read_damaged;
    assert!(replaced > 0 && replaced == read_damaged, "{t}");
    assert!(
        std::fs::read(&out).unwrap() == reference(&scene.b, &d.join("fresh.pack")),
        "a damaged blob reached the pack"
    );
    // The blobs this cook did not need stay damaged until `cache verify` removes them.
    let (code, vt) = verify(&d.join("cache-c"));
    assert_eq!(code, Some(1), "{vt}");
    assert!(
        vt.contains(&format!(", {} damaged", planted - replaced)),
        "{replaced} of {planted} replaced: {vt}"
    );
    let (code, vt) = verify(&d.join("cache-c"));
    assert_eq!(code, Some(0), "verify left damaged blobs: {vt}");
    assert!(vt.contains(", 0 damaged"), "{vt}");
    // `explain` on a machine that never cooked says what the remote holds.
    let fresh = d.join("cache-never");
    let v = common::command()
        .args(["cache", "explain"])
        .arg(&scene.b)
        .arg("--cache-dir")
        .arg(&fresh)
        .args(["--cache-url", &remote.url])
        .output()
        .unwrap();
    let vt = text(&v);
    assert_eq!(v.status.code(), Some(0), "{vt}");
    assert!(vt.contains("cache-never: no such directory"), "{vt}");
    assert!(vt.contains("held remotely"), "{vt}");
    assert!(!fresh.exists(), "{vt}");
    // `cache verify` finds every damaged blob (exit 1) and removes it; a garbage action
    // manifest too. A machine that never cooked (no local cache) reports the remote alone,
    // and makes no local directory; without a remote, a missing directory is still refused.
    let planted = damage();
    assert!(planted > 0);
    let garbage = share.join("ac").join("0".repeat(64));
    std::fs::write(&garbage, b"not json").unwrap();
    for command in ["stats", "verify"] {
        let v = common::command()
            .args(["cache", command, "--cache-write", "--cache-dir"])
            .arg(&fresh)
            .args(["--cache-url", &remote.url])
            .env_remove("CI")
            .output()
            .unwrap();
        let vt = text(&v);
        let (code, says) = match command {
            "verify" => (1, format!("objects checked, {} damaged", planted + 1)),
            _ => (0, "cas/: ".to_string()),
        };
        assert_eq!(v.status.code(), Some(code), "{vt}");
        assert!(vt.contains("cache-never: no such directory"), "{vt}");
        assert!(vt.contains(&says), "{vt}");
        assert!(!fresh.exists(), "{vt}");
    }
    assert!(!garbage.exists());
    let (code, vt) = verify(&fresh);
    assert_eq!(code, Some(0), "verify left damaged objects: {vt}");
    let v = common::command()
        .args(["cache", "stats", "--cache-dir"])
        .arg(&fresh)
        .output()
        .unwrap();
    assert_eq!(v.status.code(), Some(2), "{}", text(&v));
}

/// A writer whose work is all in its local cache, cooked before it had a remote: its hits are
/// uploaded, the scene and each step, so a machine with another design reuses the textures the
/// two share. Before, the writer uploaded nothing ("0 B up"), and the other machine cooked all.
#[test]
fn a_writer_shares_what_its_local_cache_already_held() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = small_scene(&d.join("s"));
    let share = d.join("share");
    std::fs::create_dir(&share).unwrap();
    let remote = Remote::plain(format!("file://{}", share.display()));
    let cache_a = d.join("cache-a");
    let out_a = d.join("a.pack");
    let o = common::command()
        .args(["cook"])
        .arg(&scene.a)
        .arg("-o")
        .arg(&out_a)
        .arg("--cache-dir")
        .arg(&cache_a)
        .output()
        .unwrap();
    ok(&o);
    // What writes that failed half way left in the share's temp folder: one from two hours
    // ago is swept by the next writer, one from now may be another machine's write in flight.
    let tmp = share.join(".tmp");
    std::fs::create_dir(&tmp).unwrap();
    let stale = tmp.join("stale.partial");
    std::fs::write(&stale, b"half a blob").unwrap();
    std::fs::File::options()
        .write(true)
        .open(&stale)
        .unwrap()
        .set_modified(std::time::SystemTime::now() - std::time::Duration::from_secs(7200))
        .unwrap();
    let in_flight = tmp.join("in-flight.partial");
    std::fs::write(&in_flight, b"a blob being written").unwrap();
    let t = ok(&cook(
        &scene.a,
        &out_a,
        &cache_a,
        &remote,
        &["--cache-write"],
    ));
    assert!(t.contains("the remote cache lacks this scene"), "{t}");
    assert!(!stale.exists() && in_flight.exists(), "{t}");
    let listed = |sub: &str| std::fs::read_dir(share.join(sub)).map_or(0, |r| r.count());
    assert!(listed("ac") > 2 && listed("cas") > 2, "{t}");
    // A second time the remote holds it all: the scene is reused, nothing more is sent.
    let t = ok(&cook(
        &scene.a,
        &out_a,
        &cache_a,
        &remote,
        &["--cache-write"],
    ));
    assert!(!t.contains("the remote cache lacks this scene"), "{t}");
    // B, another design: the steps the two scenes share come from the remote.
    let design_b = scene.b.parent().unwrap().join(scene.design);
    edit(&design_b, [1, 2, 3, 255]);
    let out_b = d.join("b.pack");
    let t = ok(&cook(&scene.b, &out_b, &d.join("cache-b"), &remote, &[]));
    let (hits, _, errors) = remote_counts(&t);
    assert!(hits > 0 && errors == 0, "{t}");
    assert!(
        t.contains("textures reused") && !t.contains(" 0 textures reused"),
        "{t}"
    );
    assert!(std::fs::read(&out_b).unwrap() == reference(&scene.b, &d.join("fresh.pack")));
}

#[test]
fn redis_machines_share_and_a_server_stopped_mid_cook_is_a_miss() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let password = "redis-pw-0f3c";
    let (mut redis, port) = servers::redis(d, password);
    let remote = Remote::plain(format!("redis://:{password}@127.0.0.1:{port}/0"));
    let scene = small_scene(&d.join("s"));
    machines_share(d, &scene, &remote, &[password]);

    // The server stops while a cook of the default scene runs: one warning, exit 0, and the
    // same pack as a cook without any cache.
    let big = default_scene(&d.join("big"));
    let out = d.join("stopped.pack");
    let child = cook_cmd(
        &big.a,
        &out,
        &d.join("cache-s"),
        &remote,
        &["--cache-write"],
    )
    .stdout(Stdio::piped())
    .stderr(Stdio::piped())
    .spawn()
    .unwrap();
    std::thread::sleep(Duration::from_millis(300));
    redis.stop();
    let o = child.wait_with_output().unwrap();
    let t = ok(&o);
    assert!(!t.contains(password), "{t}");
    let warnings: Vec<&str> = t
        .lines()
        .filter(|l| l.starts_with("warning: remote cache"))
        .collect();
    assert_eq!(warnings.len(), 1, "one warning: {t}");
    assert!(warnings[0].ends_with("cooking locally"), "{t}");
    assert!(remote_counts(&t).2 > 0, "{t}");
    let fresh = reference(&big.a, &d.join("fresh.pack"));
    assert!(std::fs::read(&out).unwrap() == fresh);
    // Nothing is lost: the local cache holds the cook, so the next one reuses it whole.
    let again = common::command()
        .arg("cook")
        .arg(&big.a)
        .arg("-o")
        .arg(&out)
        .arg("--cache-dir")
        .arg(d.join("cache-s"))
        .output()
        .unwrap();
    assert!(ok(&again).contains("is up to date"), "{}", text(&again));

    // Required: the stopped server is an error (exit 4) before the output is touched.
    let required = d.join("required.pack");
    let o = cook(
        &big.a,
        &required,
        &d.join("cache-r"),
        &remote,
        &["--cache-remote-required"],
    );
    let t = text(&o);
    assert_eq!(o.status.code(), Some(4), "{t}");
    assert!(
        t.contains("--cache-remote-required") && !t.contains(password),
        "{t}"
    );
    assert!(!required.exists());
}

/// Forwards connections to `upstream`, but cuts every reply off after `limit` bytes.
fn truncating_proxy(upstream: u16, limit: usize) -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        // Bounded: enough connections for the cooks of one test.
        for conn in listener.incoming().take(200) {
            let Ok(client) = conn else { continue };
            let Ok(server) = TcpStream::connect(("127.0.0.1", upstream)) else {
                continue;
            };
            let (mut c_read, mut s_write) =
                (client.try_clone().unwrap(), server.try_clone().unwrap());
            std::thread::spawn(move || {
                let _ = std::io::copy(&mut c_read, &mut s_write);
            });
            let (mut s_read, mut c_write) = (server, client);
            std::thread::spawn(move || {
                let mut sent = 0;
                let mut buf = [0u8; 16384];
                while sent < limit {
                    let n = match s_read.read(&mut buf) {
                        Ok(0) | Err(_) => break,
                        Ok(n) => n.min(limit - sent),
                    };
                    if c_write.write_all(&buf[..n]).is_err() {
                        break;
                    }
                    sent += n;
                }
                let _ = c_write.shutdown(std::net::Shutdown::Both);
                let _ = s_read.shutdown(std::net::Shutdown::Both);
            });
        }
    });
    port
}

#[test]
fn webdav_machines_share_a_truncated_reply_and_a_read_only_token() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (_nginx, port) = servers::nginx(&d.join("nginx"));
    let remote = Remote::plain(format!("http://127.0.0.1:{port}/cache/"));
    let scene = small_scene(&d.join("s"));
    machines_share(d, &scene, &remote, &[]);

    // Replies cut short (the connection closes mid-body): a miss, one warning, the same pack.
    let proxy = truncating_proxy(port, 600);
    let cut = Remote::plain(format!("http://127.0.0.1:{proxy}/cache/"));
    let out = d.join("cut.pack");
    let t = ok(&cook(&scene.b, &out, &d.join("cache-cut"), &cut, &[]));
    assert_eq!(
        t.lines()
            .filter(|l| l.starts_with("warning: remote cache"))
            .count(),
        1,
        "{t}"
    );
    assert!(remote_counts(&t).2 > 0, "{t}");
    assert!(std::fs::read(&out).unwrap() == reference(&scene.b, &d.join("fresh.pack")));

    // A read-only token: reads work, each write is refused (403), the cook still succeeds and
    // nothing is stored; the token is never printed.
    let token = Remote {
        url: format!("http://127.0.0.1:{port}/ro/"),
        args: Vec::new(),
        env: vec![("STAINED_GLASS_CACHE_TOKEN".into(), "read-only".into())],
    };
    let t = ok(&cook(
        &scene.a,
        &d.join("ro.pack"),
        &d.join("cache-ro"),
        &token,
        &["--cache-write"],
    ));
    assert!(t.contains("403"), "{t}");
    assert!(!t.contains("Bearer"), "{t}");
    assert!(remote_counts(&t).2 >= 1, "{t}");
    assert_eq!(
        t.lines()
            .filter(|l| l.starts_with("warning: remote cache"))
            .count(),
        1,
        "{t}"
    );
    assert!(!d.join("nginx/dav/ro/ac").exists());
    let o = cook(
        &scene.a,
        &d.join("ro2.pack"),
        &d.join("cache-ro2"),
        &token,
        &["--cache-write", "--cache-remote-required"],
    );
    assert_eq!(o.status.code(), Some(4), "{}", text(&o));
    assert!(text(&o).contains("403"), "{}", text(&o));
}

fn s3_remote(port: u16, user: &str, secret: &str) -> Remote {
    Remote {
        url: "s3://cache/stained-glass".into(),
        args: vec![
            "--cache-endpoint".into(),
            format!("http://127.0.0.1:{port}"),
        ],
        env: vec![
            ("AWS_ACCESS_KEY_ID".into(), user.into()),
            ("AWS_SECRET_ACCESS_KEY".into(), secret.into()),
            ("AWS_REGION".into(), "us-east-1".into()),
        ],
    }
}

#[test]
fn s3_default_scene_shared_racing_writers_read_only_identity_and_a_planted_blob() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (_weed, port) = servers::seaweed(&d.join("weed"));
    let ci = s3_remote(port, "ci", "ci-secret-5d1e");
    let scene = default_scene(&d.join("s"));
    machines_share(d, &scene, &ci, &["ci-secret-5d1e"]);

    // Two cooks racing on the same keys into the same bucket (another prefix, so both start
    // cold): both succeed with the same pack, and a third machine reuses it intact.
    let race = Remote {
        url: "s3://cache/race".into(),
        ..ci.clone()
    };
    let small = small_scene(&d.join("race"));
    let children: Vec<Child> = (0..2)
        .map(|i| {
            cook_cmd(
                &small.a,
                &d.join(format!("race{i}.pack")),
                &d.join(format!("cache-race{i}")),
                &race,
                &["--cache-write"],
            )
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
        })
        .collect();
    for c in children {
        let t = ok(&c.wait_with_output().unwrap());
        assert_eq!(remote_counts(&t).2, 0, "{t}");
    }
    let race0 = std::fs::read(d.join("race0.pack")).unwrap();
    assert!(race0 == std::fs::read(d.join("race1.pack")).unwrap());
    let t = ok(&cook(
        &small.b,
        &d.join("race2.pack"),
        &d.join("cache-race2"),
        &race,
        &[],
    ));
    assert!(t.contains("reused the cached pack"), "{t}");
    assert!(std::fs::read(d.join("race2.pack")).unwrap() == race0);
    let v = common::command()
        .args(["cache", "verify", "--cache-dir"])
        .arg(d.join("cache-race2"))
        .args(["--cache-url", &race.url])
        .args(&race.args)
        .envs(race.env.iter().map(|(k, v)| (k, v)))
        .output()
        .unwrap();
    assert_eq!(v.status.code(), Some(0), "{}", text(&v));

    // The read-only identity: it reads what CI stored; its writes are refused (403) and the
    // cook still succeeds.
    let dev = Remote {
        url: "s3://cache/race".into(),
        ..s3_remote(port, "dev", "dev-secret-77aa")
    };
    edit(
        &small.b.parent().unwrap().join(small.design),
        [1, 2, 3, 255],
    );
    let t = ok(&cook(
        &small.b,
        &d.join("dev.pack"),
        &d.join("cache-dev"),
        &dev,
        &["--cache-write"],
    ));
    assert!(t.contains("403") || t.contains("PermissionDenied"), "{t}");
    assert!(!t.contains("dev-secret-77aa"), "{t}");
    let (hits, _, errors) = remote_counts(&t);
    assert!(hits > 0 && errors >= 1, "{t}");

    // A blob replaced on the server (same name, other bytes): caught, and the cook is right.
    let blobs = list_s3(port, "race/cas/");
    assert!(!blobs.is_empty());
    for key in &blobs {
        let put = Command::new("curl")
            .args(["-s", "-f", "-X", "PUT", "--data-binary", "not the blob"])
            .args(["-H", "x-amz-content-sha256: UNSIGNED-PAYLOAD"])
            .args([
                "--aws-sigv4",
                "aws:amz:us-east-1:s3",
                "--user",
                "ci:ci-secret-5d1e",
            ])
            .arg(format!("http://127.0.0.1:{port}/cache/{key}"))
            .output()
            .unwrap();
        assert!(put.status.success(), "{}", text(&put));
    }
    let out = d.join("planted.pack");
    let t = ok(&cook(&small.a, &out, &d.join("cache-planted"), &race, &[]));
    assert!(t.contains("damaged blob cas/"), "{t}");
    assert!(std::fs::read(&out).unwrap() == race0);
}

/// Keys under `prefix` in the bucket, by a plain ListObjectsV2.
fn list_s3(port: u16, prefix: &str) -> Vec<String> {
    let o = Command::new("curl")
        .args([
            "-s",
            "-f",
            "--aws-sigv4",
            "aws:amz:us-east-1:s3",
            "--user",
            "ci:ci-secret-5d1e",
        ])
        .arg(format!(
            "http://127.0.0.1:{port}/cache/?list-type=2&prefix={}",
            prefix.replace('/', "%2F")
        ))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let body = String::from_utf8_lossy(&o.stdout);
    body.split("<Key>")
        .skip(1)
        .filter_map(|s| s.split("</Key>").next())
        .map(str::to_string)
        .collect()
}
