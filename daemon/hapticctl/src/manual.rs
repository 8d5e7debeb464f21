//! The manual pages (`hapticctl manual DIR`), generated from the code so they cannot drift
//! from it. The programs' pages come from their command-line definitions (clap); the file
//! formats' pages from the documentation at the top of the module that parses each format.

use clap::CommandFactory;

/// A file format's page.
struct Format {
    /// The page's name (section 5).
    name: &'static str,
    /// What the NAME section says it is.
    summary: &'static str,
    /// Its sections: a title, and the source of the module whose documentation fills it.
    parts: &'static [(&'static str, &'static str)],
}

/// The formats' pages.
const FORMATS: [Format; 4] = [
    Format {
        name: "hapticd.yaml",
        summary: "configuration of the hapticd haptics daemon",
        parts: &[("DESCRIPTION", include_str!("../../config/src/file.rs"))],
    },
    Format {
        name: "hapticd-mechanism",
        summary: "mechanism descriptors of hapticd: the strings of a SPIDAR in YAML",
        parts: &[(
            "DESCRIPTION",
            include_str!("../../core/src/mechanism/descriptor.rs"),
        )],
    },
    Format {
        name: "hapticd-scene",
        summary: "scene files of hapticd: static scenes and physics scenes",
        parts: &[
            (
                "STATIC SCENES",
                include_str!("../../core/src/scene/static_scene/mod.rs"),
            ),
            (
                "PHYSICS SCENES",
                include_str!("../../../plugins/lib/physics/src/scene/mod.rs"),
            ),
            (
                "JOINTS",
                include_str!("../../../plugins/lib/physics/src/scene/joints.rs"),
            ),
            (
                "ROBOTS",
                include_str!("../../../plugins/lib/physics/src/scene/urdf.rs"),
            ),
            (
                "SOFT BODIES",
                include_str!("../../../plugins/lib/physics/src/scene/soft.rs"),
            ),
        ],
    },
    Format {
        name: "hapticd-hand",
        summary: "scripts of hapticd's simulated hand",
        parts: &[("DESCRIPTION", include_str!("../../device/src/sim/hand.rs"))],
    },
];

/// What every page ends with.
const SEE_ALSO: &str = "hapticd(8), hapticd-render(8), hapticd-zenoh(8), hapticd-world(8), hapticctl(1), hapticd.yaml(5), hapticd-mechanism(5), \
                        hapticd-scene(5), hapticd-hand(5), systemd.service(5), busctl(1)";

