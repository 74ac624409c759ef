//! The token-level grammar (stage-worldfile.md §3, §5; player-cfg.md §3).
//!
//! This follows upstream's recursive structure on purpose: a macro instance is expanded by
//! re-parsing the macro's stored token range (`PARENT ( body )`) at the point of use, so children
//! written in a `define` are created anew for every instance, base-most body first, and later
//! properties replace earlier ones. The differences from upstream are deliberate and documented:
//! tuples may span lines and hold comments, every failure is an error with a location (upstream
//! sometimes fails silently or builds a partial world), stray `(` and macro cycles are errors
//! (upstream nests entities / overflows its stack), and expansion is bounded by [`Limits`].
//!
//! What upstream re-parses, we parse once: a macro body's entities, once expanded, are copied
//! for its later instances (until a new `define` could change what its words mean), and each
//! value written is converted once and shared by every property that repeats it. A copied
//! entity other than the body's own (which the instance adds properties to) shares the
//! property records of the entity it copies. Copies count against [`Limits`] exactly as the
//! parse they stand for, so a 10,000-robot world of one `define` loads in the time of its
//! instance lines, with the same document and errors.

use std::collections::HashMap;

use crate::document::{Document, Entity, EntityId, Property, Value, ValueKind, ValueRange};
use crate::error::{Error, ErrorKind, Warning};
use crate::lexer::{Dialect, Token, TokenKind, TokenStream};
use crate::loader::Limits;
use crate::source::{Location, SourceMap};

struct Macro {
    /// Index of the PARENT word; the macro's tokens run from there to its closing `)`.
    start: usize,
    loc: Location,
}

/// The values a property written at a token were stored as, so that the next instance of the
/// same macro body reuses them.
#[derive(Clone, Copy)]
struct Parsed {
    values: ValueRange,
    /// Index of the last token of the value (the `]` of a tuple).
    end: usize,
}

/// What expanding a macro body made, kept so that later instances copy it instead of parsing
/// the body again: its entities (the first is the body's own, whose parent is the instance's;
/// the others' parents are offsets from the first, and they hold no properties, as their
/// copies share those of the entities they copy), and what parsing it took, so that the copy
/// still counts against [`Limits`] exactly as a parse would.
struct Expansion {
    entities: Vec<Entity>,
    /// The type word token of each entity, for [`Parser::type_tokens`].
    type_tokens: Vec<u32>,
    steps: u64,
    /// How much deeper than where it started the expansion nested.
    depth: usize,
}

struct Parser<'a> {
    stream: &'a TokenStream,
    toks: &'a [Token],
    /// The document's value store: every value token is converted into it once.
    values: Vec<Value>,
    /// For each token that starts a property's value (a scalar or a `[`), 0 until it has been
    /// parsed, then 1 + its index in `parsed` (zeroed memory costs nothing until touched).
    parsed_at: Vec<u32>,
    parsed: Vec<Parsed>,
    /// For each type word, the most properties an entity made at it has had so far.
    property_counts: Vec<u32>,
    /// For each entity, the token of its type word (entity 0: none, `u32::MAX`), which
    /// indexes `property_counts`.
    type_tokens: Vec<u32>,
    /// The entities each macro body (by the index of its PARENT word) expanded to, while the
    /// set of macros stays the same.
    expansions: HashMap<usize, Expansion>,
    /// The deepest `depth` reached (to know how deep an expansion nests).
    deepest: usize,
    sources: &'a SourceMap,
    dialect: Dialect,
    limits: &'a Limits,
    entities: Vec<Entity>,
    macros: HashMap<&'a str, Macro>,
    expanding: Vec<&'a str>,
    plugins: Vec<(String, Location)>,
    warnings: Vec<Warning>,
    steps: u64,
    depth: usize,
    /// Whether values met before are reused (off only in tests, to show reuse changes nothing).
    reuse: bool,
}

/// Parses a spliced token stream into a document, then reads `unit_length`/`unit_angle`/`test`
/// from the global entity.
pub fn parse(
    toks: TokenStream,
    sources: SourceMap,
    dialect: Dialect,
    limits: &Limits,
) -> Result<Document, Error> {
    parse_reusing(toks, sources, dialect, limits, true)
}

