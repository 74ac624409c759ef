//! Finds the shared reference material: `$PLAYERSTAGE_SHARED`, else `../shared` beside the
//! workspace root; `None` (and the caller skips with a message) when neither exists.

use std::path::{Path, PathBuf};

/// The `shared/` directory, if present.
pub fn shared_dir() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("PLAYERSTAGE_SHARED") {
        let p = PathBuf::from(p);
        if p.is_dir() {
            return Some(p);
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).ancestors().nth(2)?;
    let p = root.join("../shared");
    p.is_dir().then_some(p)
}

/// Every `.world` file of Stage's suite, sorted.
pub fn suite_worlds() -> Option<Vec<PathBuf>> {
    let dir = shared_dir()?.join("stage-worlds");
    if !dir.is_dir() {
        return None;
    }
    let mut out = Vec::new();
    let mut stack = vec![dir];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).ok()?.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "world") {
                out.push(p);
            }
        }
    }
    out.sort();
    Some(out)
}
