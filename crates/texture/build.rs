//! The ISPC texture compressor (`intel_tex_2`) ships prebuilt kernels with a C++ part that
//! needs the C++ runtime at link time, which the crate does not ask for on Linux.

fn main() {
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    match os.as_str() {
        "linux" | "freebsd" => println!("cargo:rustc-link-lib=dylib=stdc++"),
        "macos" | "ios" => println!("cargo:rustc-link-lib=dylib=c++"),
        _ => {}
    }
}