/// The rest of hapticd(8), after what clap writes from its options.
const DAEMON_SECTIONS: &str = r#".SH FILES
.TP
.I /etc/hapticd/hapticd.yaml
The configuration, see hapticd.yaml(5).
.TP
.I /etc/hapticd/mechanisms, /usr/lib/hapticd/plugins, /usr/share/hapticd/mechanisms
Mechanism descriptors (hapticd\-mechanism(5)) and plugins, searched in this order.
.TP
.I /etc/hapticd/scenes, /usr/share/hapticd/scenes, /usr/lib/hapticd/scenes
Scene files (hapticd\-scene(5)) and the scene plugins physics scenes run on.
.TP
.I /var/lib/hapticd
Calibration and changed parameters of each device (the unit's StateDirectory).
.PP
Installed under another prefix, hapticd reads PREFIX/etc/hapticd and PREFIX/lib and
PREFIX/share in place of /etc/hapticd and /usr.
.SH SIGNALS
.TP
.B SIGHUP
Re\-read the configuration and rescan the plugins (systemctl reload hapticd).
.TP
.B SIGTERM, SIGINT
Drive the motors to zero force and exit.
.SH EXIT STATUS
0 when stopped or after \-\-duration; 1 when it cannot start (the reason is logged);
2 for bad arguments.
"#;

/// The rest of hapticd-render(8).
const RENDERER_SECTIONS: &str = r#".SH ENVIRONMENT
.TP
.B VK_DRIVER_FILES
The Vulkan drivers to load (the loader's own variable); Mesa's lavapipe draws on the CPU
where there is no GPU.
.SH EXIT STATUS
1 when it cannot serve its name on the bus (the reason is logged); 2 for bad arguments.
"#;

/// The rest of hapticd-zenoh(8).
const BRIDGE_SECTIONS: &str = r#".SH FILES
.TP
.I /etc/hapticd/network.yaml
Where to listen and connect, the ROS 2 domain, the rate, whether commands are taken, the
administrator's Zenoh configuration (access control).
.SH EXIT STATUS
0 after \-\-duration; 1 when it cannot start or loses hapticd (the reason is logged);
2 for bad arguments.
"#;

/// The rest of hapticd-world(8).
const WORLD_SECTIONS: &str = r#".SH FILES
.TP
.I /etc/hapticd/world.yaml
The world's scene file (a rapier scene), where hapticd-world.service looks for it.
.TP
.I /etc/hapticd/network.yaml
Where to listen and connect, and the administrator's Zenoh configuration.
.SH EXIT STATUS
0 after \-\-duration; 1 when it cannot start or the world stops being finite (the reason is
logged); 2 for bad arguments.
"#;

/// The rest of hapticctl(1).
const CLIENT_SECTIONS: &str = r#".SH EXIT STATUS
0 on success; 1 when the operation failed (a refused request gives the daemon's reason,
and a daemon that is not running is said so); 2 for bad arguments.
.SH ENVIRONMENT
.TP
.B HAPTICD_MECHANISM_PATH
Colon\-separated directories that replace the default mechanism search path.
"#;

/// Every page as its file's name (`hapticd.8`, `hapticctl-scene-run.1`, `hapticd.yaml.5`, …)
/// and its roff, dated `date`: hapticd's programs', hapticctl's from its command line
/// `client` (a page for it and one per subcommand, as git has) and the file formats'.
pub fn pages(client: clap::Command, date: &str) -> Vec<(String, Vec<u8>)> {
    let source = format!("hapticd {}", env!("CARGO_PKG_VERSION"));
    let program = |command: clap::Command, section: &str, extra: &str| -> Vec<u8> {
        let mut page = Vec::new();
        clap_mangen::Man::new(command)
            .section(section)
            .date(date)
            .source(source.clone())
            .manual("hapticd")
            .render(&mut page)
            .expect("rendering into memory");
        page.extend_from_slice(extra.as_bytes());
        page.extend_from_slice(format!(".SH SEE ALSO\n{}\n", escape(SEE_ALSO)).as_bytes());
        page
    };
    let mut pages = vec![
        (
            "hapticd.8".to_string(),
            program(hapticd_service::cli::Cli::command(), "8", DAEMON_SECTIONS),
        ),
        (
            "hapticd-render.8".to_string(),
            program(
                hapticd_service::cli::RenderCli::command(),
                "8",
                RENDERER_SECTIONS,
            ),
        ),
        (
            "hapticd-zenoh.8".to_string(),
            program(
                hapticd_service::cli::ZenohCli::command(),
                "8",
                BRIDGE_SECTIONS,
            ),
        ),
        (
            "hapticd-world.8".to_string(),
            program(
                hapticd_service::cli::WorldCli::command(),
                "8",
                WORLD_SECTIONS,
            ),
        ),
        (
            "hapticctl.1".to_string(),
            program(client.clone(), "1", CLIENT_SECTIONS),
        ),
    ];
    // A page per subcommand (hapticctl-scene-run.1, …) with all its options.
    let mut client = client.disable_help_subcommand(true);
    client.build();
    let mut pending: Vec<clap::Command> = client.get_subcommands().cloned().collect();
    while let Some(command) = pending.pop() {
        pending.extend(command.get_subcommands().cloned());
        let name = command
            .get_display_name()
            .unwrap_or(command.get_name())
            .to_string();
        pages.push((format!("{name}.1"), program(command, "1", "")));
    }
    for format in &FORMATS {
        pages.push((
            format!("{}.5", format.name),
            format_page(format, date, &source),
        ));
    }
    pages
}

/// The page of a file format, dated `date`, from `source` (the package and its version).
fn format_page(format: &Format, date: &str, source: &str) -> Vec<u8> {
    let mut page = format!(
        ".TH {} 5 \"{date}\" \"{source}\" hapticd\n.SH NAME\n{} \\- {}\n",
        format.name.to_uppercase(),
        escape(format.name),
        escape(format.summary)
    );
    for (title, module) in format.parts {
        page.push_str(&format!(".SH {title}\n"));
        page.push_str(&roff_from_markdown(&module_doc(module)));
    }
    page.push_str(&format!(".SH SEE ALSO\n{}\n", escape(SEE_ALSO)));
    page.into_bytes()
}

/// The pages' date: that of `$SOURCE_DATE_EPOCH` when set (reproducible builds), else today.
pub fn page_date() -> String {
    let seconds = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.parse::<u64>().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs())
        });
    let (y, m, d) = civil_date(seconds / 86_400);
    format!("{y:04}-{m:02}-{d:02}")
}

