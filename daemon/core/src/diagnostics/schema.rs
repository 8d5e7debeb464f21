//! The schema pass: every unknown key, wrong length, wrong type and missing key of a YAML
//! text at once, where the YAML library stops at the first.
//!
//! The text is read into a tree of nodes with their places, then deserialised into the
//! target type by a deserialiser that records each mistake and carries on with a stand-in
//! (zero, empty text, the first variant, a padded sequence). A missing key cannot be stood
//! in for from inside the type's own visitor, so the pass starts again with that key
//! supplied, until nothing is missing. The value that comes out is good for the checks of
//! values that follow (their findings under a mistaken field are dropped), never for use.
//!
//! Scalars are read by the YAML library itself, one at a time, so a number or a flag means
//! here exactly what it means when the whole file is read.

use std::cell::RefCell;
use std::collections::{HashMap, HashSet};
use std::fmt;
use std::path::Path;

use serde::de::{self, DeserializeOwned, DeserializeSeed, IntoDeserializer, Visitor};
use serde_saphyr::granit_parser::{Event, Parser, ScalarStyle};

use super::{Diagnostic, Position, Severity};

/// Most nodes a text may expand to, aliases included: a guard against an alias bomb.
const MAX_NODES: usize = 1 << 20;

/// Most times the pass starts again to supply a missing key: far more keys than any
/// format hapticd reads has.
const MAX_PASSES: usize = 256;

/// A mistake found: the field it is about, where, and what.
type Mistake = (String, Position, String);

/// A node of the text, where it begins.
#[derive(Debug, Clone)]
struct Node {
    kind: Kind,
    at: Position,
}

#[derive(Debug, Clone)]
enum Kind {
    /// A scalar as written, and whether it was written without quotes.
    Scalar {
        text: String,
        plain: bool,
    },
    Sequence(Vec<Node>),
    /// Each key, where it is written, and its value.
    Mapping(Vec<(String, Position, Node)>),
    /// Nothing is written here: a stand-in for a missing key or item.
    Absent,
}

impl Kind {
    fn noun(&self) -> String {
        match self {
            Kind::Scalar { text, plain: true } => format!("`{text}`"),
            Kind::Scalar { text, plain: false } => format!("the text {text:?}"),
            Kind::Sequence(_) => "a list".into(),
            Kind::Mapping(_) => "a mapping".into(),
            Kind::Absent => "nothing".into(),
        }
    }

    fn is_null(&self) -> bool {
        matches!(self, Kind::Scalar { text, plain: true }
            if matches!(text.as_str(), "" | "~" | "null" | "Null" | "NULL"))
    }
}

/// A collection being read.
enum Open {
    Sequence(Vec<Node>, Position, usize),
    Mapping(
        Vec<(String, Position, Node)>,
        Position,
        usize,
        Option<(String, Position)>,
    ),
}

