//! The scene manifest parser: any text gives a manifest or an error naming the line, never a
//! panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = cook::Manifest::parse(std::path::Path::new("/nonexistent/scene.toml"), text);
    }
});
