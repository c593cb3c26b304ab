//! Like `pack_reader`, but with every checksum recomputed first, so mutations reach the
//! structural checks, the TOC decoder and the semantic validation instead of stopping at a CRC.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let mut bytes = data.to_vec();
    pack::testing::fix_checksums(&mut bytes);
    let whole = pack::Pack::from_bytes("fuzz.pack", &bytes);
    if let Ok(p) = &whole {
        for m in &p.toc().meshes {
            assert!(p.indices(m).iter().all(|&i| i < m.vertex_count));
        }
    }
    let streamed = pack::StreamReader::new("fuzz.pack", bytes.as_slice()).and_then(|mut s| {
        while s.next_section()?.is_some() {}
        Ok(())
    });
    assert_eq!(whole.is_ok(), streamed.is_ok());
});
