//! Any byte string either validates as a pack (and then every accessor is safe to use) or is
//! rejected with an error; it never panics, in the mmap-style reader or the streaming one.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let whole = pack::Pack::from_bytes("fuzz.pack", data);
    if let Ok(p) = &whole {
        let toc = p.toc();
        for m in &toc.meshes {
            let _ = p.vertex_bytes(m);
            let idx = p.indices(m);
            assert!(idx.iter().all(|&i| i < m.vertex_count));
        }
        for (t, tex) in toc.textures.iter().enumerate() {
            for level in 0..tex.mips.len() {
                assert_eq!(p.mip_bytes(t, level).len() as u64, tex.level_bytes(level));
            }
        }
    }
    let mut streamed = Ok(());
    match pack::StreamReader::new("fuzz.pack", data) {
        Ok(mut s) => loop {
            match s.next_section() {
                Ok(Some(_)) => {}
                Ok(None) => break,
                Err(e) => {
                    streamed = Err(e);
                    break;
                }
            }
        },
        Err(e) => streamed = Err(e),
    }
    // Both readers apply the same checks, so they must agree on every input.
    assert_eq!(whole.is_ok(), streamed.is_ok());
});
