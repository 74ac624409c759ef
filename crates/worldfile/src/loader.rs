//! Reading files into one token stream, splicing `include`d files in (stage-worldfile.md §4,
//! player-cfg.md §2–3), then parsing it into a [`Document`].
//!
//! Include names resolve against the directory of the *top-level* file, as upstream does, then
//! (worldfiles only) against each `STAGEPATH` directory. Unlike upstream we detect include cycles,
//! stop at end of file on a last `include` line without a newline (Stage hangs), and keep the
//! top-level path fixed when a file is found through `STAGEPATH`.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::document::Document;
use crate::error::{Error, ErrorKind};
use crate::lexer::{Dialect, TokenKind, TokenStream, next_token, rest_of_line};
use crate::parser;
use crate::source::{FileId, Location, SourceMap};

/// Bounds that keep hostile input from taking unbounded time or memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Limits {
    /// Largest file read (bytes).
    pub max_file_bytes: u64,
    /// Most tokens after include expansion.
    pub max_tokens: usize,
    /// Deepest include nesting.
    pub max_include_depth: usize,
    /// Most entities after macro expansion.
    pub max_entities: usize,
    /// Most parser steps (tokens visited, counting every macro re-parse).
    pub max_parse_steps: u64,
    /// Deepest nesting of entities and macro expansions (bounds recursion).
    pub max_nesting: usize,
    /// Largest bitmap, in pixels.
    pub max_bitmap_pixels: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_file_bytes: 64 << 20,
            max_tokens: 20_000_000,
            max_include_depth: 64,
            max_entities: 2_000_000,
            max_parse_steps: 200_000_000,
            max_nesting: 200,
            max_bitmap_pixels: 100_000_000,
        }
    }
}

/// How files are found and how much may be read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadOptions {
    /// Directories searched (in order) for includes and bitmaps not found next to the top-level
    /// worldfile: Stage's `STAGEPATH`.
    pub stage_path: Vec<PathBuf>,
    /// Resource bounds.
    pub limits: Limits,
    /// How bitmaps become rectangles.
    pub bitmap_rows: crate::bitmap::BitmapRows,
}

impl LoadOptions {
    /// Default limits, with `stage_path` taken from the `STAGEPATH` environment variable.
    pub fn from_env() -> Self {
        let stage_path = std::env::var_os("STAGEPATH")
            .map(|v| {
                std::env::split_paths(&v)
                    .filter(|p| !p.as_os_str().is_empty())
                    .collect()
            })
            .unwrap_or_default();
        LoadOptions {
            stage_path,
            ..LoadOptions::default()
        }
    }
}

/// `name` resolved the way Stage resolves include and bitmap names: verbatim if it starts with
/// `/` or `~` (`~` is not expanded), else relative to the directory of the top-level file.
pub fn relative_to_top(top: &Path, name: &str) -> PathBuf {
    if name.starts_with('/') || name.starts_with('~') {
        PathBuf::from(name)
    } else {
        top.parent().unwrap_or(Path::new("")).join(name)
    }
}

/// The candidate paths for `name`: next to the top-level file, then those of
/// [`on_stage_path`].
pub fn candidates(top: &Path, name: &str, stage_path: &[PathBuf]) -> Vec<PathBuf> {
    let mut out = vec![relative_to_top(top, name)];
    out.extend(on_stage_path(name, stage_path));
    out.dedup();
    out
}

/// Where `name` is looked for on `STAGEPATH`: for each directory `D`, `D/name` (unless `name`
/// is absolute) and `D/basename(name)` (upstream tries only the basename). Also how a cfg's
/// `worldfile` not found beside the cfg is looked for.
pub fn on_stage_path(name: &str, stage_path: &[PathBuf]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let base = Path::new(name).file_name().map(PathBuf::from);
    for dir in stage_path {
        if !name.starts_with('/') {
            out.push(dir.join(name));
        }
        if let Some(base) = &base {
            out.push(dir.join(base));
        }
    }
    out
}

/// Reads a file, enforcing the size limit.
pub(crate) fn read_limited(path: &Path, limit: u64) -> Result<Vec<u8>, String> {
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("not a regular file".into());
    }
    if meta.len() > limit {
        return Err(format!("file is larger than {limit} bytes"));
    }
    std::fs::read(path).map_err(|e| e.to_string())
}

fn what(dialect: Dialect) -> &'static str {
    match dialect {
        Dialect::World => "world file",
        Dialect::Cfg => "cfg file",
    }
}

