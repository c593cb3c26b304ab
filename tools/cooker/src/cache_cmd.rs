//! The cache options every command that cooks shares, and `cooker cache stats|verify|explain`.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use cook::Manifest;
use cook::cache::{Cache, Lookup, hex, scene_key};

use crate::exit::{FOUND_PROBLEMS, OK, Outcome};
use crate::remote::{self, Remote, human};
use crate::scene_cache;

#[derive(clap::Args, Clone, Debug)]
pub struct CacheArgs {
    /// Where cooked artifacts are kept between cooks (default: $STAINED_GLASS_CACHE, else
    /// $XDG_CACHE_HOME/stained-glass, else ~/.cache/stained-glass).
    #[arg(long, value_name = "DIR")]
    pub cache_dir: Option<PathBuf>,
    /// Cook everything from scratch; read and write no cache, local or remote.
    #[arg(long, conflicts_with = "cache_dir")]
    pub no_cache: bool,
    /// The local cache's size cap: after each cook the least recently used entries beyond it
    /// are deleted. Bytes, or with a unit: 500M, 5G, 5GiB (K, M, G, T are powers of 1024).
    #[arg(long, value_name = "SIZE", env = "STAINED_GLASS_CACHE_MAX_SIZE",
          default_value = "5GiB", value_parser = crate::size::parse)]
    pub cache_max_size: u64,
    /// A remote cache shared by machines, consulted after a local miss: file:///share/dir,
    /// redis://host:6379/0, http(s)://host/dav/ (WebDAV), s3://bucket/prefix.
    #[arg(long, value_name = "URL", env = "STAINED_GLASS_CACHE_URL")]
    pub cache_url: Option<String>,
    /// The S3 endpoint (default: $AWS_ENDPOINT_URL_S3, $AWS_ENDPOINT_URL, else AWS).
    #[arg(long, requires = "cache_url", value_name = "URL")]
    pub cache_endpoint: Option<String>,
    /// Only read the remote cache. Without this or --cache-write, only CI writes (when $CI is
    /// set), so workstations never fill the shared cache with their local edits.
    #[arg(long, requires = "cache_url", conflicts_with = "cache_write")]
    pub cache_read_only: bool,
    /// Write to the remote cache, even outside CI.
    #[arg(long, requires = "cache_url")]
    pub cache_write: bool,
    /// A remote failure (unreachable, refused, timed out) is an error instead of a miss: for CI
    /// jobs that must hit. Exit code 4.
    #[arg(long, requires = "cache_url")]
    pub cache_remote_required: bool,
    /// The longest wait for one remote request, in seconds.
    #[arg(long, value_name = "SECONDS", default_value = "60")]
    pub cache_timeout: f64,
}

/// The remote cache failed where it had to answer: `--cache-remote-required` was given, or
/// the command is about the cache (`stats`, `verify`). Exit 4.
#[derive(Debug, thiserror::Error)]
#[error("remote cache {url}: {what}")]
pub struct RemoteFailure {
    pub url: String,
    pub what: String,
}

/// Whether this runs in CI, by the variable CI services set.
fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0")
}

impl CacheArgs {
    /// The local cache and, when a URL is set, the remote behind it; `None` with `--no-cache`.
    pub fn open(&self) -> anyhow::Result<Option<(Cache, Option<Arc<Remote>>)>> {
        self.open_with(false)
    }

    /// [`CacheArgs::open`] for a cook, which a local cache it cannot open (a file in its
    /// place, no permission) does not fail: the cache only saves time, so the cook goes on
    /// without one and says so, as it does when a remote cannot be reached.
    pub fn open_for_cook(&self) -> anyhow::Result<Option<(Cache, Option<Arc<Remote>>)>> {
        self.open_with(true)
    }

