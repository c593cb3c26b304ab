//! The remote second level of the cook cache, on storage a studio already runs, through
//! `opendal`: `file://` (a network share), `redis://`, `http(s)://` (WebDAV) and `s3://`.
//!
//! The layout is Bazel's: `ac/<key>` (the action cache) maps a cook step's key to a manifest
//! of its output blobs, and `cas/<sha256>` holds each blob under the SHA-256 of its content.
//!
//! The remote is never trusted and never fails a cook:
//! - every blob read is re-hashed and its length checked; a mismatch is a miss, and reported;
//! - a blob is uploaded only when absent, with a conditional write where the service has one
//!   (else the service's own atomic replace: S3 and WebDAV PUT, Redis SET, a temp file and
//!   rename on a share); two writers of one key write the same bytes, and a manifest names only
//!   blobs already stored;
//! - an error (unreachable, timeout, refused, rate-limited, a truncated reply) is a miss: one
//!   warning, and after an error that says the server is gone the remote is left alone for the
//!   rest of the run. `--cache-remote-required` makes them errors instead.
//!
//! Credentials come from the URL's user part or the usual variables, and are never printed:
//! the URL is shown without its password, and error messages have every secret blanked.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use anyhow::{Context, bail};
use cook::cache::{Key, digest, hex, parse_hex32};
use opendal::{ErrorKind, Operator};
use serde::{Deserialize, Serialize};

/// How to reach and use the remote.
#[derive(Clone, Debug)]
pub struct Options {
    pub url: String,
    /// An S3 endpoint (`http://127.0.0.1:8333`), overriding the AWS variables.
    pub endpoint: Option<String>,
    pub read_only: bool,
    pub required: bool,
    /// Longest wait for one request.
    pub timeout: Duration,
}

/// What a run did with the remote.
#[derive(Debug, Default)]
struct Counters {
    hits: AtomicU64,
    misses: AtomicU64,
    errors: AtomicU64,
    bytes_down: AtomicU64,
    bytes_up: AtomicU64,
    uploads: AtomicU64,
}

/// A summary of a run's remote traffic.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Summary {
    pub hits: u64,
    pub misses: u64,
    pub errors: u64,
    pub bytes_down: u64,
    pub bytes_up: u64,
    pub uploads: u64,
    /// Blobs whose content did not match their name: `cas/<sha256>: why`.
    pub corrupt: Vec<String>,
    /// The first error, without secrets.
    pub first_error: Option<String>,
}

#[derive(Serialize, Deserialize)]
struct ActionManifest {
    /// The output blobs, in order (a cook step of ours has one).
    outputs: Vec<BlobRef>,
}

#[derive(Serialize, Deserialize)]
struct BlobRef {
    sha256: String,
    size: u64,
}

pub struct Remote {
    op: Operator,
    rt: tokio::runtime::Runtime,
    shown: String,
    secrets: Vec<String>,
    read_only: bool,
    timeout: Duration,
    counters: Counters,
    /// Off for the rest of the run: the server is gone.
    off: AtomicBool,
    /// Writes refused (a read-only token): keep reading, stop writing.
    no_writes: AtomicBool,
    warned: AtomicBool,
    /// Wakes the requests in flight when the remote is switched off.
    switched_off: tokio::sync::Notify,
    /// The server's host and port, for probes.
    address: Option<(String, u16)>,
    corrupt: Mutex<Vec<String>>,
    /// Blobs read damaged this run: a writer replaces them rather than skip a name that is
    /// there (a damaged blob was never repaired: every writer saw its name and went on).
    damaged: Mutex<std::collections::HashSet<[u8; 32]>>,
    first_error: Mutex<Option<String>>,
    if_not_exists: bool,
}

impl std::fmt::Debug for Remote {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Remote").field("url", &self.shown).finish()
    }
}

/// A URL as it may be printed: the password (and a query, which may hold a token) removed.
pub fn redact(url: &str) -> String {
    match url::Url::parse(url) {
        Ok(mut u) => {
            if u.password().is_some() {
                let _ = u.set_password(None);
            }
            u.set_query(None);
            u.to_string()
        }
        // Not a URL: show only what comes before anything that could be a user part.
        Err(_) => match url.split_once('@') {
            Some((_, host)) => format!("…@{host}"),
            None => url.to_string(),
        },
    }
}

