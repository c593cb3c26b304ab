//! Names in files that are not UTF-8.
//!
//! Windows tools write OBJ and MTL files in the machine's ANSI code page (windows-1251 on a
//! Russian system, Shift_JIS on a Japanese one, windows-1250 in Central Europe), and archives
//! keep such file names as raw bytes. Read as UTF-8, a name like `Витраж` becomes replacement
//! characters: no keyword matches, the window gets no light, and its texture is not found.
//!
//! An MTL is decoded whole: UTF-8 where its bytes are UTF-8, otherwise the encoding given
//! (`--text-encoding`) or the one [chardetng] guesses from its bytes. An OBJ is read in
//! parallel pieces before its encoding can be known, so a name there that is not UTF-8 is kept
//! *escaped*: every byte that is not part of a UTF-8 sequence becomes the private-use character
//! U+10FF00 + byte. That is lossless, so materials match `usemtl` names by their bytes, and
//! once the file is read every escaped name is decoded with one encoding for the whole file.

use std::borrow::Cow;
use std::path::PathBuf;

use encoding_rs::Encoding;
use serde::{Serialize, Serializer};

/// The first of the 256 private-use characters standing for the bytes of an escaped name.
const ESCAPE_BASE: u32 = 0x10_FF00;

/// A legacy text encoding a model's names are written in (`--text-encoding`), or UTF-8.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct TextEncoding(&'static Encoding);

impl TextEncoding {
    /// The encoding with this WHATWG label (`windows-1251`, `cp1250`, `shift_jis`, `gbk`,
    /// `latin1`, `utf-8`…), in any case.
    pub fn from_label(label: &str) -> Result<Self, String> {
        let enc = Encoding::for_label_no_replacement(label.trim().as_bytes()).ok_or_else(|| {
            format!(
                "unknown text encoding {label:?}: give a WHATWG label such as windows-1251, \
                 windows-1250, windows-1252, shift_jis, gbk, big5, euc-kr or utf-8"
            )
        })?;
        // UTF-16 cannot be a name's encoding in an ASCII-based format (the OBJ reader refuses
        // such files already).
        if enc.output_encoding() != enc {
            return Err(format!(
                "text encoding {label:?} ({}) is not ASCII-compatible; OBJ and MTL files \
                 are read as ASCII-based text",
                enc.name()
            ));
        }
        Ok(TextEncoding(enc))
    }

    pub(crate) fn of(encoding: &'static Encoding) -> Self {
        TextEncoding(encoding)
    }

    pub fn name(self) -> &'static str {
        self.0.name()
    }
}

impl std::fmt::Debug for TextEncoding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for TextEncoding {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// The encoding of a file: how its text was read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Decoded {
    Utf8,
    /// Not UTF-8; read with this encoding, given by the user or (`guessed`) by chardetng.
    Legacy {
        encoding: &'static Encoding,
        guessed: bool,
    },
}

impl Decoded {
    /// Says how a file that is not UTF-8 was read, for a warning.
    pub(crate) fn describe(self) -> Option<String> {
        match self {
            Decoded::Utf8 => None,
            Decoded::Legacy {
                encoding,
                guessed: true,
            } => Some(format!(
                "its names are not UTF-8; read as {} (guessed from the text; \
                 --text-encoding LABEL gives the encoding instead)",
                encoding.name()
            )),
            Decoded::Legacy {
                encoding,
                guessed: false,
            } => Some(format!(
                "its names are not UTF-8; read as {} (given by --text-encoding or the manifest)",
                encoding.name()
            )),
        }
    }
}

/// The encoding to read `samples` (text that is not UTF-8) with: `given`, else chardetng's
/// guess from them; and whether it was guessed.
pub(crate) fn choose<'a>(
    given: Option<TextEncoding>,
    samples: impl IntoIterator<Item = &'a [u8]>,
) -> (&'static Encoding, bool) {
    if let Some(TextEncoding(encoding)) = given {
        return (encoding, false);
    }
    let samples: Vec<&[u8]> = samples.into_iter().collect();
    let mut detector = chardetng::EncodingDetector::new(chardetng::Iso2022JpDetection::Deny);
    for s in &samples {
        detector.feed(s, false);
        // Names are separate words, not one run of text.
        detector.feed(b"\n", false);
    }
    detector.feed(b"", true);
    let guess = detector.guess(None, chardetng::Utf8Detection::Deny);
    (best_named(guess, &samples), true)
}

