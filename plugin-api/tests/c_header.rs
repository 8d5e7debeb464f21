//! The committed C header is exactly what cbindgen generates from `src/abi.rs`.
//! Regenerate with `make header` (sets HAPTICD_UPDATE_HEADER=1).

use std::path::Path;

#[test]
fn c_header_matches_the_rust_abi() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/abi.rs"))
        .generate()
        .expect("cbindgen generates the header");
    let mut generated = Vec::new();
    bindings.write(&mut generated);
    let path = dir.join("include/hapticd_plugin.h");
    if std::env::var_os("HAPTICD_UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).expect("write header");
    }
    let committed = std::fs::read(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "{} is out of date with src/abi.rs: run `make header`",
        path.display()
    );
}

#[test]
fn the_header_names_each_extension_as_the_rust_abi_does() {
    // cbindgen writes no string constants: the header's come from cbindgen.toml.
    let header = include_str!("../include/hapticd_plugin.h");
    for (name, id) in [
        (
            "HAPTICD_EXT_SCENE_GEOMETRY",
            hapticd_plugin_api::HAPTICD_EXT_SCENE_GEOMETRY,
        ),
        (
            "HAPTICD_EXT_SCENE_FILES",
            hapticd_plugin_api::HAPTICD_EXT_SCENE_FILES,
        ),
        (
            "HAPTICD_EXT_SCENE_CONTROL",
            hapticd_plugin_api::HAPTICD_EXT_SCENE_CONTROL,
        ),
        (
            "HAPTICD_EXT_SCENE_CONTACTS",
            hapticd_plugin_api::HAPTICD_EXT_SCENE_CONTACTS,
        ),
    ] {
        let line = format!("#define {name} \"{}\"", id.to_str().unwrap());
        assert!(header.contains(&line), "the header lacks `{line}`");
    }
}
