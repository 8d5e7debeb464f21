//! Compiles the WGSL shaders to SPIR-V with naga (pure Rust, no C++ toolchain); a shader
//! error fails the build.

use std::path::PathBuf;

fn main() {
    let source = "shaders/mesh.wgsl";
    println!("cargo::rerun-if-changed={source}");
    let text = std::fs::read_to_string(source).expect("shader source");
    let module = naga::front::wgsl::parse_str(&text)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&text)));
    let info = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{source}: {e:?}"));
    let words =
        naga::back::spv::write_vec(&module, &info, &naga::back::spv::Options::default(), None)
            .unwrap_or_else(|e| panic!("{source}: {e}"));
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap()).join("mesh.spv");
    std::fs::write(out, bytes).expect("write SPIR-V");
}
