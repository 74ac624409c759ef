//! `stage --dump` and `player --check` end to end, on files written to a scratch directory.

use std::path::PathBuf;
use std::process::Command;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cli-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

const WORLD: &str = "define bot position ( ranger ( sensor ( ) ) ranger ( sensor ( samples 180 ) ) )\n\
                     bot ( name \"r0\" pose [ 1 2 0 90 ] )\n";

#[test]
fn stage_dump_prints_the_resolved_world() {
    let dir = scratch("dump");
    std::fs::write(dir.join("w.world"), WORLD).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_stage"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .arg("--dump")
        .arg(dir.join("w.world"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["models"].as_array().unwrap().len(), 3);
    assert_eq!(json["models"][0]["name"], "r0");
    assert_eq!(json["models"][2]["name"], "r0.ranger:1");

    std::fs::write(dir.join("bad.world"), "bot ( pose [ 1, 2 ] )\n").unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_stage"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .arg("--dump")
        .arg(dir.join("bad.world"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.world:1:15: error: illegal character `,`"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn player_check_reports_bindings_and_problems() {
    let dir = scratch("check");
    std::fs::write(dir.join("w.world"), WORLD).unwrap();
    std::fs::write(
        dir.join("ok.cfg"),
        "driver ( name \"stage\" provides [\"simulation:0\"] worldfile \"w.world\" )\n\
         driver ( name \"stage\" provides [\"7000:position2d:0\" \"7000:ranger:1\" \"7000:ranger:0\"] model \"r0\" )\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_player"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .arg("--check")
        .arg(dir.join("ok.cfg"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Addresses bind in `provides` order, not by index.
    assert!(text.contains("\"7000:ranger:1\": host 127.0.0.1 port 7000 interface ranger (62) index 1 -> model \"r0.ranger:0\""), "{text}");
    assert!(text.contains("listening ports: 6665 7000"), "{text}");

    std::fs::write(
        dir.join("bad.cfg"),
        "driver ( name \"stage\" provides [\"simulation:0\"] worldfile \"w.world\" )\n\
         driver ( name \"stage\" provides [\"bumper:0\"] model \"r0\" )\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_player"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .args(["--check", "-p", "7100"])
        .arg(dir.join("bad.cfg"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("does not support interface `bumper`"),
        "{text}"
    );
    assert!(text.contains("listening ports: 7100"), "{text}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn dump_into_a_closed_pipe_ends_quietly() {
    use std::io::Read;
    use std::process::Stdio;
    let world = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../worlds/bigbob.world");
    let mut child = Command::new(env!("CARGO_BIN_EXE_stage"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .arg("--dump")
        .arg(&world)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("stage runs");
    // read a little, then hang up, as `| head` does
    let mut out = child.stdout.take().expect("stdout");
    let mut first = [0u8; 16];
    out.read_exact(&mut first).expect("some output");
    drop(out);
    let mut err = String::new();
    child
        .stderr
        .take()
        .expect("stderr")
        .read_to_string(&mut err)
        .expect("stderr");
    let status = child.wait().expect("exits");
    assert!(!err.contains("panicked"), "stage panicked: {err}");
    assert!(status.success(), "stage failed: {err}");
}