    /// How the user named the local cache's directory, where they did: `None` for the default.
    fn named_dir(&self) -> Option<&'static str> {
        if self.cache_dir.is_some() {
            Some("--cache-dir")
        } else if std::env::var_os("STAINED_GLASS_CACHE").is_some_and(|d| !d.is_empty()) {
            Some("$STAINED_GLASS_CACHE")
        } else {
            None
        }
    }

    fn open_with(&self, lenient: bool) -> anyhow::Result<Option<(Cache, Option<Arc<Remote>>)>> {
        if self.no_cache {
            return Ok(None);
        }
        let dir = self.cache_dir.clone().unwrap_or_else(Cache::default_dir);
        // A directory the user named, on the command line or in the environment, is checked;
        // the default one may well not exist before the first cook.
        if let Some(named) = self.named_dir().filter(|_| !lenient) {
            // `cooker cache stats --cache-dir typo` made the directory and said "0 entries".
            if !dir.exists() {
                return Err(crate::exit::UsageError(format!(
                    "{named} {}: no such directory (nothing was cooked with it)",
                    dir.display()
                ))
                .into());
            }
            // A file given as the directory is the same mistake as a typo (it exited 4, an I/O
            // error, where a missing directory exits 2).
            if !dir.is_dir() {
                return Err(crate::exit::UsageError(format!(
                    "{named} {}: is a file, not a cache directory",
                    dir.display()
                ))
                .into());
            }
        }
        let mut cache = match Cache::open(&dir) {
            Ok(c) => c.with_max_size(self.cache_max_size),
            Err(e) if lenient => {
                eprintln!(
                    "warning: cache directory {:#}; cooking without a cache",
                    anyhow::Error::new(e)
                );
                return Ok(None);
            }
            Err(e) => return Err(anyhow::Error::new(e).context("opening the cache directory")),
        };
        let remote = match self.cache_url.as_deref().filter(|u| !u.is_empty()) {
            Some(url) => {
                if !(self.cache_timeout.is_finite() && self.cache_timeout > 0.0) {
                    return Err(crate::exit::UsageError(format!(
                        "--cache-timeout must be a number of seconds > 0, got {}",
                        self.cache_timeout
                    ))
                    .into());
                }
                let opened = Remote::open(&remote::Options {
                    url: url.to_string(),
                    endpoint: self.cache_endpoint.clone(),
                    read_only: self.cache_read_only || !(self.cache_write || in_ci()),
                    required: self.cache_remote_required,
                    timeout: Duration::from_secs_f64(self.cache_timeout),
                });
                match opened {
                    Ok(r) => {
                        let r = Arc::new(r);
                        cache = cache.with_remote(r.clone());
                        Some(r)
                    }
                    // A URL that is no URL is bad usage, whatever --cache-remote-required
                    // says: it exited 4 and blamed that flag.
                    Err(e) if e.downcast_ref::<crate::exit::UsageError>().is_some() => {
                        return Err(e);
                    }
                    Err(e) if self.cache_remote_required => {
                        return Err(RemoteFailure {
                            url: remote::redact(url),
                            what: format!("{e:#} (--cache-remote-required)"),
                        }
                        .into());
                    }
                    // `cache stats|verify` are about the remote: it cannot be skipped.
                    Err(e) if !lenient => {
                        return Err(RemoteFailure {
                            url: remote::redact(url),
                            what: format!("{e:#}"),
                        }
                        .into());
                    }
                    Err(e) => {
                        eprintln!(
                            "warning: remote cache {}: {e:#}; cooking locally",
                            remote::redact(url)
                        );
                        None
                    }
                }
            }
            None => None,
        };
        Ok(Some((cache, remote)))
    }
}

/// The remote's objects under `prefix`, for `cache stats|verify`: a remote that cannot be
/// listed fails the command (exit 4), as one that cannot be reached does.
fn listed(r: &Remote, prefix: &str) -> anyhow::Result<Vec<(String, u64)>> {
    r.list(prefix).map_err(|e| {
        RemoteFailure {
            url: r.shown().to_string(),
            what: format!("{e:#}"),
        }
        .into()
    })
}

/// With `--cache-remote-required`, any remote error so far fails the command.
pub fn check_remote(remote: Option<&Remote>, args: &CacheArgs) -> anyhow::Result<()> {
    if let Some(r) = remote
        && args.cache_remote_required
    {
        let s = r.summary();
        if s.errors > 0 {
            return Err(RemoteFailure {
                url: r.shown().to_string(),
                what: format!(
                    "{} failed requests, the first: {} (--cache-remote-required)",
                    s.errors,
                    s.first_error.unwrap_or_default()
                ),
            }
            .into());
        }
    }
    Ok(())
}

