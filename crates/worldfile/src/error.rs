//! The crate's one error type, and warnings.
//!
//! Upstream Stage prints `file:line : syntax error 3` (with wrong line numbers after includes) and
//! then builds a partial world; we stop and say precisely where and what, like a compiler:
//!
//! ```text
//! simple.world:12:9: error: a tuple cannot contain the word `e`
//!    12 |   pose [ 1 e 3 ]
//!       |          ^
//!   included from top.world:3:1
//! ```

use std::fmt::{self, Write as _};

use serde::Serialize;

use crate::source::{Location, SourceLoc, SourceMap};

/// What went wrong. The [`Error`] wrapping it adds where.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ErrorKind {
    /// A file could not be read.
    #[error("cannot read {what} `{path}`: {reason}")]
    Io {
        /// What the file was for ("world file", "include file", "bitmap", "cfg file").
        what: &'static str,
        /// The path tried (the first one, when several were searched).
        path: String,
        /// The operating system's reason.
        reason: String,
    },
    /// A byte that starts no token (Stage: "syntax error").
    #[error("illegal character {0}")]
    IllegalCharacter(String),
    /// A string not closed on its line.
    #[error("unterminated string constant")]
    UnterminatedString,
    /// `include` not followed by blanks and a quoted file name.
    #[error("malformed include statement: expected `include \"file\"`")]
    BadInclude,
    /// A file includes itself, directly or through others.
    #[error("include cycle: {}", .0.join(" -> "))]
    IncludeCycle(Vec<String>),
    /// Includes nested deeper than the limit.
    #[error("includes nested more than {0} deep")]
    IncludeTooDeep(usize),
    /// `plugin` not followed by a quoted name at top level of a cfg.
    #[error("malformed plugin statement: expected `plugin \"name\"`")]
    BadPlugin,
    /// A token that cannot start anything at top level (Stage: "syntax error 1").
    #[error("expected a property or entity name at top level, found {0}")]
    UnexpectedAtTopLevel(String),
    /// A name followed by something that is neither a value nor `(` (Stage: "syntax error 2").
    #[error("`{name}` must be followed by a value or `(`, found {found}")]
    ExpectedValueOrBody {
        /// The property or entity name.
        name: String,
        /// What was found instead.
        found: String,
    },
    /// A stray token inside an entity body (Stage: "syntax error 3").
    #[error("expected a property or entity name inside `{entity}( ... )`, found {found}")]
    UnexpectedInBody {
        /// The entity type.
        entity: String,
        /// What was found.
        found: String,
    },
    /// A property whose value is not on the same line as its name (Stage: "syntax error 4").
    #[error("the value of `{0}` must be on the same line as its name")]
    ValueNotOnSameLine(String),
    /// Something other than numbers and strings inside `[ ]` (Stage: "syntax error 5").
    #[error("a tuple can hold only numbers and quoted strings, found {0}")]
    BadTupleElement(String),
    /// `[` never closed.
    #[error("tuple of `{0}` is not closed with `]`")]
    UnterminatedTuple(String),
    /// `(` never closed.
    #[error("`{0}( ... )` is not closed with `)`")]
    MissingCloseParen(String),
    /// `)` with no matching `(` in a `define`.
    #[error("misplaced `)` in macro definition")]
    MisplacedCloseParen,
    /// A third word before the `(` of a `define`.
    #[error("extra word `{0}` in macro definition (expected `define NAME PARENT ( ... )`)")]
    ExtraMacroTokens(String),
    /// `define` without both a name and a parent before the `(`.
    #[error("macro definition needs a name and a parent: `define NAME PARENT ( ... )`")]
    MissingMacroName,
    /// `define` written inside an entity body.
    #[error("`define` is only allowed at top level")]
    DefineNotAtTopLevel,
    /// A macro whose expansion reaches itself.
    #[error("macro cycle: {}", .0.join(" -> "))]
    MacroCycle(Vec<String>),
    /// A `(` that does not follow a name (Stage silently nests another entity).
    #[error("`(` must follow an entity name")]
    StrayOpenParen,
    /// The input expands beyond the configured limits (guards against macro bombs).
    #[error("input too large: {0}")]
    TooLarge(String),
    /// A worldfile or cfg with a non-zero `test` property (Stage and Player refuse to load it).
    #[error("this is a test file (`test` is non-zero); refusing to load it")]
    TestFile,
    /// A tuple with fewer elements than the reader needs (Stage exits with status 255).
    #[error("`{name}` needs {needed} values, found {found}")]
    TupleTooShort {
        /// Property name.
        name: String,
        /// Elements required.
        needed: usize,
        /// Elements present.
        found: usize,
    },
    /// A value that must be a number has no numeric prefix at all.
    #[error("`{name}` needs a number, found `{text}`")]
    NotANumber {
        /// Property name.
        name: String,
        /// The offending text.
        text: String,
    },
    /// An integer beyond what 64 bits hold: Stage's `atoi` (glibc: `(int) strtol`) reads it
    /// as -1 or 0, not as written, so no reading of it agrees with the file.
    #[error(
        "`{name}` value `{text}` does not fit in a 64-bit integer (Stage's atoi would read it as \
         -1 or 0)"
    )]
    IntegerOverflow {
        /// Property name.
        name: String,
        /// The offending text.
        text: String,
    },
    /// An integer that does not fit where it goes.
    #[error("`{name}` value `{text}` is out of range")]
    OutOfRange {
        /// Property name.
        name: String,
        /// The offending text.
        text: String,
    },
    /// An entity type that no Stage version knows.
    #[error(
        "unknown model type `{0}` (Stage 4.1.1 knows model, position, ranger, blobfinder, fiducial, gripper, camera, actuator, blinkenlight, lightindicator)"
    )]
    UnknownModelType(String),
    /// A `block` that is not inside a model.
    #[error("`block` must be inside a model")]
    BlockOutsideModel,
    /// A `sensor` that is not inside a ranger.
    #[error("`sensor` must be inside a ranger")]
    SensorOutsideRanger,
    /// A block with too few vertices to be a polygon.
    #[error("block has {0} point(s); a block needs at least 3")]
    TooFewPoints(usize),
    /// A bitmap that could not be decoded.
    #[error("cannot decode bitmap `{path}`: {reason}")]
    BadBitmap {
        /// The path.
        path: String,
        /// The decoder's reason.
        reason: String,
    },
    /// A cfg `driver` block without `name`.
    #[error("driver block has no `name`")]
    MissingDriverName,
    /// A malformed device address in `provides`/`requires`.
    #[error("bad device address `{text}` in `{field}`: {reason}")]
    BadDeviceAddress {
        /// The field (`provides` or `requires`).
        field: String,
        /// The address string.
        text: String,
        /// Why it was rejected.
        reason: String,
    },
}

