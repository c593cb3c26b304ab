//! The scene on the GPU: geometry, textures and materials, filled section by section as a pack
//! arrives. Textures exist at full size from the start; a texture's view covers the levels
//! resident so far (they arrive smallest first), and a placeholder stands in until its first
//! level is in.

use pack::{MaterialClass, SectionRole, StandardVertex, Toc, VertexLayout};

use crate::occlusion::{self, WindowShadow};
use crate::projectors::Projectors;
use crate::uniforms;
use crate::view::LightGeometry;
use crate::{Gpu, RenderError, TextureCaps};

#[derive(Default)]
struct CpuMesh {
    positions: Option<Vec<glam::Vec3>>,
    indices: Option<Vec<u32>>,
    /// The vertices' material IDs, from their section's arrival to their indices': each
    /// triangle's must be its draw range's (the pack's own checks see one section at a time).
    materials: Option<Vec<u16>>,
    /// A mesh's index bytes where they arrived before its vertices.
    indices_bytes: Option<Vec<u8>>,
    /// Opaque triangles (by their first index) that are part of a backed window's uncut wall
    /// ([`occlusion::Backings`]), ascending: they cast no shadow.
    backing: Vec<u32>,
}

/// Mips up to this many bytes as RGBA8 (64×64 texels) count as "small": the first frame waits
/// for them. Counted as RGBA8 whatever the stored format, as the pack streams them (by texel
/// count), so a block-compressed pack's first frame waits for the same levels as an
/// uncompressed one: counted in stored bytes (a quarter of them in BC7) it waited for 112 of
/// the default scene's 157 levels instead of 105, and drew and decoded the larger ones.
pub const SMALL_MIP_BYTES: u64 = 64 * 64 * 4;

pub(crate) struct Placeholders {
    pub white_srgb: wgpu::TextureView,
    pub flat_normal: wgpu::TextureView,
    /// Black HDR stand-in for targets of passes that were not recorded.
    pub black_hdr: wgpu::TextureView,
}

impl Placeholders {
    fn new(gpu: &Gpu) -> Self {
        let make = |format, texel: &[u8], label| {
            let t = gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: 1,
                    height: 1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            gpu.queue.write_texture(
                t.as_image_copy(),
                texel,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(texel.len() as u32),
                    rows_per_image: None,
                },
                wgpu::Extent3d {
                    width: 1,
                    height: 1,
                    depth_or_array_layers: 1,
                },
            );
            t.create_view(&Default::default())
        };
        Self {
            white_srgb: make(
                wgpu::TextureFormat::Rgba8UnormSrgb,
                &[255, 255, 255, 255],
                "placeholder white",
            ),
            flat_normal: make(
                wgpu::TextureFormat::Rgba8Unorm,
                &[128, 128, 255, 255],
                "placeholder normal",
            ),
            black_hdr: make(
                wgpu::TextureFormat::Rgba16Float,
                &[0; 8],
                "placeholder black",
            ),
        }
    }
}

struct GpuTexture {
    texture: wgpu::Texture,
    place: Placement,
    /// Per level of the GPU texture (the pack's levels from `place.skip` on).
    loaded: Vec<bool>,
    /// The smallest GPU level index such that it and every smaller mip are resident.
    resident_from: Option<u32>,
    view: Option<wgpu::TextureView>,
}

struct GpuMesh {
    vertices: Option<wgpu::Buffer>,
    indices: Option<wgpu::Buffer>,
    index_format: wgpu::IndexFormat,
    ranges: Vec<pack::DrawRange>,
    /// The triangles that cast shadows (u32 indices) and their index count, once all
    /// geometry is in and where the pack has windows: the opaque ones less any backed
    /// window's uncut wall, drawn into the shadow maps in one call.
    casters: Option<(wgpu::Buffer, u32)>,
    /// Where some backed window's uncut wall is in this mesh: all its opaque triangles, for
    /// the light's direct map (which that wall still blocks).
    opaque: Option<(wgpu::Buffer, u32)>,
}

pub(crate) struct GpuMaterial {
    pub class: MaterialClass,
    /// A texture of it is padded to whole blocks: it is drawn with the pipelines that wrap
    /// and scale its coordinates (`PADDED_TEXTURES` in `common.wgsl`).
    pub padded: bool,
    buffer: wgpu::Buffer,
    pub bind_group: wgpu::BindGroup,
    diffuse: Option<u32>,
    normal: Option<u32>,
}

/// Load progress of a streamed scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadStatus {
    pub geometry_sections: u32,
    pub geometry_total: u32,
    pub mips_loaded: u32,
    pub mips_total: u32,
    pub bytes_uploaded: u64,
}

pub struct Scene {
    toc: Toc,
    meshes: Vec<GpuMesh>,
    textures: Vec<GpuTexture>,
    pub(crate) materials: Vec<GpuMaterial>,
    pub(crate) material_layout: wgpu::BindGroupLayout,
    pub(crate) placeholders: Placeholders,
    /// Repeats the texture: for materials whose texture coordinates leave [0, 1] (tiled
    /// floors and walls).
    material_sampler: wgpu::Sampler,
    /// Clamps to the edge texels: for materials whose coordinates stay in [0, 1] (a window's
    /// design), so bilinear filtering at an edge does not blend in the opposite edge.
    edge_sampler: wgpu::Sampler,
    projectors: Projectors,
    /// Every window's projector frame ([`crate::view::projector_frames`]): the TOC's windows
    /// and materials never change after load, and the occlusion analysis, the shadow layout
    /// and every frame's projectors read them.
    projector_frames: Vec<pack::Window>,
    /// CPU copies of the geometry, for the occlusion analysis (at load and when the light
    /// moves); kept only when the pack has windows, which nothing is analysed for otherwise.
    /// The analysis reads the opaque triangles through them rather than from a list of its
    /// own: 36 bytes a triangle, 38 MB of the 1M-triangle grid's viewer.
    cpu: Vec<CpuMesh>,
    /// Bounds of the opaque triangles (neither glass nor backdrop), once all geometry is in
    /// and only where there are windows.
    occluder_bounds: Option<(glam::DVec3, glam::DVec3)>,
    /// Per window, whether its light needs a shadow map (for the current light).
    window_shadows: Vec<WindowShadow>,
    /// Per material: some vertex has texture coordinates outside [0, 1] (with a little slack
    /// for rounding), gathered as the vertex sections arrive: its textures repeat, else they
    /// are clamped to their edges. Complete once the geometry is in, which the first frame
    /// waits for (and bind groups are made again then).
    uv_tiles: Vec<bool>,
    /// Per window, the bounds of the meshes that hold its glass ([`window_building`]).
    window_buildings: Vec<Option<[glam::Vec3; 2]>>,
    /// The windows whose glass sits on an uncut wall, once all geometry is in.
    backings: occlusion::Backings,
    /// Whether opaque geometry reaches beyond a window's plane ([`occlusion::beyond_windows`]).
    beyond_windows: bool,
    /// Per window, whether the light comes in through it (`view::window_passes_light`).
    window_passes: Vec<bool>,
    /// Bumped when the geometry or the light changes: shadow maps drawn before are stale.
    shadow_generation: u64,
    status: LoadStatus,
    dirty: bool,
    /// Bumped whenever a texture view changes, so frame bind groups can be rebuilt.
    generation: u64,
    /// Unique per scene, so a renderer can tell a swapped-in scene from the one it drew.
    id: u64,
}

pub(crate) fn material_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    use crate::passes::{sampler_entry, texture_entry};
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("material"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: wgpu::BufferSize::new(
                        std::mem::size_of::<uniforms::Material>() as u64,
                    ),
                },
                count: None,
            },
            texture_entry(1),
            texture_entry(2),
            sampler_entry(3),
        ],
    })
}

/// A block-compressed level decoded to RGBA8 (`pack::texels::decode`) in bands of block rows
/// on every core: on a CPU rasterizer this runs between frames, on the loading path to full
/// quality.
fn decode_blocks(format: pack::TextureFormat, width: u32, height: u32, bytes: &[u8]) -> Vec<u8> {
    use rayon::prelude::*;
    const BLOCK_ROWS: usize = 16;
    let block_bytes = format.block_bytes().expect("a block format") as usize;
    let row_in = width.div_ceil(4) as usize * block_bytes;
    let row_out = width as usize * 4;
    let mut out = vec![0u8; row_out * height as usize];
    if out.is_empty() {
        return out;
    }
    out.par_chunks_mut(row_out * 4 * BLOCK_ROWS)
        .zip(bytes.par_chunks(row_in * BLOCK_ROWS))
        .for_each(|(dst, src)| {
            let rows = (dst.len() / row_out) as u32;
            dst.copy_from_slice(&pack::texels::decode(format, width, rows, src));
        });
    out
}

