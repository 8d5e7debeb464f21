//! The committed C header is exactly what cbindgen generates from the Rust ABI: the core from
//! `src/abi.rs`, then one section per scene extension from its file in `src/ext/`, opened by
//! the extension's id. Regenerate with `make header` (sets HAPTICD_UPDATE_HEADER=1).

use std::path::Path;

/// A scene extension as its Rust file declares it.
struct Extension {
    /// Its file under `src/ext/`.
    file: String,
    /// The name of its id constant, such as `HAPTICD_EXT_SCENE_GEOMETRY`.
    constant: String,
    /// Its id, such as `hapticd.scene.geometry/1`.
    id: String,
    /// What it is for: the rest of its file's first line.
    about: String,
}

/// Every file of `src/ext/` but `mod.rs`, in name order, read for its id and purpose.
fn extensions(dir: &Path) -> Vec<Extension> {
    let mut files: Vec<String> = std::fs::read_dir(dir.join("src/ext"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|name| name.ends_with(".rs") && name != "mod.rs")
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|file| {
            let text = std::fs::read_to_string(dir.join("src/ext").join(&file)).unwrap();
            let first = text.lines().next().unwrap_or_default();
            let about = first
                .split_once("`: ")
                .map(|(_, about)| about.to_string())
                .unwrap_or_else(|| panic!("{file}: no `//! Scene extension `\"id\"`: …` line"));
            let declaration = text
                .lines()
                .find(|l| l.starts_with("pub const HAPTICD_EXT_"))
                .unwrap_or_else(|| panic!("{file} declares no extension id"));
            let constant = declaration["pub const ".len()..]
                .split(':')
                .next()
                .unwrap()
                .to_string();
            let id = declaration
                .split("c\"")
                .nth(1)
                .and_then(|rest| rest.split('"').next())
                .unwrap()
                .to_string();
            Extension {
                file,
                constant,
                id,
                about,
            }
        })
        .collect()
}

/// cbindgen's output for `source` under `config`.
fn generated(config: cbindgen::Config, source: &Path) -> String {
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(source)
        .generate()
        .expect("cbindgen generates the header");
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).unwrap()
}

/// The header as cbindgen writes it from the Rust ABI.
fn header(dir: &Path) -> String {
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut text = generated(config.clone(), &dir.join("src/abi.rs"));
    let mut sections = String::new();
    for extension in extensions(dir) {
        let mut section = config.clone();
        section.include_guard = None;
        section.autogen_warning = None;
        section.sys_includes.clear();
        section.no_includes = true;
        // cbindgen writes no string constants: the id is defined here.
        section.header = Some(format!(
            "/* ---------------------------------------------------------------------------\n \
             * Scene extension \"{}\": {}\n \
             * ------------------------------------------------------------------------- */\n\n\
             #define {} \"{}\"",
            extension.id, extension.about, extension.constant, extension.id
        ));
        section.after_includes = None;
        sections.push_str(&generated(
            section,
            &dir.join("src/ext").join(&extension.file),
        ));
    }
    let end = text
        .rfind("#endif")
        .expect("the include guard closes the header");
    text.insert_str(end, &sections);
    text
}

#[test]
fn c_header_matches_the_rust_abi() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let generated = header(dir);
    let path = dir.join("include/hapticd_plugin.h");
    if std::env::var_os("HAPTICD_UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).expect("write header");
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "{} is out of date with src/abi.rs and src/ext/: run `make header`",
        path.display()
    );
}

#[test]
fn each_extension_has_a_section_that_names_it_as_the_rust_abi_does() {
    let header = include_str!("../include/hapticd_plugin.h");
    let extensions = extensions(Path::new(env!("CARGO_MANIFEST_DIR")));
    assert_eq!(extensions.len(), 9, "the extensions of ABI 1.12");
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
        (
            "HAPTICD_EXT_SCENE_MOBILITY",
            hapticd_plugin_api::HAPTICD_EXT_SCENE_MOBILITY,
        ),
        (
            "HAPTICD_EXT_SCENE_JOINTS",
            hapticd_plugin_api::HAPTICD_EXT_SCENE_JOINTS,
        ),
        (
            "HAPTICD_EXT_SCENE_DEFORMATION",
            hapticd_plugin_api::HAPTICD_EXT_SCENE_DEFORMATION,
        ),
        (
            "HAPTICD_EXT_SCENE_COMPLIANCE",
            hapticd_plugin_api::HAPTICD_EXT_SCENE_COMPLIANCE,
        ),
        (
            "HAPTICD_EXT_SCENE_HELD",
            hapticd_plugin_api::HAPTICD_EXT_SCENE_HELD,
        ),
    ] {
        let id = id.to_str().unwrap();
        let line = format!("#define {name} \"{id}\"");
        assert!(header.contains(&line), "the header lacks `{line}`");
        let banner = format!("Scene extension \"{id}\":");
        let at = header
            .find(&banner)
            .unwrap_or_else(|| panic!("no section {banner}"));
        assert!(
            header[at..].find(&line) < header[at..].find("typedef struct"),
            "{id}: its id opens its section"
        );
    }
}
