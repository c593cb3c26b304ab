//! Image bytes as a texture reads them (PNG, JPEG, ..., KTX2 with a Basis Universal payload):
//! an image within the size limits or an error naming the input, never a panic or an abort.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let name = std::path::Path::new("fuzz.image");
    if let Ok(img) = texture::load_image_bytes(data, name) {
        assert!((1..=texture::MAX_SIDE).contains(&img.width()));
        assert!((1..=texture::MAX_SIDE).contains(&img.height()));
    }
});