/// A streamed section ready to upload: a level of a block-compressed texture comes with its
/// RGBA8 texels where the device samples no block formats (or, like lavapipe, only in
/// software), decoded by [`Upload::prepare`] on the caller's thread. The viewer prepares on
/// its pack reader thread, so decoding overlaps the first frame and the other uploads instead
/// of running between them.
#[derive(Debug)]
pub struct Upload {
    pub section: pack::StreamSection,
    rgba: Option<Vec<u8>>,
}

impl Upload {
    /// `caps`: the device's [`Gpu::texture_caps`]. Levels the device does not load are not
    /// decoded.
    pub fn prepare(toc: &pack::Toc, section: pack::StreamSection, caps: TextureCaps) -> Self {
        let rgba = match section.role {
            SectionRole::Mip { texture, level } => {
                let t = &toc.textures[texture as usize];
                placement(t, caps)
                    .is_some_and(|p| p.decode && level >= p.skip)
                    .then(|| decode_logical(t, level as usize, &section.bytes))
            }
            _ => None,
        };
        Self { section, rgba }
    }

    /// Whether a section of this role reaches the device: false for a texture level over the
    /// largest side it loads (see [`Scene::new`]), which a reader need not decode at all (a
    /// 16384² RGBA8 level is 1 GiB decompressed).
    pub fn needed(toc: &pack::Toc, role: SectionRole, caps: TextureCaps) -> bool {
        match role {
            SectionRole::Mip { texture, level } => {
                placement(&toc.textures[texture as usize], caps).is_none_or(|p| level >= p.skip)
            }
            _ => true,
        }
    }
}

/// Level `level` of block texture `t` decoded to RGBA8 of the level's logical size: the block
/// padding is dropped, so a decoded texture is an RGBA8 texture of the image's own size and
/// samples without the padded path's coordinate scaling (on lavapipe the padded textures made
/// the window normals pass about a quarter slower).
fn decode_logical(t: &pack::Texture, level: usize, bytes: &[u8]) -> Vec<u8> {
    let (width, height) = t.storage_level_size(level);
    let texels = decode_blocks(t.format, width, height, bytes);
    let m = &t.mips[level];
    if (m.width, m.height) == (width, height) {
        texels
    } else {
        pack::texels::crop_owned(texels, width, m.width, m.height)
    }
}

/// The GPU texture's size (its level 0: the pack's level `place.skip`), and the share of it
/// the image covers on each axis: the stored, block-padded size for blocks sampled as they
/// are (its levels are mips of the padded level 0, so the share is level 0's); the image's
/// own when decoded.
fn gpu_extent(t: &pack::Texture, place: Placement) -> ((u32, u32), [f32; 2]) {
    let skip = place.skip as usize;
    if place.decode {
        let m = &t.mips[skip];
        ((m.width, m.height), [1.0, 1.0])
    } else {
        (t.storage_level_size(skip), t.uv_scale())
    }
}

/// How a pack texture is placed on a device: whether its blocks are decoded to RGBA8 on the
/// CPU rather than sampled as they are, and how many of its largest levels are left out
/// because they are over the largest side the device loads. The one rule for [`Scene::new`]
/// (the GPU texture's format and size), the uploads and [`Upload::prepare`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Placement {
    decode: bool,
    /// Pack levels left out: the GPU texture's level `l` is the pack's level `skip + l`.
    skip: u32,
}

/// The placement that keeps the most detail within `caps.max_side`: the first level that
/// fits. `None` when none does (a pack's chains end at 1x1, so only for a limit of 0).
fn placement(t: &pack::Texture, caps: TextureCaps) -> Option<Placement> {
    (0..t.mips.len()).find_map(|level| {
        let stored = t.storage_level_size(level);
        // A block texture's level 0 must be whole blocks. The pack pads its level 0, but a
        // smaller level used as the GPU's level 0 need not be: that one is decoded instead.
        let decode = t.format.is_compressed()
            && (!caps.block_compression
                || !stored.0.is_multiple_of(4)
                || !stored.1.is_multiple_of(4));
        let place = Placement {
            decode,
            skip: level as u32,
        };
        let ((w, h), _) = gpu_extent(t, place);
        (w.max(h) <= caps.max_side).then_some(place)
    })
}

/// The GPU format a texture is created in: its own, or RGBA8 when its blocks are decoded.
fn texture_format(t: &pack::Texture, decode: bool) -> wgpu::TextureFormat {
    use pack::{ColourSpace as C, TextureFormat as F};
    use wgpu::TextureFormat as W;
    match (if decode { F::Rgba8 } else { t.format }, t.colour_space) {
        (F::Rgba8, C::Srgb) => W::Rgba8UnormSrgb,
        (F::Rgba8, C::Linear) => W::Rgba8Unorm,
        (F::Bc7, C::Srgb) => W::Bc7RgbaUnormSrgb,
        (F::Bc7, C::Linear) => W::Bc7RgbaUnorm,
        // The pack's validation allows only linear data in these.
        (F::Bc5, _) => W::Bc5RgUnorm,
        (F::Bc4, _) => W::Bc4RUnorm,
    }
}

/// True when normal map `t` reaches the shader with two channels (Z to rebuild): BC5 uploaded
/// as blocks. Decoded BC5 already has Z.
fn two_channel(textures: &[GpuTexture], toc: &Toc, t: u32) -> bool {
    toc.textures[t as usize].format == pack::TextureFormat::Bc5
        && !textures[t as usize].place.decode
}

/// The TOC with at most `max` windows, when it has more (`None` when all fit): those with a
/// projector first, then those the light comes in through (the lit pass passes it, tinted,
/// without a projector), then the largest; in TOC order. A window left out still shows its
/// glass (pass 1 draws window materials); it throws no light, and the lit pass no longer
/// counts its plane as the building's edge.
fn kept_windows(toc: &Toc, max: usize) -> Option<Toc> {
    if toc.windows.len() <= max {
        return None;
    }
    let lit = |w: &pack::Window| {
        toc.materials
            .get(w.material as usize)
            .is_some_and(|m| m.projector_texture.is_some())
    };
    // The renderer's own test of whether a window passes light.
    let light = toc
        .light
        .as_ref()
        .map(crate::view::LightGeometry::from_light);
    let enters = |w: &pack::Window| {
        light
            .as_ref()
            .is_some_and(|l| crate::view::window_projector(w, l).is_some())
    };
    let area = |w: &pack::Window| {
        glam::Vec3::from(w.u_axis)
            .cross(glam::Vec3::from(w.v_axis))
            .length()
    };
    let mut order: Vec<usize> = (0..toc.windows.len()).collect();
    order.sort_by(|&a, &b| {
        let (wa, wb) = (&toc.windows[a], &toc.windows[b]);
        lit(wb)
            .cmp(&lit(wa))
            .then(enters(wb).cmp(&enters(wa)))
            .then(area(wb).total_cmp(&area(wa)))
            .then(a.cmp(&b))
    });
    order.truncate(max);
    order.sort_unstable();
    let dropped_lit = toc
        .windows
        .iter()
        .filter(|w| lit(w) || enters(w))
        .count()
        .saturating_sub(max);
    eprintln!(
        "note: {} windows, but the lit pass projects through at most {max} on this device: {} \
         are left out, those the light does not come in through and then the smallest \
         ({dropped_lit} with light through them); they show their glass but throw no light",
        toc.windows.len(),
        toc.windows.len() - max
    );
    let mut kept = toc.clone();
    kept.windows = order.into_iter().map(|i| toc.windows[i].clone()).collect();
    Some(kept)
}