impl Remote {
    /// Connects to the remote `options.url` names. A bad URL is a usage error; an unreachable
    /// server is found at the first request (or here, when the remote is required).
    pub fn open(options: &Options) -> anyhow::Result<Self> {
        // One TLS implementation for every https request, chosen before the first client.
        let _ = rustls::crypto::ring::default_provider().install_default();
        opendal::install_default();
        opendal_http_transport_reqwest::install_default();
        let url = url::Url::parse(&options.url).map_err(|e| {
            crate::exit::UsageError(format!(
                "--cache-url {}: not a URL ({e}); expected file://, redis://, http(s):// or s3://",
                redact(&options.url)
            ))
        })?;
        let mut secrets: Vec<String> = Vec::new();
        if let Some(p) = url.password() {
            secrets.push(p.to_string());
        }
        let op = build(&url, options, &mut secrets)?;
        let if_not_exists = op.info().capability().write_with_if_not_exists;
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .context("starting the remote cache's I/O runtime")?;
        let remote = Self {
            op,
            rt,
            shown: redact(&options.url),
            secrets,
            read_only: options.read_only,
            timeout: options.timeout,
            counters: Counters::default(),
            off: AtomicBool::new(false),
            no_writes: AtomicBool::new(options.read_only),
            warned: AtomicBool::new(false),
            switched_off: tokio::sync::Notify::new(),
            address: server_address(&url, options),
            corrupt: Mutex::new(Vec::new()),
            damaged: Mutex::new(Default::default()),
            first_error: Mutex::new(None),
            if_not_exists,
        };
        // A server that is not there is found in one connection attempt, not after a
        // client's retries with backoff (Redis's take seconds) at every request.
        if let Some((host, port)) = remote.address.clone()
            && let Err(e) = connect(&host, port, options.timeout.min(CONNECT_TIMEOUT))
        {
            if options.required {
                bail!("unreachable: connecting to {host}:{port}: {e}");
            }
            remote.failed_with(&format!("connecting to {host}:{port}: {e}"), true);
        }
        if options.required {
            // Fail before cooking, not after: a probe that any reachable server answers (an
            // absent key is an answer).
            let probe = remote.call(remote.op.stat("ac/probe"));
            if let Err(e) = probe
                && e.kind() != Some(ErrorKind::NotFound)
            {
                bail!("unreachable: {}", remote.scrub(&e.to_string()));
            }
        }
        Ok(remote)
    }

    /// The URL as it may be printed.
    pub fn shown(&self) -> &str {
        &self.shown
    }

    pub fn summary(&self) -> Summary {
        let c = &self.counters;
        Summary {
            hits: c.hits.load(Ordering::Relaxed),
            misses: c.misses.load(Ordering::Relaxed),
            errors: c.errors.load(Ordering::Relaxed),
            bytes_down: c.bytes_down.load(Ordering::Relaxed),
            bytes_up: c.bytes_up.load(Ordering::Relaxed),
            uploads: c.uploads.load(Ordering::Relaxed),
            corrupt: self.corrupt.lock().unwrap().clone(),
            first_error: self.first_error.lock().unwrap().clone(),
        }
    }

    /// Runs one request to completion within the timeout, from a synchronous caller (the
    /// cook's worker threads). A request still waiting after a moment has the server's port
    /// probed: a client's reconnects with backoff would otherwise wait out the timeout on a
    /// server that is gone. Once the remote is switched off, requests in flight end at once.
    fn call<T>(&self, f: impl Future<Output = opendal::Result<T>>) -> Result<T, Failure> {
        self.rt.block_on(async {
            let switched_off = self.switched_off.notified();
            tokio::pin!(switched_off);
            switched_off.as_mut().enable();
            if self.off.load(Ordering::Relaxed) {
                return Err(Failure::SwitchedOff);
            }
            tokio::select! {
                r = tokio::time::timeout(self.timeout, f) => match r {
                    Ok(r) => r.map_err(Failure::Service),
                    Err(_) => Err(Failure::Other(format!("no answer within {:?}", self.timeout))),
                },
                e = watchdog(self.address.clone()) => Err(Failure::Other(e)),
                _ = &mut switched_off => Err(Failure::SwitchedOff),
            }
        })
    }