/// Says what the remote did in this run; with `--cache-remote-required`, fails on errors.
pub fn finish_remote(remote: Option<&Remote>, args: &CacheArgs) -> anyhow::Result<()> {
    let Some(r) = remote else { return Ok(()) };
    let s = r.summary();
    let mut line = format!(
        "remote cache {}: {} hits, {} misses, {} errors, {} down, {} up",
        r.shown(),
        s.hits,
        s.misses,
        s.errors,
        human(s.bytes_down),
        human(s.bytes_up)
    );
    // Action manifests (`ac/`) apart from blobs: sixteen damaged manifests were "16 damaged
    // blobs".
    let manifests = s.corrupt.iter().filter(|e| e.starts_with("ac/")).count();
    let blobs = s.corrupt.len() - manifests;
    for (n, what) in [(blobs, "blobs"), (manifests, "action manifests")] {
        if n > 0 {
            line.push_str(&format!(", {n} damaged {what} not used"));
        }
    }
    if args.cache_read_only || !(args.cache_write || in_ci()) {
        line.push_str(" (read-only)");
    }
    println!("{line}");
    check_remote(remote, args)
}

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand)]
enum Command {
    /// What the local cache holds (entries, blobs, bytes against the cap) and the remote's.
    Stats {
        #[command(flatten)]
        cache: CacheArgs,
    },
    /// Check every entry: local ones against their checksums, remote blobs against their
    /// SHA-256 names and remote action manifests as JSON. Damaged ones are removed: local
    /// ones always, remote ones where writes are on (`--cache-write`, or in CI). Exit 1 when
    /// any is damaged.
    Verify {
        #[command(flatten)]
        cache: CacheArgs,
    },
    /// Why a cook of the scene would miss: which input or setting changed since the last
    /// cook of it recorded here, or which cache level holds its result.
    Explain {
        /// The scene (scene.toml or a mesh file), as it would be cooked.
        input: PathBuf,
        #[command(flatten)]
        settings: crate::cook::SettingsArgs,
        #[command(flatten)]
        cache: CacheArgs,
    },
}

pub fn run(args: Args) -> Outcome {
    match args.command {
        Command::Stats { cache } => stats(&cache),
        Command::Verify { cache } => verify(&cache),
        Command::Explain {
            input,
            settings,
            cache,
        } => explain(&input, &settings, &cache),
    }
}

fn open(args: &CacheArgs) -> anyhow::Result<(Cache, Option<Arc<Remote>>)> {
    args.open()?.ok_or_else(|| {
        crate::exit::UsageError("--no-cache leaves no cache to look at".into()).into()
    })
}

/// The local cache of `args` when it is not there but a remote is set, or it is the default
/// one: on a machine that never cooked (a fresh CI runner), `cache stats|verify|explain`
/// report the remote alone, and a query never makes the default directory (`cache stats`
/// made it, empty). A missing directory the user named is still an error without a remote
/// (a typo, see [`CacheArgs::open`]).
struct Local {
    missing: Option<PathBuf>,
    /// Holds the stand-in local cache the remote is opened behind, while it is in use.
    _scratch: Option<tempfile::TempDir>,
}

fn open_maybe_remote_only(args: &CacheArgs) -> anyhow::Result<(Cache, Option<Arc<Remote>>, Local)> {
    let remote = args.cache_url.as_deref().is_some_and(|u| !u.is_empty());
    let missing = (!args.no_cache && (remote || args.named_dir().is_none()))
        .then(|| args.cache_dir.clone().unwrap_or_else(Cache::default_dir))
        .filter(|dir| !dir.exists());
    let Some(dir) = missing else {
        let (cache, remote) = open(args)?;
        let local = Local {
            missing: None,
            _scratch: None,
        };
        return Ok((cache, remote, local));
    };
    let scratch = tempfile::tempdir().map_err(|e| anyhow::anyhow!("a temporary directory: {e}"))?;
    let mut stand_in = args.clone();
    stand_in.cache_dir = Some(scratch.path().to_path_buf());
    let (cache, remote) = open(&stand_in)?;
    let local = Local {
        missing: Some(dir),
        _scratch: Some(scratch),
    };
    Ok((cache, remote, local))
}

impl Local {
    /// Says the local cache is not there; true if so.
    fn said_missing(&self) -> bool {
        if let Some(dir) = &self.missing {
            println!(
                "local cache {}: no such directory (nothing was cooked with it here)",
                dir.display()
            );
        }
        self.missing.is_some()
    }

