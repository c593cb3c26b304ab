//! Material tagging: source names → pack materials with a class.
//!
//! Ordered rules are the primary mechanism (real models name materials in any language); the
//! first rule whose glob matches one of a part's names decides. Name heuristics apply only to
//! parts no rule matched, and every such decision is reported.

use std::collections::{HashMap, HashSet};

use pack::MaterialClass;

use crate::CookError;
use crate::buckets::Counts;
use crate::import::{ImageRef, Imported, SourceMaterial};
use crate::manifest::{Manifest, NameGlob, NameKind, NameSet, Rule};

/// How a part got its material.
#[derive(Clone, Debug, PartialEq)]
pub enum Decision {
    /// Index into the manifest's rules.
    Rule(usize),
    /// No rule matched; `keyword` found in the `kind` name `name` chose the class.
    Heuristic {
        keyword: &'static str,
        kind: NameKind,
        name: String,
    },
    /// The source material's transparency made it glass (`reason` says which property).
    Glass { reason: String },
    /// Where the part lies and faces decided (`reason` gives the numbers).
    Geometry { reason: String },
    /// Nothing matched at all: class `other`.
    Unmatched,
}

impl Decision {
    pub fn is_rule(&self) -> bool {
        matches!(self, Decision::Rule(_))
    }

    /// Why a heuristic decided, for reports; `None` for rules.
    pub fn reason(&self) -> Option<String> {
        match self {
            Decision::Rule(_) => None,
            Decision::Heuristic {
                keyword,
                kind,
                name,
            } => Some(format!(
                "{} name {name:?} has {:?}",
                kind.name(),
                written_greek(keyword)
            )),
            Decision::Glass { reason } => Some(format!("material: {reason}")),
            Decision::Geometry { reason } => Some(reason.clone()),
            Decision::Unmatched => {
                Some("no rule, name, material property or geometry matched".into())
            }
        }
    }
}

/// A pack material and where its textures come from.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialPlan {
    /// Texture references are filled in by the texture stage.
    pub material: pack::Material,
    pub diffuse_texture: Option<ImageRef>,
    pub normal_texture: Option<ImageRef>,
    /// The source's strength for `normal_texture` (`SourceMaterial::normal_scale`).
    pub normal_scale: f32,
    /// For a window: its design and how it sits, filled by the window stage.
    pub window: Option<Box<crate::window_plan::WindowPlan>>,
}

/// A source name that more than one rule matches (the first wins).
#[derive(Clone, Debug, PartialEq)]
pub struct Ambiguity {
    pub kind: NameKind,
    pub name: String,
    /// Manifest lines of the matching rules, in rule order.
    pub rule_lines: Vec<usize>,
}

#[derive(Clone, Debug, Default)]
pub struct Tagging {
    pub materials: Vec<MaterialPlan>,
    /// Per source, per part: the pack material.
    pub part_material: Vec<Vec<u16>>,
    /// Per source, per part: how it was decided.
    pub decisions: Vec<Vec<Decision>>,
    /// Per source, per part: what the geometry cut made of it (see `split_mixed_parts`).
    pub cut: Vec<Vec<Cut>>,
    pub ambiguities: Vec<Ambiguity>,
    /// Source materials (per source, by index) that no triangle uses.
    pub unused_source_materials: Vec<(usize, String)>,
}

/// Keywords in the common European languages and in Russian, Ukrainian, Serbian, Greek,
/// Arabic, Hebrew, Hindi, Chinese, Japanese and Korean, matched against the words of lower-cased names (see
/// [`name_words`]; Greek written without accents and with `σ` for `ς`). Words of four letters
/// or fewer must match a whole word ("pod" is a floor, "tripod" is not); longer ones may
/// start a word or sit inside a compound ("Kirchenfenster", "walls"). Chinese, Japanese and
/// Korean write compounds without spaces, so their keywords may sit anywhere in a word
/// ("彩色玻璃窗", a stained-glass window).
const HEURISTICS: &[(&str, MaterialClass)] = &[
    ("window", MaterialClass::WindowUpper),
    ("glass", MaterialClass::WindowUpper),
    ("glazing", MaterialClass::WindowUpper),
    ("vitrail", MaterialClass::WindowUpper),
    ("vitraux", MaterialClass::WindowUpper),
    ("vitrage", MaterialClass::WindowUpper),
    ("vitre", MaterialClass::WindowUpper),
    ("verre", MaterialClass::WindowUpper),
    ("fenetre", MaterialClass::WindowUpper),
    ("fenêtre", MaterialClass::WindowUpper),
    ("vidrio", MaterialClass::WindowUpper),
    ("vidriera", MaterialClass::WindowUpper),
    ("vitral", MaterialClass::WindowUpper),
    ("ventana", MaterialClass::WindowUpper),
    ("vetro", MaterialClass::WindowUpper),
    ("vetrata", MaterialClass::WindowUpper),
    ("finestra", MaterialClass::WindowUpper),
    ("glas", MaterialClass::WindowUpper),
    // German, Danish and Norwegian compounds, which "glas" (a whole word) does not catch.
    ("glasmalerei", MaterialClass::WindowUpper),
    ("bleiglas", MaterialClass::WindowUpper),
    ("buntglas", MaterialClass::WindowUpper),
    ("glasmaleri", MaterialClass::WindowUpper),
    ("glasmosaik", MaterialClass::WindowUpper),
    ("blyglas", MaterialClass::WindowUpper),
    ("fenster", MaterialClass::WindowUpper),
    ("staklo", MaterialClass::WindowUpper),
    ("vitraj", MaterialClass::WindowUpper),
    ("prozor", MaterialClass::WindowUpper),
    ("szkło", MaterialClass::WindowUpper),
    ("szklo", MaterialClass::WindowUpper),
    ("witraż", MaterialClass::WindowUpper),
    ("witraz", MaterialClass::WindowUpper),
    ("okno", MaterialClass::WindowUpper),
    ("lancet", MaterialClass::WindowUpper),
    ("vidro", MaterialClass::WindowUpper),
    ("janela", MaterialClass::WindowUpper),
    ("sklo", MaterialClass::WindowUpper),
    ("vitraž", MaterialClass::WindowUpper),
    ("vitráž", MaterialClass::WindowUpper),
    ("vitraz", MaterialClass::WindowUpper),
    ("üveg", MaterialClass::WindowUpper),
    ("uveg", MaterialClass::WindowUpper),
    // Hungarian compounds, which "üveg" (four letters, a whole word) does not catch.
    ("ólomüveg", MaterialClass::WindowUpper),
    ("olomuveg", MaterialClass::WindowUpper),
    ("üvegablak", MaterialClass::WindowUpper),
    ("uvegablak", MaterialClass::WindowUpper),
    ("ablaküveg", MaterialClass::WindowUpper),
    ("ablakuveg", MaterialClass::WindowUpper),
    ("ablak", MaterialClass::WindowUpper),
    ("sticlă", MaterialClass::WindowUpper),
    ("sticla", MaterialClass::WindowUpper),
    ("fereastră", MaterialClass::WindowUpper),
    ("fereastra", MaterialClass::WindowUpper),
    ("vitraliu", MaterialClass::WindowUpper),
    ("fönster", MaterialClass::WindowUpper),
    ("fonster", MaterialClass::WindowUpper),
    ("vindue", MaterialClass::WindowUpper),
    ("vindu", MaterialClass::WindowUpper),
    ("lasi", MaterialClass::WindowUpper),
    ("lasimaalaus", MaterialClass::WindowUpper),
    ("lyijylasi", MaterialClass::WindowUpper),
    ("ikkuna", MaterialClass::WindowUpper),
    ("pencere", MaterialClass::WindowUpper),
    ("vitray", MaterialClass::WindowUpper),
    ("raam", MaterialClass::WindowUpper),
    // Dutch compounds, which "glas" and "raam" (whole words) do not catch.
    ("brandglas", MaterialClass::WindowUpper),
    ("glasraam", MaterialClass::WindowUpper),
    ("glasramen", MaterialClass::WindowUpper),
    ("gebrandschilderd", MaterialClass::WindowUpper),
    ("venster", MaterialClass::WindowUpper),
    ("стекло", MaterialClass::WindowUpper),
    ("скло", MaterialClass::WindowUpper),
    ("стакло", MaterialClass::WindowUpper),
    ("окно", MaterialClass::WindowUpper),
    ("вікно", MaterialClass::WindowUpper),
    ("прозор", MaterialClass::WindowUpper),
    ("витраж", MaterialClass::WindowUpper),
    ("вітраж", MaterialClass::WindowUpper),
    ("γυαλι", MaterialClass::WindowUpper),
    ("τζαμι", MaterialClass::WindowUpper),
    ("παραθυρο", MaterialClass::WindowUpper),
    ("βιτρο", MaterialClass::WindowUpper),
    ("βιτρω", MaterialClass::WindowUpper),
    // Greek's learned compounds of ύαλος: stained glass, a pane, glazing.
    ("υαλογραφ", MaterialClass::WindowUpper),
    ("υαλοπινακ", MaterialClass::WindowUpper),
    ("υαλοστασ", MaterialClass::WindowUpper),
    ("玻璃", MaterialClass::WindowUpper),
    ("窗", MaterialClass::WindowUpper),
    ("ガラス", MaterialClass::WindowUpper),
    ("窓", MaterialClass::WindowUpper),
    ("ステンドグラス", MaterialClass::WindowUpper),
    ("유리", MaterialClass::WindowUpper),
    ("창문", MaterialClass::WindowUpper),
    ("글라스", MaterialClass::WindowUpper),
    // Arabic and Hebrew words of four letters or fewer match whole words only: with the
    // article (al-, ha-) they are other words.
    ("زجاج", MaterialClass::WindowUpper),
    ("الزجاج", MaterialClass::WindowUpper),
    ("نافذة", MaterialClass::WindowUpper),
    ("نوافذ", MaterialClass::WindowUpper),
    ("זכוכית", MaterialClass::WindowUpper),
    ("חלון", MaterialClass::WindowUpper),
    ("החלון", MaterialClass::WindowUpper),
    ("חלונות", MaterialClass::WindowUpper),
    ("ויטראז", MaterialClass::WindowUpper),
    ("कांच", MaterialClass::WindowUpper),
    ("काँच", MaterialClass::WindowUpper),
    ("शीशा", MaterialClass::WindowUpper),
    // With the nukta written apart (as NFC leaves it) or composed, and without it.
    (
        "\u{916}\u{93F}\u{921}\u{93C}\u{915}\u{940}",
        MaterialClass::WindowUpper,
    ),
    (
        "\u{916}\u{93F}\u{95C}\u{915}\u{940}",
        MaterialClass::WindowUpper,
    ),
    (
        "\u{916}\u{93F}\u{921}\u{915}\u{940}",
        MaterialClass::WindowUpper,
    ),
    ("floor", MaterialClass::Floor),
    ("ground", MaterialClass::Floor),
    ("pavement", MaterialClass::Floor),
    ("paving", MaterialClass::Floor),
    ("sol", MaterialClass::Floor),
    ("plancher", MaterialClass::Floor),
    ("dallage", MaterialClass::Floor),
    ("suelo", MaterialClass::Floor),
    ("piso", MaterialClass::Floor),
    ("pavimento", MaterialClass::Floor),
    ("boden", MaterialClass::Floor),
    ("pod", MaterialClass::Floor),
    ("podloga", MaterialClass::Floor),
    ("podłoga", MaterialClass::Floor),
    ("vloer", MaterialClass::Floor),
    ("chão", MaterialClass::Floor),
    ("chao", MaterialClass::Floor),
    ("podlaha", MaterialClass::Floor),
    // Not "padlo": keywords of five letters may sit inside a word, and "padlock" is no floor.
    ("padló", MaterialClass::Floor),
    ("podea", MaterialClass::Floor),
    ("golv", MaterialClass::Floor),
    ("gulv", MaterialClass::Floor),
    ("lattia", MaterialClass::Floor),
    ("zemin", MaterialClass::Floor),
    ("пол", MaterialClass::Floor),
    ("підлога", MaterialClass::Floor),
    ("под", MaterialClass::Floor),
    ("δαπεδο", MaterialClass::Floor),
    ("πατωμα", MaterialClass::Floor),
    ("地板", MaterialClass::Floor),
    ("地面", MaterialClass::Floor),
    ("フロア", MaterialClass::Floor),
    ("바닥", MaterialClass::Floor),
    ("أرضية", MaterialClass::Floor),
    ("ارضية", MaterialClass::Floor),
    ("רצפה", MaterialClass::Floor),
    ("הרצפה", MaterialClass::Floor),
    ("\u{92B}\u{93C}\u{930}\u{94D}\u{936}", MaterialClass::Floor),
    ("\u{95E}\u{930}\u{94D}\u{936}", MaterialClass::Floor),
    ("\u{92B}\u{930}\u{94D}\u{936}", MaterialClass::Floor),
    ("wall", MaterialClass::Wall),
    ("mur", MaterialClass::Wall),
    ("murs", MaterialClass::Wall),
    ("muro", MaterialClass::Wall),
    ("pared", MaterialClass::Wall),
    ("parete", MaterialClass::Wall),
    ("wand", MaterialClass::Wall),
    ("mauer", MaterialClass::Wall),
    ("zid", MaterialClass::Wall),
    ("ściana", MaterialClass::Wall),
    ("sciana", MaterialClass::Wall),
    ("muur", MaterialClass::Wall),
    ("parede", MaterialClass::Wall),
    ("stěna", MaterialClass::Wall),
    ("stena", MaterialClass::Wall),
    ("zeď", MaterialClass::Wall),
    ("fal", MaterialClass::Wall),
    ("perete", MaterialClass::Wall),
    ("vägg", MaterialClass::Wall),
    ("vagg", MaterialClass::Wall),
    ("væg", MaterialClass::Wall),
    ("vegg", MaterialClass::Wall),
    ("seinä", MaterialClass::Wall),
    ("seina", MaterialClass::Wall),
    ("duvar", MaterialClass::Wall),
    ("стена", MaterialClass::Wall),
    ("стіна", MaterialClass::Wall),
    ("зид", MaterialClass::Wall),
    ("τοιχοσ", MaterialClass::Wall),
    ("墙", MaterialClass::Wall),
    ("牆", MaterialClass::Wall),
    ("壁", MaterialClass::Wall),
    ("벽", MaterialClass::Wall),
    ("جدار", MaterialClass::Wall),
    ("الجدار", MaterialClass::Wall),
    ("حائط", MaterialClass::Wall),
    ("الحائط", MaterialClass::Wall),
    ("קיר", MaterialClass::Wall),
    ("הקיר", MaterialClass::Wall),
    ("קירות", MaterialClass::Wall),
    ("दीवार", MaterialClass::Wall),
    ("sky", MaterialClass::Background),
    ("background", MaterialClass::Background),
    ("backdrop", MaterialClass::Background),
    ("himmel", MaterialClass::Background),
    ("ciel", MaterialClass::Background),
    ("cielo", MaterialClass::Background),
    ("céu", MaterialClass::Background),
    ("taivas", MaterialClass::Background),
    ("небо", MaterialClass::Background),
    ("ουρανοσ", MaterialClass::Background),
    ("天空", MaterialClass::Background),
    ("하늘", MaterialClass::Background),
    ("سماء", MaterialClass::Background),
    ("السماء", MaterialClass::Background),
    ("שמיים", MaterialClass::Background),
    ("שמים", MaterialClass::Background),
    ("आकाश", MaterialClass::Background),
    ("आसमान", MaterialClass::Background),
];

