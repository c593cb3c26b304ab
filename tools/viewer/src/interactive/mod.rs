//! The interactive window: fly through a cooked scene, switch between the passes, tune the
//! god rays and the light while watching each pass's cost, and (`--watch`) re-cook a
//! `scene.toml` when one of its sources changes.
//!
//! One frame: stream in a few pack sections (a time budget keeps the window responsive while
//! large mips arrive), render the scene into a display image, draw the chosen view into it,
//! copy it to the window and draw the egui panel on top.

mod camera;
mod script;
mod ui;
mod views;
mod watch;

use std::path::{Path, PathBuf};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow};
use glam::Vec3;
use render::{FrameReport, Gpu, Renderer, Scene, Settings, TimingMethod, View};
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

use camera::{FlyCamera, MoveKeys, Pose};
use script::{Script, Step};
use ui::{Controls, LightEdit, Request};
use views::{Display, ViewMode};

/// How the window was asked for.
pub struct Options {
    pub input: PathBuf,
    /// Screenshots go here.
    pub out: PathBuf,
    /// Initial inner size of the window.
    pub size: (u32, u32),
    /// Start at this camera preset.
    pub camera: Option<String>,
    pub settings: Settings,
    pub watch: bool,
    pub vsync: bool,
    /// Draw the first frame at full size even on a CPU rasterizer.
    pub no_preview: bool,
    /// Load textures at most this many texels a side (`--max-texture-size`).
    pub max_texture_size: Option<u32>,
    /// Test hook: a `;`-separated list of steps (see `script.rs`).
    pub script: Option<String>,
}

/// How the window session ended.
pub enum Outcome {
    /// The user (or the script) closed the window.
    Closed,
    /// No window could be opened; the caller renders headless instead.
    NoDisplay(String),
}

/// Opens the window and runs until it is closed. Returns [`Outcome::NoDisplay`] (having shown
/// nothing) when there is no display to open a window on.
pub fn run(options: Options) -> Result<Outcome> {
    let has_display =
        std::env::var_os("DISPLAY").is_some() || std::env::var_os("WAYLAND_DISPLAY").is_some();
    if !has_display {
        return Ok(Outcome::NoDisplay(
            "no display found (DISPLAY and WAYLAND_DISPLAY are unset)".into(),
        ));
    }
    let script = match &options.script {
        Some(s) => Some(Script::parse(s).map_err(|e| anyhow!("--script: {e}"))?),
        None => None,
    };
    let event_loop = match event_loop() {
        Ok(l) => l,
        Err(e) => return Ok(Outcome::NoDisplay(format!("cannot open the display: {e}"))),
    };
    let mut app = App::new(options, script);
    event_loop
        .run_app(&mut app)
        .context("running the window's event loop")?;
    if let Some(e) = app.failure {
        return Err(e);
    }
    Ok(app.no_display.map_or(Outcome::Closed, Outcome::NoDisplay))
}

/// X11 when no Wayland compositor is announced: winit would otherwise try Wayland first,
/// and libwayland complains on stderr under Xvfb.
#[cfg(target_os = "linux")]
fn event_loop() -> Result<EventLoop<()>, winit::error::EventLoopError> {
    use winit::platform::x11::EventLoopBuilderExtX11;
    let mut builder = EventLoop::builder();
    if std::env::var_os("WAYLAND_DISPLAY").is_none() {
        builder.with_x11();
    }
    builder.build()
}

#[cfg(not(target_os = "linux"))]
fn event_loop() -> Result<EventLoop<()>, winit::error::EventLoopError> {
    EventLoop::new()
}

/// The scene being shown, with its renderer once the first frame can be drawn.
struct Shown {
    scene: Scene,
    renderer: Option<Renderer>,
    /// The pack's light, which the panel's light edits apply to.
    base_light: Option<pack::Light>,
    applied_light: Option<LightEdit>,
    /// Length scale for camera speed and the "no falloff" light.
    size: f32,
}

enum Phase {
    /// Cooking a `scene.toml` (or opening the pack) on a thread.
    Opening(mpsc::Receiver<Result<crate::Source>>),
    Streaming(mpsc::Receiver<crate::Message>),
}

struct Load {
    started: Instant,
    phase: Phase,
    /// A reload streams into a scene of its own and replaces the shown one when complete.
    replacement: Option<Scene>,
    is_reload: bool,
}

/// Everything that exists once the window is open.
struct Windowed {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// The view format the display image is copied into (sRGB where the surface allows).
    srgb_view: wgpu::TextureFormat,
    gpu: Gpu,
    display: Display,
    egui: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
}

