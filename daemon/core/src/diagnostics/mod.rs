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
use std::path::{Path, PathBuf};

use glam::DQuat;
use serde::de::DeserializeOwned;
use serde_saphyr::granit_parser::{Event, Parser};

use crate::kinematics::quat_from_wxyz;

mod files;
mod schema;

pub use files::{
    FileError, FileRules, Refusal, WriteError, check_file, directory_of, read_file, read_opened,
    read_text, write_atomically,
};

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

/// The field path of key `key` under the entry at `at` (the top when empty), as findings
/// name fields.
pub fn key_path(at: &str, key: &str) -> String {
    match at {
        "" => key.to_string(),
        at => format!("{at}.{key}"),
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
mod tests;