/// One line for the textures loaded from a smaller level than their largest (see
/// [`placement`]), naming the largest of them: a silently blurrier scene would read as a cook
/// or pack fault.
fn say_levels_left_out(toc: &Toc, textures: &[GpuTexture], max_side: u32) {
    let reduced: Vec<(&pack::Texture, u32)> = toc
        .textures
        .iter()
        .zip(textures)
        .filter(|(_, g)| g.place.skip > 0)
        .map(|(t, g)| (t, g.place.skip))
        .collect();
    let Some(&(t, skip)) = reduced
        .iter()
        .max_by_key(|(t, _)| u64::from(t.width) * u64::from(t.height))
    else {
        return;
    };
    let m = &t.mips[skip as usize];
    eprintln!(
        "note: {} of {} textures are larger than the {max_side} texels a side this device loads \
         (its limit, or --max-texture-size): each is loaded from its first smaller level that \
         fits (the largest, {:?} at {}x{}, from level {skip}, {}x{})",
        reduced.len(),
        toc.textures.len(),
        t.name,
        t.width,
        t.height,
        m.width,
        m.height
    );
}

impl Scene {
    /// Creates every GPU object the TOC describes, with no data yet. `toc` must come from a
    /// validated pack (`Pack` or `StreamReader`), which guarantees every index used here.
    pub fn new(gpu: &Gpu, toc: &Toc) -> Result<Self, RenderError> {
        let device = &gpu.device;
        let caps = gpu.texture_caps();
        let mut textures = Vec::with_capacity(toc.textures.len());
        let mut decode_said = false;
        for t in &toc.textures {
            let place = placement(t, caps).ok_or_else(|| RenderError::TextureTooLarge {
                name: t.name.clone(),
                width: t.width,
                height: t.height,
                max: caps.max_side,
            })?;
            let decode = place.decode;
            if t.format.is_compressed() && !caps.block_compression && !decode_said {
                decode_said = true;
                let info = gpu.adapter.get_info();
                let why = if gpu
                    .device
                    .features()
                    .contains(wgpu::Features::TEXTURE_COMPRESSION_BC)
                {
                    "samples BC textures in software"
                } else {
                    "cannot sample BC textures"
                };
                eprintln!(
                    "note: {} {why}: decoding block-compressed mips to RGBA8 at load",
                    info.name
                );
            }
            let format = texture_format(t, decode);
            let ((width, height), _) = gpu_extent(t, place);
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some(&t.name),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: t.mips.len() as u32 - place.skip,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            textures.push(GpuTexture {
                texture,
                place,
                loaded: vec![false; t.mips.len() - place.skip as usize],
                resident_from: None,
                view: None,
            });
        }
        say_levels_left_out(toc, &textures, caps.max_side);
        let mips_total = textures.iter().map(|t| t.loaded.len() as u32).sum();
        // The projector array holds a layer per window and a white one, and a lamp's shadow
        // maps one per window and the direct map.
        let layers = device.limits().max_texture_array_layers as usize;
        let kept = kept_windows(toc, uniforms::MAX_WINDOWS.min(layers - 1));
        let toc = kept.as_ref().unwrap_or(toc);
        let material_layout = material_layout(device);
        let sampler = |label, mode| {
            device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some(label),
                address_mode_u: mode,
                address_mode_v: mode,
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                mipmap_filter: wgpu::MipmapFilterMode::Linear,
                anisotropy_clamp: 4,
                ..Default::default()
            })
        };
        let material_sampler = sampler("material", wgpu::AddressMode::Repeat);
        let edge_sampler = sampler("material, clamped", wgpu::AddressMode::ClampToEdge);
        let placeholders = Placeholders::new(gpu);
        let meshes = toc
            .meshes
            .iter()
            .map(|m| GpuMesh {
                vertices: None,
                indices: None,
                index_format: match m.index_format {
                    pack::IndexFormat::U16 => wgpu::IndexFormat::Uint16,
                    pack::IndexFormat::U32 => wgpu::IndexFormat::Uint32,
                },
                ranges: m.ranges.clone(),
                casters: None,
                opaque: None,
            })
            .collect();
        let mut scene = Self {
            toc: toc.clone(),
            meshes,
            textures,
            materials: Vec::new(),
            material_layout,
            placeholders,
            material_sampler,
            edge_sampler,
            projectors: Projectors::new(gpu, toc)?,
            projector_frames: crate::view::projector_frames(toc),
            cpu: toc.meshes.iter().map(|_| CpuMesh::default()).collect(),
            occluder_bounds: None,
            window_shadows: vec![WindowShadow::NoLight; toc.windows.len()],
            uv_tiles: vec![false; toc.materials.len()],
            window_buildings: toc
                .windows
                .iter()
                .map(|w| window_building(toc, w))
                .collect(),
            backings: occlusion::Backings::default(),
            beyond_windows: false,
            window_passes: Vec::new(),
            shadow_generation: 0,
            status: LoadStatus {
                geometry_total: toc.meshes.len() as u32 * 2,
                mips_total,
                ..Default::default()
            },
            dirty: false,
            generation: 0,
            id: {
                static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
                NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
            },
        };
        scene.window_passes = toc
            .windows
            .iter()
            .map(|w| {
                toc.light
                    .as_ref()
                    .is_some_and(|l| crate::view::window_passes_light(w, l))
            })
            .collect();
        // Per material, the most light any window of it passes (its god rays' weight).
        let mut light_share = vec![0.0f32; toc.materials.len()];
        if let Some(light) = &toc.light {
            for (w, _) in toc
                .windows
                .iter()
                .zip(&scene.window_passes)
                .filter(|(_, p)| **p)
            {
                if let Some(s) = light_share.get_mut(w.material as usize) {
                    *s = s.max(crate::view::window_light_share(w, light));
                }
            }
        }
        scene.materials = toc
            .materials
            .iter()
            .zip(&light_share)
            .map(|(m, &share)| {
                let u = uniforms::Material {
                    diffuse: [
                        m.diffuse[0],
                        m.diffuse[1],
                        m.diffuse[2],
                        m.diffuse_texture.is_some() as u32 as f32,
                    ],
                    specular: [m.specular[0], m.specular[1], m.specular[2], m.shininess],
                    emissive: [m.emissive[0], m.emissive[1], m.emissive[2], share],
                    flags: [
                        uniforms::class_id(m.class),
                        match m.normal_texture {
                            None => 0,
                            Some(n) if two_channel(&scene.textures, toc, n) => 2,
                            Some(_) => 1,
                        },
                        m.class.is_window() as u32,
                        0,
                    ],
                    uv_scale: {
                        let scale = |t: Option<u32>| {
                            t.map_or([1.0, 1.0], |t| {
                                gpu_extent(
                                    &toc.textures[t as usize],
                                    scene.textures[t as usize].place,
                                )
                                .1
                            })
                        };
                        let (d, n) = (scale(m.diffuse_texture), scale(m.normal_texture));
                        [d[0], d[1], n[0], n[1]]
                    },
                };
                let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(&m.name),
                    size: std::mem::size_of::<uniforms::Material>() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                gpu.queue.write_buffer(&buffer, 0, bytemuck::bytes_of(&u));
                let bind_group = scene.material_bind_group(
                    device,
                    &buffer,
                    m.diffuse_texture,
                    m.normal_texture,
                    true,
                );
                GpuMaterial {
                    class: m.class,
                    padded: u.uv_scale != [1.0; 4],
                    buffer,
                    bind_group,
                    diffuse: m.diffuse_texture,
                    normal: m.normal_texture,
                }
            })
            .collect();
        Ok(scene)
    }

    /// Uploads a whole pack.
    pub fn from_pack(gpu: &Gpu, pack: &pack::Pack) -> Result<Self, RenderError> {
        let mut scene = Self::new(gpu, pack.toc())?;
        for (i, role) in pack.roles().iter().enumerate().skip(1) {
            scene.upload(gpu, *role, pack.section_data(i as u32))?;
        }
        scene.refresh(gpu);
        Ok(scene)
    }

    /// The background's panorama scale (its colour), where the scene has a panorama.
    pub fn panorama(&self) -> Option<[f32; 3]> {
        let b = &self.toc.background;
        b.panorama.map(|_| b.colour)
    }

    /// The panorama's levels in so far, once one is.
    pub(crate) fn panorama_view(&self) -> Option<&wgpu::TextureView> {
        let i = self.toc.background.panorama?;
        self.textures.get(i as usize)?.view.as_ref()
    }

    fn texture_view(&self, index: Option<u32>, normal: bool) -> &wgpu::TextureView {
        match index.and_then(|i| self.textures[i as usize].view.as_ref()) {
            Some(v) => v,
            None if normal => &self.placeholders.flat_normal,
            None => &self.placeholders.white_srgb,
        }
    }

    fn material_bind_group(
        &self,
        device: &wgpu::Device,
        buffer: &wgpu::Buffer,
        diffuse: Option<u32>,
        normal: Option<u32>,
        tiles: bool,
    ) -> wgpu::BindGroup {
        let sampler = if tiles {
            &self.material_sampler
        } else {
            &self.edge_sampler
        };
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("material"),
            layout: &self.material_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(self.texture_view(diffuse, false)),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(self.texture_view(normal, true)),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::Sampler(sampler),
                },
            ],
        })
    }

    /// Uploads one streamed section (validated by the pack reader), decoded ahead or not.
    pub fn upload_section(&mut self, gpu: &Gpu, upload: &Upload) -> Result<(), RenderError> {
        self.upload_decoded(
            gpu,
            upload.section.role,
            &upload.section.bytes,
            upload.rgba.as_deref(),
        )
    }

    /// Uploads the bytes of one section with the role the TOC gave it. Call [`Scene::refresh`]
    /// before drawing to rebuild the views of textures that gained levels.
    pub fn upload(
        &mut self,
        gpu: &Gpu,
        role: SectionRole,
        bytes: &[u8],
    ) -> Result<(), RenderError> {
        self.upload_decoded(gpu, role, bytes, None)
    }

    /// [`Scene::upload`], with a block-compressed level's RGBA8 texels when they were decoded
    /// ahead ([`Upload::prepare`]); a texture the device samples as blocks ignores them.
    fn upload_decoded(
        &mut self,
        gpu: &Gpu,
        role: SectionRole,
        bytes: &[u8],
        rgba: Option<&[u8]>,
    ) -> Result<(), RenderError> {
        // What reached the GPU: a level decoded on the CPU uploads its texels, not its blocks.
        let mut uploaded = bytes.len();
        match role {
            SectionRole::Toc => {}
            SectionRole::Vertices { mesh } => {
                let m = &self.toc.meshes[mesh as usize];
                let count = m.vertex_count as usize;
                let standard = m.layout == VertexLayout::standard();
                let vertex_error = |reason| RenderError::VertexLayout {
                    mesh: m.name.clone(),
                    reason,
                };
                check_vertex_bytes(&m.layout, bytes, count).map_err(vertex_error)?;
                let size = count * std::mem::size_of::<StandardVertex>();
                // Converted straight into the buffer's mapping: a converted copy beside it was
                // 26 MB of the 1M-triangle grid's viewer.
                let keep = self.keeps_cpu_geometry();
                let tiles = &mut self.uv_tiles;
                let mut materials = Vec::with_capacity(count);
                let (buffer, positions) =
                    mapped_buffer(gpu, &m.name, size, wgpu::BufferUsages::VERTEX, |mapped| {
                        if standard {
                            copy_standard_vertices(bytes, mapped);
                            let (uv, material) = (
                                std::mem::offset_of!(StandardVertex, uv),
                                std::mem::offset_of!(StandardVertex, material),
                            );
                            // One pass over the vertices for the tiling, the positions and
                            // the materials.
                            let mut positions = keep.then(|| Vec::with_capacity(count));
                            for v in bytes.chunks_exact(STANDARD_STRIDE) {
                                let t: [f32; 2] = bytemuck::pod_read_unaligned(&v[uv..uv + 8]);
                                let m = u16::from_le_bytes([v[material], v[material + 1]]);
                                note_tiling(tiles, t, m);
                                materials.push(m);
                                if let Some(p) = &mut positions {
                                    let at: [f32; 3] = bytemuck::pod_read_unaligned(&v[..12]);
                                    p.push(glam::Vec3::from(at));
                                }
                            }
                            positions
                        } else {
                            let mut positions = keep.then(|| Vec::with_capacity(count));
                            convert_vertices(&m.layout, bytes, mapped, |v| {
                                note_tiling(tiles, v.uv, v.material[0]);
                                materials.push(v.material[0]);
                                if let Some(p) = &mut positions {
                                    p.push(glam::Vec3::from(v.position));
                                }
                            });
                            positions
                        }
                    });
                self.cpu[mesh as usize].positions = positions;
                match self.cpu[mesh as usize].indices_bytes.take() {
                    Some(indices) => check_draw_materials(m, &materials, &indices)?,
                    None => self.cpu[mesh as usize].materials = Some(materials),
                }
                self.meshes[mesh as usize].vertices = Some(buffer);
                self.status.geometry_sections += 1;
                self.geometry_arrived(gpu);
            }
            SectionRole::Indices { mesh } => {
                let m = &self.toc.meshes[mesh as usize];
                // A pack's vertices come before their indices; in any other order the indices
                // wait for them.
                match self.cpu[mesh as usize].materials.take() {
                    Some(materials) => check_draw_materials(m, &materials, bytes)?,
                    None => self.cpu[mesh as usize].indices_bytes = Some(bytes.to_vec()),
                }
                let indices = self
                    .keeps_cpu_geometry()
                    .then(|| m.index_format.decode(bytes).collect());
                self.cpu[mesh as usize].indices = indices;
                // An odd count of u16 indices leaves padding (see `mapped_buffer`).
                let (buffer, ()) = mapped_buffer(
                    gpu,
                    &m.name,
                    bytes.len(),
                    wgpu::BufferUsages::INDEX,
                    |mapped| {
                        let (mut data, mut padding) = mapped.split_at(bytes.len());
                        data.copy_from_slice(bytes);
                        padding.fill(0);
                    },
                );
                self.meshes[mesh as usize].indices = Some(buffer);
                self.status.geometry_sections += 1;
                self.geometry_arrived(gpu);
            }
            SectionRole::Mip { texture, level } => {
                let t = &self.toc.textures[texture as usize];
                let gt = &self.textures[texture as usize];
                // A level over the largest side loaded (see `placement`) is passed over.
                let Some(gpu_level) = level.checked_sub(gt.place.skip) else {
                    return Ok(());
                };
                let (width, height) = t.storage_level_size(level as usize);
                let decoded;
                // Rows of texels, or of 4x4 blocks, and the copy's extent in texels (whole
                // blocks for a block format: a level smaller than one is copied as one).
                let (data, row_bytes, rows, extent) = match t.format.block_bytes() {
                    Some(_) if gt.place.decode => {
                        let texels = match rgba {
                            Some(texels) => texels,
                            None => {
                                decoded = decode_logical(t, level as usize, bytes);
                                &decoded[..]
                            }
                        };
                        let m = &t.mips[level as usize];
                        (texels, m.width * 4, m.height, (m.width, m.height))
                    }
                    Some(b) => {
                        let (bw, bh) = (width.div_ceil(4), height.div_ceil(4));
                        (bytes, bw * b as u32, bh, (bw * 4, bh * 4))
                    }
                    None => (bytes, width * 4, height, (width, height)),
                };
                uploaded = data.len();
                gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &gt.texture,
                        mip_level: gpu_level,
                        origin: wgpu::Origin3d::ZERO,
                        aspect: wgpu::TextureAspect::All,
                    },
                    data,
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row_bytes),
                        rows_per_image: Some(rows),
                    },
                    wgpu::Extent3d {
                        width: extent.0,
                        height: extent.1,
                        depth_or_array_layers: 1,
                    },
                );
                let gt = &mut self.textures[texture as usize];
                gt.loaded[gpu_level as usize] = true;
                let resident = (0..gt.loaded.len())
                    .rev()
                    .take_while(|&l| gt.loaded[l])
                    .last()
                    .map(|l| l as u32);
                if resident != gt.resident_from {
                    gt.resident_from = resident;
                    self.dirty = true;
                }
                self.status.mips_loaded += 1;
            }
        }
        self.status.bytes_uploaded += uploaded as u64;
        Ok(())
    }

    /// Rebuilds texture views and material bind groups after uploads. Cheap when nothing changed.
    pub fn refresh(&mut self, gpu: &Gpu) {
        if !self.dirty {
            return;
        }
        self.dirty = false;
        for t in &mut self.textures {
            t.view = t.resident_from.map(|base| {
                t.texture.create_view(&wgpu::TextureViewDescriptor {
                    base_mip_level: base,
                    mip_level_count: Some(t.loaded.len() as u32 - base),
                    ..Default::default()
                })
            });
        }
        let groups: Vec<wgpu::BindGroup> = self
            .materials
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let tiles = self.uv_tiles.get(i).copied().unwrap_or(true);
                self.material_bind_group(&gpu.device, &m.buffer, m.diffuse, m.normal, tiles)
            })
            .collect();
        for (m, g) in self.materials.iter_mut().zip(groups) {
            m.bind_group = g;
        }
        let textures = &self.textures;
        let toc = &self.toc;
        self.projectors.update(gpu, |t| {
            let (size, scale) = gpu_extent(&toc.textures[t as usize], textures[t as usize].place);
            let t = &textures[t as usize];
            t.resident_from
                .zip(t.view.as_ref())
                .map(|(base, view)| (base, view, size, scale))
        });
        self.generation += 1;
    }

    pub fn toc(&self) -> &Toc {
        &self.toc
    }
    pub fn status(&self) -> LoadStatus {
        self.status
    }

    /// Replaces the scene's light; the next frame's shading, projectors and god rays follow.
    /// The interactive viewer tunes colour, intensity and falloff this way without a re-cook.
    pub fn set_light(&mut self, light: Option<pack::Light>) {
        // Colour and intensity change neither which windows need maps nor the maps.
        let moved = self.toc.light.as_ref().map(|l| &l.kind) != light.as_ref().map(|l| &l.kind);
        self.toc.light = light;
        if moved {
            self.analyse_occlusion();
        }
    }

    /// Once the last geometry section is in, gathers the opaque triangles, finds the windows
    /// sitting on uncut walls, uploads what casts shadows and decides which windows need
    /// shadow maps.
    fn geometry_arrived(&mut self, gpu: &Gpu) {
        if !self.geometry_complete() {
            return;
        }
        // The samplers follow the coordinates (`uv_tiles`, now complete): bind groups made
        // again at the next refresh.
        self.dirty = true;
        self.occluder_bounds = crate::shadows::bounds(self.occluders().map(|(_, _, t)| t));
        self.backings =
            occlusion::Backings::find(&self.toc.windows, self.occluders().map(|(_, _, t)| t));
        self.beyond_windows = occlusion::beyond_windows(
            &self.toc.windows,
            &self.backings,
            self.occluders().map(|(_, _, t)| t),
        );
        // One pass: each opaque triangle into the casters, or, where it is part of a backed
        // window's uncut wall, into the mesh's list of those; with such walls, every opaque
        // triangle into the direct map's list as well.
        let n = self.cpu.len();
        let (mut casters, mut opaque, mut backing) = (
            vec![Vec::new(); n],
            vec![Vec::new(); n],
            vec![Vec::new(); n],
        );
        let walls = !self.backings.is_empty();
        for (mesh, tri, t) in self.occluders() {
            let idx = self.cpu[mesh].indices.as_deref().unwrap_or(&[]);
            let corners = &idx[tri as usize..tri as usize + 3];
            if walls {
                opaque[mesh].extend_from_slice(corners);
                if self.backings.mask(t) != 0 {
                    backing[mesh].push(tri);
                    continue;
                }
            }
            casters[mesh].extend_from_slice(corners);
        }
        for (cpu, mut b) in self.cpu.iter_mut().zip(backing) {
            b.sort_unstable();
            cpu.backing = b;
        }
        let upload = |name: &str, c: Vec<u32>| {
            (!c.is_empty()).then(|| {
                let bytes: &[u8] = bytemuck::cast_slice(&c);
                let (buffer, ()) = mapped_buffer(
                    gpu,
                    name,
                    bytes.len(),
                    wgpu::BufferUsages::INDEX,
                    |mut mapped| mapped.slice(..bytes.len()).copy_from_slice(bytes),
                );
                (buffer, c.len() as u32)
            })
        };
        for (((m, gm), c), o) in self
            .toc
            .meshes
            .iter()
            .zip(&mut self.meshes)
            .zip(casters)
            .zip(opaque)
        {
            let walls = o.len() > c.len();
            gm.casters = upload(&format!("{} shadow casters", m.name), c);
            gm.opaque = if walls {
                upload(&format!("{} opaque", m.name), o)
            } else {
                None
            };
        }
        self.analyse_occlusion();
    }

    fn analyse_occlusion(&mut self) {
        let light = self.toc.light.as_ref().map(LightGeometry::from_light);
        // Over the projectors' frames: what stands in the light's penumbra past a window's
        // edge (the sides of a deep opening) must shadow it too.
        self.window_shadows = occlusion::analyse(
            &self.projector_frames,
            light.as_ref(),
            self.casting().map(|(_, _, t)| t),
        );
        self.shadow_generation += 1;
    }

    /// The opaque triangles (neither glass nor backdrop) in world positions, with their mesh
    /// and first index, read through the CPU copies: none where the pack has no
    /// windows.
    fn occluders(&self) -> impl Iterator<Item = (usize, u32, [glam::Vec3; 3])> + Clone + '_ {
        let materials = &self.toc.materials;
        self.toc
            .meshes
            .iter()
            .zip(&self.cpu)
            .enumerate()
            .filter_map(|(i, (m, cpu))| {
                Some((i, m, cpu.positions.as_deref()?, cpu.indices.as_deref()?))
            })
            .flat_map(move |(i, m, pos, idx)| {
                m.ranges
                    .iter()
                    .filter(move |r| {
                        crate::passes::casts_shadow(materials[r.material as usize].class)
                    })
                    .flat_map(move |r| {
                        let first = r.first_index as usize;
                        let end = (first + r.index_count as usize).min(idx.len());
                        let first = first.min(end);
                        idx[first..end]
                            .chunks_exact(3)
                            .enumerate()
                            .map(move |(k, t)| {
                                // Indices were validated against the vertex count by the pack
                                // reader.
                                let p = |i: u32| {
                                    pos.get(i as usize).copied().unwrap_or(glam::Vec3::ZERO)
                                };
                                (i, (first + 3 * k) as u32, [p(t[0]), p(t[1]), p(t[2])])
                            })
                    })
            })
    }

    /// [`Scene::occluders`] less the backed windows' uncut walls: what casts shadows.
    fn casting(&self) -> impl Iterator<Item = (usize, u32, [glam::Vec3; 3])> + Clone + '_ {
        self.occluders()
            .filter(|(mesh, tri, _)| self.cpu[*mesh].backing.binary_search(tri).is_err())
    }

    /// Per window (TOC order), whether its glass sits on an uncut wall, which then casts no
    /// shadow ([`occlusion::Backings`]); all false before the geometry is in.
    pub fn backed_windows(&self) -> Vec<bool> {
        (0..self.toc.windows.len())
            .map(|i| self.backings.backed(i))
            .collect()
    }

    /// Whether opaque geometry reaches beyond a window's plane, where the lit pass asks the
    /// light's direct map; false before the geometry is in.
    pub fn beyond_windows(&self) -> bool {
        self.beyond_windows
    }

    /// Whether the light comes in through any window: without, the god rays have nothing to
    /// blur.
    pub fn light_through_windows(&self) -> bool {
        self.window_passes.iter().any(|&p| p)
    }

    /// Whether the light comes in through window `i` (a spot's cone may miss it).
    pub(crate) fn window_passes_light(&self, i: usize) -> bool {
        self.window_passes.get(i).copied().unwrap_or(false)
    }

    /// The bounds (world space) of the meshes that hold window `i`'s glass: the building
    /// whose inside its plane bounds. `None` where no mesh draws its material.
    pub(crate) fn window_building(&self, i: usize) -> Option<[glam::Vec3; 2]> {
        self.window_buildings.get(i).copied().flatten()
    }

    /// How far behind window `i`'s glass its uncut wall lies, if it sits on one.
    pub(crate) fn backing_wall(&self, i: usize) -> Option<f64> {
        self.backings.wall(i)
    }

    /// Every window's projector frame, in window order.
    pub fn projector_frames(&self) -> &[pack::Window] {
        &self.projector_frames
    }

    /// Per window (in TOC order), whether its light needs a shadow map and why; decided from
    /// the geometry once it is all in (every window reads [`WindowShadow::NoLight`] before).
    pub fn window_shadows(&self) -> &[WindowShadow] {
        &self.window_shadows
    }

    /// The bounds of the opaque triangles (world positions) the shadow maps and the analysis
    /// see; `None` before all geometry is in, and where the pack has no windows.
    pub fn occluder_bounds(&self) -> Option<(glam::DVec3, glam::DVec3)> {
        self.occluder_bounds
    }

    /// What a view made for a pack without cameras frames: its opaque geometry where the CPU
    /// copies know it, so a backdrop (a sky cylinder 150 m round a 30 m church) is left out
    /// and the building seen; else every mesh's bounds ([`Self::bounds`]).
    pub fn framing_bounds(&self) -> (glam::Vec3, glam::Vec3) {
        match self.occluder_bounds {
            Some((lo, hi)) => (lo.as_vec3(), hi.as_vec3()),
            None => self.bounds(),
        }
    }

    /// Changes whenever shadow maps drawn earlier may be stale (geometry or light changed).
    pub(crate) fn shadow_generation(&self) -> u64 {
        self.shadow_generation
    }

    /// Records the shadow casters of every mesh ([`Scene::casting`]), or with `uncut_walls`
    /// all the opaque triangles, with `pipeline`, one draw a mesh; nothing before all geometry
    /// is in.
    pub(crate) fn draw_casters(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        pipeline: &wgpu::RenderPipeline,
        uncut_walls: bool,
    ) {
        pass.set_pipeline(pipeline);
        for m in &self.meshes {
            let indices = if uncut_walls {
                m.opaque.as_ref().or(m.casters.as_ref())
            } else {
                m.casters.as_ref()
            };
            let (Some(vb), Some((ib, count))) = (&m.vertices, indices) else {
                continue;
            };
            pass.set_vertex_buffer(0, vb.slice(..));
            pass.set_index_buffer(ib.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..*count, 0, 0..1);
        }
    }

    /// Records every loaded draw range with the caller's pipeline: `bind` runs before each
    /// range with its material index, so a viewer can draw its own debug views (material IDs,
    /// say) from the scene's buffers. Vertex buffers hold [`pack::StandardVertex`]es.
    pub fn draw_with(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        mut bind: impl FnMut(&mut wgpu::RenderPass<'_>, u16),
    ) {
        for m in &self.meshes {
            let (Some(vb), Some(ib)) = (&m.vertices, &m.indices) else {
                continue;
            };
            pass.set_vertex_buffer(0, vb.slice(..));
            pass.set_index_buffer(ib.slice(..), m.index_format);
            for r in &m.ranges {
                bind(pass, r.material);
                pass.draw_indexed(r.first_index..r.first_index + r.index_count, 0, 0..1);
            }
        }
    }
    /// Some material has a texture padded to whole blocks (see [`GpuMaterial::padded`]).
    pub(crate) fn has_padded_textures(&self) -> bool {
        self.materials.iter().any(|m| m.padded)
    }

    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    pub(crate) fn id(&self) -> u64 {
        self.id
    }

    pub fn geometry_complete(&self) -> bool {
        self.status.geometry_sections == self.status.geometry_total
    }

    /// Geometry and every small mip are in: enough for a first frame.
    pub fn ready_for_first_frame(&self) -> bool {
        self.geometry_complete()
            && self.toc.textures.iter().zip(&self.textures).all(|(t, g)| {
                let skip = g.place.skip as usize;
                (skip..t.mips.len())
                    .all(|l| g.loaded[l - skip] || t.level_rgba8_bytes(l) > SMALL_MIP_BYTES)
            })
    }

    pub fn fully_loaded(&self) -> bool {
        self.geometry_complete() && self.status.mips_loaded == self.status.mips_total
    }

    /// Every window's projector texture, one layer each (white where not resident yet).
    pub(crate) fn projector_array(&self) -> &wgpu::TextureView {
        self.projectors.view()
    }

    /// The projector layer that stays white.
    pub(crate) fn white_projector_layer(&self) -> u32 {
        self.projectors.white_layer()
    }

    pub(crate) fn projector_slot(&self, texture: Option<u32>) -> Option<u32> {
        self.projectors.slot(texture)
    }

    /// Whether the geometry is kept on the CPU for the occlusion analysis: only where the pack
    /// has windows, which nothing is analysed for otherwise.
    fn keeps_cpu_geometry(&self) -> bool {
        !self.toc.windows.is_empty()
    }

    /// True when some loaded range is drawn with a window material.
    pub fn has_windows(&self) -> bool {
        self.draws()
            .any(|(_, _, m)| self.materials[m as usize].class.is_window())
    }

    /// True when a drawn window material has a normal map.
    pub fn has_window_normal_maps(&self) -> bool {
        self.draws().any(|(_, _, m)| {
            let mat = &self.toc.materials[m as usize];
            mat.class.is_window() && mat.normal_texture.is_some()
        })
    }

    /// Loaded meshes' draw ranges: (mesh, range index, material).
    fn draws(&self) -> impl Iterator<Item = (usize, usize, u16)> + '_ {
        self.meshes
            .iter()
            .enumerate()
            .filter(|(_, m)| m.vertices.is_some() && m.indices.is_some())
            .flat_map(|(mi, m)| {
                m.ranges
                    .iter()
                    .enumerate()
                    .map(move |(ri, r)| (mi, ri, r.material))
            })
    }

    /// Records the draws a pass takes, each with the pipeline `pipeline_for` gives its
    /// material's class and whether a texture of it is padded (`None`: not drawn); group 1 is
    /// the material. The order is the scene's whichever pipelines draw, so surfaces at equal
    /// depth resolve alike in every pass.
    pub(crate) fn draw<'p>(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        pipeline_for: impl Fn(MaterialClass, bool) -> Option<&'p wgpu::RenderPipeline>,
    ) {
        let mut current: Option<&wgpu::RenderPipeline> = None;
        for m in &self.meshes {
            let (Some(vb), Some(ib)) = (&m.vertices, &m.indices) else {
                continue;
            };
            let mut bound = false;
            for r in &m.ranges {
                let mat = &self.materials[r.material as usize];
                let Some(pipeline) = pipeline_for(mat.class, mat.padded) else {
                    continue;
                };
                if !current.is_some_and(|c| std::ptr::eq(c, pipeline)) {
                    pass.set_pipeline(pipeline);
                    current = Some(pipeline);
                }
                if !bound {
                    pass.set_vertex_buffer(0, vb.slice(..));
                    pass.set_index_buffer(ib.slice(..), m.index_format);
                    bound = true;
                }
                pass.set_bind_group(1, &mat.bind_group, &[]);
                pass.draw_indexed(r.first_index..r.first_index + r.index_count, 0, 0..1);
            }
        }
    }

    /// Bounds of all meshes, for a default camera.
    pub fn bounds(&self) -> (glam::Vec3, glam::Vec3) {
        let mut lo = glam::Vec3::splat(f32::INFINITY);
        let mut hi = glam::Vec3::splat(f32::NEG_INFINITY);
        for m in &self.toc.meshes {
            lo = lo.min(glam::Vec3::from(m.bounds_min));
            hi = hi.max(glam::Vec3::from(m.bounds_max));
        }
        if lo.is_finite() && hi.is_finite() {
            (lo, hi)
        } else {
            (glam::Vec3::splat(-1.0), glam::Vec3::ONE)
        }
    }
}

