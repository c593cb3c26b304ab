//! Small packs for tests of this and other crates (not part of the stable API).

use crate::*;

pub fn sample_texture(name: &str, role: TextureRole, w: u32, h: u32) -> (Texture, Vec<Vec<u8>>) {
    let mut mips = Vec::new();
    let mut data = Vec::new();
    let (mut mw, mut mh) = (w, h);
    loop {
        mips.push(MipLevel {
            width: mw,
            height: mh,
            section: 0,
        });
        data.push((0..mw * mh * 4).map(|i| (i * 7 + mw) as u8).collect());
        if mw == 1 && mh == 1 {
            break;
        }
        mw = (mw / 2).max(1);
        mh = (mh / 2).max(1);
    }
    let colour_space = if role == TextureRole::Normal {
        ColourSpace::Linear
    } else {
        ColourSpace::Srgb
    };
    (
        Texture {
            name: name.into(),
            role,
            colour_space,
            format: TextureFormat::Rgba8,
            supercompression: Supercompression::None,
            width: w,
            height: h,
            mips,
        },
        data,
    )
}

/// Like [`sample_texture`], in a block format: whole blocks of arbitrary bytes per level.
pub fn sample_block_texture(
    name: &str,
    role: TextureRole,
    format: TextureFormat,
    w: u32,
    h: u32,
) -> (Texture, Vec<Vec<u8>>) {
    let (mut t, _) = sample_texture(name, role, w, h);
    t.format = format;
    if !format.allows(t.colour_space) {
        t.colour_space = ColourSpace::Linear;
    }
    let data = (0..t.mips.len())
        .map(|level| {
            (0..t.level_bytes(level))
                .map(|i| (i * 13 + level as u64) as u8)
                .collect()
        })
        .collect();
    (t, data)
}

/// Stores a sample texture's levels with `s`: returns the sections' bytes.
pub fn supercompress(t: &mut Texture, s: Supercompression, levels: &[Vec<u8>]) -> Vec<Vec<u8>> {
    t.supercompression = s;
    levels.iter().map(|l| s.compress(l)).collect()
}

pub fn material(name: &str, class: MaterialClass) -> Material {
    Material {
        name: name.into(),
        class,
        diffuse: [0.5, 0.4, 0.3],
        specular: [0.1; 3],
        shininess: 16.0,
        emissive: [0.0; 3],
        diffuse_texture: None,
        normal_texture: None,
        projector_texture: None,
        projector_margin: [0.0; 2],
    }
}

/// A small pack exercising every TOC field; its bytes are the golden file.
pub fn sample() -> (Toc, PackData) {
    let v = |p: [f32; 3], uv: [f32; 2], m: u16| StandardVertex {
        position: p,
        normal: [0.0, 0.0, 1.0],
        uv,
        tangent: [1.0, 0.0, 0.0, 1.0],
        material: [m, 0],
        colour: crate::vertex::WHITE,
    };
    let verts = [
        v([0.0, 0.0, 0.0], [0.0, 0.0], 0),
        v([1.0, 0.0, 0.0], [1.0, 0.0], 0),
        v([1.0, 1.0, 0.0], [1.0, 1.0], 0),
        v([0.0, 1.0, 0.0], [0.0, 1.0], 1),
        v([1.0, 0.0, 0.0], [1.0, 0.0], 1),
        v([1.0, 1.0, 0.0], [1.0, 1.0], 1),
    ];
    let indices: [u16; 6] = [0, 1, 2, 3, 4, 5];
    let mesh = Mesh {
        name: "quad".into(),
        layout: VertexLayout::standard(),
        vertex_count: 6,
        index_count: 6,
        index_format: IndexFormat::U16,
        vertex_section: 0,
        index_section: 0,
        bounds_min: [0.0; 3],
        bounds_max: [1.0, 1.0, 0.0],
        ranges: vec![
            DrawRange {
                material: 0,
                first_index: 0,
                index_count: 3,
            },
            DrawRange {
                material: 1,
                first_index: 3,
                index_count: 3,
            },
        ],
    };
    let (colour, cdata) = sample_texture("rose.colour", TextureRole::Colour, 4, 2);
    let (mut normal, ndata) =
        sample_block_texture("rose.normal", TextureRole::Normal, TextureFormat::Bc5, 3, 3);
    let ndata = supercompress(&mut normal, Supercompression::Zstd, &ndata);
    let mut window = material("rose", MaterialClass::WindowUpper);
    window.diffuse_texture = Some(0);
    window.normal_texture = Some(1);
    window.projector_texture = Some(0);
    window.projector_margin = [0.25, 0.125];
    let toc = Toc {
        meshes: vec![mesh],
        materials: vec![material("floor", MaterialClass::Floor), window],
        textures: vec![colour, normal],
        windows: vec![Window {
            material: 1,
            origin: [0.0; 3],
            u_axis: [1.0, 0.0, 0.0],
            v_axis: [0.0, 1.0, 0.0],
            normal: [0.0, 0.0, -1.0],
            source_materials: vec!["rose-red".into(), "rose-blue".into()],
        }],
        light: Some(Light {
            kind: LightKind::Directional {
                direction: [0.3, -0.5, -1.0],
                angular_size: 0.00925,
            },
            colour: [1.0, 0.95, 0.9],
            intensity: 3.0,
        }),
        cameras: vec![Camera {
            name: "nave".into(),
            position: [0.0, 1.7, 5.0],
            target: [0.0, 1.7, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y: 60.0,
            near: 0.05,
            far: 200.0,
        }],
        background: Background {
            colour: [0.2, 0.3, 0.5],
            panorama: None,
        },
    };
    let data = PackData {
        meshes: vec![MeshData {
            vertices: VertexLayout::standard().encode_vertices(&verts),
            indices: bytemuck::cast_slice(&indices).to_vec(),
        }],
        textures: vec![cdata, ndata],
    };
    (toc, data)
}

/// Recomputes every checksum a (possibly mangled) pack declares, where the entries are in
/// bounds, so a fuzzer gets past the CRCs and exercises the structural and TOC checks behind
/// them.
pub fn fix_checksums(bytes: &mut [u8]) {
    use crate::format::{HEADER_SIZE, SECTION_ENTRY_SIZE, crc32};
    if (bytes.len() as u64) < HEADER_SIZE {
        return;
    }
    let count = u32::from_le_bytes(bytes[16..20].try_into().unwrap()) as u64;
    let table_end = HEADER_SIZE + count * SECTION_ENTRY_SIZE;
    if count <= crate::format::MAX_SECTIONS && table_end <= bytes.len() as u64 {
        for i in 0..count {
            let at = (HEADER_SIZE + i * SECTION_ENTRY_SIZE) as usize;
            let offset = u64::from_le_bytes(bytes[at + 8..at + 16].try_into().unwrap());
            let length = u64::from_le_bytes(bytes[at + 16..at + 24].try_into().unwrap());
            if let Some(end) = offset.checked_add(length)
                && end <= bytes.len() as u64
            {
                let crc = crc32(&bytes[offset as usize..end as usize]);
                bytes[at + 24..at + 28].copy_from_slice(&crc.to_le_bytes());
            }
        }
        let crc = crc32(&bytes[HEADER_SIZE as usize..table_end as usize]);
        bytes[40..44].copy_from_slice(&crc.to_le_bytes());
    }
    let crc = crc32(&bytes[0..60]);
    bytes[60..64].copy_from_slice(&crc.to_le_bytes());
}