/// A located error, displayed like a compiler diagnostic. Boxed so `Result`s stay small; its
/// fields are reached through `Deref` ([`Diagnostic`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", self.0.render())]
pub struct Error(Box<Diagnostic>);

impl std::ops::Deref for Error {
    type Target = Diagnostic;
    fn deref(&self) -> &Diagnostic {
        &self.0
    }
}

/// The contents of an [`Error`].
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    /// What went wrong.
    pub kind: ErrorKind,
    /// Where, if the error belongs to a place in a file.
    pub location: Option<SourceLoc>,
    /// The source line at `location`.
    pub line_text: Option<String>,
    /// The offending text at `location` (underlined when shown).
    pub snippet: Option<String>,
    /// The `include` statements that led to `location`, innermost first.
    pub included_from: Vec<SourceLoc>,
}

impl Error {
    /// An error that belongs to no place in a file (e.g. the top-level file cannot be read).
    pub fn new(kind: ErrorKind) -> Self {
        Error(Box::new(Diagnostic {
            kind,
            location: None,
            line_text: None,
            snippet: None,
            included_from: Vec::new(),
        }))
    }

    /// An error at `loc`, quoting `snippet` (the offending text) and the include chain.
    pub fn at(kind: ErrorKind, sources: &SourceMap, loc: Location, snippet: &str) -> Self {
        Error(Box::new(Diagnostic {
            kind,
            location: Some(sources.resolve(loc)),
            line_text: sources.file(loc.file).line_text(loc.line),
            snippet: Some(snippet.to_owned()),
            included_from: sources.include_chain(loc),
        }))
    }

