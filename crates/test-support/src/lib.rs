//! Where the workspace's tests and benches find the shared reference material (`../shared`:
//! Stage's own worlds, the conformance recordings of the real Player/Stage, the spec): one
//! place, so every crate skips the same way when it is absent (outside this workspace) and
//! honours the same `PLAYERSTAGE_SHARED` override.

use std::path::{Path, PathBuf};

/// The workspace root (this crate lives in `crates/test-support`).
pub fn workspace_root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .and_then(Path::parent)
        .expect("crates/test-support sits two levels below the workspace root")
}

/// The shared reference folder: `$PLAYERSTAGE_SHARED`, else `shared` beside the workspace root.
/// `None` (after printing why, so a skipping test says so) when neither is a directory.
pub fn shared_dir() -> Option<PathBuf> {
    if let Some(dir) = std::env::var_os("PLAYERSTAGE_SHARED") {
        let dir = PathBuf::from(dir);
        if dir.is_dir() {
            return Some(dir);
        }
        eprintln!("PLAYERSTAGE_SHARED={} is not a directory", dir.display());
    }
    let dir = workspace_root().parent()?.join("shared");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "SKIP: shared reference folder not found (set PLAYERSTAGE_SHARED or put it at {})",
            dir.display()
        );
        None
    }
}

/// `shared/<rel>` if it exists, else `None` after printing a skip message.
pub fn shared(rel: &str) -> Option<PathBuf> {
    let path = shared_dir()?.join(rel);
    if path.exists() {
        Some(path)
    } else {
        eprintln!("SKIP: {} is absent", path.display());
        None
    }
}

/// Stage 4.1.1's own worlds (`shared/stage-worlds`), or `None` with a skip message.
pub fn stage_worlds() -> Option<PathBuf> {
    shared("stage-worlds")
}

/// Whether `pkg-config` finds every one of `packages` (Player's client libraries, for the tests
/// that build and run a real libplayerc program); when not, prints the skip message naming
/// `what` would have run.
pub fn pkg_config_finds(packages: &[&str], what: &str) -> bool {
    let found = std::process::Command::new("pkg-config")
        .arg("--exists")
        .args(packages)
        .status()
        .is_ok_and(|s| s.success());
    if !found {
        eprintln!(
            "SKIP: pkg-config finds no {} (set PKG_CONFIG_PATH to a Player 3.0.2 client install \
             to run {what})",
            packages.join("/")
        );
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_root_holds_the_workspace_manifest() {
        let manifest = std::fs::read_to_string(workspace_root().join("Cargo.toml")).unwrap();
        assert!(manifest.contains("[workspace]"));
    }

    #[test]
    fn a_package_nobody_has_is_not_found() {
        assert!(!pkg_config_finds(&["no-such-package-anywhere"], "nothing"));
    }

    #[test]
    fn an_absent_entry_is_none() {
        assert!(shared("no/such/entry/anywhere").is_none());
    }
}