/// Lines (names) that are not ASCII, at most this many, decide [`best_named`].
const NAMED_LINES: usize = 4096;

/// chardetng misreads a few short names (a model whose one non-ASCII name is its glass, `Окно`
/// in windows-1251, read as windows-1252 `Îêíî`: the window lost). The names are read in the
/// common encoding that makes the most of them into names with a tagging keyword (`окно`,
/// `窓`, `fenêtre`: real words, which a wrong code page does not spell), `guess` where none
/// makes more than it does.
fn best_named(guess: &'static Encoding, samples: &[&[u8]]) -> &'static Encoding {
    let lines: Vec<&[u8]> = samples
        .iter()
        .flat_map(|s| s.split(|&b| b == b'\n'))
        .filter(|l| !l.is_ascii())
        .take(NAMED_LINES)
        .collect();
    // A code page that cannot read every line is not the file's.
    let named = |e: &'static Encoding| {
        let mut n = 0;
        for l in &lines {
            match e.decode_without_bom_handling_and_without_replacement(l) {
                Some(text) => n += usize::from(crate::tag::spells_keyword(&text)),
                None => return 0,
            }
        }
        n
    };
    let mut best = (named(guess), guess);
    for e in COMMON.into_iter().filter(|&e| e != guess) {
        let n = named(e);
        if n > best.0 {
            best = (n, e);
        }
    }
    best.1
}

/// Encodings file names written on Windows are commonly in, for a name too short to guess
/// its encoding from (`храм.mtl` in windows-1251 is four letters).
pub(crate) const COMMON: [&Encoding; 12] = [
    encoding_rs::WINDOWS_1252,
    encoding_rs::WINDOWS_1251,
    encoding_rs::WINDOWS_1250,
    encoding_rs::WINDOWS_1253,
    encoding_rs::WINDOWS_1254,
    encoding_rs::WINDOWS_1257,
    encoding_rs::KOI8_R,
    encoding_rs::IBM866,
    encoding_rs::SHIFT_JIS,
    encoding_rs::GBK,
    encoding_rs::BIG5,
    encoding_rs::EUC_KR,
];

/// The text of a whole file: itself where it is UTF-8, else decoded as `given` says or as
/// chardetng guesses from its bytes.
pub(crate) fn decode_file(bytes: &[u8], given: Option<TextEncoding>) -> (Cow<'_, str>, Decoded) {
    if let Ok(s) = std::str::from_utf8(bytes) {
        return (Cow::Borrowed(s), Decoded::Utf8);
    }
    let (encoding, guessed) = choose(given, [bytes]);
    let (text, _) = encoding.decode_without_bom_handling(bytes);
    (text, Decoded::Legacy { encoding, guessed })
}

/// `bytes` as text, losing nothing: UTF-8 sequences as themselves, every other byte as
/// U+10FF00 + byte.
pub(crate) fn escaped(bytes: &[u8]) -> Cow<'_, str> {
    if let Ok(s) = std::str::from_utf8(bytes) {
        return Cow::Borrowed(s);
    }
    let mut out = String::with_capacity(bytes.len() * 2);
    for chunk in bytes.utf8_chunks() {
        out.push_str(chunk.valid());
        out.extend(
            chunk
                .invalid()
                .iter()
                .map(|&b| char::from_u32(ESCAPE_BASE + b as u32).expect("a valid code point")),
        );
    }
    Cow::Owned(out)
}

fn escape_byte(c: char) -> Option<u8> {
    (c as u32)
        .checked_sub(ESCAPE_BASE)
        .and_then(|b| u8::try_from(b).ok())
}

/// Whether `s` holds escaped bytes (see [`escaped`]).
pub fn is_escaped(s: &str) -> bool {
    s.chars().any(|c| escape_byte(c).is_some())
}