/// The vertex buffer layout of [`StandardVertex`], which every mesh is drawn with: position,
/// normal, UV, tangent, then (past the material ID, which draws do not read) the colour.
pub(crate) const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 5] = {
    const fn at(
        format: wgpu::VertexFormat,
        offset: u64,
        shader_location: u32,
    ) -> wgpu::VertexAttribute {
        wgpu::VertexAttribute {
            format,
            offset,
            shader_location,
        }
    }
    [
        at(wgpu::VertexFormat::Float32x3, 0, 0),
        at(wgpu::VertexFormat::Float32x3, 12, 1),
        at(wgpu::VertexFormat::Float32x2, 24, 2),
        at(wgpu::VertexFormat::Float32x4, 32, 3),
        at(wgpu::VertexFormat::Unorm8x4, 52, 4),
    ]
};

/// The pack's standard layout's stride: a [`StandardVertex`] less its colour.
const STANDARD_STRIDE: usize = 52;

/// Copies vertices of the standard layout (`bytes`, checked) into [`StandardVertex`]es in
/// `out`, front to back: its bytes are the standard vertex's first 52, and the colour a
/// layout without one decodes to is white.
fn copy_standard_vertices(bytes: &[u8], out: wgpu::WriteOnly<'_, [u8]>) {
    const SIZE: usize = std::mem::size_of::<StandardVertex>();
    let (slots, _) = out.into_chunks::<SIZE>();
    let mut v = [0u8; SIZE];
    v[STANDARD_STRIDE..].copy_from_slice(&pack::vertex::WHITE);
    for (src, slot) in bytes.chunks_exact(STANDARD_STRIDE).zip(slots) {
        v[..STANDARD_STRIDE].copy_from_slice(src);
        slot.write(v);
    }
}