    fn scrub(&self, message: &str) -> String {
        let mut m = message.to_string();
        for s in &self.secrets {
            if !s.is_empty() {
                m = m.replace(s, "***");
            }
        }
        m
    }

    /// Records a failed request: counted, the first one kept for the summary and warned about
    /// once, and the remote switched off when the server is gone.
    fn failed(&self, what: &str, e: &Failure) {
        if matches!(e, Failure::SwitchedOff) {
            // Not a failure of its own: the one that switched the remote off is counted.
            return;
        }
        // The service's message can run on with a whole HTML error page: its first line says it.
        let full = self.scrub(&e.to_string());
        let first_line = full
            .lines()
            .next()
            .unwrap_or("")
            .trim_end_matches(" => <html>");
        let message = format!("{what}: {first_line}");
        if e.kind() == Some(ErrorKind::PermissionDenied) && what.starts_with("writing") {
            // A read-only token: keep reading, stop writing.
            self.no_writes.store(true, Ordering::Relaxed);
            self.failed_with(&message, false);
        } else {
            // Refused, rate-limited, garbled or gone: no further request would fare better in
            // this run, and each could wait for a timeout.
            self.failed_with(&message, true);
        }
    }

    fn failed_with(&self, message: &str, off: bool) {
        self.counters.errors.fetch_add(1, Ordering::Relaxed);
        {
            let mut first = self.first_error.lock().unwrap();
            if first.is_none() {
                *first = Some(message.to_string());
            }
        }
        if !self.warned.swap(true, Ordering::Relaxed) {
            eprintln!(
                "warning: remote cache {}: {message}; cooking locally",
                self.shown
            );
        }
        if off {
            self.off.store(true, Ordering::Relaxed);
            self.switched_off.notify_waiters();
        }
    }

    /// Reads an object; `None` when absent, or on an error (recorded).
    fn read(&self, path: &str) -> Option<Vec<u8>> {
        if self.off.load(Ordering::Relaxed) {
            return None;
        }
        match self.call(self.op.read(path)) {
            Ok(b) => {
                let v = Vec::from(b.to_bytes());
                self.counters
                    .bytes_down
                    .fetch_add(v.len() as u64, Ordering::Relaxed);
                Some(v)
            }
            Err(e) if e.kind() == Some(ErrorKind::NotFound) => None,
            Err(e) => {
                self.failed(&format!("reading {path}"), &e);
                None
            }
        }
    }

    fn writable(&self) -> bool {
        !(self.read_only
            || self.off.load(Ordering::Relaxed)
            || self.no_writes.load(Ordering::Relaxed))
    }

    fn write(&self, path: &str, bytes: &[u8], if_absent: bool) {
        if !self.writable() {
            return;
        }
        let len = bytes.len() as u64;
        let w = self
            .op
            .write_with(path, bytes.to_vec())
            .if_not_exists(if_absent && self.if_not_exists);
        match self.call(w.into_future()) {
            Ok(_) => {
                self.counters.bytes_up.fetch_add(len, Ordering::Relaxed);
                self.counters.uploads.fetch_add(1, Ordering::Relaxed);
            }
            // Another writer stored it first: the same bytes, by their name.
            Err(e) if e.kind() == Some(ErrorKind::ConditionNotMatch) => {}
            Err(e) => self.failed(&format!("writing {path}"), &e),
        }
    }

    /// A blob by its SHA-256, checked: `None` when absent, damaged or unreadable.
    fn fetch_blob(&self, sha: &[u8; 32], size: Option<u64>) -> Option<Vec<u8>> {
        let path = format!("cas/{}", hex(sha));
        let bytes = self.read(&path)?;
        let why = if size.is_some_and(|s| s != bytes.len() as u64) {
            Some(format!(
                "{} bytes, but its manifest says {}",
                bytes.len(),
                size.unwrap_or(0)
            ))
        } else if digest(&bytes) != *sha {
            Some(format!(
                "content hashes to {}, not its name",
                hex(&digest(&bytes))
            ))
        } else {
            None
        };
        if let Some(why) = why {
            let entry = format!("{path}: {why}");
            eprintln!(
                "warning: remote cache {}: damaged blob {entry}; not used",
                self.shown
            );
            self.corrupt.lock().unwrap().push(entry);
            self.damaged.lock().unwrap().insert(*sha);
            return None;
        }
        Some(bytes)
    }

