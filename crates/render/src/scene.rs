//! The scene on the GPU: geometry, textures and materials, filled section by section as a pack
//! arrives. Textures exist at full size from the start; a texture's view covers the levels
//! resident so far (they arrive smallest first), and a placeholder stands in until its first
//! level is in.

use pack::{MaterialClass, SectionRole, StandardVertex, Toc, VertexLayout};

use crate::uniforms;
use crate::{Gpu, RenderError};

/// Mips up to this many bytes (64×64 RGBA8) count as "small": the first frame waits for them.
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
    /// Block-compressed levels are decoded to RGBA8 before upload (no device support).
    decode: bool,
    loaded: Vec<bool>,
    /// The smallest level index such that it and every smaller mip are resident.
    resident_from: Option<u32>,
    view: Option<wgpu::TextureView>,
}

struct GpuMesh {
    vertices: Option<wgpu::Buffer>,
    indices: Option<wgpu::Buffer>,
    index_format: wgpu::IndexFormat,
    ranges: Vec<pack::DrawRange>,
}

pub(crate) struct GpuMaterial {
    pub class: MaterialClass,
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
    material_sampler: wgpu::Sampler,
    /// Texture index of each projector array layer.
    projector_slots: Vec<u32>,
    projectors: Projectors,
    status: LoadStatus,
    dirty: bool,
    /// Bumped whenever a texture view changes, so frame bind groups can be rebuilt.
    generation: u64,
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
    toc.textures[t as usize].format == pack::TextureFormat::Bc5 && !textures[t as usize].decode
}