/// [`parse`], with the reuse of values parsed in an earlier instance of a macro on or off.
pub(crate) fn parse_reusing(
    toks: TokenStream,
    sources: SourceMap,
    dialect: Dialect,
    limits: &Limits,
    reuse: bool,
) -> Result<Document, Error> {
    let (entities, values, plugins, warnings) = {
        let mut p = Parser {
            stream: &toks,
            toks: toks.tokens(),
            sources: &sources,
            dialect,
            limits,
            values: Vec::new(),
            parsed_at: vec![0; toks.len()],
            parsed: Vec::new(),
            property_counts: vec![0; toks.len()],
            type_tokens: vec![u32::MAX],
            expansions: HashMap::new(),
            deepest: 0,
            entities: vec![Entity::new(None, None, None, None, Vec::new(), None)],
            macros: HashMap::new(),
            expanding: Vec::new(),
            plugins: Vec::new(),
            warnings: Vec::new(),
            steps: 0,
            depth: 0,
            reuse,
        };
        p.file()?;
        (p.entities, p.values, p.plugins, p.warnings)
    };
    // the tokens themselves are not needed any more, only their text
    let text = toks.into_text();
    let mut doc = Document::new(dialect, sources, entities, plugins, warnings, text, values);
    read_globals(&mut doc)?;
    Ok(doc)
}

/// `unit_length`, `unit_angle` (after a successful parse, like upstream) and `test`.
fn read_globals(doc: &mut Document) -> Result<(), Error> {
    let mut warnings = Vec::new();
    if let Some(p) = doc.use_property(0, "test") {
        let v = doc.values(p).first().and_then(Value::int).map(|n| n.value);
        if v.unwrap_or(0) != 0 {
            return Err(Error::at(ErrorKind::TestFile, &doc.sources, p.loc, "test"));
        }
    }
    if let Some(f) = unit_factor(doc, "unit_length", LENGTH_UNITS, "metres", &mut warnings) {
        doc.units.length = f;
    }
    if let Some(f) = unit_factor(doc, "unit_angle", ANGLE_UNITS, "degrees", &mut warnings) {
        doc.units.angle = f;
    }
    doc.warnings.extend(warnings);
    Ok(())
}

/// The words `unit_length` takes, with metres per unit.
const LENGTH_UNITS: &[(&str, f64)] = &[("m", 1.0), ("cm", 0.01), ("mm", 0.001)];
/// The words `unit_angle` takes, with radians per unit.
const ANGLE_UNITS: &[(&str, f64)] = &[("degrees", std::f64::consts::PI / 180.0), ("radians", 1.0)];

/// The factor of the unit word written as the top-level property `key`, marking it used;
/// `None` when it is absent, or (with a warning, the unit staying Stage's `default`) when the
/// word is not one of `units`.
fn unit_factor(
    doc: &Document,
    key: &str,
    units: &[(&str, f64)],
    default: &str,
    warnings: &mut Vec<Warning>,
) -> Option<f64> {
    let p = doc.use_property(0, key)?;
    let word = doc.values(p).first().map(|v| &*v.text);
    if let Some(&(_, factor)) = units.iter().find(|(name, _)| Some(*name) == word) {
        return Some(factor);
    }
    let names: Vec<String> = units.iter().map(|(name, _)| format!("{name:?}")).collect();
    let (last, rest) = names.split_last().expect("a unit table is not empty");
    warnings.push(Warning::at(
        doc.loc(p.loc),
        format!(
            "{key} {:?} is not {} or {last}; using {default} as Stage does",
            word.unwrap_or(""),
            rest.join(", ")
        ),
    ));
    None
}

fn is_blank(kind: TokenKind) -> bool {
    matches!(kind, TokenKind::Space | TokenKind::Comment | TokenKind::Eol)
}

impl<'a> Parser<'a> {
    fn err(&self, kind: ErrorKind, tok: &Token) -> Error {
        Error::at(kind, self.sources, tok.loc, &tok.snippet(self.text(tok)))
    }