pub(crate) fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<StandardVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &VERTEX_ATTRIBUTES,
    }
}

/// Marks `material` as tiling when `uv` leaves [0, 1] by more than rounding: exporters write
/// a design's corners as 1.0000001 or -1e-7.
fn note_tiling(tiles: &mut [bool], uv: [f32; 2], material: u16) {
    const SLACK: f32 = 1e-3;
    let inside = |x: f32| (-SLACK..=1.0 + SLACK).contains(&x);
    if let Some(t) = tiles.get_mut(material as usize)
        && !(inside(uv[0]) && inside(uv[1]))
    {
        *t = true;
    }
}

/// A buffer of `size` bytes (rounded up to a multiple of 4, as buffers must be, and at least 4,
/// so a mesh without triangles needs no special case), its contents written once by `write`
/// straight into its mapping, and what `write` returned.
fn mapped_buffer<R>(
    gpu: &Gpu,
    label: &str,
    size: usize,
    usage: wgpu::BufferUsages,
    write: impl FnOnce(wgpu::WriteOnly<'_, [u8]>) -> R,
) -> (wgpu::Buffer, R) {
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (size.div_ceil(4) * 4).max(4) as u64,
        usage,
        mapped_at_creation: true,
    });
    let written = {
        let mut mapped = buffer
            .slice(..)
            .get_mapped_range_mut()
            .expect("a buffer mapped at creation");
        write(mapped.slice(..))
    };
    buffer.unmap();
    (buffer, written)
}

