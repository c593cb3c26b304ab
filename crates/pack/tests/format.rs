use std::path::{Path, PathBuf};

use pack::*;
use proptest::prelude::*;

use pack::testing::{sample, sample_block_texture, sample_texture};

fn sample_bytes() -> Vec<u8> {
    let (toc, data) = sample();
    encode(toc, &data).expect("sample encodes")
}

fn golden_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/golden")
        .join(format!("sample-v{FORMAT_VERSION}.pack"))
}

#[test]
fn golden_bytes_match_this_format_version() {
    let bytes = sample_bytes();
    let path = golden_path();
    if std::env::var_os("BLESS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, &bytes).unwrap();
    }
    let golden = std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e}; run with BLESS=1 after a deliberate format change (and bump FORMAT_VERSION)",
            path.display()
        )
    });
    assert!(
        golden == bytes,
        "the encoding changed without a FORMAT_VERSION bump: the bytes differ from {}",
        path.display()
    );
    // And the committed file still reads.
    Pack::from_bytes(&path, &golden).unwrap();
}

#[test]
fn the_previous_version_golden_says_recook() {
    let path = golden_path().with_file_name(format!("sample-v{}.pack", FORMAT_VERSION - 1));
    let bytes = std::fs::read(&path).unwrap();
    let e = Pack::from_bytes(&path, &bytes).unwrap_err();
    assert_eq!(
        e.problem(),
        Some(&Problem::Version {
            found: FORMAT_VERSION - 1,
            expected: FORMAT_VERSION
        }),
        "{e}"
    );
    assert!(e.to_string().contains("re-cook"), "{e}");
}

#[test]
fn round_trip_mmap_and_stream() {
    let bytes = sample_bytes();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.pack");
    let (toc, data) = sample();
    write_pack(&path, toc, &data).unwrap();
    assert_eq!(
        std::fs::read(&path).unwrap(),
        bytes,
        "file and memory encodings agree"
    );
    let pack = Pack::open(&path).unwrap();
    let toc = pack.toc().clone();
    assert_eq!(toc.meshes[0].vertex_count, 6);
    assert_eq!(pack.indices(&toc.meshes[0]).as_ref(), &[0, 1, 2, 3, 4, 5]);
    assert_eq!(pack.mip_bytes(0, 0), data.textures[0][0].as_slice());
    assert_eq!(toc.triangles_per_material(), vec![1, 1]);

    let mut stream = StreamReader::new(&path, std::io::Cursor::new(&bytes)).unwrap();
    let mut roles = Vec::new();
    while let Some(s) = stream.next_section().unwrap() {
        assert_eq!(&*s.bytes, pack.section_data(s.index));
        roles.push(s.role);
    }
    assert_eq!(stream.toc(), Some(&toc));
    // Streaming order: TOC, geometry, then every texture's levels by texel count.
    assert_eq!(roles[0], SectionRole::Toc);
    assert!(matches!(roles[1], SectionRole::Vertices { .. }));
    assert!(matches!(roles[2], SectionRole::Indices { .. }));
    let sizes: Vec<u64> = roles[3..]
        .iter()
        .map(|r| match *r {
            SectionRole::Mip { texture, level } => {
                toc.textures[texture as usize].level_rgba8_bytes(level as usize)
            }
            _ => panic!("geometry after mips"),
        })
        .collect();
    assert!(
        sizes.windows(2).all(|w| w[0] <= w[1]),
        "mips smallest first: {sizes:?}"
    );
}