/// Year, month and day of `days` since 1970-01-01 (the proleptic Gregorian calendar, in
/// eras of 400 years).
fn civil_date(days: u64) -> (u64, u64, u64) {
    let z = days + 719_468;
    let era = z / 146_097;
    let day_of_era = z % 146_097;
    let year_of_era =
        (day_of_era - day_of_era / 1460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let mp = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = year_of_era + era * 400 + u64::from(month <= 2);
    (year, month, day)
}

/// The `//!` documentation at the top of a Rust source file, as Markdown.
fn module_doc(source: &str) -> String {
    source
        .lines()
        .take_while(|l| l.starts_with("//!"))
        .map(|l| l.trim_start_matches("//!").strip_prefix(' ').unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Text made safe for roff: backslashes and minus signs.
fn escape(text: &str) -> String {
    text.replace('\\', "\\e").replace('-', "\\-")
}

/// A line of roff text that would otherwise read as a request (a leading dot or quote).
fn text_line(text: String) -> String {
    if text.starts_with(['.', '\'']) {
        format!("\\&{text}\n")
    } else {
        format!("{text}\n")
    }
}

/// Inline Markdown: `code` and **strong** in bold, rustdoc links as their text.
fn inline(text: &str) -> String {
    let text = text
        .replace("[`", "`")
        .replace("`]", "`")
        .replace("**", "`");
    let mut out = String::new();
    for (i, part) in text.split('`').enumerate() {
        if i % 2 == 1 {
            out.push_str(&format!("\\fB{}\\fR", escape(part)));
        } else {
            out.push_str(&escape(part));
        }
    }
    out
}

/// The subset of Markdown the module documentation uses: paragraphs, fenced examples and
/// bulleted lists.
fn roff_from_markdown(markdown: &str) -> String {
    let mut out = String::new();
    let mut in_code = false;
    for line in markdown.lines() {
        if line.starts_with("```") {
            out.push_str(if in_code {
                ".fi\n.RE\n"
            } else {
                ".PP\n.RS 4\n.nf\n"
            });
            in_code = !in_code;
        } else if in_code {
            out.push_str(&text_line(escape(line)));
        } else if line.trim().is_empty() {
            out.push_str(".PP\n");
        } else if let Some(item) = line.strip_prefix("- ") {
            out.push_str(".IP \\(bu 2\n");
            out.push_str(&text_line(inline(item)));
        } else {
            out.push_str(&text_line(inline(line.trim_start())));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_becomes_roff_that_no_line_of_text_can_break() {
        let roff = roff_from_markdown(
            "A `key: value` and [`Thing`].\n\n```yaml\n.start: -1  # \\n\n```\n- one item\n",
        );
        assert_eq!(
            roff,
            "A \\fBkey: value\\fR and \\fBThing\\fR.\n.PP\n.PP\n.RS 4\n.nf\n\
             \\&.start: \\-1  # \\en\n.fi\n.RE\n.IP \\(bu 2\none item\n"
        );
    }

    #[test]
    fn dates_follow_the_calendar() {
        assert_eq!(civil_date(0), (1970, 1, 1));
        // 2000-02-29 (a leap day of a century year) and 2026-11-30.
        assert_eq!(civil_date(11_016), (2000, 2, 29));
        assert_eq!(civil_date(20_787), (2026, 11, 30));
    }

    /// The fenced examples of a module's documentation.
    fn examples(module: &str) -> Vec<String> {
        let doc = module_doc(module);
        doc.split("```")
            .skip(1)
            .step_by(2)
            .map(|block| block.trim_start_matches("yaml").to_string())
            .collect()
    }

    #[test]
    fn the_examples_in_the_format_pages_are_accepted_by_the_parsers() {
        use hapticd_core::diagnostics::Diagnostics;
        use std::path::Path;
        // Beside the shipped scenes, whose meshes the examples name.
        let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/scenes");
        let path = &scenes.join("example.yaml");
        type Parse = fn(&str, &Path) -> Result<(), Diagnostics>;
        let parsers: [(&str, Parse); 5] = [
            ("hapticd.yaml", |t, p| {
                hapticd_config::Config::parse(t, p).map(drop)
            }),
            ("hapticd-mechanism", |t, p| {
                hapticd_core::mechanism::descriptor::parse(t, p).map(drop)
            }),
            ("hapticd-scene", |t, p| {
                let files = hapticd_mesh::scene_files();
                hapticd_core::scene::static_scene::StaticSceneSpec::parse_with_files(t, p, files)
                    .map(drop)
            }),
            ("hapticd-scene", |t, p| {
                // Pieces cut into a cache of this test's own, never the user's.
                let cache =
                    std::env::temp_dir().join(format!("hapticctl-manual-{}", std::process::id()));
                let parsed = hapticd_physics::scene::SceneFile::parse_cached(
                    t,
                    p,
                    1,
                    &hapticd_mesh::cache::Cache::at(&cache),
                );
                let _ = std::fs::remove_dir_all(&cache);
                parsed.map(drop)
            }),
            ("hapticd-hand", |t, p| {
                // Less the step that follows a recording, which the example cannot ship.
                let t: String = t
                    .lines()
                    .filter(|l| !l.contains("path:"))
                    .collect::<Vec<_>>()
                    .join("\n");
                hapticd_device::sim::hand::Script::parse(&t, p).map(drop)
            }),
        ];
        let mut checked = 0;
        for Format { name, parts, .. } in FORMATS {
            let candidates: Vec<Parse> = parsers
                .iter()
                .filter(|(n, _)| *n == name)
                .map(|(_, p)| *p)
                .collect();
            for (_, module) in parts {
                for example in examples(module) {
                    // Each example is one of its page's formats.
                    let results: Vec<_> = candidates.iter().map(|p| p(&example, path)).collect();
                    assert!(
                        results.iter().any(Result::is_ok),
                        "{name}: {:?}\n{example}",
                        results
                    );
                    checked += 1;
                }
            }
        }
        assert_eq!(checked, 11);
    }
}
