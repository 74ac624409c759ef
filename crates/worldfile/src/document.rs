//! The document level: entities in pre-order with their raw properties (stage-worldfile.md §6).
//!
//! Both languages produce the same shape. Values stay raw token text, as upstream keeps them: the
//! type of a value is decided by whoever reads it (see [`crate::reader`]). Every property has a
//! `used` flag that readers set, so "defined but not used" warnings fall out of reading.

use std::cell::Cell;
use std::f64::consts::PI;

use serde::Serialize;

use crate::error::Warning;
use crate::lexer::Dialect;
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

/// One value of a property, as written.
#[derive(Clone, Debug, PartialEq)]
pub struct Value {
    /// Token class it came from.
    pub kind: ValueKind,
    /// Raw text (without quotes for strings).
    pub text: Box<str>,
    /// Where it is written.
    pub loc: Location,
}

/// A property (Stage) or field (Player): a name with zero or more values.
#[derive(Clone, Debug)]
pub struct Property {
    /// The name as written, e.g. `pose` or `point[3]`.
    pub name: Box<str>,
    /// The values: one for a scalar, any number for a tuple.
    pub values: Vec<Value>,
    /// Where the name is written (for an inherited property, inside the `define`).
    pub loc: Location,
    /// Whether the property was written as a `[ ... ]` tuple.
    pub is_tuple: bool,
    used: Cell<bool>,
}

impl Property {
    /// A new, unused property.
    pub fn new(name: Box<str>, values: Vec<Value>, loc: Location, is_tuple: bool) -> Self {
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
}

/// An entity: `type ( ... )`, or the global entity 0.
#[derive(Clone, Debug)]
pub struct Entity {
    /// Enclosing entity (`None` only for entity 0).
    pub parent: Option<EntityId>,
    /// Child entities in source order.
    pub children: Vec<EntityId>,
    /// The base type word (for a macro instance, the ultimate non-macro parent word).
    pub type_name: Box<str>,
    /// The macro the entity was written as, if any (e.g. `pioneer2dx` for a `position`).
    pub macro_name: Option<Box<str>>,
    /// Where the entity's name is written (`None` for entity 0).
    pub loc: Option<Location>,
    /// Properties in the order first written.
    pub properties: Vec<Property>,
}

impl Entity {
    /// The property with this name, without marking it used.
    pub fn property(&self, name: &str) -> Option<&Property> {
        self.properties.iter().find(|p| &*p.name == name)
    }
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
}

impl Document {
    /// The entity with this id.
    ///
    /// # Panics
    /// If the id is not from this document.
    pub fn entity(&self, id: EntityId) -> &Entity {
        &self.entities[id]
    }

    /// The property `name` of entity `id`, without marking it used.
    pub fn property(&self, id: EntityId, name: &str) -> Option<&Property> {
        self.entities.get(id).and_then(|e| e.property(name))
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
        self.entities
            .iter()
            .enumerate()
            .filter(move |(_, e)| &*e.type_name == type_name)
            .map(|(i, _)| i)
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
                    format!("in `{}`", entity_label(entity))
                };
                out.push(Warning::at(
                    self.loc(p.loc),
                    format!("property `{}` {owner} is defined but not used", p.name),
                ));
            }
        }
        out
    }
}

/// `type` or `macro (type)` for messages.
pub fn entity_label(entity: &Entity) -> String {
    match &entity.macro_name {
        Some(m) => format!("{m} (a {})", entity.type_name),
        None => entity.type_name.to_string(),
    }
}
