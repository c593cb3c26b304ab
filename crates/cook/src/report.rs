//! What a cook did, for the command line: per-mesh numbers, tagging guesses, what was
//! skipped, reused or re-cooked, and stage times.

use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::import::Warning;
use crate::mesh::MeshStats;

/// Numbers about one cooked mesh.
#[derive(Clone, Debug)]
pub struct MeshReport {
    pub name: String,
    pub source: PathBuf,
    pub import_time: Duration,
    /// n-gons split into triangles by the importer.
    pub polygons: usize,
    pub stats: MeshStats,
    pub vertex_bytes: usize,
    pub index_bytes: usize,
    pub quantization: Option<QuantizationError>,
    /// Vertex attributes left out because no material of the mesh uses them.
    pub dropped_attributes: Vec<&'static str>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuantizationError {
    pub position: f32,
    pub normal_deg: f32,
    pub uv: f32,
}

/// A tagging decision made by heuristics rather than a rule.
#[derive(Clone, Debug, PartialEq)]
pub struct HeuristicNote {
    pub source: PathBuf,
    pub names: String,
    /// The pack materials its triangles went to, with their classes: one, or each window its
    /// glass became (a window's class is decided by its sill).
    pub materials: Vec<(String, pack::MaterialClass)>,
    /// The name keyword that decided, if a name did.
    pub keyword: Option<&'static str>,
    /// Why: the keyword, the material property or the geometry that decided, or that nothing
    /// matched.
    pub reason: String,
    pub triangles: usize,
}

impl HeuristicNote {
    /// Its classes, in the order first met: `window-lower`, `window-lower and window-upper`.
    pub fn classes(&self) -> String {
        let mut classes: Vec<pack::MaterialClass> = Vec::new();
        for (_, c) in &self.materials {
            if !classes.contains(c) {
                classes.push(*c);
            }
        }
        let words: Vec<String> = classes.iter().map(|c| c.to_string()).collect();
        words.join(" and ")
    }

    /// What it was tagged: `wall as material "Stone"`, or `window-lower as 3 windows
    /// ("Glass#1", "Glass#2", "Glass#3")`.
    pub fn tagged(&self) -> String {
        match &self.materials[..] {
            [(name, class)] => format!("{class} as material {name:?}"),
            many => {
                let names: Vec<&str> = many.iter().map(|(n, _)| n.as_str()).collect();
                let what = if many.iter().all(|(_, c)| c.is_window()) {
                    "windows"
                } else {
                    "materials"
                };
                format!(
                    "{} as {} {what} ({})",
                    self.classes(),
                    many.len(),
                    few_names(&names)
                )
            }
        }
    }
}

/// Heuristic notes that say the same (the same source, tagged alike for the same reason) as
/// one group each, in the order first met: a floor laid as 400 tiles, each its own object,
/// is one line, not 400 equal ones.
pub fn group_heuristics(notes: &[HeuristicNote]) -> Vec<Vec<&HeuristicNote>> {
    let mut groups: Vec<Vec<&HeuristicNote>> = Vec::new();
    let mut index: std::collections::HashMap<(&Path, String, &str), usize> = Default::default();
    for n in notes {
        let key = (n.source.as_path(), n.tagged(), n.reason.as_str());
        match index.get(&key) {
            Some(&g) => groups[g].push(n),
            None => {
                index.insert(key, groups.len());
                groups.push(vec![n]);
            }
        }
    }
    groups
}

/// The parts of a group ([`group_heuristics`]): `material "Stone", object "pier"` for one,
/// `216 parts (…; …; … and 213 more)` for many.
pub fn group_names(group: &[&HeuristicNote]) -> String {
    match group {
        [one] => one.names.clone(),
        many => {
            let shown: Vec<&str> = many
                .iter()
                .take(shown_of(many.len()))
                .map(|n| n.names.as_str())
                .collect();
            let more = many.len() - shown.len();
            format!(
                "{} parts ({}{})",
                many.len(),
                shown.join("; "),
                if more > 0 {
                    format!(" and {more} more")
                } else {
                    String::new()
                }
            )
        }
    }
}

/// More than this many things skipped for one reason are one line of the report, naming
/// the first few: a line each buried the rest of a big model's output (a hall's 225 shaded
/// windows, a shared MTL library's unused materials).
pub(crate) const NAMED: usize = 3;

