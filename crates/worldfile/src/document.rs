//! The document level: entities in pre-order with their raw properties (stage-worldfile.md §6).
//!
//! Both languages produce the same shape. Values stay raw token text, as upstream keeps them: the
//! type of a value is decided by whoever reads it (see [`crate::reader`]). Every property has a
//! `used` flag that readers set, so "defined but not used" warnings fall out of reading.

use std::cell::Cell;
use std::f64::consts::PI;

use serde::Serialize;

use crate::error::Warning;
use crate::lexer::{Dialect, TextSpan, TokenStream};
use crate::numeric::{Prefix, atof, atoi};
use crate::source::{Location, SourceLoc, SourceMap};

/// Index of an entity in a [`Document`]; 0 is the global (top-level) entity.
pub type EntityId = usize;

/// The kind of token a value came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ValueKind {
    /// A NUMBER token (any run of `+-.0-9`, possibly with an exponent).
    Number,
    /// A quoted string.
    Str,
    /// `true`/`false`/`yes`/`no` (cfg files only).
    Bool,
}

/// Index of a token in a [`Document`]'s token stream. Properties and entities name the word they
/// were written with by its token, so the thousandth instance of a macro shares its macro's text
/// instead of copying it.
pub type TokenId = usize;

/// One value of a property, as written, with what C's `atof`/`atoi` make of it.
///
/// A value is stored once per token written ([`Document::values`]): every instance of a macro
/// shares the values of its body, so a number is converted once however often it is read.
#[derive(Clone, Debug, PartialEq)]
pub struct Value {
    /// Token class it came from.
    pub kind: ValueKind,
    /// Raw text (without quotes for strings).
    pub text: Box<str>,
    /// Where it is written.
    pub loc: Location,
    float: Option<Prefix<f64>>,
    int: Option<Prefix<i64>>,
}

impl Value {
    /// A value with its text converted once, as `atof` and as `atoi` would read it.
    pub fn new(kind: ValueKind, text: Box<str>, loc: Location) -> Self {
        Value {
            kind,
            float: atof(&text),
            int: atoi(&text),
            text,
            loc,
        }
    }

    /// The text as C's `atof` reads it (`None`: no numeric prefix at all).
    pub fn float(&self) -> Option<Prefix<f64>> {
        self.float
    }

    /// The text as C's `atoi` reads it (`None`: no numeric prefix at all).
    pub fn int(&self) -> Option<Prefix<i64>> {
        self.int
    }
}

/// Where a property's values are in its document's value store (see [`Document::values`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ValueRange {
    /// Index of the first value.
    pub start: usize,
    /// Number of values.
    pub len: usize,
}

/// A property (Stage) or field (Player): a name with zero or more values.
///
/// Its text lives in the [`Document`]: [`Document::name`] and [`Document::values`] read it.
#[derive(Clone, Debug)]
pub struct Property {
    /// Where the name as written (e.g. `pose` or `point[3]`) is in the document's token text;
    /// [`Document::name`] gives it.
    pub name: TextSpan,
    /// The values: one for a scalar, any number for a tuple.
    pub values: ValueRange,
    /// Where the name is written (for an inherited property, inside the `define`).
    pub loc: Location,
    /// Whether the property was written as a `[ ... ]` tuple.
    pub is_tuple: bool,
    used: Cell<bool>,
}

impl Property {
    /// A new, unused property.
    pub fn new(name: TextSpan, values: ValueRange, loc: Location, is_tuple: bool) -> Self {
        Property {
            name,
            values,
            loc,
            is_tuple,
            used: Cell::new(false),
        }
    }

    /// Whether any reader has looked at this property.
    pub fn is_used(&self) -> bool {
        self.used.get()
    }

    /// Marks the property as read.
    pub fn mark_used(&self) {
        self.used.set(true);
    }

    /// Whether it has no values (an empty tuple).
    pub fn is_empty(&self) -> bool {
        self.values.len == 0
    }
}

/// An entity: `type ( ... )`, or the global entity 0.
#[derive(Clone, Debug)]
pub struct Entity {
    /// Enclosing entity (`None` only for entity 0).
    pub parent: Option<EntityId>,
    /// Child entities in source order.
    pub children: Vec<EntityId>,
    /// The token of the base type word (for a macro instance, the ultimate non-macro parent
    /// word); `None` for entity 0. [`Document::type_name`] gives its text.
    pub type_word: Option<TokenId>,
    /// The token of the macro name the entity was written as, if any (e.g. `pioneer2dx` for a
    /// `position`). [`Document::macro_name`] gives its text.
    pub macro_word: Option<TokenId>,
    /// Where the entity's name is written (`None` for entity 0).
    pub loc: Option<Location>,
    /// Properties in the order first written.
    pub properties: Vec<Property>,
    /// An earlier entity this one is a copy of: made by the same text of a macro body, with the
    /// same properties in the same order, all written at the same places. Reading one reads
    /// the same as reading the other, so a reader may reuse what it read there.
    pub copy_of: Option<EntityId>,
}

