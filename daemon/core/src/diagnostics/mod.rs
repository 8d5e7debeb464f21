//! Findings about a file a person wrote, in the form compilers use
//! (`file:line:column: error: field: message`), for every YAML format hapticd reads:
//! configuration, mechanism descriptors, static and physics scenes, hand scripts.
//!
//! A loader reports every finding at once, not the first: syntax and schema errors come from
//! the YAML parser with their place; checks of values name a field path such as
//! `strings[3].tension_min` or `bodies[2].size`, and a [`YamlMap`] of the same text finds the
//! line and column it was written at.

use std::collections::HashMap;
use std::fmt;
use std::fs::File;
use std::path::{Path, PathBuf};

use glam::DQuat;
use serde::de::DeserializeOwned;
use serde_saphyr::granit_parser::{Event, Parser};

use crate::kinematics::quat_from_wxyz;

mod schema;

/// Largest file any loader reads: far above any real descriptor or scene, and small
/// enough that a mistaken path (a disk image, a device node) fails at once.
pub const MAX_FILE_BYTES: u64 = 16 << 20;

/// Longest name of a mechanism, effector or scene, bytes.
pub const MAX_NAME_BYTES: usize = 64;

/// Longest description or title, bytes.
pub const MAX_TEXT_BYTES: usize = 1024;

/// A place in a text file: 1-based line and column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub struct Position {
    /// Line, from 1.
    pub line: u64,
    /// Column, from 1.
    pub column: u64,
}

/// How serious a finding is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// The file cannot be used.
    Error,
    /// The file works, with a limitation worth knowing.
    Warning,
}

/// One finding, located in its file.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// Error or warning.
    pub severity: Severity,
    /// File the finding is in (empty for text that came from no file).
    pub file: PathBuf,
    /// Where in the file, when the source has places (YAML does, plugins do not).
    pub position: Option<Position>,
    /// Field path such as `strings[3].tension_min`; empty for the whole file.
    pub field: String,
    /// What is wrong, in words.
    pub message: String,
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(Position { line, column }) = self.position {
            write!(f, ":{line}:{column}")?;
        }
        let kind = match self.severity {
            Severity::Error => "error",
            Severity::Warning => "warning",
        };
        write!(f, ": {kind}: ")?;
        if !self.field.is_empty() {
            write!(f, "{}: ", self.field)?;
        }
        f.write_str(&self.message)
    }
}

/// Why a file could not be used: every finding, errors first, one per line when shown.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostics {
    /// The findings, errors first.
    pub diagnostics: Vec<Diagnostic>,
}

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.diagnostics.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostics {}

/// The binaries report every error as text, one path for all of them.
impl From<Diagnostics> for String {
    fn from(d: Diagnostics) -> String {
        d.to_string()
    }
}

impl Diagnostics {
    /// A single error about a whole file.
    pub fn file(file: &Path, message: impl Into<String>) -> Self {
        Self::at(file, None, String::new(), message)
    }

    /// A single error at `position` of `file`, about `field`.
    pub fn at(
        file: &Path,
        position: Option<Position>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Self {
            diagnostics: vec![Diagnostic {
                severity: Severity::Error,
                file: file.to_path_buf(),
                position,
                field: field.into(),
                message: message.into(),
            }],
        }
    }

    /// A YAML syntax or schema error of `file`, at its place, without the parser's own
    /// position suffix and its advice about parser options, which mean nothing to someone
    /// editing the file.
    pub fn yaml(file: &Path, error: &serde_saphyr::Error) -> Self {
        let rendered = error.without_snippet().to_string();
        let message = rendered
            .rsplit_once(" at line ")
            .map_or(rendered.as_str(), |(m, _)| m)
            .replace(", set DuplicateKeyPolicy in Options if acceptable", "");
        let position = error.location().filter(|l| l.line() > 0).map(|l| Position {
            line: l.line(),
            column: l.column(),
        });
        Self::at(file, position, String::new(), message)
    }
}

