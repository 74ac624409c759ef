//! Finds the shared reference material: `$PLAYERSTAGE_SHARED`, else `../shared` beside the
//! workspace root; `None` (and the caller skips with a message) when neither exists.

use std::path::PathBuf;

#[allow(unused_imports)] // test binaries each use a different subset
pub use test_support::shared_dir;

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