    fn counted(&self, found: Option<Vec<u8>>) -> Option<Vec<u8>> {
        let c = if found.is_some() {
            &self.counters.hits
        } else {
            &self.counters.misses
        };
        c.fetch_add(1, Ordering::Relaxed);
        found
    }

    fn lookup(&self, key: &Key) -> Option<Vec<u8>> {
        let manifest = self.read(&format!("ac/{}", key.hex()))?;
        let Ok(manifest) = serde_json::from_slice::<ActionManifest>(&manifest) else {
            let entry = format!("ac/{}: not a manifest", key.hex());
            eprintln!(
                "warning: remote cache {}: damaged entry {entry}; not used",
                self.shown
            );
            self.corrupt.lock().unwrap().push(entry);
            return None;
        };
        let [out] = manifest.outputs.as_slice() else {
            return None;
        };
        let sha = parse_hex32(&out.sha256)?;
        self.fetch_blob(&sha, Some(out.size))
    }

    /// Whether a blob is there already (so it need not be sent again, or for `cache explain`).
    pub fn has_blob(&self, sha: &[u8; 32]) -> bool {
        if self.off.load(Ordering::Relaxed) {
            return false;
        }
        self.call(self.op.stat(&format!("cas/{}", hex(sha))))
            .is_ok()
    }

    fn store_blob(&self, sha: &[u8; 32], bytes: &[u8]) {
        if !self.writable() {
            return;
        }
        let repair = self.damaged.lock().unwrap().contains(sha);
        if !repair && self.has_blob(sha) {
            return;
        }
        self.write(&format!("cas/{}", hex(sha)), bytes, !repair);
        if repair && self.writable() {
            self.damaged.lock().unwrap().remove(sha);
            eprintln!(
                "note: remote cache {}: damaged blob cas/{} replaced",
                self.shown,
                hex(sha)
            );
        }
    }

    /// Deletes one object, for `cooker cache verify`: whether it is gone.
    pub fn remove(&self, path: &str) -> Result<(), String> {
        if !self.writable() {
            return Err("the remote is read-only here".into());
        }
        self.call(self.op.delete(path))
            .map_err(|e| self.scrub(&e.to_string()))
    }

    /// Reads one action manifest and checks it parses, for `cooker cache verify`.
    pub fn verify_action(&self, path: &str) -> Result<(), String> {
        let bytes = self
            .call(self.op.read(path))
            .map_err(|e| self.scrub(&e.to_string()))?;
        serde_json::from_slice::<ActionManifest>(&bytes.to_vec())
            .map(drop)
            .map_err(|e| format!("not an action manifest ({e})"))
    }

    /// Lists objects under `prefix` (`ac/`, `cas/`) with their sizes.
    pub fn list(&self, prefix: &str) -> anyhow::Result<Vec<(String, u64)>> {
        let entries = self
            .call(self.op.list_with(prefix).recursive(true).into_future())
            .map_err(|e| anyhow::anyhow!("listing {prefix}: {}", self.scrub(&e.to_string())))?;
        let mut out = Vec::new();
        for e in entries {
            if e.metadata().is_file() {
                let mut size = e.metadata().content_length();
                if size == 0 {
                    // Some services list without sizes.
                    size = self
                        .call(self.op.stat(e.path()))
                        .map(|m| m.content_length())
                        .unwrap_or(0);
                }
                out.push((e.path().to_string(), size));
            }
        }
        out.sort();
        Ok(out)
    }

    /// Reads one blob and checks it against its name, for `cooker cache verify`.
    pub fn verify_blob(&self, path: &str) -> Result<(), String> {
        let name = path.rsplit('/').next().unwrap_or(path);
        let sha = parse_hex32(name).ok_or_else(|| "not named by a SHA-256".to_string())?;
        let bytes = self
            .call(self.op.read(path))
            .map_err(|e| self.scrub(&e.to_string()))?;
        let got = digest(&bytes.to_vec());
        if got != sha {
            return Err(format!("content hashes to {}", hex(&got)));
        }
        Ok(())
    }

