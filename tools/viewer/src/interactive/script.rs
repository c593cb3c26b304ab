//! `--script`: synthetic input for tests and demos, run one frame at a time once the first
//! frame is drawn. Steps are separated by `;`:
//!
//! `wait N` (frames) · `loaded` (until streaming ends) · `view final|background|mask|normals|
//! lit|rays|ids` · `camera N` (preset, from 1) · `press KEY` · `hold KEY N` (frames) ·
//! `look DX DY` (pixels) · `set NAME VALUE` · `resize W H` · `shot [PATH]` · `quit`.
//!
//! Keys go through the same handler as the keyboard (`w`, `shift`, `f3`, `2`, …).

use std::collections::VecDeque;
use std::path::PathBuf;

use super::ui::Controls;
use super::views::ViewMode;

#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    View(ViewMode),
    Camera(usize),
    Key(String, bool),
    Look(f32, f32),
    Set(String, f32),
    Resize(u32, u32),
    Shot(Option<PathBuf>),
    Quit,
}

#[derive(Clone, Debug, PartialEq)]
enum Item {
    Wait(u32),
    Loaded,
    Do(Step),
}

#[derive(Debug)]
pub struct Script {
    items: VecDeque<Item>,
    waiting: u32,
}

const SETTINGS: &[&str] = &[
    "exposure",
    "tone-exposure",
    "decay",
    "density",
    "weight",
    "samples",
    "scale",
    "jitter",
    "refraction",
    "intensity",
    "falloff",
    "gain",
];

impl Script {
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut items = VecDeque::new();
        for raw in text.split(';').map(str::trim).filter(|s| !s.is_empty()) {
            let words: Vec<&str> = raw.split_whitespace().collect();
            let num = |i: usize| -> Result<f32, String> {
                words
                    .get(i)
                    .ok_or_else(|| format!("{raw:?}: missing a number"))?
                    .parse::<f32>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| format!("{raw:?}: {:?} is not a number", words[i]))
            };
            let count = |i: usize| -> Result<u32, String> {
                let v = num(i)?;
                if v >= 0.0 && v.fract() == 0.0 && v <= 1e6 {
                    Ok(v as u32)
                } else {
                    Err(format!("{raw:?}: {v} is not a frame count"))
                }
            };
            let arity = |n: usize| {
                if words.len() == n {
                    Ok(())
                } else {
                    Err(format!("{raw:?}: expected {} argument(s)", n - 1))
                }
            };
            match words[0] {
                "wait" => {
                    arity(2)?;
                    items.push_back(Item::Wait(count(1)?));
                }
                "loaded" => {
                    arity(1)?;
                    items.push_back(Item::Loaded);
                }
                "view" => {
                    arity(2)?;
                    let v = ViewMode::from_key(words[1]).ok_or_else(|| {
                        let keys: Vec<&str> = ViewMode::ALL.iter().map(|m| m.key()).collect();
                        format!("{raw:?}: views are {}", keys.join(", "))
                    })?;
                    items.push_back(Item::Do(Step::View(v)));
                }
                "camera" => {
                    arity(2)?;
                    let n = count(1)?;
                    if n == 0 {
                        return Err(format!("{raw:?}: presets count from 1"));
                    }
                    items.push_back(Item::Do(Step::Camera(n as usize - 1)));
                }
                "press" => {
                    arity(2)?;
                    items.push_back(Item::Do(Step::Key(words[1].into(), true)));
                    items.push_back(Item::Do(Step::Key(words[1].into(), false)));
                }
                "hold" => {
                    arity(3)?;
                    items.push_back(Item::Do(Step::Key(words[1].into(), true)));
                    items.push_back(Item::Wait(count(2)?));
                    items.push_back(Item::Do(Step::Key(words[1].into(), false)));
                }
                "look" => {
                    arity(3)?;
                    items.push_back(Item::Do(Step::Look(num(1)?, num(2)?)));
                }
                "set" => {
                    arity(3)?;
                    if !SETTINGS.contains(&words[1]) {
                        return Err(format!("{raw:?}: settings are {}", SETTINGS.join(", ")));
                    }
                    items.push_back(Item::Do(Step::Set(words[1].into(), num(2)?)));
                }
                "resize" => {
                    arity(3)?;
                    let (w, h) = (count(1)?, count(2)?);
                    if w == 0 || h == 0 {
                        return Err(format!("{raw:?}: size must be positive"));
                    }
                    items.push_back(Item::Do(Step::Resize(w, h)));
                }
                "shot" => {
                    if words.len() > 2 {
                        return Err(format!("{raw:?}: expected at most one path"));
                    }
                    items.push_back(Item::Do(Step::Shot(words.get(1).map(PathBuf::from))));
                }
                "quit" => {
                    arity(1)?;
                    items.push_back(Item::Do(Step::Quit));
                }
                other => return Err(format!("unknown step {other:?} in {raw:?}")),
            }
        }
        Ok(Self { items, waiting: 0 })
    }

    /// The next step to run this frame, or `None` when the script waits (or is done).
    /// Call until `None` once per frame; `loaded` says whether streaming has finished.
    pub fn next(&mut self, loaded: bool) -> Option<Step> {
        if self.waiting > 0 {
            self.waiting -= 1;
            return None;
        }
        match self.items.front()? {
            Item::Loaded if !loaded => None,
            Item::Loaded => {
                self.items.pop_front();
                self.next(loaded)
            }
            Item::Wait(n) => {
                self.waiting = *n;
                self.items.pop_front();
                // The rest of this frame's steps wait too.
                None
            }
            Item::Do(_) => match self.items.pop_front() {
                Some(Item::Do(s)) => Some(s),
                _ => None,
            },
        }
    }
}

