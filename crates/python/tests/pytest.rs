//! Runs the Python package's test suite (`crates/python/tests/python/`, pytest) from
//! `cargo test`, so the README's one test command covers it.
//!
//! In the target directory it creates a virtualenv (`python-venv/`) with [`TEST_DEPS`] from
//! PyPI (once; `pip` is not run again while the venv's marker file lists exactly them, so adding
//! a dependency reinstalls into an existing venv), builds and installs the package into it with `maturin develop` (dev profile, same
//! target directory: the workspace's crates are not built twice), makes sure the `player` and
//! `stage_ros2` binaries exist, and runs pytest, which starts `player` servers on free ports and
//! `stage_ros2` nodes on loopback-only DDS. The test fails
//! when pytest fails; without a `python3` it fails too, unless `PLAYERSTAGE_SKIP_PYTHON=1`
//! says to skip (for machines that deliberately have no Python).

use std::path::{Path, PathBuf};
use std::process::Command;

/// The workspace root.
fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .ancestors()
        .nth(2)
        .expect("crates/python sits two levels below the workspace")
        .to_path_buf()
}

/// `target/<profile>` of this test binary (`target/<profile>/deps/pytest-HASH`).
fn profile_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    exe.parent()
        .and_then(Path::parent)
        .expect("test binaries live in target/<profile>/deps")
        .to_path_buf()
}

fn run(cmd: &mut Command, what: &str) {
    eprintln!("pytest.rs: {what}: {cmd:?}");
    let status = cmd
        .status()
        .unwrap_or_else(|e| panic!("{what}: cannot run {cmd:?}: {e}"));
    assert!(status.success(), "{what} failed ({status})");
}

/// What the test virtualenv gets from PyPI; `.ci/run` installs the same list and writes the
/// same marker (one line: the list joined by spaces).
const TEST_DEPS: &[&str] = &[
    "maturin>=1.5,<2",
    "pytest",
    "numpy",
    "gymnasium",
    "pettingzoo",
    "cyclonedds",
    "ray",
];

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

#[test]
fn python_package_test_suite() {
    if std::env::var("PLAYERSTAGE_SKIP_PYTHON").is_ok_and(|v| v == "1") {
        eprintln!("SKIP: PLAYERSTAGE_SKIP_PYTHON=1");
        return;
    }
    let python = std::env::var("PYTHON").unwrap_or_else(|_| "python3".into());
    let found = Command::new(&python).arg("--version").output();
    assert!(
        found.as_ref().is_ok_and(|o| o.status.success()),
        "no `{python}` to test the Python package with ({found:?}); install Python 3.9+ or set \
         PLAYERSTAGE_SKIP_PYTHON=1"
    );

    let root = workspace();
    let profile = profile_dir();
    let target = profile
        .parent()
        .expect("target/<profile> has a parent")
        .to_path_buf();
    let release = profile.file_name().is_some_and(|n| n == "release");

    let venv = target.join("python-venv");
    let vpython = venv.join("bin/python");
    if !vpython.is_file() {
        run(
            Command::new(&python).args(["-m", "venv"]).arg(&venv),
            "creating the virtualenv",
        );
    }
    let marker = venv.join("playerstage-test-deps");
    let want = format!("{}\n", TEST_DEPS.join(" "));
    if std::fs::read_to_string(&marker).ok().as_deref() != Some(want.as_str()) {
        run(
            Command::new(&vpython)
                .args([
                    "-m",
                    "pip",
                    "install",
                    "--quiet",
                    "--disable-pip-version-check",
                ])
                .args(TEST_DEPS),
            "installing the test dependencies from PyPI",
        );
        std::fs::write(&marker, &want).expect("writing the venv marker");
    }

    // The servers the tests start: this workspace's `player`, and `stage_ros2` for the ROS 2
    // bridge's tests.
    let player = profile.join("player");
    let stage_ros2 = profile.join("stage_ros2");
    for bin in [&player, &stage_ros2] {
        if bin.is_file() {
            continue;
        }
        let name = bin
            .file_name()
            .and_then(|n| n.to_str())
            .expect("a binary name");
        let mut build = cargo();
        build
            .current_dir(&root)
            .args(["build", "-p", "cli", "--bin", name])
            .env("CARGO_TARGET_DIR", &target);
        if release {
            build.arg("--release");
        }
        run(&mut build, &format!("building `{name}`"));
    }

    let mut develop = Command::new(venv.join("bin/maturin"));
    develop
        .current_dir(root.join("crates/python"))
        .args(["develop", "--quiet", "--profile"])
        .arg(if release { "release" } else { "dev" })
        .env("VIRTUAL_ENV", &venv)
        .env("CARGO_TARGET_DIR", &target)
        .env_remove("CONDA_PREFIX");
    run(
        &mut develop,
        "building and installing the package (maturin develop)",
    );

    run(
        Command::new(&vpython)
            .current_dir(root.join("crates/python/tests/python"))
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider", "-rs", "."])
            .env("PLAYERSTAGE_PLAYER", &player)
            .env("PLAYERSTAGE_STAGE_ROS2", &stage_ros2)
            .env("CARGO_TARGET_DIR", &target),
        "the Python test suite (pytest)",
    );
}