struct App {
    options: Options,
    script: Option<Script>,
    win: Option<Windowed>,
    shown: Option<Shown>,
    load: Option<Load>,
    controls: Controls,
    camera: Option<FlyCamera>,
    keys: MoveKeys,
    drag: Option<(f64, f64)>,
    cursor: (f64, f64),
    report: Option<FrameReport>,
    timed: Option<FrameReport>,
    last_frame: Option<Instant>,
    frame_ms: f64,
    frames: u64,
    first_frame_ms: Option<f64>,
    full_quality_ms: Option<f64>,
    /// When the first load's last mip was uploaded.
    stream_done_ms: Option<f64>,
    watcher: Option<watch::Watcher>,
    /// Recent notes for the panel; `true` marks a problem.
    messages: Vec<(bool, String)>,
    screenshots: u32,
    pending_screenshot: Option<PathBuf>,
    failure: Option<anyhow::Error>,
    no_display: Option<String>,
    /// When the first load began, for the time to first frame.
    started: Instant,
}

fn effective_light(
    base: &pack::Light,
    edit: &LightEdit,
    size: f32,
    toc: &pack::Toc,
) -> pack::Light {
    let mut light = base.clone();
    light.colour = edit.colour;
    light.intensity = edit.intensity;
    if let (
        false,
        pack::LightKind::Point { position, radius }
        | pack::LightKind::Spot {
            position, radius, ..
        },
    ) = (edit.falloff, &mut light.kind)
    {
        // No falloff: clamp the distance term at a radius far beyond the scene, scaled so the
        // light arriving at the windows keeps its brightness; only the attenuation goes.
        let p = Vec3::from(*position);
        let reference = if toc.windows.is_empty() {
            size * 0.5
        } else {
            toc.windows
                .iter()
                .map(|w| {
                    let c =
                        Vec3::from(w.origin) + (Vec3::from(w.u_axis) + Vec3::from(w.v_axis)) * 0.5;
                    p.distance(c)
                })
                .sum::<f32>()
                / toc.windows.len() as f32
        };
        let reference = reference.max(*radius).max(1e-3);
        let far = 1e3 * (size + reference);
        *radius = far;
        light.intensity *= (far / reference).powi(2);
    }
    light
}

/// A length that makes camera speed sensible: how far the presets look, or the bounds'
/// diagonal (which a distant background may inflate) when there are none.
fn scene_size(scene: &Scene) -> f32 {
    let (lo, hi) = scene.bounds();
    let diagonal = (hi - lo).length();
    let looks = scene
        .toc()
        .cameras
        .iter()
        .map(|c| (Vec3::from(c.target) - Vec3::from(c.position)).length() * 2.0)
        .fold(0.0f32, f32::max);
    let size = if looks > 0.0 {
        looks.min(diagonal.max(looks * 0.1))
    } else {
        diagonal
    };
    if size.is_finite() && size > 0.0 {
        size
    } else {
        10.0
    }
}

fn key_name(code: KeyCode) -> Option<&'static str> {
    Some(match code {
        KeyCode::KeyW => "w",
        KeyCode::KeyA => "a",
        KeyCode::KeyS => "s",
        KeyCode::KeyD => "d",
        KeyCode::KeyQ => "q",
        KeyCode::KeyE => "e",
        KeyCode::KeyC => "c",
        KeyCode::KeyH => "h",
        KeyCode::Space => "space",
        KeyCode::ShiftLeft | KeyCode::ShiftRight => "shift",
        KeyCode::ControlLeft | KeyCode::ControlRight => "ctrl",
        KeyCode::F1 => "f1",
        KeyCode::F2 => "f2",
        KeyCode::F3 => "f3",
        KeyCode::F4 => "f4",
        KeyCode::F5 => "f5",
        KeyCode::F6 => "f6",
        KeyCode::F7 => "f7",
        KeyCode::F8 => "f8",
        KeyCode::F12 => "f12",
        KeyCode::KeyP => "p",
        KeyCode::Escape => "escape",
        KeyCode::Digit1 => "1",
        KeyCode::Digit2 => "2",
        KeyCode::Digit3 => "3",
        KeyCode::Digit4 => "4",
        KeyCode::Digit5 => "5",
        KeyCode::Digit6 => "6",
        KeyCode::Digit7 => "7",
        KeyCode::Digit8 => "8",
        KeyCode::Digit9 => "9",
        _ => return None,
    })
}