/// `O_NONBLOCK` of Linux (the core links no libc): opening a FIFO then returns at once
/// instead of waiting for a writer.
#[cfg(any(target_arch = "mips", target_arch = "mips64"))]
const O_NONBLOCK: i32 = 0o200;
#[cfg(any(target_arch = "sparc", target_arch = "sparc64"))]
const O_NONBLOCK: i32 = 0x4000;
#[cfg(not(any(
    target_arch = "mips",
    target_arch = "mips64",
    target_arch = "sparc",
    target_arch = "sparc64"
)))]
const O_NONBLOCK: i32 = 0o4000;

/// What a guarded read accepts, besides being a regular file.
#[derive(Debug, Clone, Copy)]
pub struct FileRules<'a> {
    /// Largest size, bytes.
    pub max_bytes: u64,
    /// A directory the file must lie in once its links are followed, if any.
    pub within: Option<&'a Path>,
}

impl FileRules<'_> {
    /// Files a person wrote: at most [`MAX_FILE_BYTES`], anywhere.
    pub const TEXT: FileRules<'static> = FileRules {
        max_bytes: MAX_FILE_BYTES,
        within: None,
    };
}

/// Why a guarded read refused a file or failed.
#[derive(Debug)]
pub enum Refusal {
    /// The system refused (`NotFound` included).
    Io(std::io::Error),
    /// A FIFO, a device, a directory: reading it could block for ever or never end.
    NotRegular,
    /// More bytes than the rules allow.
    TooLarge {
        /// The file's size (or what was read of it before it grew past the limit).
        bytes: u64,
        /// The limit.
        max: u64,
    },
    /// A link to a file outside the directory the rules confine it to.
    Outside {
        /// Where the link leads.
        target: PathBuf,
        /// The directory.
        dir: PathBuf,
    },
    /// Not UTF-8 text.
    NotText,
}

/// A file a guarded read refused, named as it was given.
#[derive(Debug)]
pub struct FileError {
    /// The file, as given.
    pub file: PathBuf,
    /// Why.
    pub refusal: Refusal,
}

impl FileError {
    /// Whether the file is simply not there.
    pub fn is_missing(&self) -> bool {
        matches!(&self.refusal, Refusal::Io(e) if e.kind() == std::io::ErrorKind::NotFound)
    }

    /// What is wrong, without the file's name.
    pub fn message(&self) -> String {
        match &self.refusal {
            Refusal::Io(e) => format!("cannot read: {e}"),
            Refusal::NotRegular => "not a regular file".into(),
            Refusal::TooLarge { bytes, max } => {
                format!("{bytes} bytes is more than the {max} a file may have")
            }
            Refusal::Outside { target, dir } => {
                format!("a link to {}, outside {}", target.display(), dir.display())
            }
            Refusal::NotText => "not UTF-8 text".into(),
        }
    }
}

impl fmt::Display for FileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: error: {}", self.file.display(), self.message())
    }
}

impl std::error::Error for FileError {}

impl From<FileError> for Diagnostics {
    fn from(e: FileError) -> Self {
        Diagnostics::file(&e.file, e.message())
    }
}

/// The binaries report every error as text.
impl From<FileError> for String {
    fn from(e: FileError) -> String {
        e.to_string()
    }
}

/// Whether `file` may be read under `rules`, looking without opening it (opening a FIFO
/// waits for a writer; opening a device may start it): the path to open, links resolved
/// when the rules confine the file to a directory.
pub fn check_file(file: &Path, rules: FileRules) -> Result<PathBuf, FileError> {
    let refuse = |refusal| FileError {
        file: file.to_path_buf(),
        refusal,
    };
    let path = match rules.within {
        Some(dir) => {
            let target = file.canonicalize().map_err(|e| refuse(Refusal::Io(e)))?;
            let dir = dir.canonicalize().map_err(|e| refuse(Refusal::Io(e)))?;
            if !target.starts_with(&dir) {
                return Err(refuse(Refusal::Outside { target, dir }));
            }
            target
        }
        None => file.to_path_buf(),
    };
    let meta = std::fs::metadata(&path).map_err(|e| refuse(Refusal::Io(e)))?;
    if !meta.is_file() {
        return Err(refuse(Refusal::NotRegular));
    }
    if meta.len() > rules.max_bytes {
        return Err(refuse(Refusal::TooLarge {
            bytes: meta.len(),
            max: rules.max_bytes,
        }));
    }
    Ok(path)
}