/// Words that make a window keyword in the same name, or in a less specific one (a material
/// `Frame_Wood` in a group `Window1`), mean the stone or wood around the glass
/// ("window_frame", "prozor_okvir"), not the glass.
const NOT_GLASS: &[&str] = &[
    "frame",
    "sill",
    "mullion",
    "muntin",
    "jamb",
    "tracery",
    "okvir",
    "rahmen",
    "cadre",
    "marco",
    "telaio",
    "ledge",
    "kozijn",
    "рама",
    "рамка",
    "πλαισιο",
    "框",
    "枠",
    "窗台",
    "帘",
    "창틀",
];

/// Words that put a window in the lower class.
const LOWER: &[&str] = &[
    "lower",
    "bottom",
    "unten",
    "bas",
    "donji",
    "inferior",
    "inferiore",
];

/// The words of a name, lower-cased: split at anything but letters, digits and combining
/// marks, and at lower-to-upper case changes ("StainedGlass_01" → stained, glass, 01). Marks
/// a name may or may not write are left out ([`optional_mark`]); the others belong to their
/// word (a Hindi word's nukta and virama split it in three before).
pub fn name_words(name: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut cur = String::new();
    let mut prev_lower = false;
    for c in name.chars() {
        if optional_mark(c) {
            continue;
        }
        if !(c.is_alphanumeric() || is_mark(c)) {
            if !cur.is_empty() {
                words.push(std::mem::take(&mut cur));
            }
            prev_lower = false;
            continue;
        }
        if c.is_uppercase() && prev_lower && !cur.is_empty() {
            words.push(std::mem::take(&mut cur));
        }
        prev_lower = c.is_lowercase();
        cur.extend(c.to_lowercase().map(fold_greek));
    }
    if !cur.is_empty() {
        words.push(cur);
    }
    words
}

/// A combining mark: part of the word it is written in.
fn is_mark(c: char) -> bool {
    use unicode_general_category::{GeneralCategory as G, get_general_category};
    matches!(
        get_general_category(c),
        G::NonspacingMark | G::SpacingMark | G::EnclosingMark
    )
}

/// Marks a name may write or leave out, left out of its words so both spellings match: accents
/// written as combining characters (a name typed on macOS, "τοι\u{301}χος"; Greek keywords are
/// written without accents, and Latin ones also without), Hebrew points and Arabic vowel
/// marks (optional in both scripts), the Arabic tatweel (a stretch of the line), and the
/// zero-width (non-)joiners that shape Arabic and Indic letters.
fn optional_mark(c: char) -> bool {
    matches!(c,
        '\u{300}'..='\u{36F}' // combining diacritical marks
        | '\u{591}'..='\u{5BD}' | '\u{5BF}' | '\u{5C1}'..='\u{5C2}' | '\u{5C4}'..='\u{5C5}'
        | '\u{5C7}' // Hebrew points
        | '\u{610}'..='\u{61A}' | '\u{64B}'..='\u{65F}' | '\u{670}' // Arabic vowel marks
        | '\u{640}' // tatweel
        | '\u{200C}' | '\u{200D}'
    )
}

/// Han, kana and Hangul: scripts that write compounds without spaces.
fn unspaced(c: char) -> bool {
    matches!(c,
        '\u{3040}'..='\u{30FF}' // hiragana, katakana
        | '\u{3400}'..='\u{4DBF}' | '\u{4E00}'..='\u{9FFF}' | '\u{F900}'..='\u{FAFF}' // Han
        | '\u{AC00}'..='\u{D7AF}' // Hangul syllables
    )
}

fn word_matches(word: &str, keyword: &str) -> bool {
    if matches_inside(keyword) {
        word.contains(keyword)
    } else {
        word == keyword
    }
}

/// Whether `keyword` may sit inside a word, rather than be one.
fn matches_inside(keyword: &str) -> bool {
    keyword.chars().any(unspaced) || keyword.chars().count() > 4
}

/// A keyword as Greek writes it: a word's last `σ` as `ς` (keywords are kept folded, see
/// [`fold_greek`], and a reason said `"Τοίχος" has "τοιχοσ"`).
fn written_greek(keyword: &str) -> String {
    let chars: Vec<char> = keyword.chars().collect();
    chars
        .iter()
        .enumerate()
        .map(|(i, &c)| {
            let last = chars.get(i + 1).is_none_or(|n| !n.is_alphabetic());
            let alone = i == 0 || !chars[i - 1].is_alphabetic();
            if c == 'σ' && last && !alone { 'ς' } else { c }
        })
        .collect()
}

