//! The `stage` binary end to end: headless runs to `quit_time`, clock output, `--dump`, errors.

use std::process::Command;

use test_support::stage_worlds;

fn stage(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_stage"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .args(args)
        .output()
        .expect("run stage")
}

#[test]
fn headless_run_stops_at_quit_time_with_clock() {
    let Some(root) = stage_worlds() else {
        eprintln!("skipping: ../shared/stage-worlds not found (set PLAYERSTAGE_SHARED)");
        return;
    };
    let world = root.join("simple.world");
    let out = stage(&[
        "-g",
        "-c",
        "--fast",
        "--quit-time",
        "20",
        world.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("[GUI disabled]") && stdout.contains("[Clock enabled]"),
        "{stdout}"
    );
    assert!(stdout.contains("[Stage:  0m 10s 000msec]"), "{stdout}");
    assert!(stdout.trim_end().ends_with("[Stage: done]"), "{stdout}");
}

#[test]
fn speedup_paces_headless_runs() {
    let Some(root) = stage_worlds() else {
        eprintln!("skipping: ../shared/stage-worlds not found (set PLAYERSTAGE_SHARED)");
        return;
    };
    // simple.world has the default speedup 1: 0.5 simulated seconds take about 0.5 s
    let world = root.join("simple.world");
    let t0 = std::time::Instant::now();
    let out = stage(&["-g", "--quit-time", "0.5", world.to_str().unwrap()]);
    assert!(out.status.success());
    let secs = t0.elapsed().as_secs_f64();
    assert!(secs >= 0.45, "ran too fast for speedup 1: {secs} s");
}

#[test]
fn dump_prints_the_resolved_world() {
    let Some(root) = stage_worlds() else {
        eprintln!("skipping: ../shared/stage-worlds not found (set PLAYERSTAGE_SHARED)");
        return;
    };
    let out = stage(&["--dump", "-q", root.join("simple.world").to_str().unwrap()]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert!(v["models"].as_array().is_some_and(|m| m.len() == 4), "{v}");
}

#[test]
fn missing_or_broken_files_are_clear_errors() {
    let out = stage(&["-g", "/nonexistent/nothing.world"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("nothing.world"), "{err}");
    let dir = std::env::temp_dir().join(format!("stage-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.world");
    std::fs::write(&bad, "model( pose [ 1 2 3 ] \n").unwrap();
    let out = stage(&["-g", bad.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.world:"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