/// Why a file could not be replaced, and at which step.
#[derive(Debug)]
pub struct WriteError {
    /// The file.
    pub path: PathBuf,
    /// What could not be done: "create its directory", "create", "write", "flush" or
    /// "replace".
    pub step: &'static str,
    /// Why.
    pub error: std::io::Error,
}

impl std::fmt::Display for WriteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: cannot {}: {}",
            self.path.display(),
            self.step,
            self.error
        )
    }
}

impl std::error::Error for WriteError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}

/// Replace `path` with `contents` so that a crash leaves either the old file or the new one:
/// the one writer of every file hapticd keeps (records, caches).
pub fn write_atomically(path: &Path, contents: &[u8]) -> Result<(), WriteError> {
    use std::io::Write;
    let fail = |step: &'static str| {
        move |error: std::io::Error| WriteError {
            path: path.to_path_buf(),
            step,
            error,
        }
    };
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(fail("create its directory"))?;
    let name = path
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into());
    let temporary = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        // A new file of its own: never written through a link left under the temporary name.
        let _ = std::fs::remove_file(&temporary);
        let mut file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temporary)
            .map_err(fail("create"))?;
        file.write_all(contents).map_err(fail("write"))?;
        file.sync_all().map_err(fail("flush"))?;
        std::fs::rename(&temporary, path).map_err(fail("replace"))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&temporary);
        return result;
    }
    // Renamed, the new file is what the directory holds; should the directory's flush fail,
    // a power loss keeps the old file whole, and an error now would have the caller keep its
    // old record in memory against the new one on disk.
    let _ = File::open(dir).and_then(|d| d.sync_all());
    Ok(())
}

