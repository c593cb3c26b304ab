//! WGSL sources, one file per pass under `shaders/`, with shared includes.
//!
//! WGSL has no include mechanism; a pass file names its includes in `//#include file.wgsl`
//! comment lines, which keeps every file valid WGSL syntax for editors, and the composed
//! module is what naga and the GPU see.

/// Every shader file, by name.
pub const FILES: &[(&str, &str)] = &[
    ("common.wgsl", include_str!("../../../shaders/common.wgsl")),
    (
        "fullscreen.wgsl",
        include_str!("../../../shaders/fullscreen.wgsl"),
    ),
    (
        "background.wgsl",
        include_str!("../../../shaders/background.wgsl"),
    ),
    (
        "windows.wgsl",
        include_str!("../../../shaders/windows.wgsl"),
    ),
    (
        "normals.wgsl",
        include_str!("../../../shaders/normals.wgsl"),
    ),
    ("lit.wgsl", include_str!("../../../shaders/lit.wgsl")),
    (
        "godrays.wgsl",
        include_str!("../../../shaders/godrays.wgsl"),
    ),
    (
        "composite.wgsl",
        include_str!("../../../shaders/composite.wgsl"),
    ),
    ("blit.wgsl", include_str!("../../../shaders/blit.wgsl")),
    ("sky.wgsl", include_str!("../../../shaders/sky.wgsl")),
    ("shadow.wgsl", include_str!("../../../shaders/shadow.wgsl")),
    (
        "shadow_view.wgsl",
        include_str!("../../../shaders/shadow_view.wgsl"),
    ),
];

/// The pass entry files; each composes into one shader module.
pub const PASSES: &[&str] = &[
    "background.wgsl",
    "windows.wgsl",
    "normals.wgsl",
    "lit.wgsl",
    "godrays.wgsl",
    "composite.wgsl",
    "blit.wgsl",
    "sky.wgsl",
    "shadow.wgsl",
    "shadow_view.wgsl",
];

/// Passes that write depth only and have no fragment stage.
pub const DEPTH_ONLY: &[&str] = &["shadow.wgsl"];

const INCLUDE: &str = "//#include ";

fn file(name: &str) -> Option<&'static str> {
    FILES.iter().find(|(n, _)| *n == name).map(|(_, s)| *s)
}

/// The composed source of a pass file: its includes (recursively, each once) followed by the
/// file itself. `None` for an unknown file or include.
pub fn compose(name: &str) -> Option<String> {
    let mut out = String::new();
    let mut seen = Vec::new();
    append(name, &mut out, &mut seen)?;
    Some(out)
}

/// Composes a WGSL source that lives outside this crate (the viewer's own passes) with this
/// crate's includes, so shared pieces such as `fullscreen.wgsl` exist once.
pub fn compose_source(name: &str, src: &str) -> Option<String> {
    let mut out = String::new();
    let mut seen = vec![name.to_owned()];
    append_source(name, src, &mut out, &mut seen)?;
    Some(out)
}

fn append(name: &str, out: &mut String, seen: &mut Vec<String>) -> Option<()> {
    if seen.iter().any(|s| s == name) {
        return Some(());
    }
    seen.push(name.to_owned());
    append_source(name, file(name)?, out, seen)
}

fn append_source(name: &str, src: &str, out: &mut String, seen: &mut Vec<String>) -> Option<()> {
    for line in src.lines() {
        if let Some(inc) = line.trim().strip_prefix(INCLUDE) {
            append(inc.trim(), out, seen)?;
        }
    }
    out.push_str(&format!("// ---- {name} ----\n"));
    out.push_str(src);
    out.push('\n');
    Some(())
}

/// Creates the shader module of a pass file.
pub(crate) fn module(device: &wgpu::Device, name: &'static str) -> wgpu::ShaderModule {
    let source = compose(name).unwrap_or_else(|| panic!("shader {name} is compiled in"));
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(name),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    })
}