/// Read `text` into its tree, with the mistakes of the tree itself (duplicate keys,
/// collections as keys); `None` if the text is not YAML or expands past [`MAX_NODES`].
fn tree(text: &str) -> Option<(Node, Vec<Mistake>)> {
    let mut anchors: HashMap<usize, Node> = HashMap::new();
    let mut stack: Vec<Open> = Vec::new();
    let mut mistakes = Vec::new();
    let mut nodes = 0usize;
    for event in Parser::new_from_str(text) {
        let (event, span) = event.ok()?;
        let at = Position {
            line: span.start.line() as u64,
            column: span.start.col() as u64 + 1,
        };
        let (node, anchor) = match event {
            Event::Scalar(value, style, anchor, _) => {
                let plain = matches!(style, ScalarStyle::Plain);
                // A plain scalar in key position names the next value.
                if let Some(Open::Mapping(_, _, _, key @ None)) = stack.last_mut() {
                    *key = Some((value.into_owned(), at));
                    continue;
                }
                let text = value.into_owned();
                nodes += 1;
                (
                    Node {
                        kind: Kind::Scalar { text, plain },
                        at,
                    },
                    anchor,
                )
            }
            Event::Alias(id) => {
                let node = anchors.get(&id)?;
                // Counted before it is copied: a copy could be the bomb itself.
                nodes += count(node);
                if nodes > MAX_NODES {
                    return None;
                }
                (node.clone(), 0)
            }
            Event::SequenceStart(_, anchor, _) => {
                stack.push(Open::Sequence(Vec::new(), at, anchor));
                continue;
            }
            Event::MappingStart(_, anchor, _) => {
                stack.push(Open::Mapping(Vec::new(), at, anchor, None));
                continue;
            }
            Event::SequenceEnd | Event::MappingEnd => {
                nodes += 1;
                match stack.pop()? {
                    Open::Sequence(items, at, anchor) => (
                        Node {
                            kind: Kind::Sequence(items),
                            at,
                        },
                        anchor,
                    ),
                    Open::Mapping(entries, at, anchor, _) => (
                        Node {
                            kind: Kind::Mapping(entries),
                            at,
                        },
                        anchor,
                    ),
                }
            }
            Event::DocumentEnd if stack.is_empty() => break,
            _ => continue,
        };
        if nodes > MAX_NODES {
            return None;
        }
        if anchor != 0 {
            anchors.insert(anchor, node.clone());
        }
        match stack.last_mut() {
            None => return Some((node, mistakes)),
            Some(Open::Sequence(items, ..)) => items.push(node),
            Some(Open::Mapping(entries, _, _, key)) => match key.take() {
                Some((k, key_at)) if entries.iter().any(|(e, ..)| *e == k) => {
                    let message = format!("`{k}` is given twice; give it once");
                    mistakes.push((String::new(), key_at, message));
                }
                Some((k, key_at)) => entries.push((k, key_at, node)),
                None => {
                    // A collection or an alias in key position: skip its value too.
                    mistakes.push((String::new(), node.at, "a key must be a plain name".into()));
                    *key = Some((String::new(), node.at));
                }
            },
        }
    }
    // An empty text: an empty mapping, so that missing keys are named.
    Some((
        Node {
            kind: Kind::Mapping(Vec::new()),
            at: Position { line: 1, column: 1 },
        },
        mistakes,
    ))
}

fn count(node: &Node) -> usize {
    1 + match &node.kind {
        Kind::Sequence(items) => items.iter().map(count).sum(),
        Kind::Mapping(entries) => entries.iter().map(|(.., n)| count(n)).sum(),
        _ => 0,
    }
}

/// Why a pass could not go on.
#[derive(Debug)]
enum Error {
    /// A key the type requires is missing from the mapping at `path` (`None` until the
    /// mapping's deserialiser names it).
    Missing {
        path: Option<String>,
        field: &'static str,
    },
    /// Anything else the type's own code refused.
    Other(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Missing { field, .. } => write!(f, "`{field}` is missing"),
            Error::Other(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Error {}

impl de::Error for Error {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Error::Other(msg.to_string())
    }

    fn missing_field(field: &'static str) -> Self {
        Error::Missing { path: None, field }
    }
}

/// What one pass shares: the mistakes so far and the keys to supply.
struct Pass<'a> {
    mistakes: RefCell<Vec<Mistake>>,
    supplied: &'a HashSet<(String, &'static str)>,
}

impl Pass<'_> {
    fn mistake(&self, path: &str, at: Position, message: String) {
        self.mistakes
            .borrow_mut()
            .push((path.to_string(), at, message));
    }
}