/// Loads and parses a top-level file (with its includes).
pub fn load_document(path: &Path, dialect: Dialect, opts: &LoadOptions) -> Result<Document, Error> {
    let text = read_limited(path, opts.limits.max_file_bytes).map_err(|reason| {
        Error::new(ErrorKind::Io {
            what: what(dialect),
            path: path.display().to_string(),
            reason,
        })
    })?;
    parse_document(path, text, dialect, opts)
}

/// Parses `text` as if it were the file at `path` (includes resolve relative to `path`).
pub fn parse_document(
    path: &Path,
    text: Vec<u8>,
    dialect: Dialect,
    opts: &LoadOptions,
) -> Result<Document, Error> {
    let (tokens, sources) = lex_document(path, text, dialect, opts)?;
    parser::parse(tokens, sources, dialect, &opts.limits)
}

/// The token stream of `text` as the file at `path`, includes spliced in, with the files read.
pub(crate) fn lex_document(
    path: &Path,
    text: Vec<u8>,
    dialect: Dialect,
    opts: &LoadOptions,
) -> Result<(TokenStream, SourceMap), Error> {
    let mut loader = Loader {
        sources: SourceMap::new(),
        dialect,
        opts,
        top: path.to_path_buf(),
        stack: Vec::new(),
        tokens: TokenStream::new(),
    };
    let id = loader
        .sources
        .add(path.to_path_buf(), Arc::from(text), None);
    loader.stack.push(canonical_or_same(path));
    loader.lex_file(id)?;
    let Loader {
        sources, tokens, ..
    } = loader;
    Ok((tokens, sources))
}

fn canonical_or_same(path: &Path) -> PathBuf {
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf())
}

struct Loader<'o> {
    sources: SourceMap,
    dialect: Dialect,
    opts: &'o LoadOptions,
    top: PathBuf,
    /// Files being lexed, outermost first (canonical paths), for cycle detection.
    stack: Vec<PathBuf>,
    tokens: TokenStream,
}

