//! The document level: entities in pre-order with their raw properties (stage-worldfile.md §6).
//!
//! Both languages produce the same shape. Values stay raw token text, as upstream keeps them: the
//! type of a value is decided by whoever reads it (see [`crate::reader`]). Every property of
//! every entity has a `used` flag that readers set ([`Document::use_property`]), so "defined but
//! not used" warnings fall out of reading.
//!
//! A document is sized for worlds of many thousands of robots made from one `define`: entities
//! that copy a macro body share its property records ([`Entity::copy_of`]), only the flags are
//! per entity, children lists live in one store, and the token stream is dropped once parsed
//! (names are spans of its text, which is kept).

use std::cell::Cell;
use std::f64::consts::PI;

use serde::Serialize;

use crate::error::Warning;
use crate::lexer::{Dialect, TextSpan};
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
/// Whether it was read is the document's record, per entity ([`Document::is_used`]): the
/// entities copied from one macro body share their property records.
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
}

impl Property {
    /// A property as written.
    pub fn new(name: TextSpan, values: ValueRange, loc: Location, is_tuple: bool) -> Self {
        Property {
            name,
            values,
            loc,
            is_tuple,
        }
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
    /// Where the base type word (for a macro instance, the ultimate non-macro parent word) is
    /// in the document's token text; `None` for entity 0. [`Document::type_name`] gives it.
    pub type_word: Option<TextSpan>,
    /// Where the macro name the entity was written as, if any (e.g. `pioneer2dx` for a
    /// `position`), is in the document's token text. [`Document::macro_name`] gives it.
    pub macro_word: Option<TextSpan>,
    /// Where the entity's name is written (`None` for entity 0).
    pub loc: Option<Location>,
    /// Properties in the order first written; empty for a copy, which shares those of
    /// [`Entity::copy_of`] ([`Document::properties`] reads either).
    pub(crate) properties: Vec<Property>,
    /// An earlier entity this one is a copy of: made by the same text of a macro body, with the
    /// same properties in the same order, all written at the same places. Reading one reads
    /// the same as reading the other, so a reader may reuse what it read there. That entity is
    /// never a copy itself, and holds the property records both share.
    pub copy_of: Option<EntityId>,
    /// Where its children are in [`Document`]'s children store.
    children: ChildSpan,
    /// Where its properties' `used` flags start in [`Document`]'s flag store.
    used_at: usize,
}

impl Entity {
    /// A new entity with no properties (yet) and no children.
    pub(crate) fn new(
        parent: Option<EntityId>,
        type_word: Option<TextSpan>,
        macro_word: Option<TextSpan>,
        loc: Option<Location>,
        properties: Vec<Property>,
        copy_of: Option<EntityId>,
    ) -> Self {
        Entity {
            parent,
            type_word,
            macro_word,
            loc,
            properties,
            copy_of,
            children: ChildSpan::default(),
            used_at: 0,
        }
    }
}

/// Where an entity's children are in the document's children store.
#[derive(Clone, Copy, Debug, Default)]
struct ChildSpan {
    start: usize,
    len: usize,
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
/// The document keeps the text of the tokens it was parsed from and one store of values:
/// entities and properties refer into them by span and index, so expanding a macro copies no
/// text (a 10,000-robot world made of one `define` holds its body's text once).
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
    /// The text of the token stream (includes spliced in) that [`TextSpan`]s index.
    text: String,
    /// Every value written, once: what [`ValueRange`]s index.
    pub(crate) values: Vec<Value>,
    /// Every entity's children, entity by entity.
    children: Vec<EntityId>,
    /// Whether each property of each entity was read, entity by entity (a copy has flags of
    /// its own for the records it shares).
    used: Vec<Cell<bool>>,
}

impl Document {
    /// A document from the parser's results: `text` is the token text the [`TextSpan`]s index,
    /// `values` the store the [`ValueRange`]s index. Each entity's children and flags are laid
    /// out here, once every entity is known; the stores are trimmed to their length, as the
    /// document lives on while the world is resolved from it.
    pub(crate) fn new(
        dialect: Dialect,
        sources: SourceMap,
        mut entities: Vec<Entity>,
        plugins: Vec<(String, Location)>,
        warnings: Vec<Warning>,
        text: String,
        mut values: Vec<Value>,
    ) -> Self {
        entities.shrink_to_fit();
        values.shrink_to_fit();
        let children = link_children(&mut entities);
        let mut flags = 0;
        for id in 0..entities.len() {
            let owner = entities[id].copy_of.unwrap_or(id);
            let count = entities[owner].properties.len();
            entities[id].used_at = flags;
            flags += count;
        }
        Document {
            dialect,
            sources,
            entities,
            units: Units::default(),
            plugins,
            warnings,
            text,
            values,
            children,
            used: vec![Cell::new(false); flags],
        }
    }