    /// The local cache's directory as the user named it (not the scratch standing in for a
    /// missing one).
    fn shown<'a>(&'a self, cache: &'a Cache) -> &'a std::path::Path {
        self.missing.as_deref().unwrap_or(cache.dir())
    }
}

fn stats(args: &CacheArgs) -> Outcome {
    let (cache, remote, local) = open_maybe_remote_only(args)?;
    if !local.said_missing() {
        let u = cache.usage()?;
        println!(
            "local cache {}: {} entries, {} blobs, {} of {} ({:.1}%)",
            cache.dir().display(),
            u.entries,
            u.blobs,
            human(u.bytes),
            human(cache.max_size()),
            100.0 * u.bytes as f64 / cache.max_size().max(1) as f64
        );
    }
    if let Some(r) = remote {
        for prefix in ["ac/", "cas/"] {
            let objects = listed(&r, prefix)?;
            let bytes: u64 = objects.iter().map(|o| o.1).sum();
            println!(
                "remote cache {}: {prefix}: {} objects, {}",
                r.shown(),
                objects.len(),
                human(bytes)
            );
        }
    }
    Ok(OK)
}

/// The records of last cooks (`scenes/*.json`, for `explain`) checked as `verify` checks
/// entries: how many there are, and the unreadable ones, removed where they can be (a garbled
/// record made `explain` say that no earlier cook was recorded).
fn verify_records(cache: &Cache) -> (usize, Vec<cook::cache::Damaged>) {
    let mut checked = 0;
    let mut damaged = Vec::new();
    let Ok(dir) = std::fs::read_dir(cache.dir().join("scenes")) else {
        return (0, damaged);
    };
    let mut paths: Vec<std::path::PathBuf> = dir
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    paths.sort();
    for path in paths {
        checked += 1;
        let why = match std::fs::metadata(&path) {
            Ok(m) if !m.is_file() => "not a regular file".to_string(),
            _ => match std::fs::read(&path) {
                Ok(b) => match serde_json::from_slice::<scene_cache::Record>(&b) {
                    Ok(_) => continue,
                    Err(e) => format!("not a record of a cook: {e}"),
                },
                Err(e) => format!("unreadable: {e}"),
            },
        };
        let kept = std::fs::remove_file(&path).err().map(|e| e.to_string());
        damaged.push(cook::cache::Damaged { path, why, kept });
    }
    (checked, damaged)
}

fn verify(args: &CacheArgs) -> Outcome {
    let (cache, remote, local) = open_maybe_remote_only(args)?;
    let mut bad = 0;
    if !local.said_missing() {
        let (mut checked, mut damaged) = cache.verify()?;
        let (records, damaged_records) = verify_records(&cache);
        checked += records;
        damaged.extend(damaged_records);
        for d in &damaged {
            let fate = d
                .kept
                .as_ref()
                .map_or("removed".to_string(), |e| format!("not removed: {e}"));
            println!("damaged: {}: {} ({fate})", d.path.display(), d.why);
        }
        println!(
            "local cache {}: {checked} checked, {} damaged",
            cache.dir().display(),
            damaged.len()
        );
        bad = damaged.len();
    }
    if let Some(r) = remote {
        // Damaged objects are removed, as local entries are, so the next cook that makes one
        // stores it again; a read-only remote keeps them and says so.
        let mut remote_bad = 0;
        let mut checked = 0;
        for (prefix, check) in [
            (
                "cas/",
                remote::Remote::verify_blob as fn(&remote::Remote, &str) -> _,
            ),
            ("ac/", remote::Remote::verify_action),
        ] {
            let objects = listed(&r, prefix)?;
            checked += objects.len();
            for (path, _) in &objects {
                if let Err(why) = check(&r, path) {
                    let fate = match r.remove(path) {
                        Ok(()) => "removed".to_string(),
                        Err(e) => format!("not removed: {e}"),
                    };
                    println!("damaged: {} {path}: {why} ({fate})", r.shown());
                    remote_bad += 1;
                }
            }
        }
        println!(
            "remote cache {}: {checked} objects checked, {remote_bad} damaged",
            r.shown(),
        );
        bad += remote_bad;
    }
    Ok(if bad == 0 { OK } else { FOUND_PROBLEMS })
}