impl Scene {
    /// Creates every GPU object the TOC describes, with no data yet. `toc` must come from a
    /// validated pack (`Pack` or `StreamReader`), which guarantees every index used here.
    pub fn new(gpu: &Gpu, toc: &Toc) -> Result<Self, RenderError> {
        let device = &gpu.device;
        let max = device.limits().max_texture_dimension_2d;
        let mut textures = Vec::with_capacity(toc.textures.len());
        let mut decode_said = false;
        for t in &toc.textures {
            if t.width > max || t.height > max {
                return Err(RenderError::TextureTooLarge {
                    name: t.name.clone(),
                    width: t.width,
                    height: t.height,
                    max,
                });
            }
            let decode = t.format.is_compressed() && !gpu.block_compression;
            if decode && !decode_said {
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
            let (width, height) = t.storage_size();
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some(&t.name),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: t.mips.len() as u32,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            textures.push(GpuTexture {
                texture,
                decode,
                loaded: vec![false; t.mips.len()],
                resident_from: None,
                view: None,
            });
        }
        let mut projector_slots: Vec<u32> = Vec::new();
        for w in &toc.windows {
            if let Some(p) = toc.materials[w.material as usize].projector_texture
                && !projector_slots.contains(&p)
            {
                projector_slots.push(p);
            }
        }
        let max_layers = device.limits().max_texture_array_layers as usize;
        if projector_slots.len() > max_layers {
            return Err(RenderError::TooManyProjectors {
                found: projector_slots.len(),
                max: max_layers,
            });
        }
        if toc.windows.len() > uniforms::MAX_WINDOWS {
            return Err(RenderError::TooManyWindows {
                found: toc.windows.len(),
                max: uniforms::MAX_WINDOWS,
            });
        }
        let material_layout = material_layout(device);
        let material_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("material"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            anisotropy_clamp: 4,
            ..Default::default()
        });
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
            projectors: Projectors::new(gpu, toc, &projector_slots),
            projector_slots,
            status: LoadStatus {
                geometry_total: toc.meshes.len() as u32 * 2,
                mips_total: toc.textures.iter().map(|t| t.mips.len() as u32).sum(),
                ..Default::default()
            },
            dirty: false,
            generation: 0,
        };
        scene.materials = toc
            .materials
            .iter()
            .map(|m| {
                let u = uniforms::Material {
                    diffuse: [
                        m.diffuse[0],
                        m.diffuse[1],
                        m.diffuse[2],
                        m.diffuse_texture.is_some() as u32 as f32,
                    ],
                    specular: [m.specular[0], m.specular[1], m.specular[2], m.shininess],
                    emissive: [m.emissive[0], m.emissive[1], m.emissive[2], 0.0],
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
                            t.map_or([1.0, 1.0], |t| toc.textures[t as usize].uv_scale())
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
                let bind_group =
                    scene.material_bind_group(device, &buffer, m.diffuse_texture, m.normal_texture);
                GpuMaterial {
                    class: m.class,
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
            scene.upload(gpu, *role, pack.section_bytes(i as u32))?;
        }
        scene.refresh(gpu);
        Ok(scene)
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
    ) -> wgpu::BindGroup {
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
                    resource: wgpu::BindingResource::Sampler(&self.material_sampler),
                },
            ],
        })
    }

    /// Uploads one streamed section (validated by the pack reader).
    pub fn upload_section(
        &mut self,
        gpu: &Gpu,
        section: &pack::StreamSection,
    ) -> Result<(), RenderError> {
        self.upload(gpu, section.role, &section.bytes)
    }

    /// Uploads the bytes of one section with the role the TOC gave it. Call [`Scene::refresh`]
    /// before drawing to rebuild the views of textures that gained levels.
    pub fn upload(
        &mut self,
        gpu: &Gpu,
        role: SectionRole,
        bytes: &[u8],
    ) -> Result<(), RenderError> {
        use wgpu::util::DeviceExt;
        match role {
            SectionRole::Toc => {}
            SectionRole::Vertices { mesh } => {
                let m = &self.toc.meshes[mesh as usize];
                let converted = standard_vertices(&m.layout, bytes, m.vertex_count as usize)
                    .map_err(|reason| RenderError::VertexLayout {
                        mesh: m.name.clone(),
                        reason,
                    })?;
                let data: &[u8] = converted
                    .as_deref()
                    .map(bytemuck::cast_slice)
                    .unwrap_or(bytes);
                let buffer = gpu
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some(&m.name),
                        contents: if data.is_empty() { &[0u8; 4] } else { data },
                        usage: wgpu::BufferUsages::VERTEX,
                    });
                self.meshes[mesh as usize].vertices = Some(buffer);
                self.status.geometry_sections += 1;
            }
            SectionRole::Indices { mesh } => {
                let m = &self.toc.meshes[mesh as usize];
                // Buffers must be a multiple of 4 bytes (an odd count of u16 indices is padded)
                // and are kept non-empty, so a mesh without triangles needs no special case.
                let mut data = bytes.to_vec();
                data.resize((bytes.len().div_ceil(4) * 4).max(4), 0);
                let buffer = gpu
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some(&m.name),
                        contents: &data,
                        usage: wgpu::BufferUsages::INDEX,
                    });
                self.meshes[mesh as usize].indices = Some(buffer);
                self.status.geometry_sections += 1;
            }
            SectionRole::Mip { texture, level } => {
                let t = &self.toc.textures[texture as usize];
                let gt = &self.textures[texture as usize];
                let (width, height) = t.storage_level_size(level as usize);
                let decoded;
                // Rows of texels, or of 4x4 blocks, and the copy's extent in texels (whole
                // blocks for a block format: a level smaller than one is copied as one).
                let (data, row_bytes, rows, extent) = match t.format.block_bytes() {
                    Some(_) if gt.decode => {
                        decoded = pack::texels::decode(t.format, width, height, bytes);
                        (&decoded[..], width * 4, height, (width, height))
                    }
                    Some(b) => {
                        let (bw, bh) = (width.div_ceil(4), height.div_ceil(4));
                        (bytes, bw * b as u32, bh, (bw * 4, bh * 4))
                    }
                    None => (bytes, width * 4, height, (width, height)),
                };
                gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &gt.texture,
                        mip_level: level,
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
                gt.loaded[level as usize] = true;
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
        self.status.bytes_uploaded += bytes.len() as u64;
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
            .map(|m| self.material_bind_group(&gpu.device, &m.buffer, m.diffuse, m.normal))
            .collect();
        for (m, g) in self.materials.iter_mut().zip(groups) {
            m.bind_group = g;
        }
        let sources: Vec<Option<ProjectorSource>> = self
            .projector_slots
            .iter()
            .map(|&t| {
                let info = &self.toc.textures[t as usize];
                let (w, h) = info.storage_size();
                let scale = info.uv_scale();
                let t = &self.textures[t as usize];
                t.resident_from
                    .zip(t.view.as_ref())
                    .map(|(base, view)| ProjectorSource {
                        base,
                        view,
                        full: w.max(h),
                        scale,
                    })
            })
            .collect();
        self.projectors.update(gpu, &sources);
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
        self.toc.light = light;
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
    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    pub fn geometry_complete(&self) -> bool {
        self.status.geometry_sections == self.status.geometry_total
    }

    /// Geometry and every small mip are in: enough for a first frame.
    pub fn ready_for_first_frame(&self) -> bool {
        self.geometry_complete()
            && self.toc.textures.iter().zip(&self.textures).all(|(t, g)| {
                (0..t.mips.len()).all(|l| g.loaded[l] || t.level_bytes(l) > SMALL_MIP_BYTES)
            })
    }

    pub fn fully_loaded(&self) -> bool {
        self.geometry_complete() && self.status.mips_loaded == self.status.mips_total
    }

    /// Every window's projector texture, one layer each (white where not resident yet).
    pub(crate) fn projector_array(&self) -> &wgpu::TextureView {
        &self.projectors.view
    }

    /// The projector layer that stays white.
    pub(crate) fn white_projector_layer(&self) -> u32 {
        self.projector_slots.len() as u32
    }

    pub(crate) fn projector_slot(&self, texture: Option<u32>) -> Option<u32> {
        let t = texture?;
        self.projector_slots
            .iter()
            .position(|&p| p == t)
            .map(|s| s as u32)
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

    /// Records the draws whose material passes `filter`; group 1 is the material.
    pub(crate) fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        filter: impl Fn(MaterialClass) -> bool,
    ) {
        for (mi, m) in self.meshes.iter().enumerate() {
            let (Some(vb), Some(ib)) = (&m.vertices, &m.indices) else {
                continue;
            };
            let mut bound = false;
            for r in &m.ranges {
                let mat = &self.materials[r.material as usize];
                if !filter(mat.class) {
                    continue;
                }
                if !bound {
                    pass.set_vertex_buffer(0, vb.slice(..));
                    pass.set_index_buffer(ib.slice(..), m.index_format);
                    bound = true;
                }
                pass.set_bind_group(1, &mat.bind_group, &[]);
                pass.draw_indexed(r.first_index..r.first_index + r.index_count, 0, 0..1);
            }
            let _ = mi;
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

/// The vertex buffer layout of [`StandardVertex`], which every mesh is drawn with.
pub(crate) const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 4] = wgpu::vertex_attr_array![
    0 => Float32x3,
    1 => Float32x3,
    2 => Float32x2,
    3 => Float32x4,
];

pub(crate) fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<StandardVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &VERTEX_ATTRIBUTES,
    }
}