/// A reader that decodes sections on other threads reads them raw and decodes them in any
/// order, getting what the reader in file order hands out.
#[test]
fn raw_sections_decode_in_any_order_like_streamed_ones() {
    let bytes = sample_bytes();
    let mut stream = StreamReader::new("p", std::io::Cursor::new(&bytes)).unwrap();
    let mut want = Vec::new();
    while let Some(s) = stream.next_section().unwrap() {
        want.push((s.index, s.role, s.bytes.to_vec()));
    }
    let mut stream = StreamReader::new("p", std::io::Cursor::new(&bytes)).unwrap();
    let mut raws = Vec::new();
    while let Some(raw) = stream.next_raw().unwrap() {
        raws.push(raw);
    }
    let toc = stream.toc().unwrap().clone();
    let mut got: Vec<_> = raws
        .into_iter()
        .rev()
        .map(|raw| {
            let s = raw.decode(&toc).unwrap();
            (s.index, s.role, s.bytes.to_vec())
        })
        .collect();
    got.reverse();
    assert_eq!(got, want);
}

fn read_all_stream(bytes: &[u8]) -> Result<(), PackError> {
    let mut s = StreamReader::new("p", std::io::Cursor::new(bytes))?;
    while s.next_section()?.is_some() {}
    Ok(())
}

#[test]
fn every_truncated_prefix_is_rejected() {
    let bytes = sample_bytes();
    for len in 0..bytes.len() {
        let prefix = &bytes[..len];
        assert!(
            Pack::from_bytes("p", prefix).is_err(),
            "prefix of {len} bytes accepted"
        );
        assert!(
            read_all_stream(prefix).is_err(),
            "stream prefix of {len} bytes accepted"
        );
    }
}

#[test]
fn every_single_bit_flip_is_detected() {
    let bytes = sample_bytes();
    let mut flipped = bytes.clone();
    for i in 0..bytes.len() {
        for bit in 0..8 {
            flipped[i] ^= 1 << bit;
            assert!(
                Pack::from_bytes("p", &flipped).is_err(),
                "flip of bit {bit} in byte {i} accepted"
            );
            assert!(
                read_all_stream(&flipped).is_err(),
                "stream: flip of bit {bit} in byte {i} accepted"
            );
            flipped[i] ^= 1 << bit;
        }
    }
}

#[test]
fn trailing_bytes_are_rejected() {
    let mut bytes = sample_bytes();
    bytes.push(0);
    let e = Pack::from_bytes("p", &bytes).unwrap_err();
    assert_eq!(e.problem(), Some(&Problem::TrailingData), "{e}");
    let e = read_all_stream(&bytes).unwrap_err();
    assert_eq!(e.problem(), Some(&Problem::TrailingData), "{e}");
}

/// Rewrites the header's CRC after an edit, so a test reaches the check behind it.
fn fix_header_crc(bytes: &mut [u8]) {
    let crc = crc32fast::hash(&bytes[0..60]);
    bytes[60..64].copy_from_slice(&crc.to_le_bytes());
}

/// An older pack says to re-cook it; a newer one, that it wants the tools of its version
/// (re-cooking it with this cooker would not help a user who has only the pack).
#[test]
fn other_version_says_what_to_do() {
    for (version, name, advice) in [
        (
            FORMAT_VERSION - 1,
            "old.pack",
            "re-cook the pack with this cooker",
        ),
        (
            FORMAT_VERSION + 1,
            "new.pack",
            "the pack is from a newer cooker; read it with the viewer and cooker of its version",
        ),
    ] {
        let mut bytes = sample_bytes();
        bytes[8..12].copy_from_slice(&version.to_le_bytes());
        fix_header_crc(&mut bytes);
        let msg = Pack::from_bytes(name, &bytes).unwrap_err().to_string();
        assert!(
            msg.contains(name)
                && msg.contains(&format!("version {version}"))
                && msg.ends_with(advice),
            "{msg}"
        );
    }
}