/// Greek as names often write it: accents dropped (capitals are written without them) and
/// final `ς` as `σ`, so "ΤΟΙΧΟΣ", "Τοίχος" and "τοιχος" are one word.
fn fold_greek(c: char) -> char {
    match c {
        'ά' => 'α',
        'έ' => 'ε',
        'ή' => 'η',
        'ί' | 'ϊ' | 'ΐ' => 'ι',
        'ό' => 'ο',
        'ύ' | 'ϋ' | 'ΰ' => 'υ',
        'ώ' => 'ω',
        'ς' => 'σ',
        c => c,
    }
}

/// [`HEURISTICS`] indexed for a pass over a name's words: whole-word keywords by their text,
/// the others (which may sit inside a word) in one Aho-Corasick automaton. Going through the
/// 220 keywords for every word of every name, a model of 40,000 objects spent half of its
/// 0.9 s of tagging in the keyword test.
struct KeywordIndex {
    whole: HashMap<&'static str, Vec<usize>>,
    inside: aho_corasick::AhoCorasick,
    /// Per pattern of `inside`, its index in [`HEURISTICS`].
    inside_at: Vec<usize>,
}

static KEYWORDS: std::sync::LazyLock<KeywordIndex> = std::sync::LazyLock::new(|| {
    let mut whole: HashMap<&'static str, Vec<usize>> = HashMap::new();
    let (mut inside, mut inside_at) = (Vec::new(), Vec::new());
    for (i, &(keyword, _)) in HEURISTICS.iter().enumerate() {
        if matches_inside(keyword) {
            inside.push(keyword);
            inside_at.push(i);
        } else {
            whole.entry(keyword).or_default().push(i);
        }
    }
    KeywordIndex {
        whole,
        inside: aho_corasick::AhoCorasick::new(inside).expect("keywords build an automaton"),
        inside_at,
    }
});

/// The indices in [`HEURISTICS`] of the keywords some word matches ([`word_matches`]), in
/// order.
fn keyword_hits(words: &[String]) -> Vec<usize> {
    let k = &*KEYWORDS;
    let mut hits = Vec::new();
    for w in words {
        if let Some(at) = k.whole.get(w.as_str()) {
            hits.extend_from_slice(at);
        }
        hits.extend(
            k.inside
                .find_overlapping_iter(w.as_str())
                .map(|m| k.inside_at[m.pattern().as_usize()]),
        );
    }
    hits.sort_unstable();
    hits.dedup();
    hits
}

/// Whether a word of `name` is or holds a tagging keyword (of any class), a keyword of one
/// character (`窓`, `墙`) counting only as a whole word: a text read in the wrong code page
/// spells one inside a run of other ideographs often enough (windows-1251 `нн` is EUC-KR
/// `牆`), a whole word of it or a longer keyword hardly ever.
pub(crate) fn spells_keyword(name: &str) -> bool {
    name_words(name).iter().any(|w| {
        keyword_hits(std::slice::from_ref(w)).into_iter().any(|i| {
            let k = HEURISTICS[i].0;
            k.chars().nth(1).is_some() || *w == k
        })
    })
}

/// The class the name keywords give `names`, if any keyword occurs.
pub fn heuristic(
    names: &crate::import::Names,
) -> Option<(&'static str, NameKind, String, MaterialClass)> {
    // A frame word in a name also holds for the less specific names after it: a material
    // `Frame_Wood` in a group `Window1` is the window's frame, not its glass.
    let mut framed = false;
    for kind in NameKind::ALL {
        let Some(name) = names.get(kind) else {
            continue;
        };
        // Which words, not where: a long generated name repeats a few words hundreds of
        // times (2,000 names of 4,000 characters took 1.7 s here).
        let mut words = name_words(name);
        words.sort_unstable();
        words.dedup();
        let has = |list: &[&str]| {
            words
                .iter()
                .any(|w| list.iter().any(|k| word_matches(w, k)))
        };
        framed |= has(NOT_GLASS);
        for i in keyword_hits(&words) {
            let (keyword, class) = HEURISTICS[i];
            if class.is_window() && framed {
                continue;
            }
            let class = if class.is_window() && has(LOWER) {
                MaterialClass::WindowLower
            } else {
                class
            };
            return Some((keyword, kind, name.to_string(), class));
        }
    }
    None
}

/// Where a part's triangles lie and face, for the geometry heuristics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PartGeometry {
    pub area: f64,
    /// Area of triangles within about 25° of horizontal (facing up or down).
    pub horizontal: f64,
    /// Area of triangles within about 15° of vertical.
    pub vertical: f64,
    /// Area-weighted sum of heights ([`PartGeometry::mean_y`] divides it): kept a sum so that
    /// geometry built triangle by triangle is never judged before it is divided (a building's
    /// floor cut out of one material was judged by the sum, so it was a floor only at y = 0).
    pub y_moment: f64,
    /// Lowest and highest point.
    pub y_range: [f64; 2],
    /// Where the part is shaped as a floor ([`floor_shaped`]): the floor-shaped parts of its
    /// source material, itself included (of every material where no one material's made a
    /// floor); empty otherwise.
    pub floor_kin: Kin,
    /// The area-weighted squares of its triangles' unit normals' horizontal components: x²,
    /// z², xz; whether most of it faces one horizontal way, either side ([`faces_one_way`]).
    pub facing: [f64; 3],
    /// As `floor_kin`, for wall-shaped parts that face one way ([`wall_shaped`]).
    pub wall_kin: Kin,
}

/// Parts shaped alike that are judged together, as one object of them would be: their area and
/// how many they are.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Kin {
    pub area: f64,
    pub parts: usize,
    /// Whether they are of every material: where those of no one material made the class.
    pub across: bool,
}

impl Kin {
    /// Whose parts they are, as a note says it: "its material", or every material's where no
    /// one material's made a `class` (floor, wall).
    fn whose(&self, class: &str) -> String {
        if self.across {
            format!("every material (no one material's made a {class})")
        } else {
            "its material".into()
        }
    }
}

/// Makes the parts `shaped` picks one kin, whatever their material (their `kin` field).
fn kin_of_every_material(
    out: &mut [PartGeometry],
    shaped: impl Fn(&PartGeometry) -> bool,
    kin: fn(&mut PartGeometry) -> &mut Kin,
) {
    let picked: Vec<usize> = (0..out.len()).filter(|&i| shaped(&out[i])).collect();
    let all = Kin {
        area: picked.iter().map(|&i| out[i].area).sum(),
        parts: picked.len(),
        across: true,
    };
    for i in picked {
        *kin(&mut out[i]) = all;
    }
}

impl PartGeometry {
    fn empty() -> Self {
        PartGeometry {
            y_range: [f64::INFINITY, f64::NEG_INFINITY],
            ..Default::default()
        }
    }

    /// Area-weighted mean height (0 for a part without area).
    pub fn mean_y(&self) -> f64 {
        if self.area > 0.0 {
            self.y_moment / self.area
        } else {
            0.0
        }
    }

    /// Adds one triangle, given its area and `up` (|cos| of its normal against +Y).
    fn add(&mut self, [a, b, c]: [glam::DVec3; 3], area: f64, up: f64) {
        self.area += area;
        if up > HORIZONTAL_UP {
            self.horizontal += area;
        }
        if up < VERTICAL_UP {
            self.vertical += area;
        }
        self.y_moment += area * (a.y + b.y + c.y) / 3.0;
        let n = (b - a).cross(c - a) / (2.0 * area);
        self.facing[0] += area * n.x * n.x;
        self.facing[1] += area * n.z * n.z;
        self.facing[2] += area * n.x * n.z;
        for y in [a.y, b.y, c.y] {
            self.y_range[0] = self.y_range[0].min(y);
            self.y_range[1] = self.y_range[1].max(y);
        }
    }
}

/// `up` above this is horizontal (within about 25°), below [`VERTICAL_UP`] vertical (about 15°).
const HORIZONTAL_UP: f64 = 0.9;
const VERTICAL_UP: f64 = 0.26;

/// Triangle `t`'s corners, area and `up`; `None` for one without area.
fn triangle_shape(src: &Imported, t: &[u32]) -> Option<([glam::DVec3; 3], f64, f64)> {
    let corners = [t[0], t[1], t[2]].map(|k| {
        let p = src.positions[k as usize];
        glam::DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    });
    let [a, b, c] = corners;
    let n = (b - a).cross(c - a);
    let area = n.length() * 0.5;
    if area.is_nan() || area <= 0.0 {
        return None;
    }
    Some((corners, area, (n.y / (2.0 * area)).abs()))
}

