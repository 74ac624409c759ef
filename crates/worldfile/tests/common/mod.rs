//! Test helpers: where the shared reference material is, and scratch directories.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The shared reference folder: `$PLAYERSTAGE_SHARED`, else `../shared` beside the workspace
/// root. `None` (after printing why) when neither exists, so callers can skip.
pub fn shared_dir() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("PLAYERSTAGE_SHARED") {
        let p = PathBuf::from(p);
        if p.is_dir() {
            return Some(p);
        }
    }
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).ancestors().nth(2)?;
    let p = workspace.join("../shared");
    if p.is_dir() {
        return Some(p);
    }
    eprintln!(
        "skipping: shared reference material not found (set PLAYERSTAGE_SHARED or put it at {})",
        p.display()
    );
    None
}

/// `shared/stage-worlds`, or `None` with a message.
pub fn stage_worlds() -> Option<PathBuf> {
    let p = shared_dir()?.join("stage-worlds");
    if p.is_dir() {
        Some(p)
    } else {
        eprintln!("skipping: {} not found", p.display());
        None
    }
}

/// A scratch directory removed when dropped.
pub struct Scratch {
    pub dir: PathBuf,
}

impl Scratch {
    pub fn new() -> Scratch {
        static N: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "worldfile-test-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::SeqCst)
        ));
        std::fs::create_dir_all(&dir).unwrap();
        Scratch { dir }
    }

    /// Writes `text` to `name` (creating directories) and returns the path.
    pub fn file(&self, name: &str, text: &str) -> PathBuf {
        let p = self.dir.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
