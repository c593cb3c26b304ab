//! GPU-free checks: every pass's WGSL parses and validates with naga, every shader file is used,
//! and the Rust uniform structs match naga's layout of the WGSL structs.

use render::{shaders, uniforms};

fn parse(name: &str) -> naga::Module {
    let src = shaders::compose(name).unwrap_or_else(|| panic!("{name}: unknown file or include"));
    let module = naga::front::wgsl::parse_str(&src)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&src)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&src)));
    module
}

#[test]
fn every_pass_parses_and_validates() {
    for name in shaders::PASSES {
        let module = parse(name);
        assert!(
            shaders::DEPTH_ONLY.contains(name)
                || module
                    .entry_points
                    .iter()
                    .any(|e| e.stage == naga::ShaderStage::Fragment),
            "{name}: no fragment entry point"
        );
        assert!(
            module
                .entry_points
                .iter()
                .any(|e| e.stage == naga::ShaderStage::Vertex),
            "{name}: no vertex entry point"
        );
    }
}

#[test]
fn every_file_is_part_of_some_pass() {
    for (file, _) in shaders::FILES {
        let used = shaders::PASSES.iter().any(|p| {
            let src = shaders::compose(p).unwrap();
            src.contains(&format!("// ---- {file} ----"))
        });
        assert!(used, "{file} is not included by any pass");
    }
    // And every shader file on disk is compiled in.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        if name.ends_with(".wgsl") {
            assert!(
                shaders::FILES.iter().any(|(f, _)| *f == name),
                "{name} is not in shaders::FILES"
            );
        }
    }
}

#[test]
fn uniform_sizes_match_naga_layout() {
    let mut checked = std::collections::HashSet::new();
    for name in shaders::PASSES {
        let module = parse(name);
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        for (handle, ty) in module.types.iter() {
            let Some(ty_name) = &ty.name else { continue };
            if let Some((rust, _, size)) = uniforms::LAYOUTS.iter().find(|(_, w, _)| w == ty_name) {
                let wgsl = layouter[handle].size as usize;
                assert_eq!(
                    *size, wgsl,
                    "{name}: Rust {rust} is {size} bytes, WGSL {ty_name} is {wgsl}"
                );
                // Uniform buffers need 16-byte multiples; the Rust side must not rely on padding.
                assert_eq!(size % 16, 0, "{rust}");
                checked.insert(*rust);
            }
        }
    }
    for (rust, _, _) in uniforms::LAYOUTS {
        assert!(checked.contains(rust), "{rust} is not used by any shader");
    }
}

/// The windows' storage buffer is `uniforms::Windows::bytes`: the direct map's entry, then the
/// windows' back to back, so WGSL must put `items` right after `direct` with the entry's size
/// as its stride.
#[test]
fn windows_buffer_matches_naga_layout() {
    let module = parse("lit.wgsl");
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).unwrap();
    let entry = std::mem::size_of::<uniforms::WindowProjector>() as u32;
    let (_, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some("Windows"))
        .expect("a Windows struct");
    let naga::TypeInner::Struct { members, .. } = &ty.inner else {
        panic!("Windows is not a struct: {ty:?}");
    };
    let names: Vec<_> = members.iter().map(|m| m.name.as_deref()).collect();
    assert_eq!(names, [Some("direct"), Some("items")]);
    assert_eq!((members[0].offset, members[1].offset), (0, entry));
    match module.types[members[1].ty].inner {
        naga::TypeInner::Array {
            size: naga::ArraySize::Dynamic,
            stride,
            ..
        } => assert_eq!(stride, entry),
        ref other => panic!("items is not a runtime-sized array: {other:?}"),
    }
    let w = uniforms::Windows::new(3);
    assert_eq!(w.bytes().len() as u64, uniforms::Windows::buffer_size(3));
}

#[test]
fn wgsl_constants_match_rust() {
    let src = shaders::compose("lit.wgsl").unwrap();
    assert!(src.contains(&format!(
        "const MAX_WINDOWS: u32 = {}u;",
        uniforms::MAX_WINDOWS
    )));
    for class in pack::MaterialClass::ALL {
        let id = uniforms::class_id(class);
        let name = class.name().to_uppercase().replace('-', "_");
        assert!(
            src.contains(&format!("const CLASS_{name}: u32 = {id}u;")),
            "CLASS_{name} != {id}"
        );
    }
}