/// The bytes [`escaped`] made `s` from.
pub(crate) fn raw(s: &str) -> Vec<u8> {
    let mut out = Vec::with_capacity(s.len());
    for c in s.chars() {
        match escape_byte(c) {
            Some(b) => out.push(b),
            None => out.extend_from_slice(c.encode_utf8(&mut [0; 4]).as_bytes()),
        }
    }
    out
}

/// `s` decoded with `encoding` where it is escaped; itself otherwise.
pub(crate) fn decode_escaped(s: &str, encoding: &'static Encoding) -> String {
    if !is_escaped(s) {
        return s.to_string();
    }
    encoding.decode_without_bom_handling(&raw(s)).0.into_owned()
}

/// A warning's message with the escaped names in it decoded: raw escape characters, and the
/// `\u{10ffXX}` that `{:?}` formatting writes for them.
pub(crate) fn decode_message(message: &str, encoding: &'static Encoding) -> String {
    if !message.contains("\\u{10ff") && !is_escaped(message) {
        return message.to_string();
    }
    // Back to bytes, then decode the whole: a multi-byte character's bytes may stand apart.
    let mut bytes = Vec::with_capacity(message.len());
    let mut rest = message;
    while let Some(c) = rest.chars().next() {
        if let Some(tail) = rest.strip_prefix("\\u{10ff")
            && let Some(end) = tail.find('}')
            && let Ok(b) = u8::from_str_radix(&tail[..end], 16)
        {
            bytes.push(b);
            rest = &tail[end + 1..];
            continue;
        }
        match escape_byte(c) {
            Some(b) => bytes.push(b),
            None => bytes.extend_from_slice(c.encode_utf8(&mut [0; 4]).as_bytes()),
        }
        rest = &rest[c.len_utf8()..];
    }
    encoding.decode_without_bom_handling(&bytes).0.into_owned()
}

/// The path a name means on this system: an escaped name's own bytes on Unix, where file
/// names are bytes (an archive made on Windows unpacks its names so).
pub(crate) fn path_of(name: &str) -> PathBuf {
    #[cfg(unix)]
    if is_escaped(name) {
        use std::os::unix::ffi::OsStringExt;
        return PathBuf::from(std::ffi::OsString::from_vec(raw(name)));
    }
    PathBuf::from(name)
}

/// A file's name for a message or a texture name: decoded with `encoding` (the model's names'
/// encoding) where it is not UTF-8, so a name written on Windows reads as its letters.
pub fn file_name_for_display(name: &std::ffi::OsStr, encoding: Option<TextEncoding>) -> String {
    let text = file_name_text(name);
    match encoding {
        Some(TextEncoding(e)) if is_escaped(&text) => decode_escaped(&text, e),
        _ => name.to_string_lossy().into_owned(),
    }
}