    /// The entity with this id.
    ///
    /// # Panics
    /// If the id is not from this document.
    pub fn entity(&self, id: EntityId) -> &Entity {
        &self.entities[id]
    }

    /// The text of a span of this document's token text (a name as written).
    ///
    /// # Panics
    /// If the span is not from this document.
    pub fn text(&self, span: TextSpan) -> &str {
        &self.text[span.range()]
    }

    /// The name of a property of this document.
    pub fn name(&self, p: &Property) -> &str {
        self.text(p.name)
    }

    /// The children of entity `id`, in source order.
    ///
    /// # Panics
    /// If the id is not from this document.
    pub fn children(&self, id: EntityId) -> &[EntityId] {
        let span = self.entities[id].children;
        &self.children[span.start..span.start + span.len]
    }

    /// The properties of entity `id` in the order first written (for a copy, the records of
    /// the entity it copies).
    ///
    /// # Panics
    /// If the id is not from this document.
    pub fn properties(&self, id: EntityId) -> &[Property] {
        let owner = self.entities[id].copy_of.unwrap_or(id);
        &self.entities[owner].properties
    }

    /// Whether a reader has looked at the `index`th property of entity `id`.
    ///
    /// # Panics
    /// If the entity or the index is not from this document.
    pub fn is_used(&self, id: EntityId, index: usize) -> bool {
        self.used_flag(id, index).get()
    }

    /// Marks the `index`th property of entity `id` as read.
    ///
    /// # Panics
    /// If the entity or the index is not from this document.
    pub fn mark_used(&self, id: EntityId, index: usize) {
        self.used_flag(id, index).set(true);
    }

    fn used_flag(&self, id: EntityId, index: usize) -> &Cell<bool> {
        let flags = self.used_flags(id);
        let count = flags.len();
        assert!(
            index < count,
            "entity {id} has {count} properties, not {index}"
        );
        &flags[index]
    }

    /// The `used` flags of entity `id`'s properties, in their order.
    fn used_flags(&self, id: EntityId) -> &[Cell<bool>] {
        let at = self.entities[id].used_at;
        &self.used[at..at + self.properties(id).len()]
    }

    /// Marks as read, on entity `copy`, every property read on `original`, which it copies
    /// ([`Entity::copy_of`]): reading a copy is reading its original again.
    pub(crate) fn mark_used_as(&self, copy: EntityId, original: EntityId) {
        for (to, from) in self.used_flags(copy).iter().zip(self.used_flags(original)) {
            to.set(to.get() | from.get());
        }
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
        self.find_property(id, name).map(|(_, p)| p)
    }

    /// The property `name` of entity `id`, marked used.
    pub fn use_property(&self, id: EntityId, name: &str) -> Option<&Property> {
        let (index, p) = self.find_property(id, name)?;
        // the index was just found among the entity's properties
        self.used[self.entities[id].used_at + index].set(true);
        Some(p)
    }

    /// The property `name` of entity `id` with its index among the entity's properties.
    #[inline]
    fn find_property(&self, id: EntityId, name: &str) -> Option<(usize, &Property)> {
        if id >= self.entities.len() {
            return None;
        }
        let properties = self.properties(id);
        // Readers look up dozens of names per entity, most of them absent: the length in the
        // span rejects most without reading any text.
        let (name, text) = (name.as_bytes(), self.text.as_bytes());
        let index = properties
            .iter()
            .position(|p| p.name.len as usize == name.len() && &text[p.name.range()] == name)?;
        Some((index, &properties[index]))
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
        for id in 0..self.entities.len() {
            let properties = self.properties(id).iter().zip(self.used_flags(id));
            for (p, _) in properties.filter(|(_, used)| !used.get()) {
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

/// Lays each entity's children out in one store (counted first, so that it is allocated
/// once); returns the store.
fn link_children(entities: &mut [Entity]) -> Vec<EntityId> {
    let mut start = vec![0usize; entities.len() + 1];
    for e in entities.iter() {
        if let Some(parent) = e.parent {
            start[parent + 1] += 1;
        }
    }
    for id in 0..entities.len() {
        start[id + 1] += start[id];
    }
    let mut store = vec![0; start[entities.len()]];
    for (e, &at) in entities.iter_mut().zip(&start) {
        e.children = ChildSpan { start: at, len: 0 };
    }
    for id in 1..entities.len() {
        if let Some(parent) = entities[id].parent {
            let span = &mut entities[parent].children;
            store[span.start + span.len] = id;
            span.len += 1;
        }
    }
    store
}