    /// Whether an action is recorded, without fetching its blob.
    pub fn has_action(&self, key: &Key) -> bool {
        self.call(self.op.stat(&format!("ac/{}", key.hex())))
            .is_ok()
    }
}

impl cook::cache::Remote for Remote {
    fn get(&self, key: &Key) -> Option<Vec<u8>> {
        if self.off.load(Ordering::Relaxed) {
            return None;
        }
        let found = self.lookup(key);
        self.counted(found)
    }

    fn put(&self, key: &Key, payload: &[u8]) {
        if !self.writable() {
            return;
        }
        let sha = digest(payload);
        self.store_blob(&sha, payload);
        // After the blob: a manifest never names a blob not yet stored.
        if !self.writable() {
            return;
        }
        let manifest = ActionManifest {
            outputs: vec![BlobRef {
                sha256: hex(&sha),
                size: payload.len() as u64,
            }],
        };
        let bytes = serde_json::to_vec(&manifest).expect("manifest serializes");
        self.write(&format!("ac/{}", key.hex()), &bytes, false);
    }

    fn get_blob(&self, sha: &[u8; 32]) -> Option<Vec<u8>> {
        if self.off.load(Ordering::Relaxed) {
            return None;
        }
        let found = self.fetch_blob(sha, None);
        self.counted(found)
    }

    fn put_blob(&self, sha: &[u8; 32], bytes: &[u8]) {
        self.store_blob(sha, bytes);
    }

    fn publish(&self, key: &Key, payload: &[u8]) -> bool {
        if !self.writable()
            || self
                .call(self.op.stat(&format!("ac/{}", key.hex())))
                .is_ok()
        {
            return false;
        }
        self.put(key, payload);
        true
    }

    fn publish_blob(&self, sha: &[u8; 32], bytes: &[u8]) {
        self.store_blob(sha, bytes);
    }
}

/// The operator for a URL: the scheme picks the service, the path is the root inside it.
fn build(url: &url::Url, options: &Options, secrets: &mut Vec<String>) -> anyhow::Result<Operator> {
    let shown = redact(url.as_str());
    match url.scheme() {
        "file" => fs(url, &shown, options.read_only),
        "redis" | "rediss" => redis(url, &shown),
        "http" | "https" => webdav(url, &shown, secrets),
        "s3" => s3(url, options, &shown, secrets),
        other => Err(crate::exit::UsageError(format!(
            "--cache-url {shown}: unknown scheme {other:?}; expected file://, redis://, \
             http(s):// or s3://"
        ))
        .into()),
    }
}

/// The error for a service this build left out.
#[allow(dead_code)]
fn unsupported(shown: &str, feature: &str) -> anyhow::Error {
    crate::exit::UsageError(format!(
        "--cache-url {shown}: this cooker was built without the {feature} feature"
    ))
    .into()
}

/// A shared folder, which must exist: one that does not is most often a share that is not
/// mounted, and was made and used as an empty cache (a read-only one too), so every machine
/// missed in silence.
fn fs(url: &url::Url, shown: &str, read_only: bool) -> anyhow::Result<Operator> {
    let dir = url
        .to_file_path()
        .map_err(|_| crate::exit::UsageError(format!("--cache-url {shown}: not a local path")))?;
    if !dir.is_dir() {
        anyhow::bail!(
            "{} is not a folder (a share that is not mounted?); create it to start a shared cache",
            dir.display()
        );
    }
    let mut b = opendal::services::Fs::default().root(&dir.to_string_lossy());
    if !read_only {
        let tmp = dir.join(".tmp");
        std::fs::create_dir_all(&tmp)
            .with_context(|| format!("creating the remote cache folder {}", tmp.display()))?;
        // Each write lands in a temp file there and is renamed into place.
        b = b.atomic_write_dir(&tmp.to_string_lossy());
        sweep_stale_temp_files(&tmp);
    }
    Ok(Operator::new(b)?)
}