/// `names` for such a line, each quoted: all of them up to [`NAMED`], else the first few
/// and how many more.
pub(crate) fn few_names(names: &[impl std::fmt::Debug]) -> String {
    let shown: Vec<String> = names
        .iter()
        .take(shown_of(names.len()))
        .map(|n| format!("{n:?}"))
        .collect();
    if shown.len() == names.len() {
        shown.join(", ")
    } else {
        format!(
            "{} and {} more",
            shown.join(", "),
            names.len() - shown.len()
        )
    }
}

/// `s` padded with spaces to `width` columns as a terminal shows it: a CJK character takes
/// two, so names in Chinese pushed the columns after them out of line (`cooker info`, then
/// `cooker validate`'s material table, which padded by characters).
pub fn padded(s: &str, width: usize) -> String {
    let s = shown(s);
    let w = unicode_width::UnicodeWidthStr::width(&*s);
    format!("{s}{}", " ".repeat(width.saturating_sub(w)))
}

/// A name read from a file, safe to print unquoted: control characters as their escapes
/// (`\u{1b}`), all else as it is. A pack's names are whatever the model's tool wrote, and
/// `info` printed an escape sequence in a material's name to the terminal, which ran it.
pub fn shown(s: &str) -> std::borrow::Cow<'_, str> {
    // Control characters, and the invisible ones that reorder or hide text (bidirectional
    // overrides and isolates, zero-width marks), which can make a name read as another.
    let hidden = |c: char| {
        c.is_control()
            || matches!(c, '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}'
                | '\u{2060}'..='\u{2064}' | '\u{2066}'..='\u{2069}' | '\u{061c}' | '\u{feff}')
    };
    if !s.chars().any(hidden) {
        return s.into();
    }
    s.chars()
        .map(|c| {
            if hidden(c) {
                c.escape_debug().to_string()
            } else {
                c.to_string()
            }
        })
        .collect::<String>()
        .into()
}

/// A length for messages: two decimals, or three significant digits where those say less. A
/// model in metres scaled to millimetres had windows "0.00 x 0.00", and a nave scaled to a
/// fraction of a millimetre windows "0–0 units long".
pub fn length(x: f64) -> String {
    let digits = if x.abs() > 0.0 && x.is_finite() {
        (2 - x.abs().log10().floor() as i64).clamp(2, 15) as usize
    } else {
        2
    };
    format!("{x:.digits$}")
}

/// How many of `n` things a line names: all where one more than [`NAMED`] (its name is no
/// longer than "and 1 more", and a rose of four panes hid one of them), else [`NAMED`].
pub(crate) fn shown_of(n: usize) -> usize {
    if n <= NAMED + 1 { n } else { NAMED }
}

/// What happened while cooking, for the CLI.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// Every file the cook read (sorted, without duplicates): what a cache entry depends on.
    pub inputs: Vec<PathBuf>,
    /// Files the sources name that were not found (sorted, without duplicates): the cook
    /// depends on their staying absent.
    pub absent: Vec<crate::import::Absent>,
    /// Per cooked artifact (texture), whether it was cooked or reused from the cache.
    pub artifacts: Vec<(String, ArtifactSource)>,
    pub warnings: Vec<Warning>,
    /// What a user should know about how the cook read the scene: information, not a problem,
    /// so not among the warnings.
    pub notes: Vec<Warning>,
    /// The choices the error budget made per texture (blur, mips, encoder, with their measured
    /// errors): what `-v` shows.
    pub details: Vec<Warning>,
    pub meshes: Vec<MeshReport>,
    pub heuristics: Vec<HeuristicNote>,
    /// What the scene defines but nothing uses, so it was not cooked: one line each.
    pub skipped: Vec<String>,
    pub stages: Vec<Stage>,
    /// How long a bare model's guessed light and cameras took, on another core during the
    /// mesh stage (its normals and dedupe): `None` where nothing was guessed.
    pub guess_time: Option<Duration>,
}

/// One stage of a cook, in order.
#[derive(Clone, Debug)]
pub struct Stage {
    pub name: &'static str,
    pub time: Duration,
    /// The process's peak resident memory so far, in bytes, read as the stage ended: the
    /// stage that raised it is the first whose figure is the final one. `None` where the
    /// system does not say.
    pub peak_rss: Option<u64>,
}

impl Report {
    pub(crate) fn stage(&mut self, name: &'static str, time: Duration) {
        self.stages.push(Stage {
            name,
            time,
            peak_rss: peak_rss(),
        });
    }
}