fn child(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

/// Deserialise `text` (named `file` in findings) into `T`, recording every schema mistake:
/// the stand-in value and the findings, each at its place and field. `None` when the text
/// is not YAML, expands too far, or the type refuses it in a way no stand-in mends; the
/// caller then reports the YAML library's own first error.
pub(crate) fn parse<T: DeserializeOwned>(text: &str, file: &Path) -> Option<(T, Vec<Diagnostic>)> {
    let (root, tree_mistakes) = tree(text)?;
    let mut supplied = HashSet::new();
    let mut missing = Vec::new();
    for _ in 0..MAX_PASSES {
        let pass = Pass {
            mistakes: RefCell::new(Vec::new()),
            supplied: &supplied,
        };
        let de = De {
            node: &root,
            path: String::new(),
            pass: &pass,
        };
        match T::deserialize(de) {
            Ok(value) => {
                let mut found = tree_mistakes.clone();
                found.extend(pass.mistakes.into_inner());
                found.extend(missing);
                found.sort_by_key(|(_, at, _)| *at);
                let findings = found
                    .into_iter()
                    .map(|(field, at, message)| Diagnostic {
                        severity: Severity::Error,
                        file: file.to_path_buf(),
                        position: Some(at),
                        field,
                        message,
                    })
                    .collect();
                return Some((value, findings));
            }
            Err(Error::Missing {
                path: Some(path),
                field,
            }) => {
                // Supplied and still missing: a type this pass cannot stand in for.
                if supplied.contains(&(path.clone(), field)) {
                    return None;
                }
                let at = place(&root, &path).unwrap_or(root.at);
                missing.push((child(&path, field), at, "required, but not given".into()));
                supplied.insert((path, field));
            }
            Err(_) => return None,
        }
    }
    None
}

/// Where the node at `path` begins.
fn place(root: &Node, path: &str) -> Option<Position> {
    let mut node = root;
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let (key, indices) = part.split_once('[').map_or((part, ""), |(k, i)| (k, i));
        if !key.is_empty() {
            let Kind::Mapping(entries) = &node.kind else {
                return None;
            };
            node = &entries.iter().find(|(k, ..)| k == key)?.2;
        }
        for index in indices.split('[').filter(|i| !i.is_empty()) {
            let i: usize = index.trim_end_matches(']').parse().ok()?;
            let Kind::Sequence(items) = &node.kind else {
                return None;
            };
            node = items.get(i)?;
        }
    }
    Some(node.at)
}

/// The stand-in where nothing is written.
const ABSENT: Node = Node {
    kind: Kind::Absent,
    at: Position { line: 0, column: 0 },
};

/// The deserialiser of one node.
struct De<'a> {
    node: &'a Node,
    path: String,
    pass: &'a Pass<'a>,
}

impl<'a> De<'a> {
    fn at(&self, node: &'a Node, path: String) -> Self {
        De {
            node,
            path,
            pass: self.pass,
        }
    }

    /// The node read as `T` by the YAML library, or a mistake naming `what` was expected
    /// and `T`'s stand-in.
    fn scalar<T: DeserializeOwned + Default + std::str::FromStr>(&self, what: &str) -> T {
        match &self.node.kind {
            Kind::Absent => T::default(),
            Kind::Scalar { text, plain: true } => {
                // Plain decimal numbers read the same either way, and this way a file of a
                // million of them is read in a moment.
                if text
                    .bytes()
                    .all(|b| b.is_ascii_digit() || b"+-.eE".contains(&b))
                    && let Ok(v) = text.parse()
                {
                    return v;
                }
                match serde_saphyr::from_str(text) {
                    Ok(v) => v,
                    Err(_) => self.wrong(what),
                }
            }
            _ => self.wrong(what),
        }
    }

    fn wrong<T: Default>(&self, what: &str) -> T {
        self.pass.mistake(
            &self.path,
            self.node.at,
            format!("expected {what}, found {}", self.node.kind.noun()),
        );
        T::default()
    }

    /// The node's items if it is a list; none (a mistake naming `what`) if it is anything
    /// else written.
    fn items(&self, what: &str) -> &'a [Node] {
        match &self.node.kind {
            Kind::Sequence(items) => items,
            Kind::Absent => &[],
            _ => {
                self.wrong::<()>(what);
                &[]
            }
        }
    }

    /// The node's entries if it is a mapping; none (a mistake) if it is anything else written.
    fn entries(&self) -> &'a [(String, Position, Node)] {
        match &self.node.kind {
            Kind::Mapping(entries) => entries,
            Kind::Absent => &[],
            _ => {
                self.wrong::<()>("a mapping");
                &[]
            }
        }
    }

    fn text(&self) -> String {
        match &self.node.kind {
            Kind::Scalar { text, .. } => text.clone(),
            Kind::Absent => String::new(),
            _ => self.wrong("text"),
        }
    }
}

macro_rules! scalars {
    ($($method:ident $visit:ident $ty:ty, $what:literal;)*) => {
        $(fn $method<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
            visitor.$visit(self.scalar::<$ty>($what))
        })*
    };
}

