//! Helpers shared by the fuzz targets: a scratch folder per process for inputs that are files
//! (worldfiles with their includes, cfgs, logs, images), and the split of one fuzz input into
//! a small tree of files.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use worldfile::{Limits, LoadOptions};

/// What the worldfile and cfg targets load with: no STAGEPATH (inputs stay inside their
/// tree) and limits far below the defaults, so an input that merely asks for a huge file,
/// token count or bitmap is refused quickly instead of using up the run's time and memory.
pub fn load_options() -> LoadOptions {
    LoadOptions {
        limits: Limits {
            max_file_bytes: 1 << 20,
            max_tokens: 200_000,
            max_include_depth: 16,
            max_entities: 5_000,
            max_parse_steps: 2_000_000,
            max_nesting: 100,
            max_bitmap_pixels: 1 << 16,
        },
        ..LoadOptions::default()
    }
}

/// The process's scratch folder (made once, emptied of the previous input's files by
/// [`write_tree`]). Under the system temp folder, named by process id so parallel fuzz jobs
/// do not share it.
pub fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("playerstage-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("bitmaps")).expect("scratch folder");
        dir
    })
}

/// Separates the files of one input: the top-level file first, then each include as a line
/// with its name followed by its text.
pub const FILE_SEPARATOR: &[u8] = b"\n%%file ";

/// Writes `data` as a tree under the scratch folder and returns the top-level file's path.
///
/// `data` is the top-level file's text, then for every [`FILE_SEPARATOR`] a file whose first
/// line is its name (letters, digits, `.`, `_`, `-`, one optional `dir/` prefix; anything else
/// is replaced by `_`) and whose other lines are its text. So `include "pioneer.inc"` in the
/// top file finds the part named `pioneer.inc`, a cycle of includes can be written, and a
/// missing include is just a part the input lacks. Files of the previous input are removed
/// first (the `bitmaps/` images made by [`write_bitmaps`] stay).
pub fn write_tree(data: &[u8], top_name: &str) -> PathBuf {
    let dir = scratch();
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let p = e.path();
            if p.is_file() {
                let _ = std::fs::remove_file(&p);
            } else if p.file_name().is_some_and(|n| n != "bitmaps") {
                let _ = std::fs::remove_dir_all(&p);
            }
        }
    }
    let mut parts = split(data, FILE_SEPARATOR).into_iter();
    let top = dir.join(top_name);
    std::fs::write(&top, parts.next().unwrap_or_default()).expect("write top file");
    for part in parts.take(16) {
        let (name, text) = match part.iter().position(|&b| b == b'\n') {
            Some(i) => (&part[..i], &part[i + 1..]),
            None => (part, &[][..]),
        };
        let name = file_name(name);
        if name.is_empty() || name == top_name || name.starts_with("bitmaps/") {
            continue;
        }
        let path = dir.join(&name);
        if let Some(parent) = path.parent() {
            let _ = std::fs::create_dir_all(parent);
        }
        let _ = std::fs::write(path, text);
    }
    top
}

/// The top-level file's bytes of an input written by [`write_tree`].
pub fn top_part(data: &[u8]) -> &[u8] {
    split(data, FILE_SEPARATOR)[0]
}

fn split<'a>(data: &'a [u8], sep: &[u8]) -> Vec<&'a [u8]> {
    let mut out = Vec::new();
    let mut rest = data;
    while let Some(i) = rest.windows(sep.len()).position(|w| w == sep) {
        out.push(&rest[..i]);
        rest = &rest[i + sep.len()..];
    }
    out.push(rest);
    out
}

/// A safe relative file name from the bytes of a part's first line.
fn file_name(raw: &[u8]) -> String {
    let text = String::from_utf8_lossy(raw);
    let text = text.trim();
    let (dir, base) = match text.split_once('/') {
        Some((d, b)) => (Some(d), b),
        None => (None, text),
    };
    let clean = |s: &str| -> String {
        s.chars()
            .take(40)
            .map(|c| {
                if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') {
                    c
                } else {
                    '_'
                }
            })
            .collect::<String>()
            .trim_start_matches('.')
            .to_string()
    };
    let base = clean(base);
    match dir.map(clean) {
        Some(d) if !d.is_empty() && !base.is_empty() => format!("{d}/{base}"),
        _ => base,
    }
}

/// Small images under the names Stage's worlds and our own use (`bitmaps/cave.png`, ...), so
/// fuzzed worlds that name them load a real bitmap without the cost of a full-size map.
pub fn write_bitmaps() {
    static DONE: OnceLock<()> = OnceLock::new();
    DONE.get_or_init(|| {
        let dir = scratch().join("bitmaps");
        // A room with walls and a pillar: occupied (black) and free (white) pixels, 40 x 30.
        let img = image::GrayImage::from_fn(40, 30, |x, y| {
            let wall = x == 0 || y == 0 || x == 39 || y == 29 || (15..20).contains(&x) && y > 10;
            image::Luma([if wall { 0 } else { 255 }])
        });
        for name in [
            "cave.png",
            "bigbob_cave.png",
            "ghost.png",
            "autolab.png",
            "hospital_section.png",
            "simple_rooms.png",
            "space_invader.png",
            "human_outline.png",
            "submarine.png",
            "sal2.png",
            "table.png",
        ] {
            img.save(dir.join(name)).expect("write bitmap");
        }
    });
}