/// Per part of `src`: [`PartGeometry`]; and the source's height range and total area.
///
/// Sums run over fixed runs of triangles in parallel, each run's sums per part (a part's
/// triangles are mostly consecutive, so a run holds few), then are added up run by run in
/// order: the same sums on any number of threads.
pub fn part_geometry(src: &Imported) -> (Vec<PartGeometry>, [f64; 2], f64) {
    use rayon::prelude::*;
    const RUN: usize = 16384;
    let empty = PartGeometry::empty();
    let triangles = src.tri_part.len().min(src.corners.len() / 3);
    let runs: Vec<(Vec<(u32, PartGeometry)>, f64)> = (0..triangles.div_ceil(RUN))
        .into_par_iter()
        .map(|r| {
            let span = r * RUN..((r + 1) * RUN).min(triangles);
            let mut sums: Vec<(u32, PartGeometry)> = Vec::new();
            // Where each part's sums are, for runs that mix many parts.
            let mut at: HashMap<u32, usize> = HashMap::new();
            let mut total = 0.0;
            for (t, &part) in src.corners.positions()[span.start * 3..span.end * 3]
                .chunks_exact(3)
                .zip(&src.tri_part[span])
            {
                let Some((corners, area, up)) = triangle_shape(src, t) else {
                    continue;
                };
                let i = match sums.last() {
                    Some((p, _)) if *p == part => sums.len() - 1,
                    _ => *at.entry(part).or_insert_with(|| {
                        sums.push((part, empty));
                        sums.len() - 1
                    }),
                };
                sums[i].1.add(corners, area, up);
                total += area;
            }
            (sums, total)
        })
        .collect();
    let mut out = vec![empty; src.parts.len()];
    let mut range = [f64::INFINITY, f64::NEG_INFINITY];
    let mut total = 0.0;
    for (sums, run_total) in runs {
        for (part, s) in sums {
            let g = &mut out[part as usize];
            g.area += s.area;
            g.horizontal += s.horizontal;
            g.vertical += s.vertical;
            g.y_moment += s.y_moment;
            for k in 0..3 {
                g.facing[k] += s.facing[k];
            }
            g.y_range = [
                g.y_range[0].min(s.y_range[0]),
                g.y_range[1].max(s.y_range[1]),
            ];
            range = [range[0].min(s.y_range[0]), range[1].max(s.y_range[1])];
        }
        total += run_total;
    }
    // Floor-shaped parts of one material are a floor together: a floor laid as tiles, boards
    // or one slab a bay, each its own object, had every piece under 2 % of the model and no
    // floor at all, so no window light was guessed onto it.
    // So are walls built a bay at a time, as flat panels or slabs: columns, which face every
    // way, are not (24 pillars of a nave, each its own object, became walls that way).
    let mut kin: HashMap<(Option<u32>, bool), Kin> = HashMap::new();
    for (part, g) in src.parts.iter().zip(&out) {
        for (floor, shaped) in [
            (true, floor_shaped(g, range)),
            (false, wall_shaped(g, range)),
        ] {
            if shaped {
                let k = kin.entry((part.material, floor)).or_default();
                k.area += g.area;
                k.parts += 1;
            }
        }
    }
    for (part, g) in src.parts.iter().zip(&mut out) {
        if floor_shaped(g, range) {
            g.floor_kin = kin[&(part.material, true)];
        }
        if wall_shaped(g, range) {
            g.wall_kin = kin[&(part.material, false)];
        }
    }
    // Where no material's floor-shaped parts make a floor, those of every material do: a
    // mosaic or a marble pavement, each colour (or each tile) its own material, had no floor
    // and no window light. Only then, so a rug on a floor of tiles stays what it was. (Kin
    // too small to make a floor together makes none: `floor_like` weighs it.)
    if !out.iter().any(|g| floor_like(g, range, total)) {
        kin_of_every_material(&mut out, |g| floor_shaped(g, range), |g| &mut g.floor_kin);
    }
    // The same for walls: a nave whose bays are each painted in a material of their own.
    let base = wall_base(&out, range, total);
    if !out.iter().any(|g| wall_like(g, range, base)) {
        kin_of_every_material(&mut out, |g| wall_shaped(g, range), |g| &mut g.wall_kin);
    }
    (out, range, total)
}

/// Whether three quarters of a part's area or more faces one horizontal way, either side: the
/// largest eigenvalue of its normals' horizontal squares ([`PartGeometry::facing`]) against
/// its area. A panel or a slab of a wall does (a 5 m bay 1 m thick: 0.8); a square pillar or a
/// round column faces two ways or every way (0.5).
fn faces_one_way(g: &PartGeometry) -> bool {
    let [xx, zz, xz] = g.facing;
    let most = (xx + zz) / 2.0 + (((xx - zz) / 2.0).powi(2) + xz * xz).sqrt();
    g.area > 0.0 && most >= 0.75 * g.area
}

/// Whether a part is shaped as a wall that joins others of its material: mostly vertical,
/// rising through at least half the model's height (`height`), and facing one way.
fn wall_shaped(g: &PartGeometry, height: [f64; 2]) -> bool {
    let span = (height[1] - height[0]).max(1e-9);
    g.area > 0.0
        && g.vertical / g.area >= 0.75
        && (g.y_range[1] - g.y_range[0]) >= 0.5 * span
        && faces_one_way(g)
}

/// Whether a part is shaped as a floor, whatever its size: mostly horizontal, in the lowest
/// tenth of the model's height (`height`).
fn floor_shaped(g: &PartGeometry, height: [f64; 2]) -> bool {
    let span = (height[1] - height[0]).max(1e-9);
    g.area > 0.0 && g.horizontal / g.area >= 0.75 && (g.mean_y() - height[0]) / span <= 0.1
}

/// Whether a part's geometry makes it a floor: shaped as one ([`floor_shaped`]), and, alone or
/// with the other floor-shaped parts of its material, at least 2 % of the model's area.
fn floor_like(g: &PartGeometry, height: [f64; 2], total_area: f64) -> bool {
    floor_shaped(g, height) && g.area.max(g.floor_kin.area) >= 0.02 * total_area
}

/// Whether a part's geometry makes it a wall: mostly vertical and rising through at least half
/// the model's height (a wall rises through most of the building; a block or a statue does
/// not), and, alone or with its kin, at least 2 % of `wall_base` ([`wall_base`]).
fn wall_like(g: &PartGeometry, height: [f64; 2], wall_base: f64) -> bool {
    let span = (height[1] - height[0]).max(1e-9);
    g.area > 0.0
        && g.area.max(g.wall_kin.area) >= 0.02 * wall_base
        && g.vertical / g.area >= 0.75
        && (g.y_range[1] - g.y_range[0]) >= 0.5 * span
}

/// The area a wall is measured against: the model's, less its floors. A building on open
/// ground (a terrain plane forty times its footprint) had walls under 2 % of the model's area,
/// and they were `other`.
pub fn wall_base(parts: &[PartGeometry], height: [f64; 2], total_area: f64) -> f64 {
    let floors: f64 = parts
        .iter()
        .filter(|g| floor_like(g, height, total_area))
        .map(|g| g.area)
        .sum();
    (total_area - floors).max(0.0)
}

/// The class geometry suggests: a large, mostly horizontal surface in the lowest tenth of the
/// model's height is a floor; a large, mostly vertical one rising through at least half the
/// model's height is a wall. "Large" is at least 2 % of the model's surface area for a floor,
/// and of that area less the floors' (`wall_base`, see [`wall_base`]) for a wall, so
/// furniture, blocks, statues and trim stay `other`.
pub fn geometry_heuristic(
    g: &PartGeometry,
    height: [f64; 2],
    total_area: f64,
    wall_base: f64,
) -> Option<(String, MaterialClass)> {
    let class = geometry_class(g, height, total_area, wall_base)?;
    let span = (height[1] - height[0]).max(1e-9);
    let rel = (g.mean_y() - height[0]) / span;
    let share = |a: f64| a / g.area;
    if class != MaterialClass::Wall {
        debug_assert_eq!(class, MaterialClass::Floor);
        return Some((
            format!(
                "geometry: {:.0}% horizontal, {:.0}% of the model's area{}, at {:.0}% of its \
                 height",
                share(g.horizontal) * 100.0,
                g.area / total_area * 100.0,
                if g.area < 0.02 * total_area {
                    format!(
                        ", {:.0}% with the {} other floor-shaped parts of {}",
                        g.floor_kin.area / total_area * 100.0,
                        g.floor_kin.parts - 1,
                        g.floor_kin.whose("floor")
                    )
                } else {
                    String::new()
                },
                rel * 100.0
            ),
            MaterialClass::Floor,
        ));
    }
    Some((
        format!(
            "geometry: {:.0}% vertical, {:.0}% of the model's area{}",
            share(g.vertical) * 100.0,
            g.area / total_area * 100.0,
            if g.area < 0.02 * wall_base {
                format!(
                    ", {:.0}% of it less the floors with the {} other wall-shaped parts \
                         of {}",
                    g.wall_kin.area / wall_base * 100.0,
                    g.wall_kin.parts - 1,
                    g.wall_kin.whose("wall")
                )
            } else if g.area < 0.02 * total_area {
                format!(", {:.0}% of it less the floors", g.area / wall_base * 100.0)
            } else {
                String::new()
            }
        ),
        MaterialClass::Wall,
    ))
}

/// The class of [`geometry_heuristic`] without its reason, for the many parts whose reason is
/// never shown.
fn geometry_class(
    g: &PartGeometry,
    height: [f64; 2],
    total_area: f64,
    wall_base: f64,
) -> Option<MaterialClass> {
    if g.area.is_nan() || g.area <= 0.0 {
        None
    } else if floor_like(g, height, total_area) {
        Some(MaterialClass::Floor)
    } else if wall_like(g, height, wall_base) {
        Some(MaterialClass::Wall)
    } else {
        None
    }
}

struct CompiledRule<'a> {
    rule: &'a Rule,
    glob: NameGlob,
}

/// The manifest's rules, compiled. Per kind of name, the rules that look at it are also one
/// [`NameSet`], which finds every rule a name matches at once (a literal pattern, as `cooker
/// init` writes one per material, is a hash lookup): matching each part against each rule in
/// turn took 161 s for the 10,000 rules `init` wrote for a model of 10,000 materials.
struct CompiledRules<'a> {
    rules: Vec<CompiledRule<'a>>,
    /// Per [`NameKind::ALL`] entry: the rules that look at that kind of name, by index.
    sets: Vec<NameSet>,
}

fn compile(manifest: &Manifest) -> Result<CompiledRules<'_>, CookError> {
    let rules: Vec<CompiledRule<'_>> = manifest
        .rules
        .iter()
        .map(|rule| {
            let glob = NameGlob::checked(&rule.pattern).map_err(|e| CookError::Manifest {
                path: manifest.path.clone(),
                line: Some(rule.line.0),
                message: format!("invalid glob {:?}: {e}", rule.pattern),
            })?;
            Ok(CompiledRule { rule, glob })
        })
        .collect::<Result<_, CookError>>()?;
    let sets = NameKind::ALL
        .iter()
        .map(|&kind| {
            NameSet::new(
                rules
                    .iter()
                    .enumerate()
                    .filter(|(_, r)| r.rule.on.contains(&kind))
                    .map(|(i, r)| (i, &r.glob)),
            )
        })
        .collect();
    Ok(CompiledRules { rules, sets })
}

impl<'a> std::ops::Index<usize> for CompiledRules<'a> {
    type Output = CompiledRule<'a>;
    fn index(&self, i: usize) -> &CompiledRule<'a> {
        &self.rules[i]
    }
}

