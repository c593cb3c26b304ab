//! Helpers shared by the GPU tests: one device per test binary and synthetic packs.

// Each test crate compiles this module and uses a different subset of it.
#![allow(dead_code)]

use std::sync::{Mutex, MutexGuard, OnceLock};

use glam::Vec3;
use pack::{DrawRange, IndexFormat, Mesh, MeshData, PackData, StandardVertex, Toc, VertexLayout};
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

/// Uploads a pack's bytes.
pub fn load(gpu: &Gpu, bytes: &[u8]) -> Scene {
    let pack = pack::Pack::from_bytes("<synthetic>", bytes).expect("valid pack");
    Scene::from_pack(gpu, &pack).expect("upload")
}

/// A pack of `toc` and `data` plus one mesh, "scene", of standard vertices and 32-bit indices
/// drawn in `ranges`.
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
    toc.meshes.push(Mesh {
        name: "scene".into(),
        layout: VertexLayout::standard(),
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
        vertices: bytemuck::cast_slice(vertices).to_vec(),
        indices: bytemuck::cast_slice(indices).to_vec(),
    });
    pack::encode(toc, &data).expect("synthetic pack is valid")
}

/// A linear HDR image (the lit target, or the CPU reference) as the composite would show it
/// without glass or god rays: exposure 1, Narkowicz's ACES fit, sRGB, 8 bits.
pub fn tone_mapped(w: u32, h: u32, px: &[[f32; 4]]) -> image::RgbImage {
    let aces = |x: f32| {
        let x = x.max(0.0);
        ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
    };
    let srgb = |c: f32| {
        let s = if c <= 0.0031308 {
            c * 12.92
        } else {
            1.055 * c.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round().clamp(0.0, 255.0) as u8
    };
    image::RgbImage::from_fn(w, h, |x, y| {
        let p = px[(y * w + x) as usize];
        image::Rgb([0, 1, 2].map(|c| srgb(aces(p[c]))))
    })
}

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