/// A write that failed half way (a share that filled up, a cook killed mid-upload) leaves its
/// temp file behind, and nothing else ever removes it. A writer opening the share removes
/// those older than an hour, far longer than any one entry's write takes, so a write in
/// flight on another machine is never cut short. Best effort: a share that refuses is left.
fn sweep_stale_temp_files(tmp: &std::path::Path) {
    const STALE: Duration = Duration::from_secs(3600);
    let Ok(entries) = std::fs::read_dir(tmp) else {
        return;
    };
    let now = std::time::SystemTime::now();
    for e in entries.flatten() {
        let stale = e.metadata().is_ok_and(|m| {
            m.is_file()
                && m.modified()
                    .ok()
                    .and_then(|t| now.duration_since(t).ok())
                    .is_some_and(|age| age > STALE)
        });
        if stale {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

#[cfg(feature = "remote-redis")]
fn redis(url: &url::Url, shown: &str) -> anyhow::Result<Operator> {
    let host = url.host_str().unwrap_or("127.0.0.1");
    let port = url.port().unwrap_or(6379);
    let mut b =
        opendal::services::Redis::default().endpoint(&format!("{}://{host}:{port}", url.scheme()));
    // The path is the database number: redis://host:6379/2.
    let db = url.path().trim_start_matches('/');
    if !db.is_empty() {
        let n: i64 = db.parse().map_err(|_| {
            crate::exit::UsageError(format!(
                "--cache-url {shown}: the path must be a database number, got {db:?}"
            ))
        })?;
        b = b.db(n);
    }
    if !url.username().is_empty() {
        b = b.username(url.username());
    }
    if let Some(p) = url.password() {
        b = b.password(p);
    }
    Ok(Operator::new(b.root("/stained-glass/"))?)
}

#[cfg(not(feature = "remote-redis"))]
fn redis(_: &url::Url, shown: &str) -> anyhow::Result<Operator> {
    Err(unsupported(shown, "remote-redis"))
}

/// The root inside a service: the URL's path.
#[allow(dead_code)]
fn root(url: &url::Url) -> String {
    match url.path() {
        "" => "/".to_string(),
        p => p.to_string(),
    }
}

#[cfg(feature = "remote-webdav")]
fn webdav(url: &url::Url, _: &str, secrets: &mut Vec<String>) -> anyhow::Result<Operator> {
    let mut endpoint = format!("{}://{}", url.scheme(), url.host_str().unwrap_or(""));
    if let Some(p) = url.port() {
        endpoint.push_str(&format!(":{p}"));
    }
    let mut b = opendal::services::Webdav::default()
        .endpoint(&endpoint)
        .root(&root(url));
    if !url.username().is_empty() {
        b = b.username(url.username());
    }
    if let Some(p) = url.password() {
        b = b.password(p);
    }
    if let Ok(t) = std::env::var("STAINED_GLASS_CACHE_TOKEN")
        && !t.is_empty()
    {
        secrets.push(t.clone());
        b = b.token(&t);
    }
    Ok(Operator::new(b)?)
}

#[cfg(not(feature = "remote-webdav"))]
fn webdav(_: &url::Url, shown: &str, _: &mut Vec<String>) -> anyhow::Result<Operator> {
    Err(unsupported(shown, "remote-webdav"))
}

#[cfg(feature = "remote-s3")]
fn s3(
    url: &url::Url,
    options: &Options,
    shown: &str,
    secrets: &mut Vec<String>,
) -> anyhow::Result<Operator> {
    let bucket = url.host_str().unwrap_or("");
    if bucket.is_empty() {
        return Err(crate::exit::UsageError(format!(
            "--cache-url {shown}: name a bucket: s3://bucket/prefix"
        ))
        .into());
    }
    let var = |names: &[&str]| {
        names
            .iter()
            .find_map(|n| std::env::var(n).ok().filter(|v| !v.is_empty()))
    };
    let region = var(&["AWS_REGION", "AWS_DEFAULT_REGION"]).unwrap_or_else(|| "us-east-1".into());
    let mut b = opendal::services::S3::default()
        .bucket(bucket)
        .root(&root(url))
        .region(&region)
        // Credentials from the variables or the profile, never from an instance metadata
        // service a workstation does not have (its probe takes seconds).
        .disable_ec2_metadata();
    if let Some(e) = s3_endpoint(options) {
        b = b.endpoint(&e);
    }
    if let (Some(id), Some(secret)) = (var(&["AWS_ACCESS_KEY_ID"]), var(&["AWS_SECRET_ACCESS_KEY"]))
    {
        secrets.push(secret.clone());
        b = b.access_key_id(&id).secret_access_key(&secret);
    }
    Ok(Operator::new(b)?)
}

#[cfg(not(feature = "remote-s3"))]
fn s3(_: &url::Url, _: &Options, shown: &str, _: &mut Vec<String>) -> anyhow::Result<Operator> {
    Err(unsupported(shown, "remote-s3"))
}

/// `--cache-endpoint`, else the AWS variables' endpoint.
fn s3_endpoint(options: &Options) -> Option<String> {
    options.endpoint.clone().or_else(|| {
        ["AWS_ENDPOINT_URL_S3", "AWS_ENDPOINT_URL"]
            .iter()
            .find_map(|n| std::env::var(n).ok().filter(|v| !v.is_empty()))
    })
}

/// Why a request failed.
#[derive(Debug)]
enum Failure {
    /// The service's own error.
    Service(opendal::Error),
    /// No answer in time, or the server is gone.
    Other(String),
    /// The remote was switched off by another request's failure while this one waited.
    SwitchedOff,
}

impl Failure {
    fn kind(&self) -> Option<ErrorKind> {
        match self {
            Failure::Service(e) => Some(e.kind()),
            _ => None,
        }
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::Service(e) => write!(f, "{e}"),
            Failure::Other(m) => write!(f, "{m}"),
            Failure::SwitchedOff => write!(f, "remote switched off after an error"),
        }
    }
}

/// Resolves with an error once the server's port stops accepting connections; never for a
/// remote without one (a folder).
async fn watchdog(address: Option<(String, u16)>) -> String {
    let Some((host, port)) = address else {
        return std::future::pending().await;
    };
    loop {
        tokio::time::sleep(Duration::from_millis(500)).await;
        let attempt = tokio::time::timeout(
            CONNECT_TIMEOUT,
            tokio::net::TcpStream::connect((host.as_str(), port)),
        )
        .await;
        let why = match attempt {
            Ok(Ok(_)) => continue,
            Ok(Err(e)) => e.to_string(),
            Err(_) => format!("no connection within {CONNECT_TIMEOUT:?}"),
        };
        return format!("the server is gone: connecting to {host}:{port}: {why}");
    }
}

/// The longest wait for a connection to the server.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(3);

/// The host and port a network remote talks to.
fn server_address(url: &url::Url, options: &Options) -> Option<(String, u16)> {
    let parsed;
    let u = match url.scheme() {
        "redis" | "rediss" | "http" | "https" => url,
        "s3" => {
            parsed = url::Url::parse(&s3_endpoint(options)?).ok()?;
            &parsed
        }
        _ => return None,
    };
    let port = u.port_or_known_default().or(match u.scheme() {
        "redis" | "rediss" => Some(6379),
        _ => None,
    })?;
    Some((u.host_str()?.to_string(), port))
}

fn connect(host: &str, port: u16, timeout: Duration) -> std::io::Result<()> {
    use std::net::ToSocketAddrs;
    let mut last = std::io::Error::new(std::io::ErrorKind::NotFound, "no address");
    for addr in (host, port).to_socket_addrs()? {
        match std::net::TcpStream::connect_timeout(&addr, timeout) {
            Ok(_) => return Ok(()),
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// Bytes in a short human form: `39.9 MB`.
pub fn human(bytes: u64) -> String {
    match bytes {
        b if b >= 1_000_000 => format!("{:.1} MB", b as f64 / 1e6),
        b if b >= 1_000 => format!("{:.1} kB", b as f64 / 1e3),
        b => format!("{b} B"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_are_shown_without_passwords_or_tokens() {
        assert_eq!(
            redact("redis://:hunter2@127.0.0.1:6379/0"),
            "redis://127.0.0.1:6379/0"
        );
        assert_eq!(
            redact("https://ci:s3cret@cache.example/dav/?token=abc"),
            "https://ci@cache.example/dav/"
        );
        assert_eq!(redact("s3://bucket/prefix"), "s3://bucket/prefix");
        assert!(!redact("not a url:pw@host").contains("pw"));
    }
}