/// A section count out of range says the range (0 was said to "must be 1"); one whose table
/// would run past the file's end says that, not that the file has the table's length.
#[test]
fn a_section_count_out_of_range_or_past_the_end_is_said_as_such() {
    for count in [0u32, 65537] {
        let mut bytes = sample_bytes();
        bytes[16..20].copy_from_slice(&count.to_le_bytes());
        fix_header_crc(&mut bytes);
        let e = Pack::from_bytes("p", &bytes).unwrap_err().to_string();
        assert!(
            e.contains(&format!(
                "offset 16: section count is {count} but must be from 1 to 65536"
            )),
            "{e}"
        );
    }
    let mut bytes = sample_bytes();
    let len = bytes.len();
    bytes[16..20].copy_from_slice(&65536u32.to_le_bytes());
    fix_header_crc(&mut bytes);
    let e = Pack::from_bytes("p", &bytes).unwrap_err().to_string();
    assert!(
        e.contains(&format!(
            "offset 16: the section table's 65536 entries end at byte {}, past the file's end at {len}",
            64 + 65536 * 32
        )),
        "{e}"
    );
}

/// A reserved header byte set (its CRC made right) is named at its own offset, not the
/// first reserved field's.
#[test]
fn a_reserved_header_byte_is_named_at_its_offset() {
    for at in [20usize, 23, 44, 48, 59] {
        let mut bytes = sample_bytes();
        bytes[at] = 1;
        fix_header_crc(&mut bytes);
        let e = Pack::from_bytes("p", &bytes).unwrap_err();
        assert_eq!(e.problem(), Some(&Problem::NonZeroPadding), "{e}");
        assert!(
            e.to_string().contains(&format!("offset {at}:")),
            "{at}: {e}"
        );
    }
}

#[test]
fn unknown_section_kind_is_rejected() {
    let mut bytes = sample_bytes();
    // Section 1's kind, with the table CRC fixed so the kind check itself must catch it.
    bytes[64 + 32..64 + 36].copy_from_slice(&99u32.to_le_bytes());
    let count = u32::from_le_bytes(bytes[16..20].try_into().unwrap()) as usize;
    let table_crc = crc32fast::hash(&bytes[64..64 + 32 * count]);
    bytes[40..44].copy_from_slice(&table_crc.to_le_bytes());
    fix_header_crc(&mut bytes);
    let e = Pack::from_bytes("p", &bytes).unwrap_err();
    assert_eq!(
        e.problem(),
        Some(&Problem::UnknownSection { index: 1, kind: 99 }),
        "{e}"
    );
}

/// A section's length shortened (its checksums made to agree) is blamed on where the next
/// section must then start, naming the section before and its length: the message named the
/// next section's span alone, as if it were the one edited.
#[test]
fn a_shortened_section_length_names_the_section_before() {
    let mut bytes = sample_bytes();
    let count = u32::from_le_bytes(bytes[16..20].try_into().unwrap()) as usize;
    assert!(count >= 3);
    let entry = 64 + 32;
    let length = u64::from_le_bytes(bytes[entry + 16..entry + 24].try_into().unwrap());
    bytes[entry + 16..entry + 24].copy_from_slice(&(length - 16).to_le_bytes());
    let table_crc = crc32fast::hash(&bytes[64..64 + 32 * count]);
    bytes[40..44].copy_from_slice(&table_crc.to_le_bytes());
    fix_header_crc(&mut bytes);
    let e = Pack::from_bytes("p", &bytes).unwrap_err();
    let said = e.to_string();
    assert!(
        matches!(e.problem(), Some(Problem::SectionPlace { index: 2, .. }))
            && said.contains("where section 1 (")
            && said.contains(&format!("{} bytes long", length - 16)),
        "{said}"
    );
}

#[test]
fn writer_refuses_out_of_range_indices_and_material_ids() {
    let (toc, mut data) = sample();
    data.meshes[0].indices[10] = 6; // index 5 -> 6, past the 6 vertices
    let e = encode(toc, &data).unwrap_err();
    assert!(e.to_string().contains("index 5 is 6"), "{e}");

    let (toc, mut data) = sample();
    let stride = toc.meshes[0].layout.stride as usize;
    data.meshes[0].vertices[stride * 2 + 48] = 7;
    let e = encode(toc, &data).unwrap_err();
    assert!(e.to_string().contains("material ID 7"), "{e}");

    // A vertex far outside the bounds the mesh states (the views and shadow maps are fitted
    // to them) is as corrupt as a non-finite one.
    let (toc, mut data) = sample();
    data.meshes[0].vertices[stride..stride + 4].copy_from_slice(&1e30f32.to_le_bytes());
    let e = encode(toc, &data).unwrap_err();
    assert!(
        e.to_string().contains("vertex 1 at [1e30,")
            && e.to_string().contains("outside the mesh's bounds"),
        "{e}"
    );
}