/// Length and angle multipliers from `unit_length` / `unit_angle` (stage-worldfile.md §7).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Units {
    /// Metres per file length unit.
    pub length: f64,
    /// Radians per file angle unit.
    pub angle: f64,
}

impl Default for Units {
    fn default() -> Self {
        Units {
            length: 1.0,
            angle: PI / 180.0,
        }
    }
}

/// A parsed worldfile or cfg file: entities in pre-order and their raw properties.
///
/// The document keeps the token stream it was parsed from and one store of values: entities and
/// properties refer into them by index, so expanding a macro copies no text (a 10,000-robot
/// world made of one `define` holds its body's text once).
#[derive(Clone, Debug)]
pub struct Document {
    /// Which language.
    pub dialect: Dialect,
    /// Every file read (top-level first) and the include links between them.
    pub sources: SourceMap,
    /// Entities in pre-order; entity 0 is the global one.
    pub entities: Vec<Entity>,
    /// Units read from entity 0.
    pub units: Units,
    /// Top-level `plugin "name"` statements of a cfg file.
    pub plugins: Vec<(String, Location)>,
    /// Problems noticed while parsing that do not stop loading.
    pub warnings: Vec<Warning>,
    /// The token stream (includes spliced in) that [`TokenId`]s index.
    pub(crate) tokens: TokenStream,
    /// Every value written, once: what [`ValueRange`]s index.
    pub(crate) values: Vec<Value>,
}

impl Document {
    /// A document from the parser's results: `tokens` is the stream the [`TokenId`]s index,
    /// `values` the store the [`ValueRange`]s index.
    pub(crate) fn new(
        dialect: Dialect,
        sources: SourceMap,
        entities: Vec<Entity>,
        plugins: Vec<(String, Location)>,
        warnings: Vec<Warning>,
        tokens: TokenStream,
        values: Vec<Value>,
    ) -> Self {
        Document {
            dialect,
            sources,
            entities,
            units: Units::default(),
            plugins,
            warnings,
            tokens,
            values,
        }
    }

    /// The entity with this id.
    ///
    /// # Panics
    /// If the id is not from this document.
    pub fn entity(&self, id: EntityId) -> &Entity {
        &self.entities[id]
    }

    /// The text of token `id` (a name as written).
    ///
    /// # Panics
    /// If the id is not from this document.
    pub fn text(&self, id: TokenId) -> &str {
        self.tokens.text(&self.tokens.tokens()[id])
    }

    /// The name of a property of this document.
    pub fn name(&self, p: &Property) -> &str {
        self.tokens.span_text(p.name)
    }

    /// The values of a property of this document.
    pub fn values(&self, p: &Property) -> &[Value] {
        &self.values[p.values.start..p.values.start + p.values.len]
    }

    /// The base type word of entity `id` (empty for entity 0).
    pub fn type_name(&self, id: EntityId) -> &str {
        self.entities[id].type_word.map_or("", |t| self.text(t))
    }

    /// The macro entity `id` was written as, if any.
    pub fn macro_name(&self, id: EntityId) -> Option<&str> {
        self.entities[id].macro_word.map(|t| self.text(t))
    }

    /// The property `name` of entity `id`, without marking it used.
    pub fn property(&self, id: EntityId, name: &str) -> Option<&Property> {
        // Readers look up dozens of names per entity, most of them absent: the length in the
        // span rejects most without reading any text.
        let name = name.as_bytes();
        self.entities.get(id).and_then(|e| {
            e.properties
                .iter()
                .find(|p| p.name.len == name.len() && self.tokens.span_bytes(p.name) == name)
        })
    }

    /// A location with its file name, for messages and resolved data.
    pub fn loc(&self, loc: Location) -> SourceLoc {
        self.sources.resolve(loc)
    }

    /// Every entity of this type, in order.
    pub fn entities_of_type<'a>(
        &'a self,
        type_name: &'a str,
    ) -> impl Iterator<Item = EntityId> + 'a {
        (0..self.entities.len()).filter(move |&id| self.type_name(id) == type_name)
    }

    /// Warnings for every property no reader looked at, in entity order (Stage's
    /// `property [x] is defined but not used`).
    pub fn unused_property_warnings(&self) -> Vec<Warning> {
        let mut out = Vec::new();
        for (id, entity) in self.entities.iter().enumerate() {
            for p in entity.properties.iter().filter(|p| !p.is_used()) {
                let owner = if id == 0 {
                    "at top level".to_string()
                } else {
                    format!("in `{}`", self.entity_label(id))
                };
                out.push(Warning::at(
                    self.loc(p.loc),
                    format!(
                        "property `{}` {owner} is defined but not used",
                        self.name(p)
                    ),
                ));
            }
        }
        out
    }

    /// `type` or `macro (a type)` for messages.
    pub fn entity_label(&self, id: EntityId) -> String {
        match self.macro_name(id) {
            Some(m) => format!("{m} (a {})", self.type_name(id)),
            None => self.type_name(id).to_string(),
        }
    }
}
