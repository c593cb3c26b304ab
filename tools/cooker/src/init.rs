//! `cooker init <mesh> [-o scene.toml] [--force]`: a starter manifest from what the cook
//! guesses about a model: tagging rules, the windows found in the geometry, a sun whose light
//! lands on the floor through them, and cameras inside the building.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use cook::Manifest;
use cook::manifest::NameKind;
use cook::tag::{Cut, Decision};
use pack::MaterialClass;

use crate::exit::{OK, Outcome, UsageError};

/// Name kinds from the narrowest (one object) to the widest (a material many objects share).
const SPECIFIC_FIRST: [NameKind; 5] = [
    NameKind::Object,
    NameKind::Node,
    NameKind::Mesh,
    NameKind::Group,
    NameKind::Material,
];

#[derive(clap::Args)]
pub struct Args {
    /// The model: an .obj, .gltf, .glb or .ply file.
    mesh: PathBuf,
    /// The manifest to write (default: scene.toml beside the model).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Replace an existing manifest.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    model: cook::cli::ModelArgs,
}

fn quote(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

/// A glob that matches exactly `s`: each metacharacter in a class of its own. Not `!`,
/// which is literal outside a class, and as `[!]` opens a negated one: a material named
/// `!start` gave a starter manifest that did not parse.
fn literal_glob(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '*' | '?' | '[' | ']' | '{' | '}' | '\\' | ',' => {
                out.push('[');
                out.push(c);
                out.push(']');
            }
            c => out.push(c),
        }
    }
    out
}

/// `v` as the manifest writes a vector read as written: each component exact on its own.
fn vec3(v: [f32; 3]) -> String {
    format!("[{}]", v.map(|x| exact1(x, 1, |r| r, x)).join(", "))
}

/// `v` with the fewest decimals (`min` at least, one decimal count for all components) that
/// the manifest reads back, through `back`, as exactly `want`: a cook of the starter manifest
/// then gets the guess's very bits, and `cooker diff` finds it equal to the bare cook. Four
/// fixed decimals moved the light and views by up to 1e-4 (and, on a model in large units,
/// rounded a view's eye onto its target). The read is mirrored as the manifest does it: a
/// TOML float is an f64, narrowed to f32.
fn exact<const N: usize>(
    v: [f32; N],
    min: usize,
    back: impl Fn([f32; N]) -> [f32; N],
    want: [f32; N],
) -> String {
    let read = |d: Option<usize>| -> (String, [f32; N]) {
        let parts = v.map(|x| match d {
            Some(d) => format!("{x:.d$}"),
            // Rust's shortest round-trip form, with a decimal point so TOML reads a float.
            None => format!("{x:?}"),
        });
        let back_in =
            std::array::from_fn(|i| parts[i].parse::<f64>().map_or(f32::NAN, |f| f as f32));
        let text = if N == 1 {
            parts[0].clone()
        } else {
            format!("[{}]", parts.join(", "))
        };
        (text, back(back_in))
    };
    let same = |a: [f32; N]| a.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits());
    (min..=9)
        .map(|d| read(Some(d)))
        .find(|(_, r)| same(*r))
        .unwrap_or_else(|| read(None))
        .0
}

/// One value, as [`exact`] writes it.
fn exact1(v: f32, min: usize, back: impl Fn(f32) -> f32, want: f32) -> String {
    exact([v], min, |[r]| [back(r)], [want])
}

/// The path to write for `mesh` in a manifest in `dir`: relative when the mesh lies under it.
fn relative(mesh: &Path, dir: &Path) -> String {
    let abs = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
    let (m, d) = (abs(mesh), abs(dir));
    let path = m.strip_prefix(&d).unwrap_or(&m);
    // A name that is not UTF-8 (an archive made on Windows unpacks `часовня.obj` as its
    // windows-1251 bytes) is written escaped, as the cook reads such names back: lossy, it
    // named no file and the starter manifest did not parse.
    let text: Vec<String> = path
        .components()
        .map(|c| match c {
            std::path::Component::RootDir => String::new(),
            other => cook::import::text::file_name_text(other.as_os_str()).into_owned(),
        })
        .collect();
    text.join("/")
}