/// Vertex colours travel as 8-bit sRGB beside the other attributes; a colour in any other
/// format is refused.
#[test]
fn vertex_colours_round_trip_as_unorm8x4_only() {
    let (mut toc, mut data) = sample();
    let standard = toc.meshes[0].layout.clone();
    let verts: Vec<StandardVertex> = data.meshes[0]
        .vertices
        .chunks_exact(standard.stride as usize)
        .enumerate()
        .map(|(i, b)| StandardVertex {
            colour: [i as u8 * 40, 255 - i as u8, 7, 0],
            ..standard.decode(b)
        })
        .collect();
    let everything = vertex::Encoding {
        normal: true,
        uv: true,
        tangent: true,
        colour: true,
        quantize: None,
    };
    let layout = vertex::layout(everything, false, [0.0; 3], [1.0; 3]);
    assert_eq!(layout.stride, standard.stride + 4);
    data.meshes[0].vertices = layout.encode_vertices(&verts);
    toc.meshes[0].layout = layout.clone();
    let bytes = encode(toc.clone(), &data).unwrap();
    let pack = Pack::from_bytes("c.pack", &bytes).unwrap();
    let back = pack.vertex_bytes(&pack.toc().meshes[0]);
    for (v, b) in verts.iter().zip(back.chunks_exact(layout.stride as usize)) {
        assert_eq!(layout.decode(b), *v);
    }

    let colour = toc.meshes[0]
        .layout
        .attributes
        .iter_mut()
        .find(|a| a.semantic == Semantic::Colour)
        .unwrap();
    colour.format = AttributeFormat::Unorm16x2;
    let e = encode(toc, &data).unwrap_err();
    assert!(
        e.to_string()
            .contains("colour format Unorm16x2 must be Unorm8x4"),
        "{e}"
    );
}

