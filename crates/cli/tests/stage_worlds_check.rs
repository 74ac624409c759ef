//! `player --check` on every cfg of Stage 4.1.1's own suite (`../shared/stage-worlds`): the
//! server is built as start-up builds it.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;
use worldfile::{CfgFile, LoadOptions};

/// `shared/stage-worlds`: `$PLAYERSTAGE_SHARED/stage-worlds`, else `../shared/stage-worlds`
/// beside the workspace root; `None` (after saying so) when absent.
fn stage_worlds() -> Option<PathBuf> {
    let shared = std::env::var_os("PLAYERSTAGE_SHARED")
        .map(PathBuf::from)
        .filter(|p| p.is_dir())
        .or_else(|| {
            let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).ancestors().nth(2)?;
            Some(workspace.join("../shared"))
        })?;
    let p = shared.join("stage-worlds");
    if p.is_dir() {
        Some(p)
    } else {
        eprintln!(
            "skipping: {} not found (set PLAYERSTAGE_SHARED or put the shared material beside \
             the workspace)",
            p.display()
        );
        None
    }
}

/// The cfgs of the suite, relative to its root, sorted.
fn cfgs(root: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for dir in ["", "wifi", "benchmark"] {
        for e in std::fs::read_dir(root.join(dir)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|e| e == "cfg") {
                out.push(p.strip_prefix(root).unwrap().to_string_lossy().into_owned());
            }
        }
    }
    out.sort();
    out
}

/// `player --check --json` on `root/name`, as a user with `STAGEPATH` pointing at Stage's
/// worlds folder (the `wifi/` worlds include `pioneer.inc` and bitmaps from one level up).
/// Returns the report, whether the exit status was success, and stderr.
fn check(root: &Path, name: &str) -> (Value, bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_player"))
        .env("STAGEPATH", root)
        .env("RUST_BACKTRACE", "0")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .args(["--check", "--json"])
        .arg(root.join(name))
        .output()
        .expect("player runs");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let report = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{name}: no JSON report ({e}):\n{stderr}"));
    (report, out.status.success(), stderr)
}

/// The suite's cfgs checked the way the server builds them; counts checked by hand for a few
/// (these assertions lived beside the worldfile crate's old `check` until the check moved into
/// the server).
#[test]
fn hand_checked_cfg_reports() {
    let Some(root) = stage_worlds() else {
        return;
    };
    let opts = LoadOptions {
        stage_path: vec![root.clone()],
        ..LoadOptions::default()
    };
    // Every block of every cfg is in its report.
    for name in cfgs(&root) {
        let cfg = CfgFile::load(&root.join(&name), &opts).unwrap_or_else(|e| panic!("{e}"));
        let (r, _, _) = check(&root, &name);
        assert_eq!(
            r["drivers"].as_array().unwrap().len(),
            cfg.drivers.len(),
            "{name}"
        );
    }
    let problems = |r: &Value| -> Vec<String> {
        r["problems"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["message"].as_str().unwrap().to_string())
            .collect()
    };
    let world_models = |r: &Value| -> Option<u64> {
        r["drivers"].as_array().unwrap().iter().find_map(|d| {
            d["devices"].as_array().unwrap().iter().find_map(|dev| {
                (dev["binding"]["kind"] == "world").then(|| dev["binding"]["models"].as_u64())?
            })
        })
    };

    // simple.cfg: ranger:0 is the sonar ring (from the macro), ranger:1 the laser.
    let (r, ok, _) = check(&root, "simple.cfg");
    assert!(ok && problems(&r).is_empty(), "{:?}", problems(&r));
    assert!(world_models(&r).is_some());
    assert_eq!(r["ports"], serde_json::json!([6665]));
    let bound: Vec<&str> = r["drivers"][1]["devices"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["binding"]["name"].as_str().unwrap_or("?"))
        .collect();
    assert_eq!(bound, ["r0", "r0.ranger:0", "r0.ranger:1"]);

    // everything.cfg: 8 driver blocks, robots on 6665..6671 (player-cfg.md §9.2).
    let (r, ok, _) = check(&root, "everything.cfg");
    assert_eq!(r["drivers"].as_array().unwrap().len(), 8);
    assert_eq!(
        r["ports"],
        serde_json::json!((6665..=6671).collect::<Vec<u16>>())
    );
    assert!(ok && problems(&r).is_empty(), "{:?}", problems(&r));
    assert_eq!(
        r["drivers"][2]["devices"][3]["addr"]["interface"],
        "fiducial"
    );
    assert_eq!(
        r["drivers"][1]["devices"][3]["addr"]["interface"],
        "blobfinder"
    );

    // autolab.cfg binds "cbr4" twice and "cbb4" six times: each extra block finds no free
    // ranger/position, 3 devices each. (The check now also tries the drivers: its `vfh` block
    // is the one other problem.)
    let (r, _, _) = check(&root, "autolab.cfg");
    let stage: Vec<String> = problems(&r)
        .into_iter()
        .filter(|p| !p.contains("couldn't find driver \"vfh\""))
        .collect();
    assert_eq!(stage.len(), 3 + 5 * 3, "{stage:#?}");
    assert!(stage.iter().all(|p| p.contains("no unbound")));
    assert_eq!(problems(&r).len(), stage.len() + 1);

    // wavefront.cfg names a worldfile the suite does not have, and asks for `laser`.
    let (r, _, _) = check(&root, "wavefront.cfg");
    assert_eq!(world_models(&r), None);
    assert!(problems(&r).iter().any(|p| p.contains("does not load")));

    // amcl-sonar.cfg is Player 2 style: `position` is no interface in Player 3.
    let (r, _, _) = check(&root, "amcl-sonar.cfg");
    assert!(
        problems(&r)
            .iter()
            .any(|p| p.contains("unknown interface `position`"))
    );

    // wifi/wifi.cfg: the Stage 3 `wifi` and `map` interfaces are not served (`laser` is, on
    // the robots' one-transducer rangers).
    let (r, _, _) = check(&root, "wifi/wifi.cfg");
    assert_eq!(world_models(&r), Some(10));
    assert!(problems(&r).iter().any(|p| p.contains("interface `wifi`")));
    let laser = &r["drivers"][2]["devices"][1];
    assert_eq!(laser["addr"]["interface"], "laser");
    assert_eq!(laser["binding"]["kind"], "model");

    // wavefront-remote.cfg: everything it requires on port 6665 is another server's; the
    // check records those devices and connects nowhere.
    let (r, _, _) = check(&root, "wavefront-remote.cfg");
    let remote: Vec<&str> = r["remote"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d["addr"].as_str().unwrap())
        .collect();
    assert_eq!(
        remote,
        [
            "127.0.0.1:6665:map:0",
            "127.0.0.1:6665:position2d:0",
            "127.0.0.1:6665:laser:0"
        ]
    );
    assert_eq!(r["ports"], serde_json::json!([7000]));
}
