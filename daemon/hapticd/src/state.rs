//! What hapticd remembers about each device across restarts: its calibration and the
//! parameters the user changed, one JSON file per device identity under the state directory
//! (`$STATE_DIRECTORY`, `/var/lib/hapticd` under systemd).
//!
//! Files are replaced atomically: written to a temporary file, flushed to disk, renamed over
//! the old one, and the directory flushed, so a crash at any moment leaves the old file or the
//! new one, never a mix. They are read as every file is (`hapticd_core::diagnostics::
//! read_file`): only a regular file of at most 16 MiB inside the state directory; anything
//! else in a record's place is left as it is, neither read nor replaced.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use hapticd_core::diagnostics::{self, FileRules, Refusal};
use hapticd_core::parameters::Overrides;

/// The calibration of a device: counter offsets for the mechanism it was taken with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Calibration {
    /// Mechanism the offsets belong to.
    pub mechanism: String,
    /// Offset of each string, metres.
    pub offsets: Vec<f64>,
}

/// Everything remembered about one device.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DeviceRecord {
    /// The last calibration, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration: Option<Calibration>,
    /// Parameters the user changed.
    pub parameters: Overrides,
    /// Mechanism the user bound to the device, if not the configured one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mechanism: Option<String>,
}

/// The state directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StateDir {
    dir: PathBuf,
}

/// Why a record could not be loaded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LoadError {
    /// What is in the record's place is not a file hapticd could have written (a FIFO, a
    /// device, a link out of the directory, a huge file): it is left as it is, and not
    /// replaced by a save until someone removes it.
    Unusable(String),
    /// The record cannot be read or does not parse.
    Damaged(String),
}

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoadError::Unusable(m) | LoadError::Damaged(m) => f.write_str(m),
        }
    }
}

/// A file name for `identity` that keeps letters, digits, `-` and `.`, and spells every other
/// byte as `_xx`, so distinct identities never share a file (and, behind the `device-`
/// prefix, none can name another directory).
fn file_name(identity: &str) -> String {
    let mut name = String::from("device-");
    for b in identity.bytes() {
        if b.is_ascii_alphanumeric() || b == b'-' || b == b'.' {
            name.push(b as char);
        } else {
            name += &format!("_{b:02x}");
        }
    }
    name + ".json"
}

impl StateDir {
    /// The state directory at `dir` (created when first written).
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        Self { dir: dir.into() }
    }

    /// `$STATE_DIRECTORY` (its first entry), when systemd set it.
    pub fn from_env() -> Option<Self> {
        let value = std::env::var_os("STATE_DIRECTORY")?;
        std::env::split_paths(&value).next().map(Self::new)
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// The file of device `identity`.
    pub fn device_file(&self, identity: &str) -> PathBuf {
        self.dir.join(file_name(identity))
    }

    /// How records are read: small regular files inside the directory.
    fn rules(&self) -> FileRules<'_> {
        FileRules {
            within: Some(&self.dir),
            ..FileRules::TEXT
        }
    }

    /// The record of device `identity`: empty when none was saved; an error naming the file
    /// when it cannot be read or parsed. Temporary files a crash left behind mid-save are
    /// removed (the record itself is whole: the old one or the new one).
    pub fn load(&self, identity: &str) -> Result<DeviceRecord, LoadError> {
        let path = self.device_file(identity);
        let leftover = format!(".{}.", file_name(identity));
        if let Ok(listing) = std::fs::read_dir(&self.dir) {
            for entry in listing.filter_map(|e| e.ok()) {
                let name = entry.file_name().to_string_lossy().into_owned();
                if name.starts_with(&leftover) && name.ends_with(".tmp") {
                    let _ = std::fs::remove_file(entry.path());
                }
            }
        }
        match diagnostics::read_file(&path, self.rules()) {
            Ok(bytes) => serde_json::from_slice(&bytes).map_err(|e| {
                LoadError::Damaged(format!(
                    "{}:{}:{}: error: {e}",
                    path.display(),
                    e.line(),
                    e.column()
                ))
            }),
            Err(e) if e.is_missing() => Ok(DeviceRecord::default()),
            Err(e) if unusable(&e.refusal) => Err(LoadError::Unusable(e.to_string())),
            Err(e) => Err(LoadError::Damaged(e.to_string())),
        }
    }

    /// Replace the record of device `identity` atomically; refused, touching nothing, when
    /// what is in its place is not a record hapticd could have written.
    pub fn save(&self, identity: &str, record: &DeviceRecord) -> Result<(), SaveError> {
        let path = self.device_file(identity);
        if let Err(e) = diagnostics::check_file(&path, self.rules())
            && unusable(&e.refusal)
        {
            return Err(SaveError::Unusable(e));
        }
        let mut text = serde_json::to_vec_pretty(record).map_err(SaveError::Encode)?;
        text.push(b'\n');
        diagnostics::write_atomically(&path, &text).map_err(SaveError::Write)
    }
}