impl Loader<'_> {
    fn err(&self, kind: ErrorKind, loc: Location, snippet: &str) -> Error {
        Error::at(kind, &self.sources, loc, snippet)
    }

    fn push(&mut self, kind: TokenKind, text: &str, loc: Location) -> Result<(), Error> {
        // The parser indexes tokens with u32, whatever the limit says.
        let max_tokens = self.opts.limits.max_tokens.min(u32::MAX as usize);
        let too_large = if self.tokens.len() >= max_tokens {
            format!("more than {max_tokens} tokens after includes")
        } else if self.tokens.push(kind, text, loc).is_err() {
            "more than 4 GiB of token text after includes".to_string()
        } else {
            return Ok(());
        };
        let token = crate::lexer::Token {
            kind,
            text: Default::default(),
            loc,
        };
        Err(self.err(ErrorKind::TooLarge(too_large), loc, &token.snippet(text)))
    }

    fn lex_file(&mut self, file: FileId) -> Result<(), Error> {
        let text = self.sources.file(file).text.clone();
        let src: &[u8] = &text;
        let mut pos = 0usize;
        let mut line = 1u32;
        let mut line_start = 0usize;
        while pos < src.len() {
            let loc = Location {
                file,
                line,
                col: (pos - line_start + 1) as u32,
            };
            let lexeme = next_token(&src[pos..], self.dialect).map_err(|kind| {
                let snippet = match &kind {
                    ErrorKind::UnterminatedString => {
                        let (len, _) = rest_of_line(&src[pos..]);
                        String::from_utf8_lossy(&src[pos..pos + len])
                            .trim_end()
                            .to_string()
                    }
                    _ => String::from_utf8_lossy(&src[pos..pos + 1]).into_owned(),
                };
                self.err(kind, loc, &snippet)
            })?;
            let text_bytes = &src[pos + lexeme.text.0..pos + lexeme.text.1];
            let text = match lexeme.kind {
                TokenKind::Space | TokenKind::Eol => "".into(),
                // Only strings and comments can hold bytes that are not UTF-8.
                _ => match std::str::from_utf8(text_bytes) {
                    Ok(text) => text.into(),
                    Err(_) => String::from_utf8_lossy(text_bytes),
                },
            };
            let word_end = pos + lexeme.len;
            pos = word_end;
            if lexeme.kind == TokenKind::Eol {
                line += 1;
                line_start = pos;
            }
            // `include` is handled as soon as the word ends, like upstream's tokenizer; a word
            // `include` that ends the file is just a word (and a parse error later).
            let is_include = lexeme.kind == TokenKind::Word && text == "include" && pos < src.len();
            self.push(lexeme.kind, &text, loc)?;
            if is_include {
                pos = self.include(file, src, pos, loc, &mut line, &mut line_start)?;
            }
        }
        Ok(())
    }

    /// Handles `include "name"` after the word; returns the position to continue lexing from.
    fn include(
        &mut self,
        file: FileId,
        src: &[u8],
        mut pos: usize,
        include_loc: Location,
        line: &mut u32,
        line_start: &mut usize,
    ) -> Result<usize, Error> {
        let here = |pos: usize, line: u32, line_start: usize| Location {
            file,
            line,
            col: (pos - line_start + 1) as u32,
        };
        // Blanks, then a string.
        if !matches!(src.get(pos), Some(b' ' | b'\t')) {
            let snippet = String::from_utf8_lossy(&src[pos..pos + 1]).into_owned();
            return Err(self.err(
                ErrorKind::BadInclude,
                here(pos, *line, *line_start),
                &snippet,
            ));
        }
        let blanks = src[pos..]
            .iter()
            .take_while(|c| matches!(c, b' ' | b'\t'))
            .count();
        self.push(TokenKind::Space, "", here(pos, *line, *line_start))?;
        pos += blanks;
        let str_loc = here(pos, *line, *line_start);
        if src.get(pos) != Some(&b'"') {
            let snippet = match src.get(pos) {
                Some(_) => String::from_utf8_lossy(&src[pos..pos + 1]).into_owned(),
                None => "include".into(),
            };
            let loc = if pos < src.len() {
                str_loc
            } else {
                include_loc
            };
            return Err(self.err(ErrorKind::BadInclude, loc, &snippet));
        }
        let lexeme = next_token(&src[pos..], self.dialect).map_err(|kind| {
            let (len, _) = rest_of_line(&src[pos..]);
            let snippet = String::from_utf8_lossy(&src[pos..pos + len])
                .trim_end()
                .to_string();
            self.err(kind, str_loc, &snippet)
        })?;
        let name =
            String::from_utf8_lossy(&src[pos + lexeme.text.0..pos + lexeme.text.1]).into_owned();
        self.push(TokenKind::Str, &name, str_loc)?;
        pos += lexeme.len;
        // Upstream ends the include statement with a line end of its own.
        self.push(TokenKind::Eol, "", here(pos, *line, *line_start))?;
        self.splice(&name, include_loc, str_loc)?;
        if self.dialect == Dialect::World {
            // Stage discards the rest of the include line (we also stop at end of file).
            let (len, had_eol) = rest_of_line(&src[pos..]);
            pos += len;
            if had_eol {
                *line += 1;
                *line_start = pos;
            }
        }
        Ok(pos)
    }

    fn splice(
        &mut self,
        name: &str,
        include_loc: Location,
        name_loc: Location,
    ) -> Result<(), Error> {
        let snippet = format!("\"{name}\"");
        if self.stack.len() > self.opts.limits.max_include_depth {
            return Err(self.err(
                ErrorKind::IncludeTooDeep(self.opts.limits.max_include_depth),
                name_loc,
                &snippet,
            ));
        }
        let tried = match self.dialect {
            Dialect::World => candidates(&self.top, name, &self.opts.stage_path),
            Dialect::Cfg => vec![relative_to_top(&self.top, name)],
        };
        let mut found = None;
        let mut first_reason = None;
        for path in &tried {
            match read_limited(path, self.opts.limits.max_file_bytes) {
                Ok(text) => {
                    found = Some((path.clone(), text));
                    break;
                }
                Err(reason) => {
                    first_reason.get_or_insert(reason);
                }
            }
        }
        let Some((path, text)) = found else {
            let mut reason = first_reason.unwrap_or_default();
            if tried.len() > 1 {
                reason.push_str(&format!(
                    " (also searched {} STAGEPATH location(s))",
                    tried.len() - 1
                ));
            }
            return Err(self.err(
                ErrorKind::Io {
                    what: "include file",
                    path: tried[0].display().to_string(),
                    reason,
                },
                name_loc,
                &snippet,
            ));
        };
        let canonical = canonical_or_same(&path);
        if let Some(start) = self.stack.iter().position(|p| *p == canonical) {
            let mut chain: Vec<String> = self.stack[start..]
                .iter()
                .map(|p| p.display().to_string())
                .collect();
            chain.push(canonical.display().to_string());
            return Err(self.err(ErrorKind::IncludeCycle(chain), name_loc, &snippet));
        }
        let id = self.sources.add(path, Arc::from(text), Some(include_loc));
        self.stack.push(canonical);
        let result = self.lex_file(id);
        self.stack.pop();
        result
    }
}