impl CompiledRules<'_> {
    /// The rules that look at names of `kind` and match `name`, in manifest order.
    fn matching(&self, kind: NameKind, name: &str) -> Vec<usize> {
        let k = NameKind::ALL.iter().position(|&a| a == kind).unwrap_or(0);
        self.sets[k].matching(name)
    }

    /// The first rule matching any of the names it looks at: the rule that tags the part.
    fn first(&self, names: &crate::import::Names) -> Option<usize> {
        NameKind::ALL
            .iter()
            .filter_map(|&kind| {
                names
                    .get(kind)
                    .and_then(|n| self.matching(kind, n).first().copied())
            })
            .min()
    }
}

/// What a part's names and material say of it, in order of trust: an explicit rule; the
/// material's own transparency (a glass named anything); a keyword in a name. Where none
/// speaks, where the part lies decides, and only then may a part be cut.
struct Evidence {
    rule: Option<usize>,
    glass: Option<String>,
    named: Option<(&'static str, NameKind, String, MaterialClass)>,
}

impl Evidence {
    fn of(src: &Imported, part: &crate::import::Part, rules: &CompiledRules<'_>) -> Self {
        Self {
            rule: rules.first(&part.names),
            glass: part
                .material
                .and_then(|m| src.materials.get(m as usize))
                .and_then(|m| m.transmission.glass_reason()),
            named: heuristic(&part.names),
        }
    }

    fn is_none(&self) -> bool {
        self.rule.is_none() && self.glass.is_none() && self.named.is_none()
    }
}

/// Cuts the parts nothing but their geometry could tag, and whose geometry is mixed, into a
/// floor, a wall and the rest: real models often give the whole building one material
/// (`Material.001`, `Default`), floor, walls, vaults and roof alike. Whole, such a part is
/// neither mostly horizontal nor mostly vertical, so it was `other`: no floor, no walls, and
/// no guessed sun could land window light on a floor. A triangle is floor when horizontal
/// and in the lowest tenth of the model's height, wall when vertical; each piece must pass
/// [`geometry_heuristic`] on its own (large enough, a wall rising through half the height),
/// else its triangles stay with the rest. The pieces are new parts with the same names.
/// Returns the part geometry after the cut, and per part whether it is the rest of a cut part
/// ([`Cut::Rest`]) or a piece cut from one ([`Cut::Piece`]).
fn split_mixed_parts(
    src: &mut Imported,
    rules: &CompiledRules<'_>,
) -> ((Vec<PartGeometry>, [f64; 2], f64), Vec<Cut>) {
    let geometry = part_geometry(src);
    let (parts, height, total) = (&geometry.0, geometry.1, geometry.2);
    let base = wall_base(parts, height, total);
    let split: Vec<bool> = src
        .parts
        .iter()
        .zip(parts)
        .map(|(part, g)| {
            g.area > 0.0
                && Evidence::of(src, part, rules).is_none()
                && geometry_class(g, height, total, base).is_none()
        })
        .collect();
    let mut cut = vec![Cut::None; src.parts.len()];
    if !split.contains(&true) {
        return (geometry, cut);
    }
    let span = (height[1] - height[0]).max(1e-9);
    // Per part to cut, its floor's triangles (key 2s, s its index among the parts to cut) and
    // its walls' (2s + 1), in triangle order: keyed, counted and placed (a counting sort), so
    // a model of 40,000 parts takes two flat arrays, not a table of per-part lists, which cost
    // such a model 40 MB of fresh pages and a fifth of its cook.
    let mut slot = vec![u32::MAX; split.len()];
    let mut cutting = 0u32;
    for (s, _) in slot.iter_mut().zip(&split).filter(|(_, c)| **c) {
        *s = cutting;
        cutting += 1;
    }
    let corners_of = src.corners.positions().chunks_exact(3);
    let keys: Vec<u32> = src
        .tri_part
        .iter()
        .zip(corners_of)
        .map(|(&part, corners)| {
            let s = slot[part as usize];
            if s == u32::MAX {
                return u32::MAX;
            }
            let Some((corners, _, up)) = triangle_shape(src, corners) else {
                return u32::MAX;
            };
            let centre = corners.iter().map(|p| p.y).sum::<f64>() / 3.0;
            if up > HORIZONTAL_UP && (centre - height[0]) / span <= 0.1 {
                2 * s
            } else if up < VERTICAL_UP {
                2 * s + 1
            } else {
                u32::MAX
            }
        })
        .collect();
    let mut counts = Counts::new(2 * cutting as usize);
    for &k in keys.iter().filter(|&&k| k != u32::MAX) {
        counts.add(k as usize);
    }
    let mut placing = counts.placing(0u32);
    for (t, &k) in keys.iter().enumerate().filter(|(_, k)| **k != u32::MAX) {
        placing.put(k as usize, t as u32);
    }
    drop(keys);
    let pieces = placing.finish();
    let piece_geometry = |src: &Imported, tris: &[u32]| {
        let mut g = PartGeometry::empty();
        for &t in tris {
            let t = t as usize * 3;
            if let Some((corners, area, up)) =
                triangle_shape(src, &src.corners.positions()[t..t + 3])
            {
                g.add(corners, area, up);
            }
        }
        g
    };
    let size = {
        let (mut lo, mut hi) = (glam::DVec3::INFINITY, glam::DVec3::NEG_INFINITY);
        for p in &src.positions {
            let p = glam::Vec3::from(*p).as_dvec3();
            lo = lo.min(p);
            hi = hi.max(p);
        }
        (hi - lo).length()
    };
    // Where another part is a floor (its own material, walls and vault sharing one), the
    // walls alone are cut; where another part holds the walls, the floor alone. Both were
    // required, and a hall whose stone was its walls and ceiling had no walls at all.
    let kinds = [MaterialClass::Floor, MaterialClass::Wall];
    let elsewhere = kinds.map(|want| {
        parts
            .iter()
            .zip(&split)
            .any(|(g, &cut)| !cut && geometry_class(g, height, total, base) == Some(want))
    });
    // A part is cut into a floor and walls, each passing the heuristic and lying mostly in
    // large planes (one of them alone where the model has the other elsewhere): a building,
    // not a sculpture (the Stanford bunny's base and steep flanks pass the heuristic, but its
    // flanks are no planes). In part order, so ids are deterministic.
    for part in 0..split.len() {
        let s = slot[part] as usize;
        if s == u32::MAX as usize {
            continue;
        }
        let tris: [&[u32]; 2] = std::array::from_fn(|k| pieces.group(2 * s + k));
        if tris.iter().all(|t| t.is_empty()) {
            continue;
        }
        let passes: [bool; 2] = std::array::from_fn(|k| {
            geometry_class(&piece_geometry(src, tris[k]), height, total, base) == Some(kinds[k])
                && in_large_planes(src, tris[k], size, total) >= 0.75
        });
        let keep: [bool; 2] = match passes {
            [true, true] => [true, true],
            [true, false] if elsewhere[1] => [true, false],
            [false, true] if elsewhere[0] => [false, true],
            _ => continue,
        };
        for (piece, _) in tris.into_iter().zip(keep).filter(|(_, k)| *k) {
            src.parts.push(src.parts[part].clone());
            cut.push(Cut::Piece);
            let id = (src.parts.len() - 1) as u32;
            for &t in piece {
                src.tri_part[t as usize] = id;
            }
        }
        cut[part] = Cut::Rest;
    }
    if cut.len() > geometry.0.len() {
        (part_geometry(src), cut)
    } else {
        (geometry, cut)
    }
}

/// What [`split_mixed_parts`] made of a part.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Cut {
    /// Left whole.
    #[default]
    None,
    /// Its floor and walls were cut out.
    Rest,
    /// A floor or walls cut out of another part of the same names.
    Piece,
}

/// The share of the area of triangles `tris` that lies in planes each holding at least 1 %
/// of the model's area: faces within 5° and 1 % of the model's size of a plane (planes taken
/// greedily, largest triangles first, at most 256 of them).
fn in_large_planes(src: &Imported, tris: &[u32], size: f64, total: f64) -> f64 {
    let mut faces: Vec<(glam::DVec3, f64, f64)> = tris
        .iter()
        .filter_map(|&t| {
            let t = t as usize;
            let ([a, b, c], area, _) =
                triangle_shape(src, &src.corners.positions()[t * 3..t * 3 + 3])?;
            let n = (b - a).cross(c - a).normalize();
            Some((n, n.dot((a + b + c) / 3.0), area))
        })
        .collect();
    faces.sort_by(|a, b| b.2.total_cmp(&a.2));
    let cos = 5f64.to_radians().cos();
    let mut planes: Vec<(glam::DVec3, f64, f64)> = Vec::new();
    let mut all = 0.0;
    for (n, d, area) in faces {
        all += area;
        let found = planes
            .iter()
            .position(|p| p.0.dot(n) >= cos && (p.1 - d).abs() <= 0.01 * size);
        match found {
            Some(i) => planes[i].2 += area,
            None if planes.len() < 256 => planes.push((n, d, area)),
            None => {}
        }
    }
    let large: f64 = planes
        .iter()
        .filter(|p| p.2 >= 0.01 * total)
        .map(|p| p.2)
        .sum();
    if all > 0.0 { large / all } else { 0.0 }
}