/// Converts vertices of any layout the pack allows into [`StandardVertex`]; `None` when the
/// layout already is the standard one (uploaded as is).
fn standard_vertices(
    layout: &VertexLayout,
    bytes: &[u8],
    count: usize,
) -> Result<Option<Vec<StandardVertex>>, String> {
    if *layout == VertexLayout::standard() {
        return Ok(None);
    }
    let stride = layout.stride as usize;
    if bytes.len() < stride * count {
        return Err(format!(
            "{} bytes for {count} vertices of stride {stride}",
            bytes.len()
        ));
    }
    let out = bytes
        .chunks_exact(stride)
        .take(count)
        .map(|v| layout.decode(v))
        .collect();
    Ok(Some(out))
}

/// What a projector layer is copied from: the texture's resident base level, a view of the
/// resident levels, its stored level-0 size (the larger side) and its `uv_scale`.
#[derive(Clone, Copy)]
struct ProjectorSource<'a> {
    base: u32,
    view: &'a wgpu::TextureView,
    full: u32,
    scale: [f32; 2],
}

/// Projector textures gathered into one array, so the lit pass can reach any window's design
/// with a single binding however many windows a scene has. Each layer is a resampled copy of
/// the levels resident so far, refreshed as larger ones stream in.
struct Projectors {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    size: u32,
    levels: u32,
    /// The resident base level each layer was last copied from.
    copied: Vec<Option<u32>>,
}