#[test]
fn writer_refuses_cameras_that_cannot_view() {
    type Break = (fn(&mut Camera), &'static str);
    // An up along the line of sight is not among them: the viewer picks a roll for it, as
    // for the guessed view straight up through a skylight.
    let broken: [Break; 4] = [
        (|c| c.far = c.near, "clip planes"),
        (|c| c.near = 0.0, "clip planes"),
        (|c| c.target = c.position, "position equal to target"),
        (|c| c.fov_y = f32::NAN, "vertical field of view"),
    ];
    for (i, (breaks, says)) in broken.iter().enumerate() {
        let (mut toc, data) = sample();
        breaks(&mut toc.cameras[0]);
        let e = encode(toc, &data).unwrap_err().to_string();
        assert!(
            e.contains("camera \"nave\" has invalid parameters: ") && e.contains(says),
            "{i}: {e}"
        );
    }
}

/// A spot light round-trips, and one whose cone or axis cannot light anything is refused:
/// the viewer divides by the cone's width and normalizes the axis.
#[test]
fn writer_keeps_spot_lights_and_refuses_broken_cones() {
    let spot = || LightKind::Spot {
        position: [0.0, 5.0, 0.0],
        radius: 0.1,
        direction: [0.0, -1.0, 0.0],
        inner: 0.2,
        outer: 0.5,
    };
    let (mut toc, data) = sample();
    toc.light.as_mut().unwrap().kind = spot();
    let bytes = encode(toc, &data).unwrap();
    let pack = Pack::from_bytes("s.pack", &bytes).unwrap();
    assert_eq!(pack.toc().light.as_ref().unwrap().kind, spot());

    let broken: [fn(&mut LightKind); 6] = [
        |k| set_cone(k, 0.6, 0.5),
        |k| set_cone(k, -0.1, 0.5),
        |k| set_cone(k, 0.0, 1.6),
        |k| set_cone(k, 0.0, f32::NAN),
        |k| {
            if let LightKind::Spot { direction, .. } = k {
                *direction = [0.0; 3];
            }
        },
        |k| {
            if let LightKind::Spot { radius, .. } = k {
                *radius = 0.0;
            }
        },
    ];
    for (i, breaks) in broken.iter().enumerate() {
        let (mut toc, data) = sample();
        let mut kind = spot();
        breaks(&mut kind);
        toc.light.as_mut().unwrap().kind = kind;
        let e = encode(toc, &data).unwrap_err().to_string();
        let says = [
            "cone angles",
            "cone angles",
            "cone angles",
            "cone angles",
            "direction",
            "radius",
        ];
        assert!(
            e.contains("the spot light has invalid parameters: ") && e.contains(says[i]),
            "{i}: {e}"
        );
    }
}

fn set_cone(kind: &mut LightKind, i: f32, o: f32) {
    if let LightKind::Spot { inner, outer, .. } = kind {
        (*inner, *outer) = (i, o);
    }
}

#[test]
fn failed_write_leaves_old_file_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.pack");
    std::fs::write(&path, b"old").unwrap();
    let (toc, mut data) = sample();
    data.meshes[0].indices[0] = 200;
    assert!(write_pack(&path, toc, &data).is_err());
    assert_eq!(std::fs::read(&path).unwrap(), b"old");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "no temp file left behind"
    );

    let (toc, data) = sample();
    let e = write_pack(&dir.path().join("missing/out.pack"), toc, &data).unwrap_err();
    assert!(
        e.is_io() && e.to_string().contains("missing/out.pack"),
        "{e}"
    );
}

#[test]
fn block_counts_are_checked_per_mip() {
    // 9x5 in BC7: stored as 12x8, levels 12x8 (3x2 blocks), 6x4 (2x1), 3x2 (1x1), 1x1 (1x1).
    let (t, d) = sample_block_texture("odd", TextureRole::Colour, TextureFormat::Bc7, 9, 5);
    assert_eq!(t.storage_size(), (12, 8));
    assert_eq!(
        d.iter().map(|l| l.len()).collect::<Vec<_>>(),
        vec![6 * 16, 2 * 16, 16, 16]
    );
    assert_eq!(t.uv_scale(), [0.75, 0.625]);
    let (mut toc, mut data) = sample();
    toc.textures.push(t.clone());
    data.textures.push(d.clone());
    let bytes = encode(toc.clone(), &data).expect("whole blocks encode");
    let pack = Pack::from_bytes("p", &bytes).unwrap();
    assert_eq!(pack.toc().textures[2].format, TextureFormat::Bc7);

    // One block short on level 1: the writer's own validation names the texture and level.
    let mut short = data.clone();
    short.textures[2][1].truncate(16);
    let e = encode(toc.clone(), &short).unwrap_err().to_string();
    assert!(
        e.contains("\"odd\"") && e.contains("mip 1") && e.contains("32"),
        "{e}"
    );

    // The RGBA8 size of the logical level is not a valid BC7 level either.
    let mut rgba = data.clone();
    rgba.textures[2][0] = vec![0; 9 * 5 * 4];
    assert!(encode(toc.clone(), &rgba).is_err());

    // Two-channel and one-channel formats hold linear data only.
    let mut srgb = toc.clone();
    srgb.textures[1].colour_space = ColourSpace::Srgb;
    let e = encode(srgb, &data).unwrap_err().to_string();
    assert!(e.contains("bc5") && e.contains("srgb"), "{e}");
}