impl<'de, 'a> de::Deserializer<'de> for De<'a> {
    type Error = Error;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        match &self.node.kind {
            Kind::Sequence(_) => self.deserialize_seq(visitor),
            Kind::Mapping(_) => self.deserialize_map(visitor),
            Kind::Absent => visitor.visit_unit(),
            kind if kind.is_null() => visitor.visit_unit(),
            Kind::Scalar { text, plain } => {
                if *plain {
                    if let Ok(b) = serde_saphyr::from_str::<bool>(text) {
                        return visitor.visit_bool(b);
                    }
                    if let Ok(i) = serde_saphyr::from_str::<i64>(text) {
                        return visitor.visit_i64(i);
                    }
                    if let Ok(x) = serde_saphyr::from_str::<f64>(text) {
                        return visitor.visit_f64(x);
                    }
                }
                visitor.visit_str(text)
            }
        }
    }

    scalars! {
        deserialize_bool visit_bool bool, "true or false";
        deserialize_i8 visit_i8 i8, "a whole number";
        deserialize_i16 visit_i16 i16, "a whole number";
        deserialize_i32 visit_i32 i32, "a whole number";
        deserialize_i64 visit_i64 i64, "a whole number";
        deserialize_u8 visit_u8 u8, "a whole number ≥ 0";
        deserialize_u16 visit_u16 u16, "a whole number ≥ 0";
        deserialize_u32 visit_u32 u32, "a whole number ≥ 0";
        deserialize_u64 visit_u64 u64, "a whole number ≥ 0";
        deserialize_f32 visit_f32 f32, "a number";
        deserialize_f64 visit_f64 f64, "a number";
    }

    fn deserialize_char<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        self.deserialize_str(visitor)
    }

    fn deserialize_str<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        visitor.visit_string(self.text())
    }

    fn deserialize_string<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        self.deserialize_str(visitor)
    }

    fn deserialize_bytes<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        self.deserialize_str(visitor)
    }

    fn deserialize_byte_buf<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        self.deserialize_str(visitor)
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        match &self.node.kind {
            Kind::Absent => visitor.visit_none(),
            kind if kind.is_null() => visitor.visit_none(),
            _ => visitor.visit_some(self),
        }
    }

    fn deserialize_unit<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        visitor.visit_unit()
    }

    fn deserialize_unit_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, Error> {
        visitor.visit_unit()
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, Error> {
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        let items = self.items("a list");
        visitor.visit_seq(Items {
            de: &self,
            items,
            next: 0,
            len: items.len(),
        })
    }

    fn deserialize_tuple<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value, Error> {
        let items = self.items(&format!("a list of {len} items"));
        if matches!(self.node.kind, Kind::Sequence(_)) && items.len() != len {
            self.pass.mistake(
                &self.path,
                self.node.at,
                format!("expected a list of {len} items, found {}", items.len()),
            );
        }
        visitor.visit_seq(Items {
            de: &self,
            items,
            next: 0,
            len,
        })
    }

    fn deserialize_tuple_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        len: usize,
        visitor: V,
    ) -> Result<V::Value, Error> {
        self.deserialize_tuple(len, visitor)
    }

    fn deserialize_map<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        let entries = self.entries();
        visitor.visit_map(Entries {
            de: &self,
            entries,
            fields: None,
            next: 0,
            supplied: Vec::new(),
            value: None,
        })
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Error> {
        let entries = self.entries();
        // Keys a previous pass found missing, and every key of a mapping not written at
        // all (its absence is the mistake already reported).
        let absent = !matches!(self.node.kind, Kind::Mapping(_));
        let supplied: Vec<&'static str> = fields
            .iter()
            .copied()
            .filter(|f| !entries.iter().any(|(k, ..)| k == f))
            .filter(|f| absent || self.pass.supplied.contains(&(self.path.clone(), *f)))
            .collect();
        let result = visitor.visit_map(Entries {
            de: &self,
            entries,
            fields: Some(fields),
            next: 0,
            supplied,
            value: None,
        });
        match result {
            Err(Error::Missing { path: None, field }) => Err(Error::Missing {
                path: Some(self.path),
                field,
            }),
            other => other,
        }
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Error> {
        // A unit variant is its name; any other is a mapping of its name to its payload,
        // which checks name by the variant (`shapes[0].floor.height`).
        let (name, payload, at, path) = match &self.node.kind {
            Kind::Scalar { text, .. } => (text.clone(), &ABSENT, self.node.at, self.path.clone()),
            Kind::Mapping(entries) if entries.len() == 1 => {
                let (name, at, payload) = &entries[0];
                (name.clone(), payload, *at, child(&self.path, name))
            }
            Kind::Absent => (
                variants[0].to_string(),
                &ABSENT,
                self.node.at,
                self.path.clone(),
            ),
            _ => {
                self.wrong::<()>(&format!("one of {}", list(variants)));
                (
                    variants[0].to_string(),
                    &ABSENT,
                    self.node.at,
                    self.path.clone(),
                )
            }
        };
        let variant = if variants.contains(&name.as_str()) {
            name
        } else {
            self.pass.mistake(
                &self.path,
                at,
                format!("`{name}` is not one of {}", list(variants)),
            );
            variants[0].to_string()
        };
        visitor.visit_enum(Variant {
            de: self.at(payload, path),
            name: variant,
        })
    }

    fn deserialize_identifier<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        self.deserialize_str(visitor)
    }

    fn deserialize_ignored_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        visitor.visit_unit()
    }
}

