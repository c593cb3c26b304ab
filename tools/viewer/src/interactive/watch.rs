//! `--watch`: the source files of a `scene.toml`, polled by modification time. Polling a
//! handful of files twice a second costs nothing and needs no platform notification API.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

/// Every file the cook of `manifest_path` reads: what its last cook read (the textures an
/// MTL or a glTF names among them) and the folders where it looked for a file a source names
/// in vain, and what the manifest names now: mesh sources, textures, normal maps, window
/// designs and the panorama, so that a file a failed re-cook missed is watched too. A
/// manifest that does not parse yields just itself and the last cook's files, so fixing it
/// triggers the next cook. A bare model (cooked without a manifest) yields itself and the
/// last cook's files.
pub fn sources(manifest_path: &Path) -> Vec<PathBuf> {
    let mut files = vec![manifest_path.to_path_buf()];
    files.extend(crate::cooked_from(manifest_path));
    // A bare model is not read as a manifest: the last cook's list is all there is.
    let is_toml = manifest_path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    let Some(m) = is_toml
        .then(|| cook::Manifest::load(manifest_path).ok())
        .flatten()
    else {
        files.sort();
        files.dedup();
        return files;
    };
    for mesh in &m.meshes {
        files.push(mesh.source.clone());
    }
    for r in &m.rules {
        files.extend(r.texture.iter().cloned());
        files.extend(r.normal_map.iter().cloned());
    }
    for w in &m.windows {
        files.extend(w.design.clone());
        files.extend(w.normal_map.iter().cloned());
    }
    files.extend(m.background.panorama.iter().cloned());
    files.sort();
    files.dedup();
    files
}

fn mtime(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

/// Polls the sources and reports a change once the files have stopped changing for
/// `settle` (editors save in several writes; cooking a half-written file only yields an
/// error message).
pub struct Watcher {
    manifest: PathBuf,
    files: Vec<(PathBuf, Option<SystemTime>)>,
    last_poll: Option<Instant>,
    interval: Duration,
    settle: Duration,
    pending_since: Option<Instant>,
}

impl Watcher {
    pub fn new(manifest: &Path) -> Self {
        let mut w = Self {
            manifest: manifest.to_path_buf(),
            files: Vec::new(),
            last_poll: None,
            interval: Duration::from_millis(500),
            settle: Duration::from_millis(300),
            pending_since: None,
        };
        w.rescan();
        w
    }

    /// Re-reads the file list (the manifest may now name other files). A file already watched
    /// keeps the time last seen, so an edit made while the cook ran still triggers the next.
    pub fn rescan(&mut self) {
        let old = std::mem::take(&mut self.files);
        self.files = sources(&self.manifest)
            .into_iter()
            .map(|p| {
                let t = match old.iter().find(|(q, _)| *q == p) {
                    Some((_, seen)) => *seen,
                    None => mtime(&p),
                };
                (p, t)
            })
            .collect();
    }

    pub fn files(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|(p, _)| p.as_path())
    }

    /// True once when a change has settled; call every frame (it rate-limits itself).
    pub fn poll(&mut self, now: Instant) -> bool {
        if self
            .last_poll
            .is_some_and(|t| now.duration_since(t) < self.interval.min(self.settle))
        {
            return false;
        }
        self.last_poll = Some(now);
        let mut changed = false;
        for (path, seen) in &mut self.files {
            let t = mtime(path);
            if t != *seen {
                *seen = t;
                changed = true;
            }
        }
        if changed {
            self.pending_since = Some(now);
            return false;
        }
        match self.pending_since {
            Some(t) if now.duration_since(t) >= self.settle => {
                self.pending_since = None;
                true
            }
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set_mtime(path: &Path, secs: u64) {
        let f = std::fs::File::options().write(true).open(path).unwrap();
        f.set_modified(SystemTime::UNIX_EPOCH + Duration::from_secs(secs))
            .unwrap();
    }

    #[test]
    fn a_touched_source_triggers_one_reload_after_it_settles() {
        let dir = tempfile::tempdir().unwrap();
        let design = dir.path().join("design.png");
        std::fs::write(&design, b"not read here").unwrap();
        let manifest = dir.path().join("scene.toml");
        std::fs::write(&manifest, "broken [").unwrap();
        let mut w = Watcher::new(&manifest);
        // An unparsable manifest is still watched itself.
        assert_eq!(w.files().collect::<Vec<_>>(), vec![manifest.as_path()]);
        let t0 = Instant::now();
        assert!(!w.poll(t0));
        set_mtime(&manifest, 1_000_000);
        assert!(!w.poll(t0 + Duration::from_secs(1)), "not settled yet");
        assert!(w.poll(t0 + Duration::from_secs(2)), "settled");
        assert!(!w.poll(t0 + Duration::from_secs(3)), "reported once");
    }

    /// A bare model is watched with what its cook read, and not parsed as a manifest.
    #[test]
    fn a_bare_model_is_watched_with_the_files_its_cook_read() {
        let dir = tempfile::tempdir().unwrap();
        let obj = dir.path().join("kirche.obj");
        std::fs::write(&obj, "mtllib kirche.mtl\nv 0 0 0\n").unwrap();
        let mtl = dir.path().join("kirche.mtl");
        let report = cook::Report {
            inputs: vec![mtl.clone(), obj.clone()],
            ..Default::default()
        };
        assert_eq!(sources(&obj), vec![obj.clone()]);
        crate::record_cooked_from(&obj, &report);
        assert_eq!(sources(&obj), vec![mtl, obj]);
    }

    /// The files the last cook read are watched, and a file a source names that was missing
    /// triggers a re-cook once it appears (a texture copied in beside an MTL, in a subfolder).
    #[test]
    fn the_last_cook_s_files_and_the_folders_of_missing_ones_are_watched() {
        let dir = tempfile::tempdir().unwrap();
        let manifest = dir.path().join("scene.toml");
        std::fs::write(&manifest, "broken [").unwrap();
        let mtl = dir.path().join("m.mtl");
        std::fs::write(&mtl, "newmtl a\nmap_Kd textures\\a.png\n").unwrap();
        let textures = dir.path().join("textures");
        std::fs::create_dir(&textures).unwrap();
        let report = cook::Report {
            inputs: vec![mtl.clone()],
            absent: vec![cook::import::Absent::new(dir.path(), "textures\\a.png")],
            ..Default::default()
        };
        crate::record_cooked_from(&manifest, &report);
        let mut w = Watcher::new(&manifest);
        let mut expected = vec![manifest.as_path(), mtl.as_path(), textures.as_path()];
        expected.sort();
        assert_eq!(w.files().collect::<Vec<_>>(), expected);
        let t0 = Instant::now();
        assert!(!w.poll(t0));
        std::fs::write(textures.join("a.png"), b"png").unwrap();
        // The folder's time as a copy a while later leaves it, on a file system that keeps
        // whole seconds too (this test runs in less).
        std::fs::File::open(&textures)
            .unwrap()
            .set_modified(SystemTime::now() + Duration::from_secs(5))
            .unwrap();
        assert!(!w.poll(t0 + Duration::from_secs(1)), "not settled yet");
        assert!(w.poll(t0 + Duration::from_secs(2)), "settled");
    }
}