/// Layers are square. Projectors are pre-blurred (the default scene's by 6 to 7 texels at
/// 1024), so 512 keeps their detail while quartering the copy each streamed level costs.
const MAX_PROJECTOR_SIZE: u32 = 512;

impl Projectors {
    fn new(gpu: &Gpu, toc: &Toc, slots: &[u32]) -> Self {
        let device = &gpu.device;
        let size = slots
            .iter()
            .map(|&t| {
                toc.textures[t as usize]
                    .width
                    .max(toc.textures[t as usize].height)
            })
            .max()
            .unwrap_or(1)
            .min(MAX_PROJECTOR_SIZE);
        // One layer per projector plus a white one for windows without a projector texture.
        let layers = slots.len() as u32 + 1;
        // A full chain: floors seen at grazing angles minify the patterns strongly.
        let levels = 32 - size.leading_zeros();
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("projectors"),
            size: wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: layers,
            },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("projector copy"),
            entries: &[
                crate::passes::texture_entry(0),
                crate::passes::sampler_entry(1),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let pipeline = crate::passes::fullscreen_pipeline(
            device,
            &layout,
            "blit.wgsl",
            wgpu::TextureFormat::Rgba8UnormSrgb,
        );
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let p = Self {
            texture,
            view,
            pipeline,
            layout,
            sampler,
            size,
            levels,
            copied: vec![None; layers as usize],
        };
        // Until a projector's first level arrives its layer is white: unfiltered light.
        let mut encoder = device.create_command_encoder(&Default::default());
        for layer in 0..layers {
            for level in 0..levels {
                p.layer_pass(&mut encoder, layer, level, true);
            }
        }
        gpu.queue.submit([encoder.finish()]);
        p
    }

    fn layer_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        layer: u32,
        level: u32,
        clear_white: bool,
    ) -> wgpu::RenderPass<'e> {
        let view = self.texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2),
            base_array_layer: layer,
            array_layer_count: Some(1),
            base_mip_level: level,
            mip_level_count: Some(1),
            ..Default::default()
        });
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("projector copy"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(if clear_white {
                        wgpu::Color::WHITE
                    } else {
                        wgpu::Color::BLACK
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    /// Copies each layer whose source gained levels since its last copy.
    fn update(&mut self, gpu: &Gpu, sources: &[Option<ProjectorSource>]) {
        use wgpu::util::DeviceExt;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let mut any = false;
        for (layer, source) in sources.iter().enumerate() {
            let Some(ProjectorSource {
                base,
                view,
                full,
                scale,
            }) = *source
            else {
                continue;
            };
            if self.copied[layer] == Some(base) {
                continue;
            }
            for level in 0..self.levels {
                // Source level of about this array level's size, relative to the view's base.
                let lod =
                    ((full as f32 / self.size as f32).log2() + level as f32 - base as f32).max(0.0);
                let u = uniforms::Blit {
                    lod: [lod, scale[0], scale[1], 0.0],
                };
                let buffer = gpu
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("projector copy"),
                        contents: bytemuck::bytes_of(&u),
                        usage: wgpu::BufferUsages::UNIFORM,
                    });
                let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("projector copy"),
                    layout: &self.layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: wgpu::BindingResource::TextureView(view),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: wgpu::BindingResource::Sampler(&self.sampler),
                        },
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: buffer.as_entire_binding(),
                        },
                    ],
                });
                let mut pass = self.layer_pass(&mut encoder, layer as u32, level, false);
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &group, &[]);
                pass.draw(0..3, 0..1);
            }
            self.copied[layer] = Some(base);
            any = true;
        }
        if any {
            gpu.queue.submit([encoder.finish()]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pack::{AttributeFormat, Semantic, VertexAttribute};

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
        let v = standard_vertices(&layout, &bytes, 1).unwrap().unwrap()[0];
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
        // The standard layout is uploaded as is, and short data is an error, not a panic.
        assert!(
            standard_vertices(&VertexLayout::standard(), &[0; 52], 1)
                .unwrap()
                .is_none()
        );
        assert!(standard_vertices(&layout, &bytes[..20], 1).is_err());
    }
}
