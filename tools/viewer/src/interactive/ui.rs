//! The egui side panel: views, camera presets, god-ray and light controls, per-pass times,
//! load progress and the material legend.

use render::{FrameReport, LoadStatus, Settings, TimingMethod};

use super::views::{ViewMode, material_colour};

/// The light as the panel edits it; applied to the scene's light from the pack.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightEdit {
    pub colour: [f32; 3],
    pub intensity: f32,
    /// Inverse-square falloff of a point light (the original compared with and without).
    pub falloff: bool,
}

/// Everything the panel can change.
#[derive(Clone, Debug, PartialEq)]
pub struct Controls {
    pub settings: Settings,
    pub light: Option<LightEdit>,
    pub view: ViewMode,
    /// Gain of an intermediate pass shown alone: faint normal perturbations and dim targets
    /// need it to be seen.
    pub view_gain: f32,
    pub show_panel: bool,
}

/// What the panel asks the viewer to do.
#[derive(Clone, Debug, PartialEq)]
pub enum Request {
    Camera(usize),
    Screenshot,
    Reload,
}

/// What the panel shows.
pub struct Info<'a> {
    pub adapter: &'a str,
    pub size: (u32, u32),
    pub vsync: bool,
    pub frame_ms: f64,
    pub report: Option<&'a FrameReport>,
    pub status: Option<LoadStatus>,
    pub first_frame_ms: Option<f64>,
    pub full_quality_ms: Option<f64>,
    pub loading: Option<&'a str>,
    pub cameras: Vec<&'a str>,
    /// (material name, class name) in material-table order.
    pub materials: Vec<(&'a str, &'a str)>,
    pub point_light: bool,
    pub watch: Option<&'a str>,
    /// Recent notes; `true` marks a problem.
    pub messages: &'a [(bool, String)],
}

fn swatch(ui: &mut egui::Ui, rgb: [u8; 3]) {
    let (rect, _) = ui.allocate_exact_size(egui::vec2(14.0, 14.0), egui::Sense::hover());
    ui.painter()
        .rect_filled(rect, 2.0, egui::Color32::from_rgb(rgb[0], rgb[1], rgb[2]));
}

/// The material legend of the false-colour view, grouped by class.
pub fn legend(ui: &mut egui::Ui, materials: &[(&str, &str)]) {
    let mut order: Vec<usize> = (0..materials.len()).collect();
    order.sort_by_key(|&i| (materials[i].1, i));
    egui::Grid::new("legend").striped(true).show(ui, |ui| {
        for i in order {
            let (name, class) = materials[i];
            swatch(ui, material_colour(i));
            ui.label(class);
            ui.label(name);
            ui.end_row();
        }
    });
}

