//! `--watch`: the source files of a `scene.toml`, polled by modification time. Polling a
//! handful of files twice a second costs nothing and needs no platform notification API.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

/// Every file the cook of `manifest_path` reads: the manifest, mesh sources (and the material
/// libraries an OBJ names), textures, normal maps, window designs and the panorama. A
/// manifest that does not parse yields just itself, so fixing it triggers the next cook.
pub fn sources(manifest_path: &Path) -> Vec<PathBuf> {
    let mut files = vec![manifest_path.to_path_buf()];
    let Ok(m) = cook::Manifest::load(manifest_path) else {
        return files;
    };
    for mesh in &m.meshes {
        files.push(mesh.source.clone());
        let is_obj = mesh
            .source
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
        if is_obj {
            files.extend(obj_material_libraries(&mesh.source));
        }
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

/// The `mtllib` files an OBJ refers to, resolved against its folder.
fn obj_material_libraries(obj: &Path) -> Vec<PathBuf> {
    let Ok(text) = std::fs::read(obj) else {
        return Vec::new();
    };
    let dir = obj.parent().unwrap_or(Path::new(""));
    String::from_utf8_lossy(&text)
        .lines()
        .filter_map(|l| l.trim_start().strip_prefix("mtllib"))
        .filter(|rest| rest.starts_with(char::is_whitespace))
        .map(|rest| dir.join(rest.trim()))
        .collect()
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

    /// Re-reads the file list (the manifest may now name other files) and their times.
    pub fn rescan(&mut self) {
        self.files = sources(&self.manifest)
            .into_iter()
            .map(|p| {
                let t = mtime(&p);
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

    #[test]
    fn obj_material_libraries_are_found_next_to_the_obj() {
        let dir = tempfile::tempdir().unwrap();
        let obj = dir.path().join("m.obj");
        std::fs::write(
            &obj,
            "# x\nmtllib a.mtl\n  mtllib   b.mtl \nmtllibx c\nv 0 0 0\n",
        )
        .unwrap();
        assert_eq!(
            obj_material_libraries(&obj),
            vec![dir.path().join("a.mtl"), dir.path().join("b.mtl")]
        );
    }
}