pub fn run(args: Args) -> Outcome {
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| args.mesh.with_file_name("scene.toml"));
    // The model first: `init scene.toml` said "exists; pass --force", and with --force that
    // a manifest is no model.
    let manifest = Manifest::from_mesh_file(&args.mesh)?;
    crate::cook::refuse_a_directory(&output, "scene.toml")?;
    // Before "exists; pass --force", which --force would then refuse.
    crate::cook::refuse_overwriting_an_input(&output, [args.mesh.as_path()])?;
    if output.exists() && !args.force {
        return Err(UsageError(format!(
            "{} exists; pass --force to replace it",
            output.display()
        ))
        .into());
    }
    let mut report = cook::Report::default();
    let mut settings = cook::Settings::new(&manifest);
    args.model.apply(&mut settings);
    let prepared = cook::prepare(&manifest, &settings, &mut report)?;
    // A manifest of a model with no face would only fail to cook.
    if let Some(e) = cook::no_faces(&manifest, &prepared) {
        return Err(e.into());
    }
    // --force replaces a manifest, never the model it describes.
    crate::cook::refuse_overwriting_an_input(
        &output,
        prepared
            .imported
            .iter()
            .flat_map(|s| std::iter::once(&s.path).chain(&s.files))
            .map(|p| p.as_path()),
    )?;
    let guess = cook::guess::guess(&prepared);
    for w in prepared
        .imported
        .iter()
        .flat_map(|s| &s.warnings)
        .chain(&report.warnings)
    {
        eprintln!("warning: {w}");
    }
    if guess.looks_z_up && args.model.up != cook::UpAxis::Z {
        eprintln!(
            "warning: {}: the model looks Z-up (its floor faces along z); `cooker init --up z` \
             writes the turn that stands it up",
            args.mesh.display()
        );
    }

    let dir = output
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let encoding = prepared.imported.iter().find_map(|i| i.text_encoding);
    let stem = args
        .mesh
        .file_stem()
        .map(|s| cook::import::text::file_name_for_display(s, encoding))
        .unwrap_or_default();
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# Written by `cooker init {}`: what the cook guessed about the model. Edit freely;\n\
         # explicit rules win over every heuristic (docs/scene-manifest.md).\n",
        args.mesh.display()
    );
    let _ = writeln!(t, "[scene]\nname = {}", quote(&stem));
    // Names that are not UTF-8 were read in this encoding (given or guessed): pinned here, so
    // every cook of the manifest reads them alike, and a wrong guess is one edit away.
    if let Some(e) = encoding {
        let _ = writeln!(
            t,
            "text_encoding = {}  # the names are not UTF-8; {}",
            quote(e.name()),
            if args.model.text_encoding.is_some() {
                "given by --text-encoding"
            } else {
                "guessed from them"
            }
        );
    }
    t.push('\n');
    let source = relative(&args.mesh, dir);
    let _ = writeln!(t, "[[mesh]]\nsource = {}", quote(&source));
    if let Some(name) = args
        .mesh
        .file_name()
        .filter(|_| cook::import::text::is_escaped(&source))
    {
        let _ = writeln!(
            t,
            "# the file's name is not UTF-8 ({}): each byte of it that is not is written as \
             the character U+10FF00 + byte",
            cook::import::text::file_name_for_display(name, encoding)
        );
    }
    if args.model.up == cook::UpAxis::Z {
        let _ = writeln!(
            t,
            "# Z-up: this turn stands it up.\nrotate_deg = [-90.0, 0.0, 0.0]"
        );
    }
    if prepared.shift != [0.0; 3] {
        // The cook moved the model from its survey coordinates; written out, the move is the
        // mesh's own, and the views below are where the cook put them.
        let [x, y, z] = prepared.shift.map(|v| 0.0 - v);
        let _ = writeln!(
            t,
            "# Survey coordinates: this moves the model near the origin, where 32-bit positions\n\
             # keep their precision.\ntranslate = [{x:.1}, {y:.1}, {z:.1}]"
        );
    }
    let _ = writeln!(t);

    // Rules: one per deciding name, in the order the parts appear.
    let _ = writeln!(
        t,
        "# Tagging rules, first match wins: one per name the guesses rest on."
    );
    let mut rules: Vec<(NameKind, String, &str, String)> = Vec::new();
    // Per deciding name: the classes of its parts, and whether the geometry cut any of them
    // (a building in one material).
    type Classes<'a> = (std::collections::BTreeSet<&'a str>, bool);
    let mut named: std::collections::BTreeMap<(usize, String), Classes> = Default::default();
    // Per name of any kind: the classes of all the parts that carry it. A glTF node or mesh
    // holds its glass beside the floor and walls as primitives of one mesh: a rule on that
    // name, written for the glass, tagged all of it a window.
    let class_of = |si: usize, pi: usize| {
        let class = prepared.tagging.materials[prepared.tagging.part_material[si][pi] as usize]
            .material
            .class;
        // Glass is tagged a window without saying upper or lower: each window instance is
        // classed by its own sill height.
        if class.is_window() {
            cook::manifest::WINDOW_BY_SILL
        } else {
            class.name()
        }
    };
    let mut carried: std::collections::BTreeMap<(usize, &str), std::collections::BTreeSet<&str>> =
        Default::default();
    for (si, src) in prepared.imported.iter().enumerate() {
        let counts = src.part_triangles();
        for (pi, part) in src.parts.iter().enumerate() {
            if counts[pi] == 0 {
                continue;
            }
            for (k, &kind) in SPECIFIC_FIRST.iter().enumerate() {
                if let Some(n) = part.names.get(kind) {
                    carried.entry((k, n)).or_default().insert(class_of(si, pi));
                }
            }
        }
    }
    for (si, src) in prepared.imported.iter().enumerate() {
        let counts = src.part_triangles();
        for (pi, part) in src.parts.iter().enumerate() {
            if counts[pi] == 0 {
                continue;
            }
            let decision = &prepared.tagging.decisions[si][pi];
            let class = class_of(si, pi);
            let why = decision.reason().unwrap_or_default();
            // A guess from geometry or material properties is about this part: name it by
            // its most specific name that no part of another class carries, so the rule does
            // not also catch other parts that share a material ("white" is the Cornell box's
            // floor, walls and blocks alike) or a node. Where every name is shared, the most
            // specific one, with the other classes, which leaves it without a rule below.
            // Its material comes first where no other class carries it.
            let (kind, name, others) = match decision {
                Decision::Heuristic { kind, name, .. } => (*kind, name.clone(), None),
                _ => {
                    let names = || {
                        SPECIFIC_FIRST
                            .iter()
                            .enumerate()
                            .filter_map(|(k, &kind)| Some((k, kind, part.names.get(kind)?)))
                    };
                    let only_this = |k: usize, n: &str| {
                        carried
                            .get(&(k, n))
                            .is_some_and(|c| c.len() == 1 && c.contains(class))
                    };
                    // A material no part of another class carries is one rule for all its
                    // parts (a floor laid as sixty tiles, each its own object, was sixty).
                    let material =
                        names().find(|&(k, kind, n)| kind == NameKind::Material && only_this(k, n));
                    match material
                        .or_else(|| names().find(|&(k, _, n)| only_this(k, n)))
                        .or_else(|| names().next())
                    {
                        Some((k, kind, n)) => (kind, n.to_string(), carried.get(&(k, n))),
                        None => continue,
                    }
                }
            };
            let k = SPECIFIC_FIRST.iter().position(|&s| s == kind).unwrap_or(0);
            let entry = named.entry((k, name.clone())).or_default();
            entry.0.insert(class);
            entry.0.extend(others.into_iter().flatten());
            entry.1 |= prepared.tagging.cut[si][pi] != Cut::None;
            // An empty name (`usemtl` alone) cannot be matched: the manifest refuses `match = ""`.
            if !name.is_empty() && !rules.iter().any(|r| r.0 == kind && r.1 == name) {
                rules.push((kind, name, class, why.replace('\n', " ")));
            }
        }
    }
    // A name whose parts the geometry classed apart gets no rule: one class for the name
    // would undo that. The parts are a building in one material that the cook cut into its
    // floor, its walls and the rest, or instances of one mesh that stand differently (a glTF
    // node's GPU instances, one name for all).
    for ((k, name), (classes, was_cut)) in &named {
        if classes.len() < 2 && !was_cut {
            continue;
        }
        let kind = SPECIFIC_FIRST[*k];
        rules.retain(|r| !(r.0 == kind && r.1 == *name));
        let classes: Vec<&str> = classes.iter().copied().collect();
        let how = if *was_cut {
            "cut by its geometry into"
        } else {
            "its parts classed by their geometry as"
        };
        let _ = writeln!(
            t,
            "# {} {}: {how} {}; no rule, so that stays\n",
            kind.name(),
            quote(name),
            classes.join(", ")
        );
    }
    // First match wins, so rules on the narrowest names come first: an object's rule before
    // a material rule that the object's triangles would also match.
    rules.sort_by_key(|r| SPECIFIC_FIRST.iter().position(|&k| k == r.0));
    for (kind, name, class, why) in &rules {
        let _ = writeln!(
            t,
            "[[rule]]\nmatch = {}\non = [{}]\nclass = {}    # {why}\n",
            quote(&literal_glob(name)),
            quote(kind.name()),
            quote(class),
        );
    }
    // Windows.
    let _ = writeln!(
        t,
        "# Windows found in the geometry. Without `design` each gets one rasterized from its\n\
         # panes' colours; `design = \"image.png\"` (with `fit = \"cover\"|\"contain\"|\"stretch\"`)\n\
         # uses an image instead."
    );
    for (inst, &m) in prepared
        .windows
        .instances
        .iter()
        .zip(&prepared.windows.material)
    {
        let plan = prepared.tagging.materials[m as usize].window.as_deref();
        let c = inst.centre();
        let _ = writeln!(
            t,
            "# {} x {}, centre {}, {} triangles of {}; inside: {}",
            cook::length(inst.width()),
            cook::length(inst.height()),
            vec3([c.x as f32, c.y as f32, c.z as f32]),
            inst.triangles.len(),
            plan.map(|p| p.materials.join(", ")).unwrap_or_default(),
            inst.inside_reason
        );
        // Written out, so the sun written below cannot turn the window: where the geometry
        // leaves the side unclear, the side the sunlight leaves through decides, which for a
        // window on the shaded side is its outside (its design then read mirrored).
        let n = inst.inside;
        let _ = writeln!(
            t,
            "[[window]]\nname = {}\ninside = {}\n",
            quote(&literal_glob(&inst.name)),
            // Only the side is read from it (the window keeps its own normal), so a −0.0 is
            // written as the 0.0 it means.
            vec3([n.x, n.y, n.z].map(|c| c as f32 + 0.0))
        );
    }

    if let Some(l) = &guess.light {
        for n in &guess.notes {
            let _ = writeln!(t, "# {n}");
        }
        // The fields in the order the manifest documents them: a lamp's position and radius,
        // the sun's or a spot's direction, the sun's size, a spot's cone.
        let kind = match l.kind {
            pack::LightKind::Directional { .. } => "directional",
            pack::LightKind::Point { .. } => "point",
            pack::LightKind::Spot { .. } => "spot",
        };
        let _ = writeln!(t, "[light]\ntype = \"{kind}\"");
        if let Some((position, radius)) = l.kind.lamp() {
            let _ = writeln!(
                t,
                "position = {}\nradius = {}",
                vec3(position),
                exact1(radius, 1, |r| r, radius)
            );
        }
        let direction = match l.kind {
            pack::LightKind::Directional { direction, .. }
            | pack::LightKind::Spot { direction, .. } => Some(direction),
            pack::LightKind::Point { .. } => None,
        };
        if let Some(d) = direction {
            let back = |d: [f32; 3]| cook::manifest::light_direction(d.into()).to_array();
            let _ = writeln!(t, "direction = {}", exact(d, 1, back, d));
        }
        if let Some((_, size)) = l.kind.sun() {
            let _ = writeln!(
                t,
                "angular_size_deg = {}",
                exact1(size.to_degrees(), 2, f32::to_radians, size)
            );
        }
        if let pack::LightKind::Spot { inner, outer, .. } = l.kind {
            let _ = writeln!(
                t,
                "inner_cone_deg = {}\nouter_cone_deg = {}",
                exact1(inner.to_degrees(), 2, f32::to_radians, inner),
                exact1(outer.to_degrees(), 2, f32::to_radians, outer)
            );
        }
        let _ = writeln!(
            t,
            "colour = {}\nintensity = {}\n",
            vec3(l.colour),
            exact1(l.intensity, 1, |r| r, l.intensity)
        );
    }
    if let Some(sky) = guess.sky {
        let _ = writeln!(
            t,
            "# Seen through the windows where no sky geometry covers the view.\n[background]\ncolour = {}\n",
            vec3(sky)
        );
    }
    for c in &guess.cameras {
        // A view the model's file frames may be rolled; a guessed one never is.
        let up = if c.up == [0.0, 1.0, 0.0] {
            String::new()
        } else {
            format!("up = {}\n", vec3(c.up))
        };
        let _ = writeln!(
            t,
            "[[camera]]\nname = {}\nposition = {}\ntarget = {}\n{up}fov_y_deg = {}\nnear = {}\nfar = {}\n",
            quote(&c.name),
            vec3(c.position),
            vec3(c.target),
            exact1(c.fov_y, 1, |r| r, c.fov_y),
            exact1(c.near, 1, |r| r, c.near),
            exact1(c.far, 1, |r| r, c.far)
        );
    }

    // The manifest must parse as written: a guess that does not is a bug here, not the user's.
    Manifest::parse(&output, &t).map_err(|e| {
        anyhow::anyhow!("the starter manifest does not parse (a bug in cooker init): {e}")
    })?;
    pack::write_atomic(&output, t.as_bytes())?;
    let windows = prepared.windows.instances.len();
    let classes = |c: MaterialClass| {
        prepared
            .tagging
            .materials
            .iter()
            .filter(|m| m.material.class == c)
            .count()
    };
    println!(
        "wrote {}: {} rules, {windows} windows, {} floor and {} wall materials, {} cameras",
        output.display(),
        rules.len(),
        classes(MaterialClass::Floor),
        classes(MaterialClass::Wall),
        guess.cameras.len()
    );
    Ok(OK)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every name comes back from its glob as the one name it matches, whatever glob syntax
    /// it holds: `!start` was written `[!]start`, a negated class that did not parse, and
    /// `x[!y]` one that matched nothing.
    #[test]
    fn literal_globs_match_their_name_only() {
        for name in [
            "!start",
            "end!",
            "x[!y]",
            "a*b?",
            "{x,y}",
            "back\\slash",
            "[]",
            "a,b",
        ] {
            let g = literal_glob(name);
            let m = cook::manifest::NameGlob::checked(&g)
                .unwrap_or_else(|e| panic!("{name:?} as {g:?}: {e}"));
            assert!(m.is_match(name), "{name:?} as {g:?}");
            for other in ["start", "xy", "x!y", "aXb?", "x", "back/slash", "ab", "a"] {
                assert!(other == name || !m.is_match(other), "{g:?} on {other:?}");
            }
        }
    }
}