/// Applies `set NAME VALUE` to the panel's controls, as if the slider had been moved.
pub fn apply_setting(c: &mut Controls, name: &str, value: f32) -> Result<(), String> {
    let g = &mut c.settings.god_rays;
    match name {
        "exposure" => g.exposure = value,
        "tone-exposure" => c.settings.exposure = value,
        "decay" => g.decay = value,
        "density" => g.density = value,
        "weight" => g.weight = value,
        "samples" => g.samples = value.clamp(1.0, render::MAX_GOD_RAY_SAMPLES as f32) as u32,
        "scale" => g.resolution_scale = value.clamp(0.125, 1.0),
        "jitter" => g.jitter = value != 0.0,
        "refraction" => c.settings.refraction_strength = value,
        "gain" => c.view_gain = value,
        "intensity" | "falloff" => {
            let l = c
                .light
                .as_mut()
                .ok_or_else(|| format!("set {name}: the scene has no light"))?;
            if name == "intensity" {
                l.intensity = value;
            } else {
                l.falloff = value != 0.0;
            }
        }
        _ => return Err(format!("unknown setting {name:?}")),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drain(s: &mut Script, loaded: bool) -> Vec<Step> {
        std::iter::from_fn(|| s.next(loaded)).collect()
    }

    #[test]
    fn steps_run_until_a_wait_and_resume_after_it() {
        let mut s =
            Script::parse("view ids; camera 2; wait 2; hold w 1; shot a.png; quit").unwrap();
        assert_eq!(
            drain(&mut s, true),
            vec![Step::View(ViewMode::MaterialIds), Step::Camera(1)]
        );
        assert!(drain(&mut s, true).is_empty());
        assert!(drain(&mut s, true).is_empty());
        assert_eq!(drain(&mut s, true), vec![Step::Key("w".into(), true)]);
        assert!(drain(&mut s, true).is_empty());
        assert_eq!(
            drain(&mut s, true),
            vec![
                Step::Key("w".into(), false),
                Step::Shot(Some("a.png".into())),
                Step::Quit
            ]
        );
    }

    #[test]
    fn loaded_blocks_until_streaming_ends() {
        let mut s = Script::parse("loaded; quit").unwrap();
        assert!(drain(&mut s, false).is_empty());
        assert_eq!(drain(&mut s, true), vec![Step::Quit]);
    }

    #[test]
    fn bad_scripts_are_rejected_with_the_step() {
        for bad in [
            "jump",
            "wait",
            "wait -1",
            "wait 1.5",
            "view sideways",
            "camera 0",
            "set colour 1",
            "resize 0 10",
            "look 1",
        ] {
            let e = Script::parse(bad).unwrap_err();
            assert!(
                e.contains(bad.split_whitespace().next().unwrap()),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn settings_reach_the_controls() {
        let mut c = Controls {
            settings: render::Settings::default(),
            light: None,
            view: ViewMode::Final,
            view_gain: 1.0,
            show_panel: true,
        };
        apply_setting(&mut c, "samples", 16.0).unwrap();
        apply_setting(&mut c, "scale", 0.5).unwrap();
        assert_eq!(c.settings.god_rays.samples, 16);
        assert_eq!(c.settings.god_rays.resolution_scale, 0.5);
        assert!(apply_setting(&mut c, "intensity", 2.0).is_err());
    }
}