    /// The text of a token of the stream being parsed.
    fn text(&self, tok: &Token) -> &'a str {
        self.stream.text(tok)
    }

    /// How a token is named in messages.
    fn describe(&self, tok: &Token) -> String {
        tok.describe(self.text(tok))
    }

    fn step(&mut self, at: &Token) -> Result<(), Error> {
        self.steps += 1;
        if self.steps > self.limits.max_parse_steps {
            return Err(self.err(
                ErrorKind::TooLarge(format!(
                    "macro expansion needs more than {} parser steps",
                    self.limits.max_parse_steps
                )),
                at,
            ));
        }
        Ok(())
    }

    fn file(&mut self) -> Result<(), Error> {
        let toks = self.toks;
        let mut i = 0;
        while i < toks.len() {
            let tok = &toks[i];
            self.step(tok)?;
            match tok.kind {
                TokenKind::Word => {
                    i = match self.text(tok) {
                        "include" => self.include_stmt(i)?,
                        "define" => self.define(i)?,
                        "plugin" if self.dialect == Dialect::Cfg => self.plugin(i)?,
                        _ => self.word_item(0, i)?,
                    };
                }
                k if is_blank(k) => {}
                _ => {
                    return Err(self.err(ErrorKind::UnexpectedAtTopLevel(self.describe(tok)), tok));
                }
            }
            i += 1;
        }
        Ok(())
    }

    /// `include "file"` — the loader already spliced the file in; skip to the line end it added.
    fn include_stmt(&mut self, i: usize) -> Result<usize, Error> {
        let toks = self.toks;
        for (j, tok) in toks.iter().enumerate().skip(i + 1) {
            match tok.kind {
                TokenKind::Str | TokenKind::Space => {}
                TokenKind::Eol => return Ok(j),
                _ => return Err(self.err(ErrorKind::BadInclude, tok)),
            }
        }
        Err(self.err(ErrorKind::BadInclude, &toks[i]))
    }

    /// Top-level `plugin "name"` in a cfg file: recorded, not loaded.
    fn plugin(&mut self, i: usize) -> Result<usize, Error> {
        let toks = self.toks;
        let mut seen = false;
        for (j, tok) in toks.iter().enumerate().skip(i + 1) {
            match tok.kind {
                TokenKind::Str => {
                    seen = true;
                    self.plugins.push((self.text(tok).to_string(), tok.loc));
                }
                TokenKind::Space => {}
                TokenKind::Eol if seen => return Ok(j),
                _ => return Err(self.err(ErrorKind::BadPlugin, tok)),
            }
        }
        if seen {
            Ok(toks.len())
        } else {
            Err(self.err(ErrorKind::BadPlugin, &toks[i]))
        }
    }

    /// `define NAME PARENT ( body )`: records the token range; the body is parsed at each use.
    fn define(&mut self, i: usize) -> Result<usize, Error> {
        let toks = self.toks;
        let mut depth = 0i64;
        let mut name: Option<&'a Token> = None;
        let mut parent: Option<usize> = None;
        for (j, tok) in toks.iter().enumerate().skip(i + 1) {
            match tok.kind {
                TokenKind::Word if depth == 0 => {
                    if name.is_none() {
                        name = Some(tok);
                    } else if parent.is_none() {
                        parent = Some(j);
                    } else {
                        return Err(
                            self.err(ErrorKind::ExtraMacroTokens(self.text(tok).to_string()), tok)
                        );
                    }
                }
                TokenKind::Open => {
                    if depth == 0 && (name.is_none() || parent.is_none()) {
                        return Err(self.err(ErrorKind::MissingMacroName, tok));
                    }
                    depth += 1;
                }
                TokenKind::Close => {
                    depth -= 1;
                    if depth < 0 {
                        return Err(self.err(ErrorKind::MisplacedCloseParen, tok));
                    }
                    if depth == 0 {
                        let (Some(name), Some(start)) = (name, parent) else {
                            return Err(self.err(ErrorKind::MissingMacroName, tok));
                        };
                        if let Some(first) = self.macros.get(self.text(name)) {
                            // Upstream silently keeps the first definition.
                            let first_at = self.sources.resolve(first.loc);
                            self.warnings.push(Warning::at(
                                self.sources.resolve(name.loc),
                                format!(
                                    "macro `{}` is already defined at {first_at}; this definition is ignored (the first one wins, as in Stage)",
                                    self.text(name)
                                ),
                            ));
                        } else {
                            // A new macro can change what a word in a body already
                            // expanded means.
                            self.expansions.clear();
                            self.macros.insert(
                                self.text(name),
                                Macro {
                                    start,
                                    loc: name.loc,
                                },
                            );
                        }
                        return Ok(j);
                    }
                }
                _ => {}
            }
        }
        let label = name
            .map(|n| self.text(n).to_string())
            .unwrap_or_else(|| "define".into());
        Err(self.err(ErrorKind::MissingCloseParen(label), &toks[i]))
    }

    /// A name at top level or in a body: a property or an entity, decided by what follows.
    fn word_item(&mut self, entity: EntityId, i: usize) -> Result<usize, Error> {
        let toks = self.toks;
        let name = &toks[i];
        if self.text(name) == "define" {
            return Err(self.err(ErrorKind::DefineNotAtTopLevel, name));
        }
        let mut j = i + 1;
        while j < toks.len() && is_blank(toks[j].kind) {
            j += 1;
        }
        let Some(next) = toks.get(j) else {
            return Err(self.err(
                ErrorKind::ExpectedValueOrBody {
                    name: self.text(name).to_string(),
                    found: "end of file".into(),
                },
                name,
            ));
        };
        match next.kind {
            TokenKind::Open => self.entity(entity, i),
            TokenKind::Number | TokenKind::Str | TokenKind::OpenTuple | TokenKind::Bool => {
                self.property(entity, i)
            }
            _ => Err(self.err(
                ErrorKind::ExpectedValueOrBody {
                    name: self.text(name).to_string(),
                    found: self.describe(next),
                },
                next,
            )),
        }
    }

    /// `name value` or `name [ values ]`; the value must be on the name's line.
    fn property(&mut self, entity: EntityId, i: usize) -> Result<usize, Error> {
        let toks = self.toks;
        let name = &toks[i];
        let mut j = i + 1;
        while j < toks.len() {
            let tok = &toks[j];
            match tok.kind {
                TokenKind::Space => {}
                TokenKind::Number | TokenKind::Str | TokenKind::Bool => {
                    let values = match self.parsed_value(j) {
                        Some(done) => done.values,
                        None => {
                            let values = self.store(std::iter::once(tok));
                            self.remember(j, Parsed { values, end: j });
                            values
                        }
                    };
                    self.set(entity, i, values, false);
                    return Ok(j);
                }
                TokenKind::OpenTuple => {
                    let (values, end) = self.tuple(name, j)?;
                    self.set(entity, i, values, true);
                    return Ok(end);
                }
                _ => break,
            }
            j += 1;
        }
        Err(self.err(
            ErrorKind::ValueNotOnSameLine(self.text(name).to_string()),
            name,
        ))
    }

    /// What the value starting at token `at` was parsed into, if it already was.
    fn parsed_value(&self, at: usize) -> Option<Parsed> {
        if !self.reuse {
            return None;
        }
        match self.parsed_at[at] {
            0 => None,
            k => Some(self.parsed[k as usize - 1]),
        }
    }

    /// Records what the value starting at token `at` was parsed into, for the next instance
    /// of the macro body it is in.
    fn remember(&mut self, at: usize, done: Parsed) {
        // There are fewer parsed values than tokens, and the loader keeps the token count
        // within u32; a value that did not fit would simply be parsed again.
        if let Ok(k) = u32::try_from(self.parsed.len() + 1) {
            self.parsed.push(done);
            self.parsed_at[at] = k;
        }
    }

    /// Appends the value tokens to the value store; returns where they are.
    fn store<'t>(&mut self, toks: impl Iterator<Item = &'t Token>) -> ValueRange {
        let start = self.values.len();
        let stream = self.stream;
        self.values
            .extend(toks.map(|tok| value_of(tok, stream.text(tok))));
        ValueRange {
            start,
            len: self.values.len() - start,
        }
    }

    /// `[ v v ... ]` starting at the `[` at `open`; returns its values and the index of `]`.
    ///
    /// A tuple met again (in another instance of a macro) reuses its stored values, after
    /// counting the parser steps reading it would take.
    fn tuple(&mut self, name: &Token, open: usize) -> Result<(ValueRange, usize), Error> {
        if let Some(done) = self.parsed_value(open) {
            let steps = (done.end - open) as u64;
            if self.steps + steps <= self.limits.max_parse_steps {
                self.steps += steps;
                return Ok((done.values, done.end));
            }
            // Too many steps: read it again to fail at the very token upstream would.
        }
        let toks = self.toks;
        let mut end = None;
        for (j, tok) in toks.iter().enumerate().skip(open + 1) {
            self.step(tok)?;
            match tok.kind {
                TokenKind::Number | TokenKind::Str => {}
                // Stage rejects line ends and comments inside tuples; we accept tuples that span
                // lines (Player's cfg parser already does).
                TokenKind::Space | TokenKind::Eol | TokenKind::Comment => {}
                TokenKind::CloseTuple => {
                    end = Some(j);
                    break;
                }
                _ => return Err(self.err(ErrorKind::BadTupleElement(self.describe(tok)), tok)),
            }
        }
        let Some(end) = end else {
            return Err(self.err(
                ErrorKind::UnterminatedTuple(self.text(name).to_string()),
                &toks[open],
            ));
        };
        let values = self.store(
            toks[open + 1..end]
                .iter()
                .filter(|t| matches!(t.kind, TokenKind::Number | TokenKind::Str)),
        );
        self.remember(open, Parsed { values, end });
        Ok((values, end))
    }

    /// Stores the property named by token `name`: a worldfile replaces a same-named property
    /// whole; a cfg overwrites it element by element, keeping any longer tail
    /// (player-cfg.md §3.1).
    fn set(&mut self, entity: EntityId, name: usize, values: ValueRange, is_tuple: bool) {
        let stream = self.stream;
        let name_tok = &self.toks[name];
        let text = stream.span_bytes(name_tok.text);
        let (span, loc) = (name_tok.text, name_tok.loc);
        let props = &mut self.entities[entity].properties;
        // The same token is the same name; otherwise compare the words.
        let existing = props
            .iter_mut()
            .find(|p| p.name == span || stream.span_bytes(p.name) == text);
        match existing {
            Some(existing) => match self.dialect {
                Dialect::World => {
                    *existing = Property::new(span, values, loc, is_tuple);
                }
                Dialect::Cfg => {
                    let old = existing.values;
                    let merged = (0..old.len.max(values.len)).map(|k| {
                        let from = if k < values.len { values } else { old };
                        from.start + k
                    });
                    let merged: Vec<Value> = merged.map(|at| self.values[at].clone()).collect();
                    let start = self.values.len();
                    self.values.extend(merged);
                    existing.values = ValueRange {
                        start,
                        len: self.values.len() - start,
                    };
                    existing.is_tuple |= is_tuple;
                }
            },
            None => props.push(Property::new(span, values, loc, is_tuple)),
        }
    }

    /// Expands the macro body whose PARENT word is at `start` into a new entity under `parent`:
    /// a copy of the last expansion of the same body when there is one and the copy stays
    /// within the limits, else by parsing (which then fails at the very token a parse does).
    ///
    /// A body expands to the same entities every time while the set of macros is the same:
    /// its tokens are the same, and a macro on the expansion stack cannot occur in it (it
    /// would have been a cycle the first time).
    fn expand(&mut self, parent: EntityId, start: usize) -> Result<(), Error> {
        let base = self.entities.len();
        if let Some(done) = self.expansions.get(&start).filter(|_| self.reuse) {
            let fits = self.steps + done.steps <= self.limits.max_parse_steps
                && self.depth + done.depth <= self.limits.max_nesting
                && base + done.entities.len() <= self.limits.max_entities;
            if fits {
                self.steps += done.steps;
                self.deepest = self.deepest.max(self.depth + done.depth);
                let counts = &self.property_counts;
                self.entities
                    .extend(done.entities.iter().enumerate().map(|(k, e)| {
                        let parent = match (k, e.parent) {
                            (0, _) | (_, None) => parent,
                            (_, Some(offset)) => base + offset,
                        };
                        // The instance adds its own properties to the body's entity (room for as
                        // many as the last instance had); the others share the records of the
                        // entities they copy.
                        let properties = if k == 0 {
                            let room = counts[done.type_tokens[0] as usize] as usize;
                            let mut properties = Vec::with_capacity(e.properties.len().max(room));
                            properties.extend_from_slice(&e.properties);
                            properties
                        } else {
                            Vec::new()
                        };
                        Entity::new(
                            Some(parent),
                            e.type_word,
                            e.macro_word,
                            e.loc,
                            properties,
                            e.copy_of,
                        )
                    }));
                self.type_tokens.extend_from_slice(&done.type_tokens);
                return Ok(());
            }
        }
        let (steps, deepest) = (self.steps, self.deepest);
        self.deepest = self.depth;
        let parsed = self.entity(parent, start);
        let depth = self.deepest - self.depth;
        self.deepest = self.deepest.max(deepest);
        parsed?;
        let entities = self.entities[base..]
            .iter()
            .enumerate()
            .map(|(k, e)| {
                if k == 0 {
                    // the body's own entity: each instance adds its properties to a copy
                    Entity::new(
                        None,
                        e.type_word,
                        e.macro_word,
                        e.loc,
                        e.properties.clone(),
                        None,
                    )
                } else {
                    // the others are copied whole: later copies share the records of the
                    // entity that holds them
                    let original = e.copy_of.unwrap_or(base + k);
                    let parent = e.parent.map(|p| p - base);
                    Entity::new(
                        parent,
                        e.type_word,
                        e.macro_word,
                        e.loc,
                        Vec::new(),
                        Some(original),
                    )
                }
            })
            .collect();
        let type_tokens = self.type_tokens[base..].to_vec();
        self.expansions.insert(
            start,
            Expansion {
                entities,
                type_tokens,
                steps: self.steps - steps,
                depth,
            },
        );
        Ok(())
    }

    /// `NAME ( body )` at `i`, where NAME is a macro or a base type word.
    fn entity(&mut self, parent: EntityId, i: usize) -> Result<usize, Error> {
        if self.depth >= self.limits.max_nesting {
            return Err(self.err(
                ErrorKind::TooLarge(format!(
                    "entities and macros nested more than {} deep",
                    self.limits.max_nesting
                )),
                &self.toks[i],
            ));
        }
        self.depth += 1;
        self.deepest = self.deepest.max(self.depth);
        let result = self.entity_inner(parent, i);
        self.depth -= 1;
        result
    }

    fn entity_inner(&mut self, parent: EntityId, i: usize) -> Result<usize, Error> {
        let toks = self.toks;
        let name = &toks[i];
        self.step(name)?;
        let text: &'a str = self.text(&toks[i]);
        let id = if let Some(start) = self.macros.get(text).map(|m| m.start) {
            if self.expanding.contains(&text) {
                let mut chain: Vec<String> = self
                    .expanding
                    .iter()
                    .skip_while(|m| **m != text)
                    .map(|m| m.to_string())
                    .collect();
                chain.push(text.to_string());
                return Err(self.err(ErrorKind::MacroCycle(chain), name));
            }
            self.expanding.push(text);
            let id = self.entities.len();
            let expanded = self.expand(parent, start);
            self.expanding.pop();
            expanded?;
            // The outermost macro name and the instance's own location win.
            self.entities[id].macro_word = Some(name.text);
            self.entities[id].loc = Some(name.loc);
            id
        } else {
            let id = self.entities.len();
            if id >= self.limits.max_entities {
                return Err(self.err(
                    ErrorKind::TooLarge(format!("more than {} entities", self.limits.max_entities)),
                    name,
                ));
            }
            self.entities.push(Entity::new(
                Some(parent),
                Some(name.text),
                None,
                Some(name.loc),
                Vec::with_capacity(self.property_counts[i] as usize),
                None,
            ));
            // the loader keeps the token count within u32
            self.type_tokens.push(i as u32);
            id
        };
        // Skip to this name's own `(`.
        let mut j = i + 1;
        while j < toks.len() && is_blank(toks[j].kind) {
            j += 1;
        }
        match toks.get(j) {
            Some(t) if t.kind == TokenKind::Open => {}
            Some(t) => {
                return Err(self.err(
                    ErrorKind::ExpectedValueOrBody {
                        name: self.text(name).to_string(),
                        found: self.describe(t),
                    },
                    t,
                ));
            }
            None => {
                return Err(self.err(
                    ErrorKind::MissingCloseParen(self.text(name).to_string()),
                    name,
                ));
            }
        }
        let end = self.body(id, j + 1, name)?;
        // The next entity made at the same type word (another instance of the same macro body)
        // allocates room for as many properties at once.
        let word = self.type_tokens[id] as usize;
        let count = u32::try_from(self.entities[id].properties.len()).unwrap_or(u32::MAX);
        self.property_counts[word] = self.property_counts[word].max(count);
        Ok(end)
    }

    /// Entity body items until the matching `)`; returns its index.
    fn body(&mut self, entity: EntityId, mut j: usize, name: &Token) -> Result<usize, Error> {
        let toks = self.toks;
        while j < toks.len() {
            let tok = &toks[j];
            self.step(tok)?;
            match tok.kind {
                TokenKind::Word => j = self.word_item(entity, j)?,
                TokenKind::Close => return Ok(j),
                k if is_blank(k) => {}
                TokenKind::Open => return Err(self.err(ErrorKind::StrayOpenParen, tok)),
                _ => {
                    return Err(self.err(
                        ErrorKind::UnexpectedInBody {
                            entity: self.text(name).to_string(),
                            found: self.describe(tok),
                        },
                        tok,
                    ));
                }
            }
            j += 1;
        }
        Err(self.err(
            ErrorKind::MissingCloseParen(self.text(name).to_string()),
            name,
        ))
    }
}

