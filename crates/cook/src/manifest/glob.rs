//! Name patterns as manifests and `--window` write them.

use std::collections::HashMap;
use std::sync::OnceLock;

use globset::{Glob, GlobMatcher, GlobSet, GlobSetBuilder};
use serde::{Serialize, Serializer};

/// A glob over names. Compiling one is a regex build, so it happens once, on first use, and
/// not at all for a pattern without glob syntax (as `cooker init` writes one per material),
/// which is compared as a string: compiling a 4,000-character window name for every window ×
/// entry pair kept a cook of 2,000 such windows busy for over 14 minutes. A pattern also
/// matches the name it spells: `--window 'brack[1]=…'` names the window `cooker info` lists
/// as `brack[1]` (as a glob it means `brack1`, and was refused as naming no window). A
/// pattern that is no valid glob matches only itself.
#[derive(Clone)]
pub struct NameGlob {
    text: String,
    /// `None` for a literal.
    glob: Option<Glob>,
    matcher: OnceLock<GlobMatcher>,
}

/// What a glob may use: `*`, `?`, classes, alternations and `\` escapes.
fn has_glob_syntax(s: &str) -> bool {
    s.contains(['*', '?', '[', ']', '{', '}', '\\'])
}

impl NameGlob {
    /// `text` as a glob; `Err` where it is not a valid one.
    pub fn checked(text: &str) -> Result<Self, globset::Error> {
        let glob = if has_glob_syntax(text) {
            Some(Glob::new(text)?)
        } else {
            None
        };
        Ok(Self {
            text: text.to_string(),
            glob,
            matcher: OnceLock::new(),
        })
    }

    /// `text` as a glob, or as a literal where it is not a valid one.
    pub fn new(text: &str) -> Self {
        Self::checked(text).unwrap_or_else(|_| Self {
            text: text.to_string(),
            glob: None,
            matcher: OnceLock::new(),
        })
    }

    pub fn is_literal(&self) -> bool {
        self.glob.is_none()
    }

    pub fn is_match(&self, name: &str) -> bool {
        self.text == name
            || self.glob.as_ref().is_some_and(|g| {
                self.matcher
                    .get_or_init(|| g.compile_matcher())
                    .is_match(name)
            })
    }
}

/// Many patterns matched against one name at once: literals through a hash table, the
/// globs through one [`GlobSet`]. (A `GlobSet` takes literals too, but keeps every one as a
/// tokenized glob: 2,000 window names of 4,000 characters held 270 MB.)
#[derive(Debug, Default)]
pub struct NameSet {
    literals: HashMap<String, Vec<usize>>,
    /// The globs' set, and the id of each of its globs.
    globs: Option<(GlobSet, Vec<usize>)>,
    /// Only where the set could not be built (a regex over its size limit): each glob and
    /// its id, tried one by one.
    one_by_one: Vec<(usize, NameGlob)>,
}

impl NameSet {
    /// The set of `patterns`, each with the id [`NameSet::matching`] gives for it.
    pub fn new<'a>(patterns: impl IntoIterator<Item = (usize, &'a NameGlob)>) -> Self {
        let mut set = Self::default();
        let mut builder = GlobSetBuilder::new();
        let mut ids = Vec::new();
        let mut globs = Vec::new();
        for (id, p) in patterns {
            set.literals.entry(p.text.clone()).or_default().push(id);
            if let Some(g) = &p.glob {
                builder.add(g.clone());
                ids.push(id);
                globs.push((id, p.clone()));
            }
        }
        if !ids.is_empty() {
            match builder.build() {
                Ok(s) => set.globs = Some((s, ids)),
                Err(_) => set.one_by_one = globs,
            }
        }
        set
    }

    /// The ids of the patterns that match `name`, in increasing order.
    pub fn matching(&self, name: &str) -> Vec<usize> {
        let mut found: Vec<usize> = self.literals.get(name).cloned().unwrap_or_default();
        if let Some((set, ids)) = &self.globs {
            found.extend(set.matches(name).into_iter().map(|i| ids[i]));
        }
        found.extend(
            self.one_by_one
                .iter()
                .filter(|(_, g)| g.is_match(name))
                .map(|&(id, _)| id),
        );
        found.sort_unstable();
        found.dedup();
        found
    }

    /// The smallest id of a pattern that matches `name`.
    pub fn first(&self, name: &str) -> Option<usize> {
        self.matching(name).first().copied()
    }
}

impl PartialEq for NameGlob {
    fn eq(&self, other: &Self) -> bool {
        self.text == other.text
    }
}

/// The pattern as written.
impl std::ops::Deref for NameGlob {
    type Target = str;
    fn deref(&self) -> &str {
        &self.text
    }
}

/// As the quoted pattern, as messages name it.
impl std::fmt::Debug for NameGlob {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(&self.text, f)
    }
}

impl std::fmt::Display for NameGlob {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.text)
    }
}

/// As the string: cache keys hold the pattern as written.
impl Serialize for NameGlob {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_and_globs_match_as_globset_does() {
        let names = [
            "rose",
            "Rose",
            "rose window",
            "a/b",
            "",
            "Fenster_ö",
            "lancet.001",
            "x*y",
            "a{b}",
        ];
        let patterns = [
            "rose",
            "ros?",
            "*",
            "r*",
            "a/b",
            "a/*",
            "",
            "Fenster_ö",
            "lancet.*",
            "[rR]ose",
            "x\\*y",
            "a\\{b\\}",
            "{rose,Rose}",
            "lancet.00[0-9]",
        ];
        for p in patterns {
            let g = NameGlob::checked(p).unwrap();
            let reference = Glob::new(p).unwrap().compile_matcher();
            for n in names {
                let spelled = p == n;
                assert_eq!(
                    g.is_match(n),
                    spelled || reference.is_match(n),
                    "{p:?} on {n:?}"
                );
            }
        }
        // The name a pattern spells, whatever the glob means.
        let brack = NameGlob::checked("brack[1]").unwrap();
        assert!(brack.is_match("brack[1]") && brack.is_match("brack1"));
        assert_eq!(NameSet::new([(0, &brack)]).matching("brack[1]"), [0]);
        assert!(NameGlob::checked("rose").unwrap().is_literal());
        assert!(!NameGlob::checked("ro*").unwrap().is_literal());
    }

    #[test]
    fn an_invalid_glob_matches_only_itself() {
        assert!(NameGlob::checked("a[b").is_err());
        let g = NameGlob::new("a[b");
        assert!(g.is_match("a[b"));
        assert!(!g.is_match("ab"));
        assert_eq!(NameSet::new([(3, &g)]).matching("a[b"), [3]);
    }

    #[test]
    fn a_set_finds_what_each_pattern_finds_in_order() {
        let patterns: Vec<NameGlob> = ["lancet*", "rose", "*", "rose", "r?se", "x", "x*"]
            .into_iter()
            .map(NameGlob::new)
            .collect();
        // Ids as a caller gives them: not the positions, and not in order.
        let ids = [10, 4, 7, 2, 30, 5, 6];
        let set = NameSet::new(ids.iter().copied().zip(&patterns));
        for name in ["rose", "lancet.3", "x", "x*", "nothing", ""] {
            let mut expected: Vec<usize> = ids
                .iter()
                .zip(&patterns)
                .filter(|(_, p)| p.is_match(name))
                .map(|(&i, _)| i)
                .collect();
            expected.sort_unstable();
            assert_eq!(set.matching(name), expected, "{name:?}");
            assert_eq!(set.first(name), expected.first().copied());
        }
        assert_eq!(set.matching("rose"), [2, 4, 7, 30]);
    }
}