impl App {
    fn new(options: Options, script: Option<Script>) -> Self {
        let controls = Controls {
            settings: options.settings,
            light: None,
            view: ViewMode::Final,
            view_gain: 1.0,
            show_panel: true,
        };
        Self {
            options,
            script,
            win: None,
            shown: None,
            load: None,
            controls,
            camera: None,
            keys: MoveKeys::default(),
            drag: None,
            cursor: (0.0, 0.0),
            report: None,
            timed: None,
            last_frame: None,
            frame_ms: 0.0,
            frames: 0,
            first_frame_ms: None,
            full_quality_ms: None,
            stream_done_ms: None,
            watcher: None,
            messages: Vec::new(),
            screenshots: 0,
            pending_screenshot: None,
            failure: None,
            no_display: None,
            started: Instant::now(),
        }
    }

    /// Whether the input is cooked here (a scene.toml or a bare model), not a cooked pack.
    fn is_cooked_here(&self) -> bool {
        !self
            .options
            .input
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("pack"))
    }

    fn note(&mut self, message: String) {
        println!("{message}");
        self.remember(false, message);
    }

    fn warn(&mut self, message: String) {
        eprintln!("warning: {message}");
        self.remember(true, message);
    }

    fn remember(&mut self, problem: bool, message: String) {
        self.messages.push((problem, message));
        if self.messages.len() > 20 {
            self.messages.remove(0);
        }
    }

    fn start_load(&mut self, is_reload: bool) {
        let (tx, rx) = mpsc::channel();
        let path = self.options.input.clone();
        std::thread::spawn(move || {
            let _ = tx.send(crate::open_source(&path));
        });
        self.load = Some(Load {
            started: Instant::now(),
            phase: Phase::Opening(rx),
            replacement: None,
            is_reload,
        });
    }

    /// Opens the window, the GPU and egui, and starts loading.
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let (w, h) = self.options.size;
        let attributes = Window::default_attributes()
            .with_title(format!("viewer — {}", self.options.input.display()))
            .with_inner_size(winit::dpi::PhysicalSize::new(w, h));
        let window = match event_loop.create_window(attributes) {
            Ok(w) => Arc::new(w),
            Err(e) => {
                self.no_display = Some(format!("cannot open a window: {e}"));
                return Ok(());
            }
        };
        let instance = wgpu::Instance::new(render::supported_backends(
            wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
                event_loop.owned_display_handle(),
            )),
        ));
        let surface = instance
            .create_surface(window.clone())
            .context("creating the window's surface")?;
        let mut gpu = Gpu::new(instance, Some(&surface))?;
        crate::cap_texture_side(&mut gpu, self.options.max_texture_size);
        println!("adapter: {}", gpu.describe());
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&gpu.adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| anyhow!("the adapter cannot present to this window"))?;
        let caps = surface.get_capabilities(&gpu.adapter);
        // egui wants a linear (non-sRGB) target; the display image goes through an sRGB view
        // of the same texture where the surface allows one.
        let format = [
            wgpu::TextureFormat::Bgra8Unorm,
            wgpu::TextureFormat::Rgba8Unorm,
        ]
        .into_iter()
        .find(|f| caps.formats.contains(f))
        .unwrap_or(config.format.remove_srgb_suffix());
        config.format = format;
        let srgb_view = format.add_srgb_suffix();
        config.view_formats = if srgb_view != format {
            vec![srgb_view]
        } else {
            Vec::new()
        };
        config.present_mode = if self.options.vsync {
            wgpu::PresentMode::AutoVsync
        } else {
            wgpu::PresentMode::AutoNoVsync
        };
        surface.configure(&gpu.device, &config);
        let display = Display::new(&gpu.device, (config.width, config.height), srgb_view);
        let ctx = egui::Context::default();
        let egui = egui_winit::State::new(
            ctx,
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(gpu.device.limits().max_texture_dimension_2d as usize),
        );
        let egui_renderer =
            egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        self.win = Some(Windowed {
            window: window.clone(),
            surface,
            config,
            srgb_view,
            gpu,
            display,
            egui,
            egui_renderer,
        });
        if self.options.watch {
            if self.is_cooked_here() {
                let w = watch::Watcher::new(&self.options.input);
                let n = w.files().count();
                self.note(format!(
                    "watching {n} source files of {}",
                    self.options.input.display()
                ));
                self.watcher = Some(w);
            } else {
                self.note(
                    "--watch applies to a scene.toml or a model; a pack is shown as is".into(),
                );
            }
        }
        self.start_load(false);
        window.request_redraw();
        Ok(())
    }

    /// Feeds arriving sections to the GPU for at most `budget`.
    fn pump_load(&mut self, budget: Duration) -> Result<()> {
        let Some(win) = &self.win else { return Ok(()) };
        let gpu = &win.gpu;
        let start = Instant::now();
        let Some(load) = &mut self.load else {
            return Ok(());
        };
        if let Phase::Opening(rx) = &load.phase {
            match rx.try_recv() {
                Ok(Ok(source)) => {
                    load.phase = Phase::Streaming(crate::stream(
                        self.options.input.clone(),
                        source,
                        gpu.texture_caps(),
                    ));
                }
                Ok(Err(e)) => {
                    let is_reload = load.is_reload;
                    self.load = None;
                    if is_reload {
                        self.warn(format!("re-cook failed, keeping the old scene: {e:#}"));
                        return Ok(());
                    }
                    return Err(e);
                }
                Err(mpsc::TryRecvError::Empty) => return Ok(()),
                Err(mpsc::TryRecvError::Disconnected) => {
                    return Err(anyhow!("the loading thread ended without an answer"));
                }
            }
        }
        let Phase::Streaming(rx) = &load.phase else {
            return Ok(());
        };
        let mut finished = false;
        while start.elapsed() < budget {
            let message = match rx.try_recv() {
                Ok(m) => m,
                Err(mpsc::TryRecvError::Empty) => break,
                Err(mpsc::TryRecvError::Disconnected) => {
                    return Err(anyhow!("the pack reader thread ended unexpectedly"));
                }
            };
            match message {
                crate::Message::Toc(toc) => {
                    let scene = Scene::new(gpu, &toc)?;
                    if load.is_reload {
                        load.replacement = Some(scene);
                    } else {
                        let size = scene_size(&scene);
                        self.shown = Some(Shown {
                            base_light: toc.light.clone(),
                            applied_light: None,
                            scene,
                            renderer: None,
                            size,
                        });
                    }
                }
                crate::Message::Section(section) => {
                    let scene = if load.is_reload {
                        load.replacement.as_mut()
                    } else {
                        self.shown.as_mut().map(|s| &mut s.scene)
                    };
                    scene
                        .context("a section arrived before the TOC")?
                        .upload_section(gpu, &section)?;
                }
                crate::Message::Done => {
                    finished = true;
                    break;
                }
                crate::Message::Failed(e) => {
                    let e = anyhow::Error::from(e)
                        .context(format!("reading {}", self.options.input.display()));
                    if load.is_reload {
                        let msg = format!("reload failed, keeping the old scene: {e:#}");
                        self.load = None;
                        self.warn(msg);
                        return Ok(());
                    }
                    return Err(e);
                }
            }
        }
        if finished {
            let load = self.load.take().expect("load in progress");
            let ms = load.started.elapsed().as_secs_f64() * 1e3;
            if let Some(scene) = load.replacement {
                let size = scene_size(&scene);
                let base_light = scene.toc().light.clone();
                self.shown = Some(Shown {
                    scene,
                    renderer: None,
                    base_light,
                    applied_light: None,
                    size,
                });
                self.controls.light = None;
                self.note(format!(
                    "reloaded {} in {ms:.0} ms",
                    self.options.input.display()
                ));
            } else {
                // Full quality is said when a frame shows it (see `redraw`): the last mip can
                // arrive before the first frame, when the window opens late.
                self.stream_done_ms = Some(ms);
            }
            // The cook behind it says what it read: the watch list follows (the first cook's
            // too, which comes after the watcher was made from the manifest alone).
            if let Some(w) = &mut self.watcher {
                w.rescan();
            }
        }
        Ok(())
    }

    /// Creates the renderer (and camera) once the shown scene can draw a first frame.
    fn prepare(&mut self) -> Result<()> {
        let (Some(win), Some(shown)) = (&mut self.win, &mut self.shown) else {
            return Ok(());
        };
        let gpu = &win.gpu;
        shown.scene.refresh(gpu);
        if shown.renderer.is_none() && shown.scene.ready_for_first_frame() {
            let (w, h) = win.display.size();
            // The very first frame may be a smaller preview (see `Gpu::first_frame_divisor`);
            // the frame after it is drawn at full size.
            let div = if self.first_frame_ms.is_none() && !self.options.no_preview {
                gpu.first_frame_divisor()
            } else {
                1
            };
            let renderer = Renderer::new(
                gpu,
                &shown.scene,
                (w / div).max(1),
                (h / div).max(1),
                views::DISPLAY_FORMAT,
                false,
                self.controls.settings,
            )?;
            win.display
                .set_materials(&gpu.device, &gpu.queue, shown.scene.toc().materials.len());
            if self.controls.light.is_none() {
                self.controls.light = shown.base_light.as_ref().map(|l| LightEdit {
                    colour: l.colour,
                    intensity: l.intensity,
                    falloff: true,
                });
            }
            if self.camera.is_none() {
                let toc = shown.scene.toc();
                let preset = match &self.options.camera {
                    // `all` is every camera headless; here, where one is shown, the first.
                    Some(name) if name == "all" && toc.cameras.iter().all(|c| c.name != "all") => {
                        toc.cameras.first()
                    }
                    Some(name) => {
                        let found = toc.cameras.iter().find(|c| &c.name == name);
                        if found.is_none() {
                            let names: Vec<&str> =
                                toc.cameras.iter().map(|c| c.name.as_str()).collect();
                            self.messages.push((
                                true,
                                format!("no camera named {name:?} (cameras: {})", names.join(", ")),
                            ));
                        }
                        found
                    }
                    None => toc.cameras.first(),
                };
                self.camera = Some(match preset {
                    Some(c) => FlyCamera::new(Pose::from_camera(c), shown.size, c.near, c.far),
                    None => {
                        let (lo, hi) = shown.scene.framing_bounds();
                        let v = View::framing(lo, hi, w as f32 / h as f32);
                        let radius = (hi - lo).length() * 0.5;
                        FlyCamera::new(
                            Pose::looking(v.position, v.forward, v.fov_y.to_degrees()),
                            shown.size,
                            (radius * 0.005).max(1e-3),
                            radius * 20.0,
                        )
                    }
                });
            }
            shown.renderer = Some(renderer);
        }
        Ok(())
    }

    fn go_to_preset(&mut self, index: usize) {
        let Some(shown) = &self.shown else { return };
        let Some(c) = shown.scene.toc().cameras.get(index) else {
            let n = shown.scene.toc().cameras.len();
            self.warn(format!(
                "no camera preset {} (this scene has {n})",
                index + 1
            ));
            return;
        };
        let pose = Pose::from_camera(c);
        let (near, far) = (c.near, c.far);
        if let Some(cam) = &mut self.camera {
            cam.go_to(pose, near, far, 0.6);
        }
    }

    fn screenshot_path(&mut self) -> PathBuf {
        self.screenshots += 1;
        self.options.out.join(format!(
            "screenshot-{}-{:03}.png",
            self.controls.view.key(),
            self.screenshots
        ))
    }

    /// A key from the keyboard or the script.
    fn key(&mut self, event_loop: &ActiveEventLoop, name: &str, pressed: bool) {
        match name {
            "w" => self.keys.forward = pressed,
            "s" => self.keys.back = pressed,
            "a" => self.keys.left = pressed,
            "d" => self.keys.right = pressed,
            "space" | "e" => self.keys.up = pressed,
            "q" | "c" => self.keys.down = pressed,
            "shift" => self.keys.fast = pressed,
            "ctrl" => self.keys.slow = pressed,
            _ if !pressed => {}
            "h" => self.controls.show_panel = !self.controls.show_panel,
            "f12" | "p" => {
                let path = self.screenshot_path();
                self.pending_screenshot = Some(path);
            }
            "escape" => event_loop.exit(),
            f if f.starts_with('f') => {
                if let Some(i) = f[1..]
                    .parse::<usize>()
                    .ok()
                    .filter(|i| (1..=ViewMode::ALL.len()).contains(i))
                {
                    self.controls.view = ViewMode::ALL[i - 1];
                }
            }
            d => {
                if let Ok(i) = d.parse::<usize>()
                    && (1..=9).contains(&i)
                {
                    self.go_to_preset(i - 1);
                }
            }
        }
    }

    /// Runs script steps until one waits; returns false when the script asks to quit.
    fn run_script(&mut self, event_loop: &ActiveEventLoop) -> Result<bool> {
        let ready =
            self.shown.as_ref().is_some_and(|s| s.renderer.is_some()) && self.report.is_some();
        if !ready {
            return Ok(true);
        }
        let loaded = self.load.is_none();
        let Some(mut script) = self.script.take() else {
            return Ok(true);
        };
        let mut keep_going = true;
        while let Some(step) = script.next(loaded) {
            match step {
                Step::View(v) => self.controls.view = v,
                Step::Camera(i) => self.go_to_preset(i),
                Step::Key(k, pressed) => self.key(event_loop, &k, pressed),
                Step::Look(dx, dy) => {
                    if let Some(c) = &mut self.camera {
                        c.look(dx, dy);
                    }
                }
                Step::Set(name, value) => script::apply_setting(&mut self.controls, &name, value)
                    .map_err(|e| anyhow!("--script: {e}"))?,
                Step::Resize(w, h) => {
                    if let Some(win) = &self.win {
                        let _ = win
                            .window
                            .request_inner_size(winit::dpi::PhysicalSize::new(w, h));
                    }
                }
                Step::Shot(path) => {
                    let path = match path {
                        Some(p) => p,
                        None => self.screenshot_path(),
                    };
                    self.pending_screenshot = Some(path);
                    // The shot shows the state so far; later steps wait for the next frame.
                    break;
                }
                Step::Quit => {
                    keep_going = false;
                    break;
                }
            }
        }
        self.script = Some(script);
        Ok(keep_going)
    }

    fn resize(&mut self, width: u32, height: u32) {
        let Some(win) = &mut self.win else { return };
        if width == 0 || height == 0 {
            return;
        }
        win.config.width = width;
        win.config.height = height;
        win.surface.configure(&win.gpu.device, &win.config);
        win.display.resize(&win.gpu.device, (width, height));
        if let Some(r) = self.shown.as_mut().and_then(|s| s.renderer.as_mut()) {
            r.resize(&win.gpu, width, height);
        }
    }

    fn save_screenshot(&mut self, path: &Path) -> Result<()> {
        let Some(win) = &self.win else { return Ok(()) };
        let img = views::read_rgba8(
            &win.gpu.device,
            &win.gpu.queue,
            win.display.display_texture(),
        )?;
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        crate::write_png(img, path).context("the screenshot")?;
        self.note(format!("wrote {}", path.display()));
        Ok(())
    }

    /// One frame. Returns false to close the window.
    fn frame(&mut self, event_loop: &ActiveEventLoop) -> Result<bool> {
        let now = Instant::now();
        let dt = match (self.script.is_some(), self.last_frame) {
            // Scripted runs move by a fixed step per frame, so they are reproducible.
            (true, _) => 1.0 / 30.0,
            (false, Some(t)) => now.duration_since(t).as_secs_f32(),
            (false, None) => 0.0,
        };
        if let Some(t) = self.last_frame {
            let ms = now.duration_since(t).as_secs_f64() * 1e3;
            self.frame_ms = if self.frame_ms == 0.0 {
                ms
            } else {
                self.frame_ms * 0.9 + ms * 0.1
            };
        }
        self.last_frame = Some(now);

        if let Some(w) = &mut self.watcher
            && w.poll(now)
            && self.load.is_none()
        {
            self.note(format!(
                "a source changed: re-cooking {}",
                self.options.input.display()
            ));
            self.start_load(true);
        }
        self.pump_load(Duration::from_millis(12))?;
        self.prepare()?;
        // A script's `quit` still finishes this frame, so a screenshot just before it is taken.
        let keep_open = self.script.is_none() || self.run_script(event_loop)?;

        let cooked_here = self.is_cooked_here();
        let Some(win) = &mut self.win else {
            return Ok(keep_open);
        };
        let aspect = win.config.width as f32 / win.config.height.max(1) as f32;
        let view = self.camera.as_mut().map(|c| {
            c.update(&self.keys, dt);
            c.view(aspect)
        });

        // Panel edits reach the renderer and the scene's light before drawing.
        if let Some(shown) = &mut self.shown {
            if shown.applied_light != self.controls.light
                && let (Some(base), Some(edit)) = (&shown.base_light, &self.controls.light)
            {
                let light = effective_light(base, edit, shown.size, shown.scene.toc());
                shown.scene.set_light(Some(light));
                shown.applied_light = self.controls.light;
            }
            if let Some(r) = &mut shown.renderer
                && *r.settings() != self.controls.settings
            {
                r.set_settings(&win.gpu, self.controls.settings);
            }
        }

        let frame = match win.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) => Some((t, false)),
            wgpu::CurrentSurfaceTexture::Suboptimal(t) => Some((t, true)),
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => None,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                win.surface.configure(&win.gpu.device, &win.config);
                None
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                return Err(anyhow!("the window's surface reported a validation error"));
            }
        };
        let Some((frame, suboptimal)) = frame else {
            return Ok(keep_open);
        };
        let gpu = &win.gpu;

        // The scene into the display image.
        let mut drew_scene = false;
        if let (Some(shown), Some(view)) = (&mut self.shown, &view)
            && let Some(renderer) = &mut shown.renderer
        {
            let timing = if gpu.timestamps {
                TimingMethod::GpuTimestamps
            } else if self.frames.is_multiple_of(30) {
                // Without timestamp queries each pass is timed alone with a wait in between,
                // which stalls the frame: sample it now and then.
                TimingMethod::CpuWallClock
            } else {
                TimingMethod::None
            };
            let report =
                renderer.render_to(gpu, &shown.scene, view, win.display.display_view(), timing)?;
            if report.method != TimingMethod::None {
                self.timed = Some(report.clone());
            }
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            win.display.draw_view(
                gpu,
                &mut encoder,
                self.controls.view,
                &views::Drawn {
                    renderer,
                    report: Some(&report),
                    scene: &shown.scene,
                    view,
                    gain: self.controls.view_gain,
                },
            );
            gpu.queue.submit([encoder.finish()]);
            self.report = Some(report);
            drew_scene = true;
            if self.first_frame_ms.is_none() {
                let ms = self.started.elapsed().as_secs_f64() * 1e3;
                let st = shown.scene.status();
                let (w, h) = renderer.size();
                let preview = if (w, h) == win.display.size() {
                    String::new()
                } else {
                    format!("{w}x{h} preview, ")
                };
                println!(
                    "first frame after {ms:.1} ms ({preview}geometry + {}/{} mips)",
                    st.mips_loaded, st.mips_total
                );
                self.first_frame_ms = Some(ms);
            }
            if self.full_quality_ms.is_none()
                && self.stream_done_ms.is_some()
                && renderer.size() == win.display.size()
            {
                let ms = self.started.elapsed().as_secs_f64() * 1e3;
                println!("full quality after {ms:.1} ms");
                self.full_quality_ms = Some(ms);
            }
            if renderer.size() != win.display.size() {
                let (w, h) = win.display.size();
                renderer.resize(gpu, w, h);
            }
        }

        let surface_view = frame.texture.create_view(&Default::default());
        let srgb_view = frame.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(win.srgb_view),
            ..Default::default()
        });
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        if drew_scene {
            win.display.present(gpu, &mut encoder, &srgb_view);
        }

        // The panel.
        let raw = win.egui.take_egui_input(&win.window);
        let mut requests = Vec::new();
        let shown = self.shown.as_ref();
        let toc = shown.map(|s| s.scene.toc());
        let loading = match &self.load {
            Some(Load {
                phase: Phase::Opening(_),
                is_reload,
                ..
            }) => Some(if *is_reload || cooked_here {
                "cooking…"
            } else {
                "opening…"
            }),
            Some(Load {
                is_reload: true, ..
            }) => Some("reloading…"),
            _ => None,
        };
        let watch_label = self
            .watcher
            .as_ref()
            .map(|w| format!("watching {} files", w.files().count()));
        // Times from the last timed frame, with the skip reasons of this one.
        let merged = self.report.as_ref().map(|r| {
            let mut r = r.clone();
            if let Some(t) = &self.timed {
                r.method = t.method;
                for p in &mut r.passes {
                    if p.skipped.is_none() && p.ms.is_none() {
                        p.ms = t
                            .passes
                            .iter()
                            .find(|q| q.pass == p.pass)
                            .and_then(|q| q.ms);
                    }
                }
            }
            r
        });
        let info = ui::Info {
            adapter: &gpu.adapter.get_info().name,
            size: (win.config.width, win.config.height),
            vsync: self.options.vsync,
            frame_ms: self.frame_ms,
            report: merged.as_ref(),
            status: shown.map(|s| s.scene.status()),
            first_frame_ms: self.first_frame_ms,
            full_quality_ms: self.full_quality_ms,
            loading,
            cameras: toc.map_or_else(Vec::new, |t| {
                t.cameras.iter().map(|c| c.name.as_str()).collect()
            }),
            materials: toc.map_or_else(Vec::new, |t| {
                t.materials
                    .iter()
                    .map(|m| (m.name.as_str(), m.class.name()))
                    .collect()
            }),
            point_light: matches!(
                shown.and_then(|s| s.base_light.as_ref()).map(|l| &l.kind),
                Some(pack::LightKind::Point { .. } | pack::LightKind::Spot { .. })
            ),
            watch: watch_label.as_deref(),
            messages: &self.messages,
        };
        let controls = &mut self.controls;
        let mut output = win.egui.egui_ctx().run_ui(raw, |ui| {
            if controls.show_panel {
                egui::Panel::left("controls")
                    .default_size(320.0)
                    .resizable(true)
                    .show(ui, |ui| {
                        requests = ui::panel(ui, controls, &info);
                    });
            }
            if controls.view == ViewMode::MaterialIds {
                // The legend floats over the view it explains, panel shown or not.
                egui::Window::new("material IDs")
                    .anchor(egui::Align2::RIGHT_TOP, [-8.0, 8.0])
                    .resizable(false)
                    .show(ui.ctx(), |ui| {
                        egui::ScrollArea::vertical().show(ui, |ui| ui::legend(ui, &info.materials))
                    });
            }
        });
        drop(info);
        win.egui
            .handle_platform_output(&win.window, std::mem::take(&mut output.platform_output));
        let jobs = win
            .egui
            .egui_ctx()
            .tessellate(std::mem::take(&mut output.shapes), output.pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [win.config.width, win.config.height],
            pixels_per_point: output.pixels_per_point,
        };
        for (id, deltas) in output.textures_delta.set.drain() {
            for delta in &deltas {
                win.egui_renderer
                    .update_texture(&gpu.device, &gpu.queue, id, delta);
            }
        }
        let extra =
            win.egui_renderer
                .update_buffers(&gpu.device, &gpu.queue, &mut encoder, &jobs, &screen);
        {
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("egui"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &surface_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: if drew_scene {
                            wgpu::LoadOp::Load
                        } else {
                            wgpu::LoadOp::Clear(wgpu::Color {
                                r: 0.02,
                                g: 0.02,
                                b: 0.03,
                                a: 1.0,
                            })
                        },
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            win.egui_renderer
                .render(&mut pass.forget_lifetime(), &jobs, &screen);
        }
        gpu.queue
            .submit(extra.into_iter().chain([encoder.finish()]));
        win.window.pre_present_notify();
        gpu.queue.present(frame);
        for id in output.textures_delta.free.drain() {
            win.egui_renderer.free_texture(&id);
        }
        if suboptimal {
            win.surface.configure(&gpu.device, &win.config);
        }
        self.frames += 1;

        for r in requests {
            match r {
                Request::Camera(i) => self.go_to_preset(i),
                Request::Screenshot => {
                    let path = self.screenshot_path();
                    self.pending_screenshot = Some(path);
                }
                Request::Reload => {
                    if self.load.is_none() && self.shown.is_some() {
                        self.note(format!("re-cooking {}", self.options.input.display()));
                        self.start_load(true);
                    }
                }
            }
        }
        if let Some(path) = self.pending_screenshot.take() {
            if drew_scene {
                self.save_screenshot(&path)?;
            } else {
                self.warn("nothing drawn yet: screenshot skipped".into());
            }
        }
        Ok(keep_open)
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.win.is_some() || self.failure.is_some() {
            return;
        }
        if let Err(e) = self.open(event_loop) {
            self.failure = Some(e);
        }
        if self.failure.is_some() || self.no_display.is_some() {
            event_loop.exit();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(win) = &mut self.win else { return };
        let response = win.egui.on_window_event(&win.window, &event);
        let egui_keyboard = win.egui.egui_ctx().egui_wants_keyboard_input();
        let egui_pointer = win.egui.egui_ctx().egui_wants_pointer_input();
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => self.resize(size.width, size.height),
            WindowEvent::RedrawRequested => match self.frame(event_loop) {
                Ok(true) => {}
                Ok(false) => event_loop.exit(),
                Err(e) => {
                    self.failure = Some(e);
                    event_loop.exit();
                }
            },
            WindowEvent::KeyboardInput { event, .. } => {
                // Releases always count, so a key held while focus moved to egui is let go.
                let pressed = event.state == ElementState::Pressed;
                if (response.consumed || egui_keyboard) && pressed {
                    return;
                }
                if event.repeat {
                    return;
                }
                if let PhysicalKey::Code(code) = event.physical_key
                    && let Some(name) = key_name(code)
                {
                    self.key(event_loop, name, pressed);
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let look_button = matches!(button, MouseButton::Left | MouseButton::Right);
                match state {
                    ElementState::Pressed if look_button && !egui_pointer => {
                        self.drag = Some(self.cursor);
                    }
                    ElementState::Released if look_button => self.drag = None,
                    _ => {}
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor = (position.x, position.y);
                if let Some((x, y)) = self.drag {
                    if let Some(c) = &mut self.camera {
                        c.look((position.x - x) as f32, (position.y - y) as f32);
                    }
                    self.drag = Some(self.cursor);
                }
            }
            WindowEvent::MouseWheel { delta, .. } if !egui_pointer => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                if let Some(c) = &mut self.camera {
                    c.speed = (c.speed * 1.2f32.powf(lines)).clamp(1e-4, 1e6);
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        // Continuous redraw: vsync (or the GPU) paces the loop, and streaming, transitions
        // and timings need frames even without input.
        if let Some(win) = &self.win {
            win.window.request_redraw();
        }
    }
}