/// Settings that hold a file's path, recorded as its bytes (`manifest::WindowDesign`).
const PATH_KEYS: &[&str] = &["design", "normal_map"];

/// A path recorded as its bytes, as JSON text to show; anything else as it is.
fn path_text(v: &serde_json::Value) -> serde_json::Value {
    let bytes: Option<Vec<u8>> = v.as_array().and_then(|a| {
        a.iter()
            .map(|b| b.as_u64().and_then(|b| u8::try_from(b).ok()))
            .collect()
    });
    match bytes {
        Some(b) => serde_json::Value::String(String::from_utf8_lossy(&b).into_owned()),
        None => v.clone(),
    }
}

/// The leaves of a JSON value that differ between `old` and `new`, as `path: old -> new`.
fn changed_leaves(prefix: &str, old: &serde_json::Value, new: &serde_json::Value) -> Vec<String> {
    use serde_json::Value;
    match (old, new) {
        (Value::Object(a), Value::Object(b)) => {
            let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
            keys.sort();
            keys.dedup();
            keys.into_iter()
                .flat_map(|k| {
                    let path = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    // A setting at its default is left out of the record (`--up y`): said
                    // as the default, not as "null".
                    match (a.get(k), b.get(k)) {
                        // Paths are recorded as their bytes (a path need not be UTF-8):
                        // compared and shown as text, not byte by byte.
                        (Some(x), Some(y)) if PATH_KEYS.contains(&k.as_str()) => {
                            let (x, y) = (path_text(x), path_text(y));
                            if x == y {
                                Vec::new()
                            } else {
                                vec![format!("{path}: {x} -> {y}")]
                            }
                        }
                        (Some(x), Some(y)) => changed_leaves(&path, x, y),
                        (None, Some(y)) => vec![format!("{path}: default -> {y}")],
                        (Some(x), None) => vec![format!("{path}: {x} -> default")],
                        (None, None) => Vec::new(),
                    }
                })
                .collect()
        }
        (Value::Array(a), Value::Array(b)) if a.len() == b.len() => a
            .iter()
            .zip(b)
            .enumerate()
            .flat_map(|(i, (x, y))| changed_leaves(&format!("{prefix}[{i}]"), x, y))
            .collect(),
        (a, b) if a == b => Vec::new(),
        // Settings hold f32s, recorded through f64 and read back: the last digit may differ,
        // which said a setting changed that had not.
        (Value::Number(a), Value::Number(b))
            if a.as_f64()
                .zip(b.as_f64())
                .is_some_and(|(x, y)| x as f32 == y as f32) =>
        {
            Vec::new()
        }
        (a, b) => vec![format!(
            "{prefix}: {} -> {}",
            paths_as_text(a),
            paths_as_text(b)
        )],
    }
}

/// `v` with every path recorded as bytes ([`PATH_KEYS`]) written as text, however deep: a
/// `--window` override's design was shown as `[109,111,115,...]`.
fn paths_as_text(v: &serde_json::Value) -> serde_json::Value {
    use serde_json::Value;
    match v {
        Value::Object(o) => Value::Object(
            o.iter()
                .map(|(k, x)| {
                    let x = if PATH_KEYS.contains(&k.as_str()) {
                        path_text(x)
                    } else {
                        paths_as_text(x)
                    };
                    (k.clone(), x)
                })
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.iter().map(paths_as_text).collect()),
        other => other.clone(),
    }
}

/// Whose record `cache explain` compares a scene with.
#[derive(Clone, Copy)]
enum Whose {
    Own,
    /// An earlier cook here of the manifest and settings as they are now, where the last
    /// cook was of others.
    OwnEarlier,
    SameManifest,
    SameFiles,
}