#[test]
fn supercompressed_levels_decode_and_are_checked() {
    let (toc, data) = sample();
    let t = &toc.textures[1];
    assert_eq!(t.supercompression, Supercompression::Zstd);
    let (_, raw) =
        sample_block_texture("rose.normal", TextureRole::Normal, TextureFormat::Bc5, 3, 3);
    let bytes = encode(toc.clone(), &data).unwrap();
    let pack = Pack::from_bytes("p", &bytes).unwrap();
    for (level, want) in raw.iter().enumerate() {
        assert_eq!(pack.mip_bytes(1, level), want.as_slice(), "level {level}");
    }
    let mut stream = StreamReader::new("p", std::io::Cursor::new(&bytes)).unwrap();
    while let Some(s) = stream.next_section().unwrap() {
        if let SectionRole::Mip { texture: 1, level } = s.role {
            assert_eq!(
                &*s.bytes,
                raw[level as usize].as_slice(),
                "streamed level {level}"
            );
        }
    }

    // A frame that decodes to a level of another size, or is no zstd frame at all, is refused
    // by both readers, naming the texture and level, even with every checksum fixed.
    let mut wrong_size = data.clone();
    wrong_size.textures[1][0] = Supercompression::Zstd.compress(&[0; 32]);
    let mut garbage = data.clone();
    garbage.textures[1][0] = vec![1, 2, 3, 4, 5, 6, 7, 8, 9];
    let mut raw_level = data.clone();
    raw_level.textures[1][0] = raw[0].clone();
    for (what, bad) in [
        ("wrong size", wrong_size),
        ("garbage", garbage),
        ("not compressed", raw_level),
    ] {
        let e = encode(toc.clone(), &bad).unwrap_err();
        assert!(
            matches!(e.problem(), Some(Problem::Supercompression { what, .. }) if what.contains("(\"rose.normal\") mip 0")),
            "{what}: {e}"
        );
    }
    // The same through the streaming reader: a valid pack whose frame is overwritten in place,
    // checksums fixed.
    let section = pack.toc().textures[1].mips[0].section;
    let entry = pack.sections()[section as usize];
    let mut patched = bytes.clone();
    patched[entry.offset as usize..entry.end() as usize].fill(0x55);
    pack::testing::fix_checksums(&mut patched);
    let e = Pack::from_bytes("p", &patched).unwrap_err();
    assert!(
        matches!(e.problem(), Some(Problem::Supercompression { .. })),
        "{e}"
    );
    let e = read_all_stream(&patched).unwrap_err();
    assert!(
        matches!(e.problem(), Some(Problem::Supercompression { .. })),
        "{e}"
    );
}

#[test]
fn block_levels_decode_to_their_logical_size() {
    let (t, d) = sample_block_texture("odd", TextureRole::Colour, TextureFormat::Bc7, 9, 5);
    for (level, bytes) in d.iter().enumerate() {
        let rgba = pack::texels::decode_level(&t, level, bytes);
        assert_eq!(
            rgba.len() as u64,
            t.level_rgba8_bytes(level),
            "level {level}"
        );
    }
}

fn arb_texture(name: String) -> impl Strategy<Value = (Texture, Vec<Vec<u8>>)> {
    (1u32..40, 1u32..40, any::<bool>(), any::<u8>()).prop_map(move |(w, h, full, seed)| {
        let (mut t, mut d) = sample_texture(&name, TextureRole::Projector, w, h);
        if !full {
            t.mips.truncate(1);
            d.truncate(1);
        }
        for level in &mut d {
            for (i, b) in level.iter_mut().enumerate() {
                *b = (i as u8).wrapping_mul(seed);
            }
        }
        (t, d)
    })
}