    /// An error at an already resolved location (no source line quoted).
    pub fn at_loc(kind: ErrorKind, location: SourceLoc, snippet: &str) -> Self {
        Error(Box::new(Diagnostic {
            kind,
            location: Some(location),
            line_text: None,
            snippet: Some(snippet.to_owned()),
            included_from: Vec::new(),
        }))
    }
}

impl Diagnostic {
    fn render(&self) -> String {
        let mut out = String::new();
        match &self.location {
            Some(loc) => {
                let _ = write!(out, "{loc}: error: {}", self.kind);
            }
            None => {
                let _ = write!(out, "error: {}", self.kind);
            }
        }
        if let (Some(loc), Some(line)) = (&self.location, &self.line_text) {
            let gutter = loc.line.to_string();
            let pad = " ".repeat(gutter.len());
            let _ = write!(out, "\n {gutter} | {line}");
            let col = (loc.col as usize).saturating_sub(1);
            let prefix: String = line
                .chars()
                .take(col)
                .map(|c| if c == '\t' { '\t' } else { ' ' })
                .collect();
            let width = self
                .snippet
                .as_deref()
                .map(|s| s.chars().count().clamp(1, 60))
                .unwrap_or(1);
            let _ = write!(out, "\n {pad} | {prefix}{}", "^".repeat(width));
        } else if let Some(snippet) = &self.snippet {
            let _ = write!(out, "\n  near `{snippet}`");
        }
        for from in &self.included_from {
            let _ = write!(out, "\n  included from {from}");
        }
        out
    }
}

/// Something Stage would accept (or silently fix) that the user probably did not mean.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Warning {
    /// Where.
    pub location: Option<SourceLoc>,
    /// What.
    pub message: String,
}

impl Warning {
    /// A warning at a place in a file.
    pub fn at(location: SourceLoc, message: impl Into<String>) -> Self {
        Warning {
            location: Some(location),
            message: message.into(),
        }
    }

    /// A warning that belongs to no place in a file.
    pub fn general(message: impl Into<String>) -> Self {
        Warning {
            location: None,
            message: message.into(),
        }
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.location {
            Some(loc) => write!(f, "{loc}: warning: {}", self.message),
            None => write!(f, "warning: {}", self.message),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;
    use std::sync::Arc;

    #[test]
    fn renders_like_a_compiler_with_include_chain() {
        let mut map = SourceMap::new();
        let top = map.add(
            PathBuf::from("top.world"),
            Arc::from(&b"include \"a.inc\"\n"[..]),
            None,
        );
        let a = map.add(
            PathBuf::from("a.inc"),
            Arc::from(&b"m (\n  pose [ 1 e 3 ]\n)\n"[..]),
            Some(Location {
                file: top,
                line: 1,
                col: 1,
            }),
        );
        let err = Error::at(
            ErrorKind::BadTupleElement("word `e`".into()),
            &map,
            Location {
                file: a,
                line: 2,
                col: 12,
            },
            "e",
        );
        let text = err.to_string();
        assert_eq!(
            text,
            "a.inc:2:12: error: a tuple can hold only numbers and quoted strings, found word `e`\n \
             2 |   pose [ 1 e 3 ]\n   |            ^\n  included from top.world:1:1"
        );
    }

    #[test]
    fn error_without_location() {
        let err = Error::new(ErrorKind::TestFile);
        assert!(err.to_string().starts_with("error: this is a test file"));
    }
}