fn value_of(tok: &Token, text: &str) -> Value {
    let kind = match tok.kind {
        TokenKind::Number => ValueKind::Number,
        TokenKind::Bool => ValueKind::Bool,
        _ => ValueKind::Str,
    };
    Value::new(kind, text.into(), tok.loc)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::loader::{LoadOptions, lex_document};

    /// Parses `src` with reuse on or off, with `max_parse_steps` set to `steps`.
    fn parse_src(src: &str, dialect: Dialect, steps: u64, reuse: bool) -> Result<Document, Error> {
        let limits = Limits {
            max_parse_steps: steps,
            ..Limits::default()
        };
        parse_limited(src, dialect, &limits, reuse)
    }

    /// Parses `src` within `limits`, with reuse on or off.
    fn parse_limited(
        src: &str,
        dialect: Dialect,
        limits: &Limits,
        reuse: bool,
    ) -> Result<Document, Error> {
        let opts = LoadOptions::default();
        let (toks, sources) =
            lex_document(Path::new("t.world"), src.into(), dialect, &opts).unwrap();
        parse_reusing(toks, sources, dialect, limits, reuse)
    }

    /// Every property of every entity as text: `entity: name = values`.
    fn listing(doc: &Document) -> Vec<String> {
        let mut out = Vec::new();
        for id in 0..doc.entities.len() {
            for p in doc.properties(id) {
                let values: Vec<String> = doc
                    .values(p)
                    .iter()
                    .map(|v| format!("{}@{}:{}", v.text, v.loc.line, v.loc.col))
                    .collect();
                out.push(format!(
                    "{id} {}: {}@{} = {values:?} tuple {}",
                    doc.entity_label(id),
                    doc.name(p),
                    p.loc.line,
                    p.is_tuple
                ));
            }
        }
        out
    }

    const MACROS: &str = "define ir sensor ( range [0 2] fov 30 color_rgba [1 0 0\n 0.3] )\n\
        define bot position ( size [0.1 0.1 0.1] ranger ( ir ( pose [0 0 0 0] ) ir ( pose [0 0 0 90] ) ) )\n\
        bot ( name \"a\" pose [1 2 0 3] )\nbot ( name \"b\" size [0.2 0.2 0.2] )\nbot ( )\n";

    #[test]
    fn macro_instances_share_their_body_values() {
        let doc = parse_src(MACROS, Dialect::World, u64::MAX, true).unwrap();
        let ranges = |name: &str| -> Vec<ValueRange> {
            (1..doc.entities.len())
                .filter_map(|id| doc.property(id, name))
                .map(|p| p.values)
                .collect()
        };
        // 6 sensors (two per robot), each with the same `range` values.
        let range = ranges("range");
        assert_eq!(range.len(), 6);
        assert!(range.iter().all(|r| *r == range[0]));
        // the second robot's own `size` replaces the macro's
        let size = ranges("size");
        assert_eq!(size.len(), 3);
        assert_eq!(size[0], size[2]);
        assert_ne!(size[0], size[1]);
        // each value written is stored once: 2 + 1 + 4 (ir), 3 + 4 + 4 (bot), 1 + 4 + 1 + 3
        assert_eq!(doc.values.len(), 27);
    }

    /// Raises one limit from 1 until `src` parses, checking at each value that reusing
    /// values and expansions gives the same document, or the same error at the same token, as
    /// parsing every instance afresh; returns the limit it parsed at.
    fn same_with_and_without_reuse(src: &str, set: impl Fn(&mut Limits, u64)) -> u64 {
        let mut limit = 1;
        loop {
            let mut limits = Limits::default();
            set(&mut limits, limit);
            let fresh = parse_limited(src, Dialect::World, &limits, false);
            let reused = parse_limited(src, Dialect::World, &limits, true);
            match (fresh, reused) {
                (Ok(a), Ok(b)) => {
                    assert_eq!(listing(&a), listing(&b));
                    assert_eq!(a.entities.len(), b.entities.len());
                    for (id, (x, y)) in a.entities.iter().zip(&b.entities).enumerate() {
                        assert_eq!(
                            (x.parent, a.children(id), x.type_word, x.macro_word, x.loc),
                            (y.parent, b.children(id), y.type_word, y.macro_word, y.loc)
                        );
                    }
                    return limit;
                }
                (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "limit {limit}"),
                (a, b) => panic!("limit {limit}: {:?} vs {:?}", a.err(), b.err()),
            }
            limit += 1;
        }
    }

    /// Reusing parsed values and expansions gives the same document, and the same error at
    /// the same token for every parser step, nesting and entity limit, as parsing every
    /// instance afresh.
    #[test]
    fn reuse_changes_nothing_but_the_work() {
        let steps = same_with_and_without_reuse(MACROS, |l, n| l.max_parse_steps = n);
        assert!(steps > 100, "parsed within {steps} steps");
        let depth = same_with_and_without_reuse(MACROS, |l, n| l.max_nesting = n as usize);
        assert_eq!(depth, 5, "bot, position, ranger, ir, sensor");
        let entities = same_with_and_without_reuse(MACROS, |l, n| l.max_entities = n as usize);
        assert_eq!(entities, 13, "the global entity and 3 x 4");
        // a macro defined after a body was expanded changes the next expansion
        let later = "define bot position ( gear ( ) )\nbot ( )\ndefine gear ranger ( )\nbot ( )\n";
        same_with_and_without_reuse(later, |l, n| l.max_parse_steps = n);
        let doc = parse_src(later, Dialect::World, u64::MAX, true).unwrap();
        assert_eq!(doc.type_name(2), "gear");
        assert_eq!(doc.type_name(4), "ranger");
        assert_eq!(doc.macro_name(4), Some("gear"));
    }

    /// A copy shares the property records of the entity it copies, never its `used` flags:
    /// each entity still reports what was not read on it.
    #[test]
    fn copies_share_properties_but_not_used_flags() {
        let src = "define ir sensor ( range [0 2] fov 30 )\n\
                   define bot position ( ranger ( ir ( ) ) )\nbot ( )\nbot ( )\n";
        let doc = parse_src(src, Dialect::World, u64::MAX, true).unwrap();
        let types: Vec<&str> = (1..doc.entities.len())
            .map(|id| doc.type_name(id))
            .collect();
        assert_eq!(types, ["position", "ranger", "sensor"].repeat(2));
        // the second robot's ranger and sensor copy the first's; its position takes the
        // instance's own properties and is not a copy
        let copies: Vec<Option<EntityId>> = doc.entities.iter().map(|e| e.copy_of).collect();
        assert_eq!(copies, [None, None, None, None, None, Some(2), Some(3)]);
        assert!(std::ptr::eq(doc.properties(6), doc.properties(3)));
        assert!(doc.entities[6].properties.is_empty());
        assert_eq!(doc.children(5), [6]);
        assert_eq!(doc.children(6), [] as [EntityId; 0]);
        // reading the copy marks the copy only
        assert!(doc.use_property(6, "range").is_some());
        assert!(doc.is_used(6, 0) && !doc.is_used(3, 0));
        doc.mark_used_as(3, 6);
        assert!(doc.is_used(3, 0) && !doc.is_used(3, 1));
        let unused: Vec<String> = doc
            .unused_property_warnings()
            .iter()
            .map(|w| w.message.clone())
            .collect();
        assert_eq!(
            unused,
            [
                "property `fov` in `ir (a sensor)` is defined but not used",
                "property `fov` in `ir (a sensor)` is defined but not used",
            ]
        );
    }

    #[test]
    fn cfg_fields_merge_element_wise_without_touching_the_first_values() {
        let doc = parse_src(
            "driver ( provides [\"a\" \"b\" \"c\"] provides [\"x\"] requires [\"r\"] requires [\"s\" \"t\"] )\n",
            Dialect::Cfg,
            u64::MAX,
            true,
        )
        .unwrap();
        let texts = |name: &str| -> Vec<String> {
            let p = doc.property(1, name).unwrap();
            doc.values(p).iter().map(|v| v.text.to_string()).collect()
        };
        assert_eq!(texts("provides"), ["x", "b", "c"]);
        assert_eq!(texts("requires"), ["s", "t"]);
        assert_eq!(doc.values.len(), 4 + 3 + 3 + 2);
    }
}