/// The process's peak resident memory so far, in bytes (`getrusage`: a system call, no file
/// to read, so every stage can afford it).
#[cfg(any(target_os = "linux", target_os = "macos"))]
pub fn peak_rss() -> Option<u64> {
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::uninit();
    // SAFETY: getrusage writes the whole struct when it returns 0, and reads nothing.
    let usage = unsafe {
        if libc::getrusage(libc::RUSAGE_SELF, usage.as_mut_ptr()) != 0 {
            return None;
        }
        usage.assume_init()
    };
    let max = u64::try_from(usage.ru_maxrss).ok()?;
    // Linux counts kilobytes, macOS bytes.
    Some(if cfg!(target_os = "linux") {
        max * 1024
    } else {
        max
    })
}

/// The process's peak resident memory so far: not known on this system.
#[cfg(not(any(target_os = "linux", target_os = "macos")))]
pub fn peak_rss() -> Option<u64> {
    None
}

/// Where a cooked artifact came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ArtifactSource {
    Cooked,
    Reused,
    /// The cache entry was damaged; it was cooked again.
    Recooked(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names pad by the columns a terminal gives them: a CJK character takes two.
    #[test]
    fn names_pad_by_their_width_on_screen() {
        assert_eq!(padded("Glass", 8), "Glass   ");
        assert_eq!(padded("红色玻璃", 10), "红色玻璃  ");
        assert_eq!(padded("Γυαλί", 6), "Γυαλί ");
        assert_eq!(padded("a long name", 4), "a long name");
        // A control character pads by its escape, which is what is shown.
        assert_eq!(padded("a\x1bb", 10), "a\\u{1b}b  ");
    }

    #[test]
    fn shown_escapes_control_characters_only() {
        assert_eq!(shown("back\\slash \"q\" 红"), "back\\slash \"q\" 红");
        assert_eq!(shown("a\x1b[31mb\tc\u{9b}d"), "a\\u{1b}[31mb\\tc\\u{9b}d");
        assert_eq!(shown("glass\u{202e}txt.exe"), "glass\\u{202e}txt.exe");
        assert!(matches!(shown("plain"), std::borrow::Cow::Borrowed(_)));
    }

    #[test]
    fn a_length_keeps_three_significant_digits() {
        let said = [1.2, 12.5, 0.03, 0.0012, 0.0, 1234.5, 5.5e-5, 1.578].map(length);
        assert_eq!(
            said,
            [
                "1.20",
                "12.50",
                "0.0300",
                "0.00120",
                "0.00",
                "1234.50",
                "0.0000550",
                "1.58"
            ]
        );
    }

    /// Tiles of one floor, each its own object, tagged alike for one reason, are one group;
    /// another material, reason or source starts another, in the order first met.
    #[test]
    fn notes_that_say_the_same_are_one_group() {
        let note = |src: &str, names: String, material: &str, reason: &str| HeuristicNote {
            source: PathBuf::from(src),
            names,
            materials: vec![(material.into(), pack::MaterialClass::Floor)],
            keyword: None,
            reason: reason.into(),
            triangles: 2,
        };
        let mut notes: Vec<HeuristicNote> = (0..400)
            .map(|i| note("a.obj", format!("object \"tile_{i}\""), "Marble", "flat"))
            .collect();
        notes.insert(1, note("a.obj", "object \"porch\"".into(), "Marble", "low"));
        notes.push(note("b.obj", "object \"tile_0\"".into(), "Marble", "flat"));
        let groups = group_heuristics(&notes);
        let sizes: Vec<usize> = groups.iter().map(|g| g.len()).collect();
        assert_eq!(sizes, [400, 1, 1]);
        assert_eq!(
            group_names(&groups[0]),
            "400 parts (object \"tile_0\"; object \"tile_1\"; object \"tile_2\" and 397 more)"
        );
        assert_eq!(group_names(&groups[1]), "object \"porch\"");
    }

    /// The peak counts memory once it is touched, and never falls.
    #[cfg(any(target_os = "linux", target_os = "macos"))]
    #[test]
    fn peak_rss_counts_touched_memory() {
        let before = peak_rss().expect("this system reports peak memory");
        let block = std::hint::black_box(vec![1u8; 64 << 20]);
        let after = peak_rss().unwrap();
        drop(block);
        assert!(after >= 64 << 20 && after >= before, "{before} -> {after}");
        assert!(peak_rss().unwrap() >= after);
    }
}