fn explain(
    input: &std::path::Path,
    settings: &crate::cook::SettingsArgs,
    args: &CacheArgs,
) -> Outcome {
    let manifest = Manifest::open(input)?;
    let settings = settings.resolve(&manifest)?;
    // On a machine that never cooked, with a remote: what the remote holds (a missing local
    // directory was a usage error, exit 2).
    let (cache, remote, missing) = open_maybe_remote_only(args)?;
    missing.said_missing();
    let local = Cache::open(cache.dir())?;
    let key = scene_key(input, &scene_cache::keyed(input, &settings))?;
    println!("scene {}: key {}", input.display(), key.hex());
    let level = |k: &cook::cache::Key| {
        let here = matches!(local.get(k), Lookup::Hit(_));
        let there = remote.as_ref().is_some_and(|r| r.has_action(k));
        match (here, there) {
            (true, true) => "held locally and remotely",
            (true, false) => "held locally",
            (false, true) => "held remotely",
            (false, false) => "held nowhere",
        }
    };
    let mut reusable = false;
    // Where the entry is, before a lookup copies a remote one here.
    let scene_level = level(&key);
    match scene_cache::inputs_of(&cache, &key) {
        Ok(entry) => {
            println!("  the manifest and settings were cooked before ({scene_level})");
            if let Some(why) = scene_cache::lookup_changed(input, &entry.absent) {
                println!("a cook would cook it: {why}");
                return Ok(OK);
            }
            match scene_cache::hash_inputs(input, &entry.inputs) {
                Ok(hashed) => {
                    let result = scene_cache::result_key(&key, &hashed);
                    let where_ = level(&result);
                    println!("  with these {} inputs: result {}", hashed.len(), where_);
                    if where_ != "held nowhere" {
                        // A result whose pack is gone is re-cooked, as the cook says.
                        match scene_cache::pack_of(&cache, &result) {
                            Ok(pack) => {
                                let sha = pack.sha;
                                let here = local.has_local_blob(&sha);
                                let there = remote.as_ref().is_some_and(|r| r.has_blob(&sha));
                                // A damaged local pack is re-cooked, as the cook checks it.
                                let damaged = here
                                    && !matches!(local.fetch_blob(&sha).0,
                                        Lookup::Hit(p) if pack.holds(&p));
                                if damaged && !there {
                                    println!(
                                        "a cook would cook it: the result's pack {} is damaged \
                                         (`cooker cache verify` removes it)",
                                        hex(&sha)
                                    );
                                    return Ok(OK);
                                }
                                if here || there {
                                    reusable = true;
                                } else {
                                    println!(
                                        "a cook would cook it: the result's pack {} is gone \
                                         (evicted, or removed as damaged by `cooker cache \
                                         verify`)",
                                        hex(&sha)
                                    );
                                    return Ok(OK);
                                }
                            }
                            Err(why) => println!("  {why}"),
                        }
                    }
                }
                Err(why) => println!("  {why}"),
            }
        }
        Err(why) => println!("  {why}"),
    }
    if reusable {
        println!("a cook would reuse the cached pack");
        return Ok(OK);
    }
    let read_record = |path: &std::path::Path| {
        std::fs::read(path)
            .ok()
            .and_then(|b| serde_json::from_slice::<scene_cache::Record>(&b).ok())
    };
    let manifest_sha = hex(&cook::cache::digest_file(input)?);
    let settings_json = serde_json::to_value(scene_cache::keyed(input, &settings))?;
    // This checkout's record; else, since keys leave the scene's folder out, the latest
    // record of the same manifest and settings from another checkout: its inputs say which
    // file differs here (without it, a changed design in a second checkout was "no earlier
    // cook recorded" under a line that said the scene was cooked before).
    let own_path = scene_cache::record_path(&cache, input);
    let own = read_record(&own_path);
    // A record that is there but unreadable is not "no earlier cook".
    if own.is_none() && own_path.is_file() {
        println!(
            "a cook would cook it: the record of the last cook of {}, {}, is damaged (`cooker \
             cache verify` removes it)",
            input.display(),
            own_path.display()
        );
        return Ok(OK);
    }
    let dir = input.parent().unwrap_or(std::path::Path::new(""));
    // Whose record: this manifest's (`Own`), the same manifest's elsewhere, or a record of
    // the same files under another manifest (a bare cook of the model `init` described).
    let (record, whose) = match own {
        Some(r) => match r.of(&manifest_sha, &settings_json) {
            Some(same) if !std::ptr::eq(same, &r) => (same.clone(), Whose::OwnEarlier),
            _ => (r, Whose::Own),
        },
        None => {
            // The same manifest first; else, the manifest edited too, a record of the same
            // settings whose every input is a file here (the same scene's layout), latest.
            let other = std::fs::read_dir(cache.dir().join("scenes"))
                .into_iter()
                .flatten()
                .flatten()
                .filter_map(|e| {
                    let r = read_record(&e.path())?;
                    let when = e.metadata().and_then(|m| m.modified()).ok()?;
                    let same_settings = changed_leaves("", &r.settings, &settings_json).is_empty();
                    let same_manifest = r.manifest_sha256 == manifest_sha;
                    let same_layout = !r.inputs.is_empty()
                        && r.inputs.iter().all(|(rel, _)| dir.join(rel).is_file());
                    (same_settings && (same_manifest || same_layout))
                        .then_some(((same_manifest, when), r))
                })
                .max_by_key(|(rank, _)| *rank);
            match other {
                Some(((true, _), r)) => (r, Whose::SameManifest),
                // A record naming a manifest of this one's name is this scene, edited.
                Some(((false, _), r))
                    if r.inputs
                        .iter()
                        .any(|(rel, _)| Some(rel.as_os_str()) == input.file_name()) =>
                {
                    (r, Whose::SameManifest)
                }
                Some(((false, _), r)) => (r, Whose::SameFiles),
                None => {
                    println!(
                        "a cook would cook it: no earlier cook of {} is recorded in {}",
                        input.display(),
                        missing.shown(&cache).display()
                    );
                    return Ok(OK);
                }
            }
        }
    };
    let mut why = Vec::new();
    if manifest_sha != record.manifest_sha256 {
        why.push(match whose {
            Whose::SameFiles => format!("{} is not that cook's manifest", input.display()),
            _ => format!("{} changed", input.display()),
        });
    }
    for c in changed_leaves("", &record.settings, &settings_json) {
        why.push(format!("setting {c}"));
    }
    for (rel, sha) in &record.inputs {
        let path = dir.join(rel);
        match cook::cache::digest_file(&path) {
            Ok(got) if hex(&got) == *sha => {}
            Ok(_) => why.push(format!("{} changed", path.display())),
            Err(_) => why.push(format!("{} cannot be read", path.display())),
        }
    }
    // The manifest is among the inputs recorded too: one line per file.
    let mut seen = std::collections::HashSet::new();
    why.retain(|w| seen.insert(w.clone()));
    let last = match whose {
        Whose::Own => "the last cook recorded here",
        Whose::OwnEarlier => {
            "the last cook of this manifest and these settings recorded here (the cooks since \
             were of other versions of it)"
        }
        Whose::SameManifest => {
            "the last cook of the same manifest and settings recorded here, in another checkout"
        }
        // It was "of the same manifest, in another checkout" after `cooker cook model.obj`
        // and `cooker cache explain scene.toml` in one folder.
        Whose::SameFiles => {
            "the last cook of these files with the same settings recorded here, under another \
             manifest or as a bare model"
        }
    };
    if why.is_empty() {
        println!(
            "a cook would cook it: nothing changed since {last}, but its entries are gone \
             (evicted, or never stored)"
        );
    } else {
        println!("a cook would cook it; since {last}:");
        for w in why {
            println!("  {w}");
        }
    }
    Ok(OK)
}