/// Whether every triangle's vertices carry its draw range's material. The passes shade by the
/// ranges, but which textures repeat is read from the vertices' IDs, as are the cooker's
/// `validate` and `diff`: a pack where they disagree (its checksums made to agree) is damaged,
/// and was drawn without a word. The pack's own checks see one section at a time.
fn check_draw_materials(
    m: &pack::Mesh,
    materials: &[u16],
    indices: &[u8],
) -> Result<(), RenderError> {
    // The ranges tile the indices in order (the pack's checks hold it).
    let mut index = m.index_format.decode(indices);
    let mut wrong = 0usize;
    let mut example = None;
    let mut t = 0usize;
    for r in &m.ranges {
        for _ in 0..r.index_count / 3 {
            let ids = [(); 3].map(|()| {
                index
                    .next()
                    .and_then(|i| materials.get(i as usize).copied())
            });
            if ids.iter().any(|&id| id != Some(r.material)) {
                wrong += 1;
                example.get_or_insert((t, r.material, ids));
            }
            t += 1;
        }
    }
    match example {
        None => Ok(()),
        Some((t, want, ids)) => Err(RenderError::VertexLayout {
            mesh: m.name.clone(),
            reason: format!(
                "{wrong} triangles have vertices whose material IDs disagree with their draw \
                 range's (triangle {t}: range material {want}, vertices {:?}); the pack is \
                 damaged or was not written by the cooker (`cooker validate` lists them)",
                ids.map(|id| id.map_or(-1, i64::from))
            ),
        }),
    }
}