/// Tags every part of every source (first cutting parts of mixed geometry, see
/// [`split_mixed_parts`]).
pub fn tag(manifest: &Manifest, sources: &mut [Imported]) -> Result<Tagging, CookError> {
    let rules = compile(manifest)?;
    let (geometries, cuts): (Vec<_>, Vec<_>) = sources
        .iter_mut()
        .map(|src| split_mixed_parts(src, &rules))
        .unzip();
    let sources: &[Imported] = sources;
    let mut out = Tagging::default();
    // (pack name, class) → material index; names used with several classes get a suffix.
    let mut index: HashMap<(String, MaterialClass), u16> = HashMap::new();
    let mut seen_names: HashMap<(NameKind, String), ()> = HashMap::new();
    // Each pack material's name before any class suffix, and whether any of its parts is not
    // a piece the geometry cut out: the names are settled after every part is tagged (see
    // `settle_names`).
    let mut bases: Vec<String> = Vec::new();
    let mut uncut: Vec<bool> = Vec::new();

    for (si, src) in sources.iter().enumerate() {
        let mut used = vec![false; src.materials.len()];
        let part_counts = src.part_triangles();
        let geometry = &geometries[si];
        let base = wall_base(&geometry.0, geometry.1, geometry.2);
        let mut mats = Vec::with_capacity(src.parts.len());
        let mut decisions = Vec::with_capacity(src.parts.len());
        for (pi, part) in src.parts.iter().enumerate() {
            for kind in NameKind::ALL {
                if let Some(n) = part.names.get(kind)
                    && seen_names.insert((kind, n.to_string()), ()).is_none()
                {
                    let lines: Vec<usize> = rules
                        .matching(kind, n)
                        .into_iter()
                        .map(|r| rules[r].rule.line.0)
                        .collect();
                    if lines.len() > 1 {
                        out.ambiguities.push(Ambiguity {
                            kind,
                            name: n.to_string(),
                            rule_lines: lines,
                        });
                    }
                }
            }
            let source_material: Option<&SourceMaterial> =
                part.material.and_then(|m| src.materials.get(m as usize));
            if part_counts[pi] > 0
                && let Some(m) = part.material
            {
                used[m as usize] = true;
            }
            let Evidence { rule, glass, named } = Evidence::of(src, part, &rules);
            let (decision, class) = match (rule, glass, named) {
                (Some(r), _, _) => (Decision::Rule(r), rules[r].rule.class),
                (None, Some(reason), named) => {
                    let lower = named
                        .as_ref()
                        .is_some_and(|n| n.3 == MaterialClass::WindowLower);
                    let class = if lower {
                        MaterialClass::WindowLower
                    } else {
                        MaterialClass::WindowUpper
                    };
                    (Decision::Glass { reason }, class)
                }
                (None, None, Some((keyword, kind, name, class))) => (
                    Decision::Heuristic {
                        keyword,
                        kind,
                        name,
                    },
                    class,
                ),
                (None, None, None) => {
                    let cut = cuts[si][pi];
                    match geometry_heuristic(&geometry.0[pi], geometry.1, geometry.2, base) {
                        Some((reason, class)) if cut == Cut::Piece => (
                            Decision::Geometry {
                                reason: format!(
                                    "{reason}; cut out of a part that mixes floor, walls and more"
                                ),
                            },
                            class,
                        ),
                        Some((reason, class)) => (Decision::Geometry { reason }, class),
                        None if cut == Cut::Rest => (
                            Decision::Geometry {
                                reason: "geometry: floor and walls cut out, the rest matched \
                                         nothing"
                                    .into(),
                            },
                            MaterialClass::Other,
                        ),
                        None => (Decision::Unmatched, MaterialClass::Other),
                    }
                }
            };
            let rule = rule.map(|r| rules[r].rule);
            let base_name = rule
                .and_then(|r| r.material.clone())
                .or_else(|| part.names.material.clone())
                .or_else(|| part.names.object.clone())
                .or_else(|| part.names.group.clone())
                .or_else(|| part.names.mesh.clone())
                .unwrap_or_else(|| "default".to_string());
            let key = (base_name.clone(), class);
            let id = match index.get(&key) {
                Some(&id) => id,
                None => {
                    if out.materials.len() > u16::MAX as usize {
                        return Err(CookError::Source {
                            path: src.path.clone(),
                            line: None,
                            message: "more than 65536 materials: material IDs are 16-bit".into(),
                        });
                    }
                    let name = base_name.clone();
                    bases.push(base_name);
                    uncut.push(false);
                    let base = source_material
                        .cloned()
                        .unwrap_or_else(|| SourceMaterial::plain(&name));
                    let mut plan = MaterialPlan {
                        material: pack::Material {
                            name,
                            class,
                            diffuse: base.diffuse,
                            specular: base.specular,
                            shininess: base.shininess,
                            emissive: base.emissive,
                            diffuse_texture: None,
                            normal_texture: None,
                            projector_texture: None,
                            projector_margin: [0.0; 2],
                        },
                        diffuse_texture: base.diffuse_texture,
                        normal_texture: base.normal_texture,
                        normal_scale: base.normal_scale,
                        window: None,
                    };
                    if let Some(r) = rule {
                        let m = &mut plan.material;
                        m.diffuse = r.diffuse.unwrap_or(m.diffuse);
                        m.specular = r.specular.unwrap_or(m.specular);
                        m.shininess = r.shininess.unwrap_or(m.shininess);
                        m.emissive = r.emissive.unwrap_or(m.emissive);
                        if let Some(t) = &r.texture {
                            plan.diffuse_texture = Some(ImageRef::File(t.clone()));
                        }
                        if let Some(t) = &r.normal_map {
                            plan.normal_texture = Some(ImageRef::File(t.clone()));
                            plan.normal_scale = 1.0;
                        }
                        if let Some(s) = r.normal_strength {
                            plan.normal_scale = s;
                        }
                    }
                    let id = out.materials.len() as u16;
                    out.materials.push(plan);
                    index.insert(key, id);
                    id
                }
            };
            uncut[id as usize] |= cuts[si].get(pi).is_none_or(|c| *c != Cut::Piece);
            mats.push(id);
            decisions.push(decision);
        }
        for (mi, u) in used.iter().enumerate() {
            if !u {
                out.unused_source_materials
                    .push((si, src.materials[mi].name.clone()));
            }
        }
        out.part_material.push(mats);
        out.decisions.push(decisions);
    }
    out.cut = cuts;
    settle_names(&mut out, &bases, &uncut);
    Ok(out)
}