#[cfg(test)]
mod tests {
    use super::changed_leaves;
    use serde_json::json;

    /// A setting at its default is left out of the record: said as the default, not "null";
    /// a recorded null stays null.
    #[test]
    fn a_setting_left_at_its_default_is_said_so() {
        let old = json!({"mesh": {"cache": "Full"}, "textures": {"max_error_lsb": null}});
        let new = json!({"mesh": {"cache": "Full"}, "textures": {"max_error_lsb": 2.0}, "up": "Z"});
        assert_eq!(
            changed_leaves("", &old, &new),
            [
                "textures.max_error_lsb: null -> 2.0",
                "up: default -> \"Z\""
            ]
        );
        assert_eq!(changed_leaves("", &new, &old)[1], "up: \"Z\" -> default");
        // A design's path, recorded as bytes, is shown as its text.
        let a = json!({"window_overrides": [{"design": b"a/x.png".to_vec()}]});
        let b = json!({"window_overrides": [{"design": b"b/x.png".to_vec()}]});
        assert_eq!(
            changed_leaves("", &a, &b),
            ["window_overrides[0].design: \"a/x.png\" -> \"b/x.png\""]
        );
        // Also where a whole override is new (it was shown byte by byte).
        let none = json!({"window_overrides": []});
        assert_eq!(
            changed_leaves("", &none, &b),
            ["window_overrides: [] -> [{\"design\":\"b/x.png\"}]"]
        );
    }
}