/// Whether `bytes` hold `count` vertices of `layout`.
fn check_vertex_bytes(layout: &VertexLayout, bytes: &[u8], count: usize) -> Result<(), String> {
    let stride = layout.stride as usize;
    if stride == 0 || bytes.len() < stride * count {
        return Err(format!(
            "{} bytes for {count} vertices of stride {stride}",
            bytes.len()
        ));
    }
    Ok(())
}

/// Converts the vertices of `bytes` (of any layout the pack allows, checked by
/// [`check_vertex_bytes`]) into [`StandardVertex`]es written to `out`, front to back (a
/// mapping may be write-combined memory, which must not be read), handing each to `each`.
fn convert_vertices(
    layout: &VertexLayout,
    bytes: &[u8],
    out: wgpu::WriteOnly<'_, [u8]>,
    mut each: impl FnMut(&StandardVertex),
) {
    const SIZE: usize = std::mem::size_of::<StandardVertex>();
    let (slots, _) = out.into_chunks::<SIZE>();
    for (v, slot) in bytes.chunks_exact(layout.stride as usize).zip(slots) {
        let v = layout.decode(v);
        slot.write(bytemuck::cast::<StandardVertex, [u8; SIZE]>(v));
        each(&v);
    }
}

/// The union of the bounds of the meshes that draw window `w`'s material: the lit pass tests a
/// window's plane only within them. Two churches cooked as two meshes of one scene each lay
/// outside the other's window planes, so each was "outside" and lit by the unfiltered sun
/// through its glass: white patches where the coloured ones belonged.
fn window_building(toc: &Toc, w: &pack::Window) -> Option<[glam::Vec3; 2]> {
    toc.meshes
        .iter()
        .filter(|m| m.ranges.iter().any(|r| r.material == w.material))
        .map(|m| {
            [
                glam::Vec3::from(m.bounds_min),
                glam::Vec3::from(m.bounds_max),
            ]
        })
        .reduce(|a, b| [a[0].min(b[0]), a[1].max(b[1])])
}

#[cfg(test)]
mod tests {
    use super::*;
    use pack::{AttributeFormat, Semantic, VertexAttribute};

    #[test]
    fn past_the_lit_pass_limit_the_windows_with_light_and_then_the_largest_are_kept() {
        let (mut toc, _) = pack::testing::sample();
        assert!(kept_windows(&toc, uniforms::MAX_WINDOWS).is_none());
        let first = toc.windows[0].clone();
        let lit = first.material;
        assert!(toc.materials[lit as usize].projector_texture.is_some());
        let mut dark = toc.materials[lit as usize].clone();
        dark.projector_texture = None;
        toc.materials.push(dark);
        let dark = (toc.materials.len() - 1) as u16;
        let n = uniforms::MAX_WINDOWS + 10;
        // Every tenth window has light through it; each is larger than the one before.
        toc.windows = (0..n)
            .map(|i| pack::Window {
                material: if i % 10 == 0 { lit } else { dark },
                u_axis: first.u_axis.map(|c| c * (1.0 + i as f32 / 100.0)),
                ..first.clone()
            })
            .collect();
        let kept = kept_windows(&toc, uniforms::MAX_WINDOWS).expect("too many windows");
        let scale = |w: &pack::Window| w.u_axis[0] / first.u_axis[0];
        let kept_ids: Vec<usize> = kept
            .windows
            .iter()
            .map(|w| ((scale(w) - 1.0) * 100.0).round() as usize)
            .collect();
        // The ten smallest windows without light are left out; TOC order stays.
        let want: Vec<usize> = (0..n).filter(|&i| i % 10 == 0 || i > 11).collect();
        assert_eq!(kept_ids, want);
    }

    #[test]
    fn banded_block_decode_matches_the_whole_level() {
        for format in [
            pack::TextureFormat::Bc7,
            pack::TextureFormat::Bc5,
            pack::TextureFormat::Bc4,
        ] {
            for (w, h) in [(1, 1), (2, 1), (8, 64), (12, 70), (68, 133), (260, 4)] {
                let n = format.level_bytes(w, h) as usize;
                let bytes: Vec<u8> = (0..n).map(|i| (i * 37 + i / 7) as u8).collect();
                assert_eq!(
                    decode_blocks(format, w, h, &bytes),
                    pack::texels::decode(format, w, h, &bytes),
                    "{format} {w}x{h}"
                );
            }
        }
    }

