//! Source files and locations.
//!
//! Every token remembers the file, line and column it came from, and every file remembers the
//! `include` that pulled it in, so diagnostics can print the real position (upstream Stage and
//! Player count lines across includes and report wrong numbers) plus the include chain.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Serialize, Serializer};

/// Index of a file in a [`SourceMap`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FileId(pub u32);

/// A position in a source file: 1-based line and 1-based byte column.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Location {
    /// The file.
    pub file: FileId,
    /// Line, starting at 1.
    pub line: u32,
    /// Byte column, starting at 1.
    pub col: u32,
}

/// One loaded file.
#[derive(Debug, Clone)]
pub struct SourceFile {
    /// The path the file was opened under (after include resolution).
    pub path: PathBuf,
    /// The path as written for display (shared so that resolved locations are cheap to copy).
    pub display: Arc<str>,
    /// The bytes of the file, kept to quote the offending line in diagnostics.
    pub text: Arc<[u8]>,
    /// Where the `include` statement that loaded this file is, if it was included.
    pub included_from: Option<Location>,
}

impl SourceFile {
    /// The text of line `line` (1-based), without its line terminator, lossily decoded.
    pub fn line_text(&self, line: u32) -> Option<String> {
        let mut current = 1u32;
        let bytes = &self.text[..];
        let mut start = 0usize;
        let mut i = 0usize;
        while i <= bytes.len() {
            let at_end = i == bytes.len();
            let is_eol = !at_end && (bytes[i] == b'\n' || bytes[i] == b'\r');
            if at_end || is_eol {
                if current == line {
                    return Some(String::from_utf8_lossy(&bytes[start..i]).into_owned());
                }
                if at_end {
                    return None;
                }
                // CRLF and LFCR are one line end, as in the tokenizer.
                let next = bytes.get(i + 1).copied();
                if (bytes[i] == b'\r' && next == Some(b'\n'))
                    || (bytes[i] == b'\n' && next == Some(b'\r'))
                {
                    i += 1;
                }
                current += 1;
                start = i + 1;
            }
            i += 1;
        }
        None
    }
}

/// All files read while loading one worldfile or cfg (the top-level file is `FileId(0)`).
#[derive(Debug, Clone, Default)]
pub struct SourceMap {
    files: Vec<SourceFile>,
}

impl SourceMap {
    /// An empty map.
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers a file and returns its id.
    pub fn add(
        &mut self,
        path: PathBuf,
        text: Arc<[u8]>,
        included_from: Option<Location>,
    ) -> FileId {
        let display: Arc<str> = Arc::from(path.display().to_string());
        let id = FileId(self.files.len() as u32);
        self.files.push(SourceFile {
            path,
            display,
            text,
            included_from,
        });
        id
    }

    /// The file with this id.
    ///
    /// # Panics
    /// Never for ids handed out by this map; ids from another map are a programming error.
    pub fn file(&self, id: FileId) -> &SourceFile {
        &self.files[id.0 as usize]
    }

    /// All files, top-level first.
    pub fn files(&self) -> &[SourceFile] {
        &self.files
    }

    /// The path of the top-level file.
    pub fn top_path(&self) -> Option<&Path> {
        self.files.first().map(|f| f.path.as_path())
    }

    /// A self-contained copy of a location, for resolved data and messages.
    pub fn resolve(&self, loc: Location) -> SourceLoc {
        SourceLoc {
            file: self.file(loc.file).display.clone(),
            line: loc.line,
            col: loc.col,
        }
    }

    /// The chain of `include` statements that led to `loc`, innermost first.
    pub fn include_chain(&self, loc: Location) -> Vec<SourceLoc> {
        let mut chain = Vec::new();
        let mut file = loc.file;
        // Bounded by the number of files: an include chain never revisits a file.
        for _ in 0..self.files.len() {
            match self.file(file).included_from {
                Some(from) => {
                    chain.push(self.resolve(from));
                    file = from.file;
                }
                None => break,
            }
        }
        chain
    }
}

/// A location that carries its file name, so it can outlive the [`SourceMap`].
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SourceLoc {
    /// File name as displayed.
    pub file: Arc<str>,
    /// Line, starting at 1.
    pub line: u32,
    /// Byte column, starting at 1.
    pub col: u32,
}

impl fmt::Display for SourceLoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.col)
    }
}

impl Serialize for SourceLoc {
    /// Serialised as the compiler-style `file:line:col` string.
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_text_handles_every_line_ending() {
        let mut map = SourceMap::new();
        let id = map.add(
            PathBuf::from("x.world"),
            Arc::from(&b"one\r\ntwo\rthree\n\rfour\nfive"[..]),
            None,
        );
        let f = map.file(id);
        assert_eq!(f.line_text(1).as_deref(), Some("one"));
        assert_eq!(f.line_text(2).as_deref(), Some("two"));
        assert_eq!(f.line_text(3).as_deref(), Some("three"));
        assert_eq!(f.line_text(4).as_deref(), Some("four"));
        assert_eq!(f.line_text(5).as_deref(), Some("five"));
        assert_eq!(f.line_text(6), None);
    }

    #[test]
    fn include_chain_walks_outwards() {
        let mut map = SourceMap::new();
        let top = map.add(PathBuf::from("top.world"), Arc::from(&b""[..]), None);
        let a = map.add(
            PathBuf::from("a.inc"),
            Arc::from(&b""[..]),
            Some(Location {
                file: top,
                line: 3,
                col: 1,
            }),
        );
        let b = map.add(
            PathBuf::from("b.inc"),
            Arc::from(&b""[..]),
            Some(Location {
                file: a,
                line: 7,
                col: 1,
            }),
        );
        let chain = map.include_chain(Location {
            file: b,
            line: 1,
            col: 1,
        });
        let shown: Vec<String> = chain.iter().map(|l| l.to_string()).collect();
        assert_eq!(shown, vec!["a.inc:7:1", "top.world:3:1"]);
    }
}