/// A file name found on disk in the form names take here: escaped where it is not UTF-8.
pub fn file_name_text(name: &std::ffi::OsStr) -> Cow<'_, str> {
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        escaped(name.as_bytes())
    }
    #[cfg(not(unix))]
    name.to_string_lossy()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn cp1251(s: &str) -> Vec<u8> {
        encoding_rs::WINDOWS_1251.encode(s).0.into_owned()
    }

    #[test]
    fn escaping_is_lossless_and_decodes_with_the_encoding() {
        let bytes = cp1251("Витраж_окна 3");
        let e = escaped(&bytes);
        assert!(is_escaped(&e));
        assert_eq!(raw(&e), bytes);
        assert_eq!(
            decode_escaped(&e, encoding_rs::WINDOWS_1251),
            "Витраж_окна 3"
        );
        // UTF-8 stays as it is.
        assert!(matches!(
            escaped("Витраж".as_bytes()),
            Cow::Borrowed("Витраж")
        ));
        assert_eq!(decode_escaped("Витраж", encoding_rs::SHIFT_JIS), "Витраж");
    }

    #[test]
    fn warnings_decode_both_raw_and_debug_escapes() {
        let sj = encoding_rs::SHIFT_JIS.encode("窓ガラス").0.into_owned();
        let name = escaped(&sj).into_owned();
        let message = format!("usemtl {name:?} names no material; raw {name}");
        assert_eq!(
            decode_message(&message, encoding_rs::SHIFT_JIS),
            "usemtl \"窓ガラス\" names no material; raw 窓ガラス"
        );
    }

    #[test]
    fn guesses_common_code_pages_from_short_names() {
        let guess = |text: &[u8]| choose(None, [text]).0.name();
        let names = "newmtl Пол_каменный\nnewmtl Стена\nnewmtl Витраж_розы\nnewmtl Окно_южное\n";
        assert_eq!(guess(&cp1251(names)), "windows-1251");
        let jp = "newmtl 床\nnewmtl 壁_石\nnewmtl ステンドグラス\nnewmtl 窓ガラス\n";
        assert_eq!(guess(&encoding_rs::SHIFT_JIS.encode(jp).0), "Shift_JIS");
        let pl = "newmtl Podłoga\nnewmtl Ściana_kamienna\nnewmtl Witraż_różany\nnewmtl Szkło\n";
        assert_eq!(
            guess(&encoding_rs::WINDOWS_1250.encode(pl).0),
            "windows-1250"
        );
        let de = "newmtl Fußboden\nnewmtl Wände\nnewmtl Kirchenfenster_Glasmalerei_Süd\n";
        assert_eq!(
            guess(&encoding_rs::WINDOWS_1252.encode(de).0),
            "windows-1252"
        );
    }

    /// One short name is too little for chardetng; a name that is a tagging keyword in one
    /// common encoding and gibberish in the others says which it is.
    #[test]
    fn a_single_short_window_name_finds_its_encoding() {
        let guess = |names: &[&[u8]]| choose(None, names.iter().copied()).0.name();
        let okno = cp1251("Окно");
        assert_eq!(guess(&[&okno, b"Part1", b"Part2"]), "windows-1251");
        let mado = encoding_rs::SHIFT_JIS.encode("窓").0;
        assert_eq!(guess(&[&mado]), "Shift_JIS");
        let fenetre = encoding_rs::WINDOWS_1252.encode("Fenêtre_1").0;
        assert_eq!(guess(&[&fenetre]), "windows-1252");
        // Names no encoding makes a keyword of keep chardetng's guess, whatever it was.
        let plain = cp1251("Камень_серый\nДерево");
        for e in [encoding_rs::KOI8_R, encoding_rs::WINDOWS_1250] {
            assert_eq!(best_named(e, &[&plain]), e);
        }
        assert_eq!(
            best_named(encoding_rs::KOI8_R, &[&okno]),
            encoding_rs::WINDOWS_1251
        );
        // windows-1251 `нн` (-нный, the commonest Russian adjective ending) is EUC-KR `牆`, a
        // wall: inside a run of other ideographs it spells no keyword.
        let russian = cp1251(
            "newmtl Окно\nnewmtl Дверь_деревянная\nnewmtl Колонна\nnewmtl Камень_серый\n\
             newmtl Латунный_крест\n",
        );
        assert_eq!(guess(&[&russian]), "windows-1251");
        let adjectives = cp1251("Деревянный\nКаменный");
        assert_eq!(
            best_named(encoding_rs::WINDOWS_1251, &[&adjectives]),
            encoding_rs::WINDOWS_1251
        );
    }

    #[test]
    fn labels() {
        assert_eq!(
            TextEncoding::from_label("CP1251").unwrap().name(),
            "windows-1251"
        );
        assert_eq!(
            TextEncoding::from_label("sjis").unwrap().name(),
            "Shift_JIS"
        );
        assert!(
            TextEncoding::from_label("utf-16le")
                .unwrap_err()
                .contains("ASCII")
        );
        assert!(
            TextEncoding::from_label("klingon")
                .unwrap_err()
                .contains("klingon")
        );
    }

    proptest! {
        #[test]
        fn raw_inverts_escaped(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
            prop_assert_eq!(raw(&escaped(&bytes)), bytes);
        }
    }
}