    /// A texture over the largest side loaded starts at its first level that fits; a block
    /// texture whose level there is not whole blocks is decoded, since a GPU block texture's
    /// level 0 must be; levels left out are not decoded ahead.
    #[test]
    fn a_texture_too_large_for_the_device_starts_at_its_first_level_that_fits() {
        use pack::{TextureFormat as F, TextureRole as R};
        let caps = |block_compression, max_side| TextureCaps {
            block_compression,
            max_side,
        };
        let at = |decode, skip| Placement { decode, skip };
        let place = |decode, skip| Some(at(decode, skip));
        let (rgba, _) = pack::testing::sample_texture("stone", R::Colour, 1000, 600);
        assert_eq!(placement(&rgba, caps(true, 1000)), place(false, 0));
        assert_eq!(placement(&rgba, caps(true, 999)), place(false, 1));
        assert_eq!(placement(&rgba, caps(true, 250)), place(false, 2));
        assert_eq!(placement(&rgba, caps(true, 1)), place(false, 9));
        assert_eq!(placement(&rgba, caps(true, 0)), None);
        assert_eq!(gpu_extent(&rgba, at(false, 2)).0, (250, 150));

        // Padded to 1000x604 as blocks: level 1 is 500x302, not whole blocks; 1024x598 pads
        // to 1024x600, whose level 1 is.
        let (bc7, levels) =
            pack::testing::sample_block_texture("stone", R::Colour, F::Bc7, 1000, 601);
        assert_eq!(placement(&bc7, caps(true, 1000)), place(false, 0));
        assert_eq!(placement(&bc7, caps(true, 600)), place(true, 1));
        assert_eq!(placement(&bc7, caps(false, 600)), place(true, 1));
        assert_eq!(gpu_extent(&bc7, at(true, 1)), ((500, 300), [1.0, 1.0]));
        let (whole, _) = pack::testing::sample_block_texture("stone", R::Colour, F::Bc7, 1024, 598);
        assert_eq!(placement(&whole, caps(true, 512)), place(false, 1));
        let blocks = gpu_extent(&whole, at(false, 1));
        assert_eq!(blocks, ((512, 300), whole.uv_scale()));

        // Levels left out are not needed, nor decoded ahead; the first one kept is.
        let mut toc = pack::testing::sample().0;
        toc.textures = vec![bc7];
        for (level, decoded) in [(0, false), (1, true), (2, true)] {
            let section = pack::StreamSection {
                index: 1 + level,
                role: SectionRole::Mip { texture: 0, level },
                bytes: pack::AlignedBytes::from_slice(&levels[level as usize]),
            };
            let role = section.role;
            assert_eq!(Upload::needed(&toc, role, caps(false, 600)), decoded);
            let upload = Upload::prepare(&toc, section, caps(false, 600));
            assert_eq!(upload.rgba.is_some(), decoded, "level {level}");
        }
    }

    #[test]
    fn uploads_prepared_ahead_carry_the_decoded_blocks_only_where_asked() {
        let (toc, data) = pack::testing::sample();
        let bytes = pack::encode(toc, &data).unwrap();
        for decode in [false, true] {
            let mut reader =
                pack::StreamReader::new("<sample>", std::io::Cursor::new(bytes.clone())).unwrap();
            let mut decoded_levels = 0;
            while let Some(section) = reader.next_section().unwrap() {
                let toc = reader.toc().unwrap();
                let role = section.role;
                let stored = section.bytes.to_vec();
                let caps = TextureCaps {
                    block_compression: !decode,
                    max_side: u32::MAX,
                };
                let upload = Upload::prepare(toc, section, caps);
                match role {
                    SectionRole::Mip { texture, level }
                        if decode && toc.textures[texture as usize].format.is_compressed() =>
                    {
                        let t = &toc.textures[texture as usize];
                        assert_eq!(
                            upload.rgba.as_deref(),
                            Some(&pack::texels::decode_level(t, level as usize, &stored)[..]),
                            "texture {texture} level {level}"
                        );
                        decoded_levels += 1;
                    }
                    _ => assert!(
                        upload.rgba.is_none(),
                        "{role:?} decoded with decode={decode}"
                    ),
                }
            }
            assert_eq!(decoded_levels > 0, decode);
        }
    }

    /// The cooker's quantized layout: positions Unorm16x4 over the bounds, octahedral normals
    /// and tangents (handedness in z), Unorm16 UVs.
    #[test]
    fn quantized_vertices_decode_to_standard() {
        let attr = |semantic, format, offset| VertexAttribute {
            semantic,
            format,
            offset,
        };
        let layout = VertexLayout {
            stride: 28,
            attributes: vec![
                attr(Semantic::Position, AttributeFormat::Unorm16x4, 0),
                attr(Semantic::Normal, AttributeFormat::Snorm16x2, 8),
                attr(Semantic::Tangent, AttributeFormat::Snorm16x4, 12),
                attr(Semantic::TexCoord, AttributeFormat::Unorm16x2, 20),
                attr(Semantic::MaterialId, AttributeFormat::Uint16x2, 24),
            ],
            position_offset: [-2.0, 0.0, 1.0],
            position_scale: [4.0, 3.0, 2.0],
        };
        let normal = glam::Vec3::new(0.3, -0.5, -0.8).normalize();
        let tangent = glam::Vec3::new(0.0, 0.848, -0.53).normalize();
        let mut bytes = Vec::new();
        for q in [0u16, 65535, 32768, 0] {
            bytes.extend_from_slice(&q.to_le_bytes());
        }
        // Snorm by hand, so a mistake the codec makes both ways cannot hide.
        let snorm = |v: glam::Vec3| {
            pack::vertex::oct_encode(v.to_array()).map(|c| (c * 32767.0).round() as i16)
        };
        for c in snorm(normal) {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
        let t = snorm(tangent);
        for c in [t[0], t[1], -32767, 0] {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
        for q in [16384u16, 65535] {
            bytes.extend_from_slice(&q.to_le_bytes());
        }
        bytes.extend_from_slice(&[3, 0, 0, 0]);
        check_vertex_bytes(&layout, &bytes, 1).unwrap();
        let mut out = [0u8; std::mem::size_of::<StandardVertex>()];
        let mut seen = Vec::new();
        convert_vertices(
            &layout,
            &bytes,
            wgpu::WriteOnly::from_mut(&mut out[..]),
            |v| seen.push(*v),
        );
        let v: StandardVertex = bytemuck::pod_read_unaligned(&out);
        assert_eq!(seen, [v], "each vertex is handed over as written");
        let p = glam::Vec3::from(v.position);
        assert!(
            (p - glam::Vec3::new(-2.0, 3.0, 1.0 + 2.0 * 32768.0 / 65535.0)).length() < 1e-5,
            "{p}"
        );
        assert!(
            glam::Vec3::from(v.normal).angle_between(normal) < 1e-3,
            "{:?}",
            v.normal
        );
        let vt = glam::Vec4::from(v.tangent);
        assert!(
            vt.truncate().angle_between(tangent) < 1e-3 && vt.w == -1.0,
            "{vt}"
        );
        assert!((v.uv[0] - 16384.0 / 65535.0).abs() < 1e-6 && v.uv[1] == 1.0);
        // Short data is an error, not a panic.
        assert!(check_vertex_bytes(&layout, &bytes[..20], 1).is_err());
        // No colour in the layout: white.
        assert_eq!(v.colour, pack::vertex::WHITE);
    }

    /// The GPU's vertex attributes sit where [`StandardVertex`] keeps its fields, and standard
    /// vertices copied for upload are those the codec decodes.
    #[test]
    fn the_gpu_layout_is_the_standard_vertex() {
        use std::mem::offset_of;
        let offsets = [
            offset_of!(StandardVertex, position),
            offset_of!(StandardVertex, normal),
            offset_of!(StandardVertex, uv),
            offset_of!(StandardVertex, tangent),
            offset_of!(StandardVertex, colour),
        ];
        for (a, at) in VERTEX_ATTRIBUTES.iter().zip(offsets) {
            assert_eq!(a.offset as usize, at, "location {}", a.shader_location);
        }
        let layout = VertexLayout::standard();
        assert_eq!(layout.stride as usize, STANDARD_STRIDE);
        let verts: Vec<StandardVertex> = (0..3)
            .map(|i| StandardVertex {
                position: [i as f32, 2.0, -3.0],
                normal: [0.0, 1.0, 0.0],
                uv: [0.5, i as f32],
                tangent: [1.0, 0.0, 0.0, -1.0],
                material: [i, 0],
                colour: [9, 9, 9, 0],
            })
            .collect();
        let bytes = layout.encode_vertices(&verts);
        let mut out = vec![0u8; verts.len() * std::mem::size_of::<StandardVertex>()];
        copy_standard_vertices(&bytes, wgpu::WriteOnly::from_mut(&mut out[..]));
        let size = std::mem::size_of::<StandardVertex>();
        for (b, v) in out.chunks_exact(size).zip(&verts) {
            assert_eq!(
                bytemuck::pod_read_unaligned::<StandardVertex>(b),
                StandardVertex {
                    colour: pack::vertex::WHITE,
                    ..*v
                }
            );
        }
    }
}