/// Why a device's record was not saved (and the old one is left as it was).
#[derive(Debug)]
pub enum SaveError {
    /// What is in its place is not a record hapticd could have written.
    Unusable(diagnostics::FileError),
    /// The record could not be put in JSON.
    Encode(serde_json::Error),
    /// It could not be written.
    Write(diagnostics::WriteError),
}

impl std::fmt::Display for SaveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SaveError::Unusable(e) => write!(
                f,
                "{e}; hapticd neither reads nor replaces it: remove it to save"
            ),
            SaveError::Encode(e) => write!(f, "{e}"),
            SaveError::Write(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for SaveError {}

/// Whether `refusal` says the file is not one hapticd could have written.
fn unusable(refusal: &Refusal) -> bool {
    matches!(
        refusal,
        Refusal::NotRegular | Refusal::TooLarge { .. } | Refusal::Outside { .. }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identities_map_to_distinct_plain_file_names() {
        assert_eq!(file_name("sim:spidar-g"), "device-sim_3aspidar-g.json");
        assert_ne!(file_name("usb:1-2"), file_name("usb_1-2"));
        assert_eq!(file_name("../x"), "device-.._2fx.json");
    }

    #[test]
    fn records_round_trip_and_bad_files_name_their_place() {
        let dir = std::env::temp_dir().join(format!("hapticd-state-{}", std::process::id()));
        let state = StateDir::new(&dir);
        assert_eq!(state.load("a").unwrap(), DeviceRecord::default());
        let record = DeviceRecord {
            calibration: Some(Calibration {
                mechanism: "spidar".into(),
                offsets: vec![0.1, -0.2],
            }),
            ..DeviceRecord::default()
        };
        state.save("a", &record).unwrap();
        assert_eq!(state.load("a").unwrap(), record);
        std::fs::write(state.device_file("b"), "{\n  \"calibration\": 3\n}").unwrap();
        let crashed = dir.join(".device-a.json.999.tmp");
        std::fs::write(&crashed, "{").unwrap();
        assert_eq!(state.load("a").unwrap(), record);
        assert!(!crashed.exists(), "a crash's temporary file is left");
        let e = state.load("b").unwrap_err();
        assert!(
            matches!(&e, LoadError::Damaged(m) if m.contains("device-b.json:2:")),
            "{e}"
        );
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .collect();
        assert!(leftovers.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn what_hapticd_could_not_have_written_is_neither_read_nor_replaced() {
        let root = std::env::temp_dir().join(format!("hapticd-unusable-{}", std::process::id()));
        let dir = root.join("state");
        std::fs::create_dir_all(&dir).unwrap();
        let state = StateDir::new(&dir);
        let outside = root.join("elsewhere.json");
        std::fs::write(&outside, "{}").unwrap();
        let file = state.device_file("a");
        let record = DeviceRecord {
            mechanism: Some("spidar".into()),
            ..DeviceRecord::default()
        };
        let cases: [(&str, &dyn Fn()); 4] = [
            ("not a regular file", &|| {
                let mode = nix::sys::stat::Mode::from_bits_truncate(0o600);
                nix::unistd::mkfifo(&file, mode).unwrap()
            }),
            // Followed, the link would lead to a device too; it leads out first.
            ("a link to /dev/zero, outside", &|| {
                std::os::unix::fs::symlink("/dev/zero", &file).unwrap()
            }),
            ("outside", &|| {
                std::os::unix::fs::symlink(&outside, &file).unwrap()
            }),
            ("more than the 16777216", &|| {
                std::fs::File::create(&file)
                    .unwrap()
                    .set_len(20 << 30)
                    .unwrap()
            }),
        ];
        for (expected, make) in cases {
            make();
            let e = state.load("a").unwrap_err();
            assert!(
                matches!(&e, LoadError::Unusable(m) if m.contains(expected)),
                "{expected}: {e}"
            );
            let e = state.save("a", &record).unwrap_err();
            assert!(matches!(e, SaveError::Unusable(_)), "{e}");
            let e = e.to_string();
            assert!(e.contains(expected) && e.contains("remove it"), "{e}");
            let kept = std::fs::symlink_metadata(&file).unwrap();
            assert!(!kept.file_type().is_file() || kept.len() == 20 << 30);
            std::fs::remove_file(&file).unwrap();
        }
        assert_eq!(std::fs::read_to_string(&outside).unwrap(), "{}");
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_save_that_cannot_write_leaves_the_old_record() {
        let dir = std::env::temp_dir().join(format!("hapticd-blocked-{}", std::process::id()));
        let state = StateDir::new(&dir);
        let old = DeviceRecord::default();
        state.save("a", &old).unwrap();
        // A directory where the temporary file goes: as root too, nothing can be written.
        let temporary = dir.join(format!(".device-a.json.{}.tmp", std::process::id()));
        std::fs::create_dir(&temporary).unwrap();
        let new = DeviceRecord {
            mechanism: Some("spidar".into()),
            ..DeviceRecord::default()
        };
        let e = state.save("a", &new).unwrap_err();
        assert!(
            matches!(&e, SaveError::Write(w) if w.step == "create"),
            "{e}"
        );
        assert!(e.to_string().contains("cannot create"), "{e}");
        assert_eq!(state.load("a").unwrap(), old);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