fn list(names: &[&str]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The items of a list; a list of fixed length is padded with stand-ins, and items past it
/// are left unread (the length mistake names them).
struct Items<'a, 'b> {
    de: &'b De<'a>,
    items: &'a [Node],
    next: usize,
    len: usize,
}

impl<'de> de::SeqAccess<'de> for Items<'_, '_> {
    type Error = Error;

    fn next_element_seed<S: DeserializeSeed<'de>>(
        &mut self,
        seed: S,
    ) -> Result<Option<S::Value>, Error> {
        if self.next >= self.len {
            return Ok(None);
        }
        let i = self.next;
        self.next += 1;
        let node = self.items.get(i).unwrap_or(&ABSENT);
        let path = format!("{}[{i}]", self.de.path);
        seed.deserialize(self.de.at(node, path)).map(Some)
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.len - self.next)
    }
}

/// The entries of a mapping; for a struct, unknown keys are mistakes and skipped, and the
/// keys to supply follow the written ones.
struct Entries<'a, 'b> {
    de: &'b De<'a>,
    entries: &'a [(String, Position, Node)],
    fields: Option<&'static [&'static str]>,
    next: usize,
    supplied: Vec<&'static str>,
    value: Option<(&'a Node, String)>,
}

impl<'de> de::MapAccess<'de> for Entries<'_, '_> {
    type Error = Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, Error> {
        while let Some((key, key_at, node)) = self.entries.get(self.next) {
            self.next += 1;
            if let Some(fields) = self.fields
                && !fields.contains(&key.as_str())
            {
                self.de.pass.mistake(
                    &child(&self.de.path, key),
                    *key_at,
                    format!("unknown key; the keys here are {}", list(fields)),
                );
                continue;
            }
            self.value = Some((node, child(&self.de.path, key)));
            return seed.deserialize(key.as_str().into_deserializer()).map(Some);
        }
        let Some(field) = self.supplied.pop() else {
            return Ok(None);
        };
        self.value = Some((&ABSENT, child(&self.de.path, field)));
        seed.deserialize(field.into_deserializer()).map(Some)
    }

    fn next_value_seed<S: DeserializeSeed<'de>>(&mut self, seed: S) -> Result<S::Value, Error> {
        let (node, path) = self.value.take().unwrap_or((&ABSENT, self.de.path.clone()));
        seed.deserialize(self.de.at(node, path))
    }
}

/// A variant of an enum, with what is written under its name.
struct Variant<'a> {
    de: De<'a>,
    name: String,
}

impl<'de, 'a> de::EnumAccess<'de> for Variant<'a> {
    type Error = Error;
    type Variant = De<'a>;

    fn variant_seed<S: DeserializeSeed<'de>>(self, seed: S) -> Result<(S::Value, De<'a>), Error> {
        let name: de::value::StringDeserializer<Error> = self.name.into_deserializer();
        Ok((seed.deserialize(name)?, self.de))
    }
}

impl<'de> de::VariantAccess<'de> for De<'_> {
    type Error = Error;

    fn unit_variant(self) -> Result<(), Error> {
        Ok(())
    }

    fn newtype_variant_seed<S: DeserializeSeed<'de>>(self, seed: S) -> Result<S::Value, Error> {
        seed.deserialize(self)
    }

    fn tuple_variant<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value, Error> {
        de::Deserializer::deserialize_tuple(self, len, visitor)
    }

    fn struct_variant<V: Visitor<'de>>(
        self,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Error> {
        de::Deserializer::deserialize_struct(self, "", fields, visitor)
    }
}

#[cfg(test)]
mod tests;