pub fn panel(ui: &mut egui::Ui, c: &mut Controls, info: &Info<'_>) -> Vec<Request> {
    let mut requests = Vec::new();
    egui::ScrollArea::vertical().show(ui, |ui| {
        ui.heading("stained glass");
        ui.label(format!(
            "{}×{}  {:.1} ms/frame ({:.0} fps){}",
            info.size.0,
            info.size.1,
            info.frame_ms,
            if info.frame_ms > 0.0 {
                1e3 / info.frame_ms
            } else {
                0.0
            },
            if info.vsync { ", vsync" } else { "" }
        ));
        ui.small(info.adapter);
        ui.small(concat!(
            "WASD fly, Space/E up, Q/C down, Shift fast, Ctrl slow, drag to look, ",
            "wheel speed, 1–9 presets, F1–F8 views, F12 screenshot, H panel, Esc quit"
        ));

        if let Some(what) = info.loading {
            ui.separator();
            ui.label(what);
        }
        if let Some(st) = info.status {
            let geometry = st.geometry_sections as f32 / st.geometry_total.max(1) as f32;
            let mips = st.mips_loaded as f32 / st.mips_total.max(1) as f32;
            if st.mips_loaded < st.mips_total || st.geometry_sections < st.geometry_total {
                ui.add(egui::ProgressBar::new(geometry).text(format!(
                    "geometry {}/{}",
                    st.geometry_sections, st.geometry_total
                )));
                ui.add(egui::ProgressBar::new(mips).text(format!(
                    "mips {}/{} ({:.1} MB)",
                    st.mips_loaded,
                    st.mips_total,
                    st.bytes_uploaded as f64 / 1e6
                )));
            } else {
                ui.label(format!(
                    "loaded: {} mips, {:.1} MB",
                    st.mips_total,
                    st.bytes_uploaded as f64 / 1e6
                ));
            }
            if let Some(t) = info.first_frame_ms {
                ui.label(format!("first frame after {t:.0} ms"));
            }
            if let Some(t) = info.full_quality_ms {
                ui.label(format!("full quality after {t:.0} ms"));
            }
        }
        if let Some(w) = info.watch {
            ui.horizontal(|ui| {
                ui.label(w);
                if ui.button("re-cook now").clicked() {
                    requests.push(Request::Reload);
                }
            });
        }
        for (problem, m) in info.messages.iter().rev().take(4) {
            if *problem {
                ui.colored_label(egui::Color32::from_rgb(255, 170, 90), m);
            } else {
                ui.weak(m);
            }
        }

        ui.separator();
        // Times sit above the controls, so the cost of a change is visible while making it.
        timings(ui, info.report);

        ui.separator();
        ui.label("view");
        ui.horizontal_wrapped(|ui| {
            for m in ViewMode::ALL {
                ui.selectable_value(&mut c.view, m, format!("{} {}", m.shortcut(), m.label()));
            }
        });
        if !matches!(c.view, ViewMode::Final | ViewMode::MaterialIds) {
            ui.add(
                egui::Slider::new(&mut c.view_gain, 0.1..=64.0)
                    .logarithmic(true)
                    .text("gain of this view"),
            );
        }
        if ui.button("screenshot (F12)").clicked() {
            requests.push(Request::Screenshot);
        }

        if !info.cameras.is_empty() {
            ui.separator();
            ui.label("cameras");
            ui.horizontal_wrapped(|ui| {
                for (i, name) in info.cameras.iter().enumerate() {
                    let label = if i < 9 {
                        format!("{} {name}", i + 1)
                    } else {
                        name.to_string()
                    };
                    if ui.button(label).clicked() {
                        requests.push(Request::Camera(i));
                    }
                }
            });
        }

        ui.separator();
        egui::CollapsingHeader::new("god rays")
            .default_open(true)
            .show(ui, |ui| {
                let g = &mut c.settings.god_rays;
                ui.add(egui::Slider::new(&mut g.exposure, 0.0..=4.0).text("exposure"));
                ui.add(
                    egui::Slider::new(&mut g.decay, 0.001..=1.0)
                        .logarithmic(true)
                        .text("decay (left after a march)"),
                );
                ui.add(egui::Slider::new(&mut g.density, 0.0..=2.0).text("density"));
                ui.add(egui::Slider::new(&mut g.weight, 0.0..=4.0).text("weight"));
                // The renderer's full range: --max-flip may choose the most, which a narrower
                // slider would clamp.
                ui.add(
                    egui::Slider::new(&mut g.samples, 1..=render::MAX_GOD_RAY_SAMPLES)
                        .logarithmic(true)
                        .text("samples"),
                );
                ui.horizontal(|ui| {
                    ui.label("resolution");
                    for (s, name) in [(1.0, "full"), (0.5, "half"), (0.25, "quarter")] {
                        ui.radio_value(&mut g.resolution_scale, s, name);
                    }
                });
                ui.checkbox(&mut g.jitter, "per-pixel jitter");
                ui.label(crate::god_rays::measured_note(g));
            });
        egui::CollapsingHeader::new("window light occlusion (shadow maps)")
            .default_open(true)
            .show(ui, |ui| {
                let s = &mut c.settings.shadows;
                ui.checkbox(&mut s.enabled, "stone blocks the window light");
                ui.add_enabled(
                    s.enabled,
                    egui::Slider::new(&mut s.bias, 0.0..=8.0).text("bias (texels of slope)"),
                );
                ui.add_enabled(
                    s.enabled,
                    egui::Slider::new(&mut s.filter, 0.0..=8.0).text("smallest filter σ (texels)"),
                );
                ui.horizontal(|ui| {
                    ui.label("map size");
                    for size in [512u32, 1024, 2048, 4096] {
                        ui.radio_value(&mut s.map_size, size, size.to_string());
                    }
                });
                ui.small(
                    "penumbra width follows the light's size and the blocker's distance; \
                     maps are redrawn only when the light or these settings change",
                );
            });
        egui::CollapsingHeader::new("light and shading")
            .default_open(true)
            .show(ui, |ui| {
                match &mut c.light {
                    Some(l) => {
                        ui.horizontal(|ui| {
                            ui.label("colour");
                            ui.color_edit_button_rgb(&mut l.colour);
                        });
                        ui.add(
                            egui::Slider::new(&mut l.intensity, 0.0..=1e4)
                                .logarithmic(true)
                                .text("intensity"),
                        );
                        ui.add_enabled(
                            info.point_light,
                            egui::Checkbox::new(&mut l.falloff, "inverse-square falloff"),
                        )
                        .on_disabled_hover_text("a directional light has no falloff");
                    }
                    None => {
                        ui.label("this scene has no light");
                    }
                }
                ui.add(
                    egui::Slider::new(&mut c.settings.refraction_strength, 0.0..=0.5)
                        .text("refraction strength"),
                );
                ui.add(
                    egui::Slider::new(&mut c.settings.exposure, 0.05..=8.0)
                        .logarithmic(true)
                        .text("exposure (tone map)"),
                );
            });
    });
    requests
}

fn timings(ui: &mut egui::Ui, report: Option<&FrameReport>) {
    let Some(r) = report else {
        ui.label("per-pass times: no frame yet");
        return;
    };
    ui.label(match r.method {
        TimingMethod::GpuTimestamps => "per-pass GPU time (timestamp queries)",
        TimingMethod::CpuWallClock => "per-pass time (CPU wall clock; no timestamp queries)",
        TimingMethod::None => "per-pass time: not measured",
    });
    egui::Grid::new("timings").striped(true).show(ui, |ui| {
        let mut total = 0.0;
        for p in &r.passes {
            ui.label(p.pass.name());
            match (p.ms, p.skipped) {
                (_, Some(why)) => ui.weak(format!("skipped: {why}")),
                (Some(ms), None) => {
                    total += ms;
                    ui.monospace(format!("{ms:7.3} ms"))
                }
                (None, None) => ui.weak("—"),
            };
            ui.end_row();
        }
        ui.label("total");
        ui.monospace(format!("{total:7.3} ms"));
        ui.end_row();
    });
    if r.god_ray_fade < 1.0 {
        ui.small(format!(
            "god-ray fade {:.2} (light leaving the view)",
            r.god_ray_fade
        ));
    }
}