fn arb_mesh() -> impl Strategy<Value = (Mesh, MeshData)> {
    (
        1usize..50,
        1usize..30,
        proptest::collection::vec(any::<u32>(), 90),
        -1e6f32..1e6,
    )
        .prop_map(|(nv, ntri, picks, scale)| {
            let verts: Vec<StandardVertex> = (0..nv)
                .map(|i| StandardVertex {
                    position: [i as f32 * scale, -(i as f32), 0.5],
                    material: [(i % 2) as u16, 0],
                    ..Default::default()
                })
                .collect();
            let idx: Vec<u32> = picks[..ntri * 3].iter().map(|p| p % nv as u32).collect();
            let mesh = Mesh {
                name: format!("m{nv}"),
                layout: VertexLayout::standard(),
                vertex_count: nv as u32,
                index_count: idx.len() as u32,
                index_format: IndexFormat::U32,
                vertex_section: 0,
                index_section: 0,
                bounds_min: [-1e9; 3],
                bounds_max: [1e9; 3],
                ranges: vec![DrawRange {
                    material: 1,
                    first_index: 0,
                    index_count: idx.len() as u32,
                }],
            };
            (
                mesh,
                MeshData {
                    vertices: VertexLayout::standard().encode_vertices(&verts),
                    indices: bytemuck::cast_slice(&idx).to_vec(),
                },
            )
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn random_packs_round_trip(
        meshes in proptest::collection::vec(arb_mesh(), 0..3),
        t0 in arb_texture("a".into()),
        t1 in arb_texture("b".into()),
        ntex in 0usize..3,
        zstd in any::<[bool; 2]>(),
    ) {
        let (mut toc, _) = sample();
        let texs: Vec<_> = [t0, t1].into_iter().take(ntex).collect();
        toc.meshes = meshes.iter().map(|m| m.0.clone()).collect();
        toc.textures = texs.iter().map(|t| t.0.clone()).collect();
        toc.materials[1].diffuse_texture = None;
        toc.materials[1].normal_texture = None;
        if ntex == 0 {
            toc.materials[1].projector_texture = None;
            toc.materials[1].projector_margin = [0.0; 2];
        }
        let stored = toc
            .textures
            .iter_mut()
            .zip(&texs)
            .zip(zstd)
            .map(|((t, (_, levels)), z)| {
                let s = if z { Supercompression::Zstd } else { Supercompression::None };
                pack::testing::supercompress(t, s, levels)
            })
            .collect();
        let data = PackData {
            meshes: meshes.iter().map(|m| m.1.clone()).collect(),
            textures: stored,
        };
        let bytes = encode(toc.clone(), &data).unwrap();
        let pack = Pack::from_bytes("p", &bytes).unwrap();
        let got = pack.toc();
        prop_assert_eq!(got.meshes.len(), toc.meshes.len());
        for (i, m) in got.meshes.iter().enumerate() {
            prop_assert_eq!(pack.vertex_bytes(m), data.meshes[i].vertices.as_slice());
            let idx = pack.indices(m);
            prop_assert_eq!(bytemuck::cast_slice::<u32, u8>(&idx), data.meshes[i].indices.as_slice());
        }
        for (ti, t) in got.textures.iter().enumerate() {
            for level in 0..t.mips.len() {
                prop_assert_eq!(pack.mip_bytes(ti, level), texs[ti].1[level].as_slice());
                prop_assert_eq!(
                    pack.section_bytes(t.mips[level].section),
                    data.textures[ti][level].as_slice()
                );
            }
        }
        // Re-encoding the decoded TOC reproduces the same bytes: the format is canonical.
        prop_assert_eq!(encode(got.clone(), &data).unwrap(), bytes.clone());
        read_all_stream(&bytes).unwrap();
    }
}

/// A projector margin must be a finite, non-negative fraction within bounds, and only where
/// the material has a projector texture: a reader builds its projection from it.
#[test]
fn bad_projector_margins_are_rejected() {
    for (margin, projector) in [
        ([f32::NAN, 0.0], true),
        ([0.0, -0.01], true),
        ([f32::INFINITY, 0.1], true),
        ([MAX_PROJECTOR_MARGIN * 2.0, 0.1], true),
        ([0.1, 0.1], false),
    ] {
        let (mut toc, data) = sample();
        let m = &mut toc.materials[1];
        m.projector_margin = margin;
        if !projector {
            m.projector_texture = None;
        }
        let e = encode(toc, &data).unwrap_err();
        assert!(
            e.to_string().contains("projector margin"),
            "{margin:?}: {e}"
        );
    }
    let (mut toc, data) = sample();
    toc.materials[1].projector_margin = [MAX_PROJECTOR_MARGIN, 0.0];
    encode(toc, &data).expect("the largest margin is valid");
}

/// An output path that is a symbolic link replaces the file it names and keeps the link; a
/// device is written as it is, never replaced by a file (`cooker cook -o /dev/null` as root
/// used to turn the system's `/dev/null` into a regular file); a directory is an error.
#[cfg(unix)]
#[test]
fn write_atomic_follows_links_and_writes_devices_in_place() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("real.pack");
    std::fs::write(&target, b"old").unwrap();
    let link = dir.path().join("link.pack");
    std::os::unix::fs::symlink("real.pack", &link).unwrap();
    pack::write_atomic(&link, b"new").unwrap();
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(std::fs::read(&target).unwrap(), b"new");
    // A dangling link names the file to create.
    let dangling = dir.path().join("dangling.pack");
    std::os::unix::fs::symlink("made.pack", &dangling).unwrap();
    pack::write_atomic(&dangling, b"made").unwrap();
    assert_eq!(
        std::fs::read(dir.path().join("made.pack")).unwrap(),
        b"made"
    );
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty(), "temp files left: {leftovers:?}");

    let null = std::path::Path::new("/dev/null");
    pack::write_atomic(null, b"nothing").unwrap();
    assert!(
        std::fs::metadata(null)
            .unwrap()
            .file_type()
            .is_char_device()
    );
    let full = std::path::Path::new("/dev/full");
    if full.exists() {
        let e = pack::write_atomic(full, b"no room")
            .unwrap_err()
            .to_string();
        assert!(e.contains("/dev/full"), "{e}");
        assert!(
            std::fs::metadata(full)
                .unwrap()
                .file_type()
                .is_char_device()
        );
    }
    let e = pack::write_atomic(dir.path(), b"x").unwrap_err();
    let cause = std::error::Error::source(&e).map(|s| s.to_string());
    assert!(
        cause.as_deref().is_some_and(|c| c.contains("directory")),
        "{e}: {cause:?}"
    );
}