/// The directory `file` lies in: its parent, or `.` for a bare name (whose parent is empty,
/// which names no directory: a scene given as `my.yaml` lost its meshes).
pub fn directory_of(file: &Path) -> &Path {
    match file.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

/// The bytes of `file`, refusing what cannot be a file a person or hapticd wrote: anything
/// but a regular file, more than `rules.max_bytes`, or a link out of `rules.within`. The
/// one reader of every file hapticd and its tools are given.
pub fn read_file(file: &Path, rules: FileRules) -> Result<Vec<u8>, FileError> {
    use std::os::unix::fs::OpenOptionsExt;
    let refuse = |refusal| FileError {
        file: file.to_path_buf(),
        refusal,
    };
    let path = check_file(file, rules)?;
    // Non-blocking, in case a FIFO took the file's place since it was looked at.
    let opened = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(O_NONBLOCK)
        .open(&path)
        .map_err(|e| refuse(Refusal::Io(e)))?;
    read_opened(opened, file, rules.max_bytes)
}

/// The bytes of the file `opened` (named `file` in errors): a regular file of at most
/// `max_bytes`, whatever it grows to while it is read. For a file opened by someone else,
/// as a descriptor a caller sends; [`read_file`] reads every file given by name through it.
pub fn read_opened(opened: File, file: &Path, max_bytes: u64) -> Result<Vec<u8>, FileError> {
    use std::io::Read;
    let refuse = |refusal| FileError {
        file: file.to_path_buf(),
        refusal,
    };
    let meta = opened.metadata().map_err(|e| refuse(Refusal::Io(e)))?;
    if !meta.is_file() {
        return Err(refuse(Refusal::NotRegular));
    }
    let too_large = |bytes| {
        refuse(Refusal::TooLarge {
            bytes,
            max: max_bytes,
        })
    };
    if meta.len() > max_bytes {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    opened
        .take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| refuse(Refusal::Io(e)))?;
    // It may have grown since it was measured.
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// [`read_file`] of text under [`FileRules::TEXT`], as findings about the file.
pub fn read_text(file: &Path) -> Result<String, Diagnostics> {
    let bytes = read_file(file, FileRules::TEXT)?;
    String::from_utf8(bytes).map_err(|_| {
        FileError {
            file: file.to_path_buf(),
            refusal: Refusal::NotText,
        }
        .into()
    })
}

/// A YAML text read into its type, with what its checks need to locate and sort their
/// findings.
pub struct Parsed<T> {
    /// The value. When `schema` is not empty, some fields hold stand-ins (zero, empty text)
    /// for what was mistaken: good for checking the rest, never for use.
    pub value: T,
    /// Where each field path begins.
    pub map: YamlMap,
    /// The schema mistakes read past: unknown and missing keys, wrong lengths and types.
    pub schema: Vec<Diagnostic>,
}

impl<T> Parsed<T> {
    /// The value, if no schema mistake was found; otherwise every one of them. For
    /// formats that check nothing more.
    pub fn strict(self) -> Result<(T, YamlMap), Diagnostics> {
        if self.schema.is_empty() {
            Ok((self.value, self.map))
        } else {
            Err(Diagnostics {
                diagnostics: self.schema,
            })
        }
    }
}

/// Parse YAML `text` (named `file` in findings) into `T`, with the map of its field paths
/// for locating the findings of later checks. A text the YAML library rejects is read
/// again by the schema pass, so that every unknown key, wrong length and wrong type is
/// reported, not the first; only a text that is not YAML at all fails here.
pub fn parse_yaml<T: DeserializeOwned>(text: &str, file: &Path) -> Result<Parsed<T>, Diagnostics> {
    let (value, schema) = match serde_saphyr::from_str(text) {
        Ok(value) => (value, Vec::new()),
        Err(e) => match schema::parse(text, file) {
            Some((value, schema)) if !schema.is_empty() => (value, schema),
            _ => return Err(Diagnostics::yaml(file, &e)),
        },
    };
    Ok(Parsed {
        value,
        map: YamlMap::new(text),
        schema,
    })
}

/// [`read_text`] then [`parse_yaml`].
pub fn load_yaml<T: DeserializeOwned>(file: &Path) -> Result<Parsed<T>, Diagnostics> {
    parse_yaml(&read_text(file)?, file)
}

/// Where each field path of a YAML text begins: `name`, `strings[3].tension_min`,
/// `calibration.grip.position`. Paths name mapping keys with `.` and sequence items with
/// `[i]`, as the checks of every loader do.
#[derive(Debug, Default, Clone)]
pub struct YamlMap {
    places: HashMap<String, Position>,
}

/// A collection being walked while indexing.
enum Open {
    Mapping { path: String, key: Option<String> },
    Sequence { path: String, next: usize },
}

impl YamlMap {
    /// Index `text`. A text the parser rejects gives the paths before the fault (the
    /// fault itself is reported by the deserialiser).
    pub fn new(text: &str) -> Self {
        let mut places = HashMap::new();
        let mut stack: Vec<Open> = Vec::new();
        for event in Parser::new_from_str(text) {
            let Ok((event, span)) = event else { break };
            let is_node = matches!(
                event,
                Event::Scalar(..)
                    | Event::SequenceStart(..)
                    | Event::MappingStart(..)
                    | Event::Alias(_)
            );
            if !is_node {
                if matches!(event, Event::SequenceEnd | Event::MappingEnd) {
                    stack.pop();
                    Self::value_done(&mut stack);
                }
                continue;
            }
            // A scalar in key position names the next value rather than being one.
            if let (
                Some(Open::Mapping {
                    key: key @ None, ..
                }),
                Event::Scalar(name, ..),
            ) = (stack.last_mut(), &event)
            {
                *key = Some(name.to_string());
                continue;
            }
            let path = match stack.last_mut() {
                None => String::new(),
                Some(Open::Mapping { path, key }) => match key.as_deref() {
                    Some(k) if path.is_empty() => k.to_string(),
                    Some(k) => format!("{path}.{k}"),
                    // A collection used as a key: nothing a check can name.
                    None => format!("{path}.?"),
                },
                Some(Open::Sequence { path, next }) => format!("{path}[{next}]"),
            };
            let at = Position {
                line: span.start.line() as u64,
                column: span.start.col() as u64 + 1,
            };
            places.entry(path.clone()).or_insert(at);
            match event {
                Event::SequenceStart(..) => stack.push(Open::Sequence { path, next: 0 }),
                Event::MappingStart(..) => stack.push(Open::Mapping { path, key: None }),
                _ => Self::value_done(&mut stack),
            }
        }
        Self { places }
    }

    /// A value of the innermost collection is complete: move to its next item or key.
    fn value_done(stack: &mut [Open]) {
        match stack.last_mut() {
            Some(Open::Mapping { key, .. }) => *key = None,
            Some(Open::Sequence { next, .. }) => *next += 1,
            None => {}
        }
    }

    /// Where `field` begins, or its nearest ancestor that is in the text.
    pub fn find(&self, field: &str) -> Option<Position> {
        let mut path = field;
        loop {
            if let Some(&at) = self.places.get(path) {
                return Some(at);
            }
            path = &path[..path.rfind(['.', '['])?];
        }
    }
}

/// A number as a person would write it: `1e308`, not three hundred digits.
pub struct Number(pub f64);

impl fmt::Display for Number {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v != 0.0 && v.is_finite() && !(1e-4..1e9).contains(&v.abs()) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}

/// Collects the findings of checks on one file.
pub struct Findings<'a> {
    file: &'a Path,
    locate: &'a dyn Fn(&str) -> Option<Position>,
    list: Vec<Diagnostic>,
    /// Fields whose values are stand-ins for a schema mistake: checks of them say nothing.
    stand_ins: Vec<String>,
}

impl<'a> Findings<'a> {
    /// Findings about `file`; `locate` maps a field path to its place.
    pub fn new(file: &'a Path, locate: &'a dyn Fn(&str) -> Option<Position>) -> Self {
        Self {
            file,
            locate,
            list: Vec::new(),
            stand_ins: Vec::new(),
        }
    }

    /// Findings about `file` that begin with the schema mistakes of [`Parsed::schema`];
    /// the checks of a field one of them is about, or of anything inside it, are dropped
    /// (they would be about its stand-in).
    pub fn after_schema(
        file: &'a Path,
        locate: &'a dyn Fn(&str) -> Option<Position>,
        schema: Vec<Diagnostic>,
    ) -> Self {
        let stand_ins = schema
            .iter()
            .filter(|d| !d.field.is_empty())
            .map(|d| d.field.clone())
            .collect();
        Self {
            file,
            locate,
            list: schema,
            stand_ins,
        }
    }

    fn push(&mut self, severity: Severity, field: String, message: String) {
        let within = |s: &String| {
            field.strip_prefix(s.as_str()).is_some_and(|rest| {
                rest.is_empty() || rest.starts_with('.') || rest.starts_with('[')
            })
        };
        if self.stand_ins.iter().any(within) {
            return;
        }
        let position = (self.locate)(&field);
        self.list.push(Diagnostic {
            severity,
            file: self.file.to_path_buf(),
            position,
            field,
            message,
        });
    }

    /// `field` is wrong.
    pub fn error(&mut self, field: impl Into<String>, message: impl Into<String>) {
        self.push(Severity::Error, field.into(), message.into());
    }

    /// `field` works, with a limitation worth knowing.
    pub fn warning(&mut self, field: impl Into<String>, message: impl Into<String>) {
        self.push(Severity::Warning, field.into(), message.into());
    }

    /// Whether every value is finite; an error on `field` if not.
    pub fn finite(&mut self, field: impl Into<String>, values: &[f64]) -> bool {
        let ok = values.iter().all(|v| v.is_finite());
        if !ok {
            self.error(field, "must be a finite number");
        }
        ok
    }

    /// Whether every component of `values` is finite and within ±`extent` `unit`; an error
    /// on `field` if not.
    pub fn coordinates(
        &mut self,
        field: impl Into<String>,
        values: &[f64],
        extent: f64,
        unit: &str,
    ) -> bool {
        let ok = values.iter().all(|v| v.abs() <= extent);
        if !ok {
            self.error(
                field,
                format!("must be finite, each within ±{extent} {unit}"),
            );
        }
        ok
    }

    /// Whether `value` can name something on the bus and on a command line: 1 to
    /// [`MAX_NAME_BYTES`] bytes, without spaces, `/` or control characters (a NUL in a
    /// D-Bus string makes the bus drop the sender).
    pub fn name(&mut self, field: impl Into<String>, value: &str) -> bool {
        let ok = !value.is_empty()
            && value.len() <= MAX_NAME_BYTES
            && !value
                .chars()
                .any(|c| c.is_whitespace() || c.is_control() || c == '/');
        if !ok {
            self.error(
                field,
                format!(
                    "{value:?} is not a usable name: 1 to {MAX_NAME_BYTES} bytes, without \
                     spaces, '/' or control characters"
                ),
            );
        }
        ok
    }

    /// Whether `value` is text to show (a description, a title): at most
    /// [`MAX_TEXT_BYTES`] bytes and no control characters but line breaks.
    pub fn text(&mut self, field: impl Into<String>, value: &str) -> bool {
        let ok =
            value.len() <= MAX_TEXT_BYTES && !value.chars().any(|c| c.is_control() && c != '\n');
        if !ok {
            self.error(
                field,
                format!(
                    "must be at most {MAX_TEXT_BYTES} bytes of text without control characters"
                ),
            );
        }
        ok
    }

    /// Whether `value` is finite and > 0; an error on `field` if not.
    pub fn positive(&mut self, field: impl Into<String>, value: f64) -> bool {
        let ok = value.is_finite() && value > 0.0;
        if !ok {
            self.error(field, "must be a finite number > 0");
        }
        ok
    }

    /// Whether `value` is finite and ≥ 0; an error on `field` if not.
    pub fn non_negative(&mut self, field: impl Into<String>, value: f64) -> bool {
        let ok = value.is_finite() && value >= 0.0;
        if !ok {
            self.error(field, "must be a finite number ≥ 0");
        }
        ok
    }

    /// Whether `value` lies in `lo..=hi` (so is finite); an error naming the range if not.
    pub fn within(
        &mut self,
        field: impl Into<String>,
        value: f64,
        lo: f64,
        hi: f64,
        unit: &str,
    ) -> bool {
        let ok = (lo..=hi).contains(&value);
        if !ok {
            self.error(
                field,
                format!(
                    "must be a number from {} to {}{unit}, not {}",
                    Number(lo),
                    Number(hi),
                    Number(value)
                ),
            );
        }
        ok
    }

    /// A unit quaternion written `[w, x, y, z]`; an error if it is not one (the identity
    /// stands in, so checks can go on).
    pub fn unit_quaternion(&mut self, field: impl Into<String>, wxyz: [f64; 4]) -> DQuat {
        let field = field.into();
        let q = quat_from_wxyz(wxyz);
        if !self.finite(field.clone(), &wxyz) {
            return DQuat::IDENTITY;
        }
        if (q.length() - 1.0).abs() > 1e-6 {
            self.error(
                field,
                format!(
                    "must be a unit quaternion (w, x, y, z); its norm is {}",
                    q.length()
                ),
            );
            return DQuat::IDENTITY;
        }
        q.normalize()
    }

    /// Every finding so far as the error, when checking cannot go on (at least one error
    /// must have been reported).
    pub fn into_error(self) -> Diagnostics {
        debug_assert!(self.has_errors());
        Diagnostics {
            diagnostics: self.list,
        }
    }

    /// Whether any error was found so far.
    pub fn has_errors(&self) -> bool {
        self.list.iter().any(|d| d.severity == Severity::Error)
    }

    /// The warnings, if there is no error; otherwise every finding, errors first.
    pub fn finish(self) -> Result<Vec<Diagnostic>, Diagnostics> {
        let (errors, warnings): (Vec<_>, Vec<_>) = self
            .list
            .into_iter()
            .partition(|d| d.severity == Severity::Error);
        if errors.is_empty() {
            Ok(warnings)
        } else {
            Err(Diagnostics {
                diagnostics: errors.into_iter().chain(warnings).collect(),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "\
name: box
bodies:
  - shape: box
    size: [1, 2, 3]
  - { shape: sphere, radius: 0.5 }
nested:
  list:
    - - 1
      - 2
";

    fn at(line: u64, column: u64) -> Option<Position> {
        Some(Position { line, column })
    }

    #[test]
    fn paths_locate_keys_items_and_flow_collections() {
        let map = YamlMap::new(TEXT);
        assert_eq!(map.find("name"), at(1, 7));
        assert_eq!(map.find("bodies[0].size"), at(4, 11));
        assert_eq!(map.find("bodies[1].radius"), at(5, 30));
        assert_eq!(map.find("nested.list[0][1]"), at(9, 9));
        // An unknown path falls back to its nearest ancestor in the text.
        assert_eq!(map.find("bodies[1].mass"), map.find("bodies[1]"));
        assert_eq!(map.find("gravity"), None);
    }

    #[test]
    fn findings_come_back_all_at_once_errors_first() {
        let map = YamlMap::new(TEXT);
        let locate = |f: &str| map.find(f);
        let mut f = Findings::new(Path::new("s.yaml"), &locate);
        f.warning("name", "short");
        f.error("bodies[0].size", "too big");
        f.finite("bodies[1].radius", &[f64::NAN]);
        let shown = f.finish().unwrap_err().to_string();
        let lines: Vec<_> = shown.lines().collect();
        assert_eq!(
            lines,
            [
                "s.yaml:4:11: error: bodies[0].size: too big",
                "s.yaml:5:30: error: bodies[1].radius: must be a finite number",
                "s.yaml:1:7: warning: name: short",
            ]
        );
    }

    #[test]
    fn files_that_are_not_regular_are_refused_without_reading() {
        let e = read_text(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(e.ends_with("not a regular file"), "{e}");
        // A FIFO named like a descriptor: opening it would wait for a writer for ever.
        let fifo = std::env::temp_dir().join(format!("hapticd-fifo-{}.yaml", std::process::id()));
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            let e = read_text(&fifo).unwrap_err().to_string();
            std::fs::remove_file(&fifo).ok();
            assert!(e.ends_with("not a regular file"), "{e}");
        }
    }

    #[test]
    fn files_larger_than_any_real_one_are_refused() {
        let big = std::env::temp_dir().join(format!("hapticd-big-{}.yaml", std::process::id()));
        let file = std::fs::File::create(&big).unwrap();
        file.set_len(MAX_FILE_BYTES + 1).unwrap();
        let e = read_text(&big).unwrap_err().to_string();
        std::fs::remove_file(&big).ok();
        assert!(e.contains("more than the 16777216 a file may have"), "{e}");
    }

    #[test]
    fn opening_a_fifo_without_blocking_returns_at_once() {
        use std::os::unix::fs::OpenOptionsExt;
        let fifo = std::env::temp_dir().join(format!("hapticd-nb-{}", std::process::id()));
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            return;
        }
        // Opened blocking, this waits for a writer that never comes: the test would hang.
        let opened = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(O_NONBLOCK)
            .open(&fifo);
        std::fs::remove_file(&fifo).ok();
        assert!(opened.is_ok(), "{opened:?}");
    }

    #[test]
    fn links_out_of_the_confining_directory_are_refused_and_links_within_it_followed() {
        let root = std::env::temp_dir().join(format!("hapticd-within-{}", std::process::id()));
        let dir = root.join("state");
        std::fs::create_dir_all(&dir).unwrap();
        let inside = dir.join("a.json");
        let outside = root.join("b.json");
        for file in [&inside, &outside] {
            std::fs::write(file, "{}").unwrap();
        }
        let rules = FileRules {
            max_bytes: 100,
            within: Some(&dir),
        };
        let near = dir.join("near.json");
        std::os::unix::fs::symlink(&inside, &near).unwrap();
        let far = dir.join("far.json");
        std::os::unix::fs::symlink(&outside, &far).unwrap();
        let (near_read, far_read) = (read_file(&near, rules), read_file(&far, rules));
        // Without confinement the same link is just a file.
        let unconfined = read_file(&far, FileRules::TEXT);
        std::fs::remove_dir_all(&root).ok();
        assert_eq!(near_read.unwrap(), b"{}");
        let e = far_read.unwrap_err();
        assert!(matches!(e.refusal, Refusal::Outside { .. }), "{e}");
        let shown = e.to_string();
        let expected = format!(
            "{}: error: a link to {}, outside ",
            far.display(),
            outside.display()
        );
        assert!(shown.starts_with(&expected), "{shown}");
        assert_eq!(unconfined.unwrap(), b"{}");
    }

    #[test]
    fn missing_files_are_told_apart_from_refused_ones() {
        let e = read_file(Path::new("/nonexistent/hapticd"), FileRules::TEXT).unwrap_err();
        assert!(e.is_missing(), "{e}");
        let e = read_file(Path::new("/dev/zero"), FileRules::TEXT).unwrap_err();
        assert!(
            !e.is_missing() && matches!(e.refusal, Refusal::NotRegular),
            "{e}"
        );
    }
}