/// Names the pack materials. A source name used with one class keeps it. Used with several,
/// one keeps the bare name and the others get `.class`: the rest of a part the geometry cut
/// (its floor and wall pieces are what is new), else the first class of floor, wall, the
/// windows, background, other. The bare name went to the class met first, so two exports of
/// one model in another object order named the same materials otherwise (`Red` and
/// `Red.wall` against `Red.other` and `Red`), and a diff saw them all changed. Names are
/// given in sorted order of their base, so a suffixed name that another material already has
/// gets one more suffix the same way whatever the order.
fn settle_names(out: &mut Tagging, bases: &[String], uncut: &[bool]) {
    let mut groups: std::collections::BTreeMap<&str, Vec<usize>> = Default::default();
    for (i, b) in bases.iter().enumerate() {
        groups.entry(b.as_str()).or_default().push(i);
    }
    let classes: Vec<MaterialClass> = out.materials.iter().map(|m| m.material.class).collect();
    let class_of = |i: usize| classes[i];
    // Bare names first, so a suffixed one never takes a name a material has of its own.
    let mut taken: HashSet<String> = HashSet::new();
    let rank = |i: usize| {
        let class = MaterialClass::ALL.iter().position(|&c| c == class_of(i));
        (!uncut[i], class)
    };
    let keepers: Vec<usize> = groups
        .iter()
        .map(|(base, ids)| {
            let keeper = *ids
                .iter()
                .min_by_key(|&&i| rank(i))
                .expect("a group is never empty");
            taken.insert(base.to_string());
            out.materials[keeper].material.name = base.to_string();
            keeper
        })
        .collect();
    for ((base, ids), keeper) in groups.iter().zip(keepers) {
        let mut others: Vec<usize> = ids.iter().copied().filter(|&i| i != keeper).collect();
        others.sort_by_key(|&i| class_of(i).name());
        for i in others {
            let mut name = format!("{base}.{}", class_of(i).name());
            while taken.contains(&name) {
                name = format!("{name}.{}", class_of(i).name());
            }
            taken.insert(name.clone());
            out.materials[i].material.name = name;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::{Names, Part};

    /// Fixed runs summed in order: the same bits on one thread as on two, within rounding of
    /// one sequential sum, for triangles whose parts interleave (a run holding many parts).
    #[test]
    fn part_geometry_is_thread_count_independent_and_matches_a_plain_sum() {
        let n = 50_000usize;
        let mut positions = Vec::new();
        let mut tris = Vec::new();
        for i in 0..n {
            let (x, y, z) = (
                i as f32 * 0.37 % 11.0,
                (i % 97) as f32 * 0.1,
                (i % 13) as f32,
            );
            let b = positions.len() as u32;
            positions.extend([
                [x, y, z],
                [x + 1.0, y + (i % 3) as f32, z],
                [x, y + 0.5, z + 1.0],
            ]);
            tris.push([b, b + 1, b + 2]);
        }
        let mut src = crate::mesh::soup(positions, tris);
        src.parts = (0..300)
            .map(|_| Part {
                names: Names::default(),
                material: None,
            })
            .collect();
        src.tri_part = (0..n).map(|i| ((i * 7919) % 300) as u32).collect();
        let on = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| part_geometry(&src))
        };
        let one = on(1);
        assert_eq!(one, on(2));
        let mut area = vec![0.0f64; 300];
        for (t, &part) in src.corners.positions().chunks_exact(3).zip(&src.tri_part) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|k| {
                let p = src.positions[k as usize];
                glam::DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
            });
            area[part as usize] += (b - a).cross(c - a).length() * 0.5;
        }
        for (g, want) in one.0.iter().zip(&area) {
            assert!((g.area - want).abs() <= 1e-9 * want, "{} {want}", g.area);
        }
        assert!((one.2 - area.iter().sum::<f64>()).abs() <= 1e-9 * one.2);
    }

    /// The keyword index finds the keywords that going through [`HEURISTICS`] in order with
    /// [`word_matches`] finds, in the same order: every keyword alone, inside and around
    /// other words, and names with several keywords or none.
    #[test]
    fn the_keyword_index_finds_what_the_plain_pass_finds() {
        let plain = |words: &[String]| -> Vec<usize> {
            (0..HEURISTICS.len())
                .filter(|&i| words.iter().any(|w| word_matches(w, HEURISTICS[i].0)))
                .collect()
        };
        let mut names: Vec<String> = Vec::new();
        for &(k, _) in HEURISTICS {
            names.push(k.to_string());
            names.push(format!("x{k}"));
            names.push(format!("{k}s_{k}"));
            names.push(format!("Kirchen{k}Rahmen"));
            names.push(format!("tri{k}"));
        }
        names.extend(
            [
                "Stained Glass Window frame",
                "MurSol",
                "彩色玻璃窗",
                "padlock",
                "Τοίχος",
                "",
            ]
            .map(str::to_string),
        );
        for name in &names {
            let words = name_words(name);
            assert_eq!(keyword_hits(&words), plain(&words), "{name:?}");
        }
    }

    /// Asserts that the keywords in `name` include one of `class`.
    fn finds(name: &str, class: MaterialClass) {
        let words = name_words(name);
        let found: Vec<MaterialClass> = keyword_hits(&words)
            .into_iter()
            .map(|i| HEURISTICS[i].1)
            .collect();
        assert!(found.contains(&class), "{name:?}: {words:?} {found:?}");
    }

    /// Every keyword, as a name of its own, as written, capitalised and upper-cased, is found:
    /// a keyword that the name's splitting cut apart (a Hindi word at its virama) or that
    /// lower-casing changes could never match.
    #[test]
    fn every_keyword_is_found_as_a_name() {
        for &(k, class) in HEURISTICS {
            let mut chars = k.chars();
            let first = chars.next().unwrap();
            let title: String = first.to_uppercase().chain(chars).collect();
            for name in [k.to_string(), title, k.to_uppercase()] {
                finds(&name, class);
            }
        }
    }

    /// Names as other tools and keyboards write them: accents as combining characters (a
    /// name typed on macOS), Hebrew with its points, Arabic with its vowel marks and with
    /// the article, Hindi with its nukta and virama, each finds its class.
    #[test]
    fn names_with_marks_find_their_keywords() {
        for (name, class) in [
            ("Τοι\u{301}χος", MaterialClass::Wall),
            ("Vitra\u{301}z\u{30C}_okno", MaterialClass::WindowUpper),
            ("Fene\u{302}tre haute", MaterialClass::WindowUpper),
            (
                "\u{5D7}\u{5B7}\u{5DC}\u{5BC}\u{5D5}\u{5B9}\u{5DF}",
                MaterialClass::WindowUpper,
            ),
            ("ויטראז'_צפוני", MaterialClass::WindowUpper),
            (
                "\u{632}\u{64F}\u{62C}\u{64E}\u{627}\u{62C}",
                MaterialClass::WindowUpper,
            ),
            ("الزجاج الملون", MaterialClass::WindowUpper),
            ("زجاج_معشق", MaterialClass::WindowUpper),
            ("جـدار", MaterialClass::Wall),
            ("रंगीन खिड़की", MaterialClass::WindowUpper),
            ("रंगीन_कांच", MaterialClass::WindowUpper),
            ("पत्थर फ़र्श", MaterialClass::Floor),
            ("Ólomüveg ablak", MaterialClass::WindowUpper),
            ("Bleiglasfenster", MaterialClass::WindowUpper),
            ("Glasmalerei_Chor", MaterialClass::WindowUpper),
            ("스테인드글라스", MaterialClass::WindowUpper),
            ("lasimaalaus", MaterialClass::WindowUpper),
        ] {
            finds(name, class);
        }
    }

    fn source(names: &[(&str, Option<&str>)]) -> Imported {
        let mut s = Imported {
            path: "t.obj".into(),
            ..Default::default()
        };
        for (i, (mat, group)) in names.iter().enumerate() {
            s.parts.push(Part {
                names: Names {
                    material: Some(mat.to_string()),
                    group: group.map(str::to_string),
                    ..Default::default()
                },
                material: None,
            });
            s.tri_part.push(i as u32);
        }
        s
    }

    fn manifest(rules: &str) -> Manifest {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.obj"), "").unwrap();
        let text = format!("[[mesh]]\nsource = \"m.obj\"\n{rules}");
        Manifest::parse(&dir.path().join("scene.toml"), &text).unwrap()
    }

    /// A 10 x 20 x 8 room of one part named `Material.001`: floor, four walls, ceiling.
    fn room() -> Imported {
        room_at(0.0)
    }

    /// [`room`] with its floor at height `y0`.
    fn room_at(y0: f32) -> Imported {
        let (w, l, h) = (10.0f32, 20.0, 8.0);
        let quads = [
            [[0., 0., 0.], [w, 0., 0.], [w, 0., l], [0., 0., l]],
            [[0., h, 0.], [0., h, l], [w, h, l], [w, h, 0.]],
            [[0., 0., 0.], [0., h, 0.], [w, h, 0.], [w, 0., 0.]],
            [[0., 0., l], [w, 0., l], [w, h, l], [0., h, l]],
            [[0., 0., 0.], [0., 0., l], [0., h, l], [0., h, 0.]],
            [[w, 0., 0.], [w, h, 0.], [w, h, l], [w, 0., l]],
        ];
        let mut positions = Vec::new();
        let mut tris = Vec::new();
        for q in quads {
            let b = positions.len() as u32;
            positions.extend(q);
            tris.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
        }
        for p in &mut positions {
            p[1] += y0;
        }
        let mut s = crate::mesh::soup(positions, tris);
        s.parts = vec![Part {
            names: Names {
                material: Some("Material.001".into()),
                ..Default::default()
            },
            material: None,
        }];
        s.tri_part = vec![0; 12];
        s
    }

    /// At any height: a scan's floor lies at its site's elevation (the cut floor was judged by
    /// its area-weighted sum of heights, so only a room standing at y = 0 had a floor).
    #[test]
    fn a_room_in_one_material_is_cut_into_floor_walls_and_the_rest_unless_a_rule_says() {
        for y0 in [0.0, 1.0, 100.0, -35.5] {
            let t = tag(&manifest(""), &mut [room_at(y0)]).unwrap();
            let tagged: Vec<(String, MaterialClass)> = t
                .materials
                .iter()
                .map(|m| (m.material.name.clone(), m.material.class))
                .collect();
            assert_eq!(
                tagged,
                [
                    ("Material.001".into(), MaterialClass::Other),
                    ("Material.001.floor".into(), MaterialClass::Floor),
                    ("Material.001.wall".into(), MaterialClass::Wall),
                ],
                "floor at y = {y0}"
            );
        }
        let t = tag(
            &manifest("[[rule]]\nmatch = \"Material.*\"\nclass = \"wall\"\n"),
            &mut [room()],
        )
        .unwrap();
        assert_eq!(t.materials.len(), 1);
        assert_eq!(t.materials[0].material.class, MaterialClass::Wall);
    }

    /// A hall of generic names (Blender's `Plane.001`, `Material.001`) whose floor is laid as
    /// tiles, each its own object under 1 % of the model's area: the tiles of one material are
    /// a floor together, as one object of them would be. Before, every tile was `other`, the
    /// model had no floor, and no window light was guessed onto it. Tiles in two materials (a
    /// chequerboard) are a floor each; a single small slab, a rug, stays `other`. As a mosaic,
    /// each tile one of 12 materials (5 m² each, under 2 % of the model's 256 m²) or each its
    /// own, no one material's tiles make a floor, so every material's floor-shaped parts are
    /// judged together, and the rug on the mosaic joins it (the hall had no floor before).
    #[test]
    fn a_floor_laid_in_tiles_is_a_floor() {
        // (materials of the floor, the rug's class, the tiles' kin as the reason says it)
        for (colours, rug, kin) in [
            (
                1,
                MaterialClass::Other,
                "59 other floor-shaped parts of its material",
            ),
            (
                2,
                MaterialClass::Other,
                "29 other floor-shaped parts of its material",
            ),
            (
                12,
                MaterialClass::Floor,
                "60 other floor-shaped parts of every material",
            ),
            (
                60,
                MaterialClass::Floor,
                "60 other floor-shaped parts of every material",
            ),
        ] {
            let (obj, mtl) = crate::testing::tiled_hall(colours);
            let (src, t) = tagged_obj(&obj, ("m.mtl", &mtl));
            let class_of = |object: &str| object_class(&src, &t, object).1;
            for k in 0..60 {
                assert_eq!(
                    class_of(&format!("Plane.{k:03}")),
                    MaterialClass::Floor,
                    "tile {k}, {colours} materials"
                );
            }
            assert_eq!(class_of("Rug"), rug, "{colours} materials");
            assert_eq!(class_of("Cube"), MaterialClass::Wall);
            assert_eq!(class_of("Cube.001"), MaterialClass::Other);
            let (tile, _) = object_class(&src, &t, "Plane.000");
            let said = t.decisions[0][tile].reason().unwrap_or_default();
            assert!(said.contains(&format!("with the {kin}")), "{said}");
        }
    }

    /// `obj` imported from a folder beside its MTL `mtl` (`(file name, text)`) and tagged by
    /// the heuristics alone (an empty manifest).
    fn tagged_obj(obj: &str, (mtl_name, mtl): (&str, &str)) -> (Imported, Tagging) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(mtl_name), mtl).unwrap();
        let path = dir.path().join("model.obj");
        std::fs::write(&path, obj).unwrap();
        let mut src = crate::import::import(&path).unwrap();
        let t = tag(&manifest(""), std::slice::from_mut(&mut src)).unwrap();
        (src, t)
    }

    /// The index of the part of object `object`, and its class.
    fn object_class(src: &Imported, t: &Tagging, object: &str) -> (usize, MaterialClass) {
        let pi = src
            .parts
            .iter()
            .position(|p| p.names.object.as_deref() == Some(object))
            .unwrap_or_else(|| panic!("no object {object:?}"));
        (
            pi,
            t.materials[t.part_material[0][pi] as usize].material.class,
        )
    }

    /// A hall whose floor is its own material and whose walls and ceiling share one ("stone",
    /// 69 % vertical): the walls are cut out of the stone, as they are where the floor shares
    /// it too (they stayed `other` with the ceiling, and the windows were classed by the
    /// model's height, not the walls' top).
    #[test]
    fn walls_sharing_a_material_with_the_ceiling_alone_are_cut_out() {
        let obj = "mtllib m.mtl\n\
            v 0 0 0\nv 8 0 0\nv 8 0 16\nv 0 0 16\n\
            v 0 6 0\nv 8 6 0\nv 8 6 16\nv 0 6 16\n\
            v 7.99 1.5 7\nv 7.99 1.5 9\nv 7.99 4.5 9\nv 7.99 4.5 7\n\
            o Floor\nusemtl floor\nf 1 2 3 4\n\
            o Hall\nusemtl stone\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\nf 5 8 7 6\n\
            o Windows\nusemtl glass\nf 9 10 11 12\n";
        let mtl = "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl stone\nKd 0.6 0.6 0.6\n\
                   newmtl glass\nKd 1 1 1\nd 0.3\n";
        let (src, t) = tagged_obj(obj, ("m.mtl", mtl));
        let classes: Vec<(MaterialClass, usize)> = src
            .parts
            .iter()
            .enumerate()
            .filter(|(_, p)| p.names.object.as_deref() == Some("Hall"))
            .map(|(i, _)| {
                let triangles = src.tri_part.iter().filter(|&&p| p as usize == i).count();
                (
                    t.materials[t.part_material[0][i] as usize].material.class,
                    triangles,
                )
            })
            .collect();
        // The four walls (8 triangles) cut out; the ceiling (2) stays the rest.
        assert!(
            classes.contains(&(MaterialClass::Wall, 8))
                && classes.contains(&(MaterialClass::Other, 2)),
            "{classes:?}"
        );
    }

    /// A nave of generic names whose walls are built a bay at a time, 32 panels each its own
    /// object and under 2 % of the model, beside 24 square pillars of the same material and
    /// height: the panels are walls together, as one object of them would be (they were
    /// `other`, and the window was classed by the model's height, not the walls' top); the
    /// pillars, which face two ways, stay `other`. With each panel painted in a material of
    /// its own, no one material's panels make a wall, so every material's are judged together.
    #[test]
    fn walls_built_a_bay_at_a_time_are_walls_and_pillars_are_not() {
        for (painted, kin) in [
            (false, "its material"),
            (true, "every material (no one material's made a wall)"),
        ] {
            let (obj, mtl) = crate::testing::nave_in_bays(painted);
            let (src, t) = tagged_obj(&obj, ("m.mtl", &mtl));
            let part = |object: &str| object_class(&src, &t, object).0;
            let class_of = |object: &str| object_class(&src, &t, object).1;
            for k in 0..32 {
                assert_eq!(
                    class_of(&format!("Cube.{k:03}")),
                    MaterialClass::Wall,
                    "bay {k}, painted {painted}"
                );
            }
            for k in 0..24 {
                assert_eq!(
                    class_of(&format!("Cylinder.{k:03}")),
                    MaterialClass::Other,
                    "pillar {k}, painted {painted}"
                );
            }
            assert_eq!(class_of("Plane"), MaterialClass::Floor);
            let said = t.decisions[0][part("Cube.000")]
                .reason()
                .unwrap_or_default();
            assert!(
                said.contains(&format!("with the 31 other wall-shaped parts of {kin}")),
                "{said}"
            );
        }
    }

    /// A hall whose ground and walls are separate objects in one material named for nothing
    /// (as SketchUp writes groups): the ground is the floor, and the walls are walls whatever
    /// the ground's size. On open ground forty times the hall's footprint, walls short of 2 %
    /// of the model's area were `other`; they are measured against the area less the floors.
    #[test]
    fn walls_are_walls_on_open_ground_of_any_size() {
        for half in [5.0, 20.0, 500.0] {
            let (obj, _) = crate::testing::hall_on_open_ground(half);
            let mut piece = 0;
            let obj: String = obj
                .lines()
                .map(|l| match l {
                    "usemtl ground" | "usemtl wall" => {
                        piece += 1;
                        format!("o piece{piece}\nusemtl Material1\n")
                    }
                    "usemtl glass" => format!("o glass\n{l}\n"),
                    _ => format!("{l}\n"),
                })
                .collect();
            let mtl = "newmtl Material1\nKd 0.6 0.6 0.6\nnewmtl glass\nKd 0.2 0.4 0.8\nd 0.3\n";
            let (src, t) = tagged_obj(&obj, ("hall.mtl", mtl));
            let class_of = |object: &str| object_class(&src, &t, object).1;
            assert_eq!(
                class_of("piece1"),
                MaterialClass::Floor,
                "{half} m of ground"
            );
            for wall in 2..=5 {
                assert_eq!(
                    class_of(&format!("piece{wall}")),
                    MaterialClass::Wall,
                    "piece{wall} on {half} m of ground"
                );
            }
        }
    }

    #[test]
    fn explicit_rules_win_over_heuristics_and_first_rule_wins() {
        let m = manifest(
            "[[rule]]\nmatch = \"Boden*\"\nclass = \"wall\"\n[[rule]]\nmatch = \"*\"\non = [\"group\"]\nclass = \"floor\"\n[[rule]]\nmatch = \"Boden_1\"\nclass = \"other\"\n",
        );
        let s = source(&[
            ("Boden_1", None),
            ("glass", Some("g")),
            ("window_lower", None),
        ]);
        let t = tag(&m, &mut [s]).unwrap();
        let class = |p: usize| t.materials[t.part_material[0][p] as usize].material.class;
        // "Boden" would be a floor by heuristics, but the rule says wall.
        assert_eq!(class(0), MaterialClass::Wall);
        assert_eq!(t.decisions[0][0], Decision::Rule(0));
        // Group rule matches before the glass heuristic could apply.
        assert_eq!(class(1), MaterialClass::Floor);
        assert_eq!(class(2), MaterialClass::WindowLower);
        assert!(matches!(
            t.decisions[0][2],
            Decision::Heuristic {
                keyword: "window",
                ..
            }
        ));
        assert_eq!(t.ambiguities.len(), 1);
        assert_eq!(t.ambiguities[0].name, "Boden_1");
        assert_eq!(t.ambiguities[0].rule_lines, vec![3, 10]);
    }

    /// A Greek keyword is said as Greek writes it, its last sigma final.
    #[test]
    fn a_greek_keyword_is_said_with_its_final_sigma() {
        let d = Decision::Heuristic {
            keyword: "τοιχοσ",
            kind: NameKind::Material,
            name: "Τοίχος".into(),
        };
        assert_eq!(
            d.reason().unwrap(),
            "material name \"Τοίχος\" has \"τοιχος\""
        );
        assert_eq!(written_greek("σοσ σ"), "σος σ");
    }

    /// A window's frame modelled in the window's group (as SketchUp and Rhino export a
    /// window assembly) is stone or wood, not glass: a frame word in a more specific name
    /// outweighs the window word of a less specific one, never the other way round.
    #[test]
    fn a_frame_in_a_window_group_is_not_glass() {
        use MaterialClass::{Other, WindowUpper};
        let class = |material: &str, group: &str| {
            let names = Names {
                material: Some(material.into()),
                group: Some(group.into()),
                ..Default::default()
            };
            heuristic(&names).map_or(Other, |h| h.3)
        };
        for (material, group, want) in [
            ("Frame_Wood", "Window1", Other),
            ("Window_Frame", "Window1", Other),
            ("Fensterrahmen", "Fenster_2", Other),
            ("Dark Oak Frame", "Window2", Other),
            ("Muntin_Bar", "Window_lower", Other),
            // A transom and a sash are glazed windows themselves.
            ("Transom_Glass", "Window4", WindowUpper),
            ("Stone", "Sash_Window_01", WindowUpper),
            ("Stone", "Window3", WindowUpper),
            ("Glass", "Window_Frame_3", WindowUpper),
        ] {
            assert_eq!(class(material, group), want, "{material:?} in {group:?}");
        }
    }

    #[test]
    fn names_in_cyrillic_greek_and_east_asian_scripts_are_read() {
        use MaterialClass::{Background, Floor, Other, Wall, WindowUpper};
        let class = |name: &str| {
            let names = Names {
                material: Some(name.into()),
                ..Default::default()
            };
            heuristic(&names).map_or(Other, |h| h.3)
        };
        for (name, want) in [
            ("Стекло_витража", WindowUpper),
            ("вікно_2", WindowUpper),
            ("Пол", Floor),
            ("СТЕНА_север", Wall),
            ("небо", Background),
            ("ΤΟΙΧΟΣ", Wall),
            ("Τοίχος", Wall),
            ("παράθυρο_βόρειο", WindowUpper),
            ("δάπεδο", Floor),
            ("彩色玻璃窗", WindowUpper),
            ("窗框", Other),
            ("地板_石", Floor),
            ("教堂墙壁", Wall),
            ("ステンドグラス01", WindowUpper),
            ("窓枠", Other),
            ("유리창", WindowUpper),
            ("바닥재", Floor),
            ("janela_vitral", WindowUpper),
            ("Fönster", WindowUpper),
            ("duvar", Wall),
            ("Υαλογράφημα", WindowUpper),
            ("Υαλοπίνακας_2", WindowUpper),
            ("βιτρώ", WindowUpper),
            ("Brandglas", WindowUpper),
            ("Gebrandschilderd", WindowUpper),
            ("Glasraam_noord", WindowUpper),
            ("kerkvenster", WindowUpper),
            // Short words of spaced scripts stay whole words.
            ("полка", Other),
            ("falafel", Other),
        ] {
            assert_eq!(class(name), want, "{name}");
        }
    }

    #[test]
    fn same_name_different_class_gets_distinct_materials() {
        // Any model file will do: the manifest of a bare model only names it.
        let model = tempfile::Builder::new().suffix(".obj").tempfile().unwrap();
        let m = Manifest::from_mesh_file(model.path()).unwrap();
        let mut s = source(&[("white", Some("floor")), ("white", Some("back_wall"))]);
        s.parts[0].names.object = s.parts[0].names.group.take();
        let t = tag(&m, &mut [s]).unwrap();
        assert_eq!(t.materials.len(), 2);
        assert_eq!(t.materials[0].material.name, "white");
        assert_eq!(t.materials[1].material.name, "white.wall");
    }
}
