//! OBJ, glTF, GLB and PLY import: any bytes give meshes or a `CookError`, never a panic; whatever
//! imports also survives the mesh stage (index validation happens before meshopt sees it).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&selector, body)) = data.split_first() else { return };
    let ext = ["obj", "gltf", "glb", "ply"][selector as usize % 4];
    let dir = std::env::temp_dir().join(format!("sg-fuzz-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(format!("input.{ext}"));
    std::fs::write(&path, body).unwrap();
    if let Ok(manifest) = cook::Manifest::from_mesh_file(&path) {
        let settings = cook::Settings { cook_textures: false, ..cook::Settings::new(&manifest) };
        if let Ok(out) = cook::cook(&manifest, &settings) {
            // A successful cook must produce a pack the reader accepts.
            let bytes = pack::encode(out.toc.clone(), &out.data).expect("cooked pack encodes");
            pack::Pack::from_bytes("fuzz.pack", &bytes).expect("cooked pack validates");
        }
    }
});