/// A device or a pipe is not read as a pack: `/dev/zero` reports no length, and was read to the
/// end of memory before its magic was looked at (`cooker info /dev/zero` took 6 GB in 5 s).
#[cfg(target_os = "linux")]
#[test]
fn a_device_is_refused_before_it_is_read() {
    let Err(e) = pack::Pack::open("/dev/zero") else {
        panic!("/dev/zero opened as a pack")
    };
    let text = format!(
        "{e}: {}",
        std::error::Error::source(&e)
            .map(|s| s.to_string())
            .unwrap_or_default()
    );
    assert!(
        text.contains("/dev/zero") && text.contains("not a regular file"),
        "{text}"
    );
}

/// A cook killed mid-write (SIGKILL) leaves its temp file, as large as the pack; the next write
/// of that output removes it. A live process's temp file (this one's, here) stays.
#[cfg(target_os = "linux")]
#[test]
fn write_atomic_removes_the_temp_files_of_dead_writers() {
    let dir = tempfile::tempdir().unwrap();
    // No process has a PID this large (the kernel's limit is 2^22).
    let dead = dir.path().join(".out.pack.tmp-999999999-0");
    let live = dir
        .path()
        .join(format!(".out.pack.tmp-{}-77", std::process::id()));
    let other = dir.path().join(".other.pack.tmp-999999999-0");
    for p in [&dead, &live, &other] {
        std::fs::write(p, b"partial").unwrap();
    }
    pack::write_atomic(&dir.path().join("out.pack"), b"whole").unwrap();
    assert!(!dead.exists(), "a dead writer's temp file was left");
    assert!(live.exists(), "a live writer's temp file was removed");
    assert!(other.exists(), "another output's temp file was removed");
}
