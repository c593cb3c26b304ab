//! Helpers shared by the GPU tests: one device per test binary and synthetic packs.

// Each test crate compiles this module and uses a different subset of it.
#![allow(dead_code)]

use std::sync::{Mutex, MutexGuard, OnceLock};

use glam::Vec3;
use pack::{DrawRange, IndexFormat, Mesh, MeshData, PackData, StandardVertex, Toc};
use render::{Gpu, Scene};

/// One device for the whole test binary (lavapipe is slow to start), used by one test at a
/// time so timings and memory stay predictable. No adapter fails the test, never skips it.
pub fn gpu() -> MutexGuard<'static, Gpu> {
    static GPU: OnceLock<Mutex<Gpu>> = OnceLock::new();
    GPU.get_or_init(|| {
        let gpu = Gpu::headless().unwrap_or_else(|e| panic!("GPU tests need an adapter: {e}"));
        eprintln!("adapter: {}", gpu.describe());
        Mutex::new(gpu)
    })
    .lock()
    .unwrap_or_else(|p| p.into_inner())
}

/// Like [`gpu`], but on lavapipe whatever else the machine has: the images in
/// `data/reference` were rendered there, and the tests hold renders to within a few 8-bit
/// steps of them. An NVIDIA H100 drew the same frames within FLIP mean 0.010–0.022 but up to
/// 116 steps apart at lead lines and tile edges (its texture filtering and edge rules differ),
/// while the tests that compare with analytic or ray-traced references pass there.
pub fn lavapipe() -> MutexGuard<'static, Gpu> {
    static GPU: OnceLock<Mutex<Gpu>> = OnceLock::new();
    GPU.get_or_init(|| {
        let gpu = Gpu::headless_matching("lavapipe", |info| info.name.starts_with("llvmpipe"))
            .unwrap_or_else(|e| {
                panic!(
                    "{e}: the golden images were rendered on lavapipe; install it \
                 (mesa-vulkan-drivers, as scripts/install-test-deps.sh does)"
                )
            });
        eprintln!("adapter: {}", gpu.describe());
        Mutex::new(gpu)
    })
    .lock()
    .unwrap_or_else(|p| p.into_inner())
}

/// Uploads a pack's bytes.
pub fn load(gpu: &Gpu, bytes: &[u8]) -> Scene {
    let pack = pack::Pack::from_bytes("<synthetic>", bytes).expect("valid pack");
    Scene::from_pack(gpu, &pack).expect("upload")
}

/// A pack of `toc` and `data` plus one mesh, "scene", of standard vertices (and their
/// colours, where some vertex is not white) and 32-bit indices drawn in `ranges`.
pub fn encode_scene(
    mut toc: Toc,
    mut data: PackData,
    vertices: &[StandardVertex],
    indices: &[u32],
    ranges: Vec<DrawRange>,
) -> Vec<u8> {
    let (lo, hi) = vertices.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), v| {
            let p = Vec3::from(v.position);
            (lo.min(p), hi.max(p))
        },
    );
    let everything = pack::vertex::Encoding {
        normal: true,
        uv: true,
        tangent: true,
        colour: vertices.iter().any(|v| v.colour != pack::vertex::WHITE),
        quantize: None,
    };
    let layout = pack::vertex::layout(everything, false, [0.0; 3], [1.0; 3]);
    toc.meshes.push(Mesh {
        name: "scene".into(),
        layout: layout.clone(),
        vertex_count: vertices.len() as u32,
        index_count: indices.len() as u32,
        index_format: IndexFormat::U32,
        vertex_section: 0,
        index_section: 0,
        bounds_min: lo.to_array(),
        bounds_max: hi.to_array(),
        ranges,
    });
    data.meshes.push(MeshData {
        vertices: layout.encode_vertices(vertices),
        indices: bytemuck::cast_slice(indices).to_vec(),
    });
    pack::encode(toc, &data).expect("synthetic pack is valid")
}

#[allow(unused_imports)] // not every test binary compares with the reference
pub use render::reference::tone_mapped;

/// Mean FLIP error (LDR) of `test` against `reference`.
pub fn flip_mean(reference: &image::RgbImage, test: &image::RgbImage) -> f32 {
    let (w, h) = reference.dimensions();
    let error = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w, h, reference),
        nv_flip::FlipImageRgb8::with_data(w, h, test),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    nv_flip::FlipPool::from_image(&error).mean()
}
