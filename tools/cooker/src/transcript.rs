//! What a cook said, kept with its cached pack so that a cache hit says it again.
//!
//! A user or a CI log must see the same warnings, `skipped:` lines, notes and `-v` statistics
//! whether the pack was cooked or reused: a hit replays them, marked as reused (as Bazel
//! replays a cached action's output). Lines depending on the cache's state (what was reused,
//! damaged entries) are not part of it; they are said afresh by each run.
//!
//! Paths in messages are spelled as the user named the scene (`assets-src/windows/x.png`). The
//! stored transcript holds the scene's folder as a placeholder, so a replay names the files
//! of the checkout it runs in, however that one was named.

use std::path::Path;

use serde::{Deserialize, Serialize};

/// Stands for the scene's folder (with its trailing separator) in stored messages.
const SCENE_DIR: &str = "\u{0}scene-dir\u{0}";

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Stream {
    Out,
    Err,
    /// To stderr with `-v` only: the error budget's choice for a texture (encoder, blur, mips,
    /// with their measured errors). Three lines a window drowned a cathedral's warnings; a
    /// run without `-v` says in one line how many there are.
    Detail,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transcript {
    /// Warnings, notes and `skipped:` lines, in the order printed.
    pub messages: Vec<(Stream, String)>,
    /// The `-v` statistics (printed only with `-v`, kept whatever the cook's flags were).
    pub stats: Vec<String>,
    /// What the pack holds: "1 meshes, 3660 triangles, …, N bytes".
    pub summary: String,
    /// The textures, for the reuse lines of a hit.
    pub textures: Vec<String>,
}

impl Transcript {
    /// Prints a message (a detail only if `verbose`) and keeps it, whatever `verbose`, for a
    /// replay with or without `-v`.
    pub fn message(&mut self, stream: Stream, text: String, verbose: bool) {
        print(stream, &text, verbose);
        self.messages.push((stream, text));
    }

    /// Prints the messages (for a replay), then, without `-v`, how many details it left out.
    pub fn print_messages(&self, verbose: bool) {
        for (stream, text) in &self.messages {
            print(*stream, text, verbose);
        }
        self.print_details_left_out(verbose);
    }

    /// Without `-v`, one line saying how many details were not printed.
    pub fn print_details_left_out(&self, verbose: bool) {
        let n = self
            .messages
            .iter()
            .filter(|(s, _)| *s == Stream::Detail)
            .count();
        if !verbose && n > 0 {
            let lines = if n == 1 { "line" } else { "lines" };
            eprintln!(
                "note: the error budget chose the encoding, blur and mips of the textures \
                 ({n} {lines} with their measured errors: -v prints them)"
            );
        }
    }

    pub fn print_stats(&self) {
        for l in &self.stats {
            println!("{l}");
        }
    }

    /// The transcript with the scene's folder replaced by a placeholder, for storing.
    pub fn portable(&self, manifest: &Path) -> Self {
        self.map(|s| swap_prefix(s, &dir_prefix(manifest), SCENE_DIR))
    }

    /// A stored transcript with its placeholder spelled as this run names the scene.
    pub fn localized(&self, manifest: &Path) -> Self {
        let prefix = dir_prefix(manifest);
        self.map(|s| s.replace(SCENE_DIR, &prefix))
    }

    fn map(&self, f: impl Fn(&str) -> String) -> Self {
        Self {
            messages: self
                .messages
                .iter()
                .map(|(stream, t)| (*stream, f(t)))
                .collect(),
            stats: self.stats.iter().map(|t| f(t)).collect(),
            summary: self.summary.clone(),
            textures: self.textures.iter().map(|t| f(t)).collect(),
        }
    }
}

fn print(stream: Stream, text: &str, verbose: bool) {
    match stream {
        Stream::Out => println!("{text}"),
        Stream::Err => eprintln!("{text}"),
        Stream::Detail if verbose => eprintln!("{text}"),
        Stream::Detail => {}
    }
}

/// The scene's folder as messages spell it, with its separator: `assets-src/`, or nothing for
/// a scene named without a folder.
fn dir_prefix(manifest: &Path) -> String {
    match manifest.parent() {
        Some(d) if !d.as_os_str().is_empty() => {
            format!("{}{}", d.display(), std::path::MAIN_SEPARATOR)
        }
        _ => String::new(),
    }
}

/// Replaces `prefix` where it starts a path: at the start of the text or after a character
/// that cannot be part of a path's folder name (so `x/` in `/other/x/` stays).
fn swap_prefix(text: &str, prefix: &str, with: &str) -> String {
    if prefix.is_empty() {
        return text.to_string();
    }
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    let mut prev: Option<char> = None;
    while let Some(i) = rest.find(prefix) {
        let before = rest[..i].chars().next_back().or(prev);
        let starts_path = before.is_none_or(|c| {
            !(c.is_alphanumeric() || matches!(c, '/' | '\\' | '.' | '_' | '-' | '~'))
        });
        out.push_str(&rest[..i]);
        out.push_str(if starts_path { with } else { prefix });
        prev = prefix.chars().next_back();
        rest = &rest[i + prefix.len()..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_folder_is_a_placeholder_only_where_a_path_starts() {
        let t = Transcript {
            messages: vec![(
                Stream::Err,
                "note: a/scene.toml: a/w.png (not /x/a/w.png, nor ba/w.png)".into(),
            )],
            stats: vec!["mesh \"m\" (a/m.obj)".into()],
            summary: "1 meshes".into(),
            textures: vec!["a/w.png (colour)".into()],
        };
        let stored = t.portable(Path::new("a/scene.toml"));
        assert!(!stored.messages[0].1.contains("a/scene.toml"));
        assert!(
            stored.messages[0].1.contains("/x/a/w.png")
                && stored.messages[0].1.contains("ba/w.png")
        );
        assert_eq!(stored.localized(Path::new("a/scene.toml")), t);
        let elsewhere = stored.localized(Path::new("/ci/b/scene.toml"));
        assert_eq!(
            elsewhere.messages[0].1,
            "note: /ci/b/scene.toml: /ci/b/w.png (not /x/a/w.png, nor ba/w.png)"
        );
        assert_eq!(elsewhere.stats[0], "mesh \"m\" (/ci/b/m.obj)");
        assert_eq!(elsewhere.textures[0], "/ci/b/w.png (colour)");
        // A scene named without a folder: nothing to swap either way.
        let bare = t.portable(Path::new("scene.toml"));
        assert_eq!(bare, t);
    }
}
