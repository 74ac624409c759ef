//! `player --check` on every cfg of Stage 4.1.1's own suite (`../shared/stage-worlds`): the
//! server is built as start-up builds it, and what it refuses is exactly the list below —
//! worlds that are not in Stage's tree, drivers not written yet, interfaces the stage driver
//! does not serve (Stage 3's `wifi`), and mistakes in the cfgs themselves — each with its line.
//! A driver landing shows up here as entries to delete.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;

use serde_json::Value;
use worldfile::{CfgFile, LoadOptions};

use test_support::stage_worlds;

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

/// What the server refuses in each cfg: (cfg, line, problem kind, a word the message names).
/// Everything else in the suite builds. Entries marked "issue 16" go when those drivers land.
const EXPECTED: &[(&str, u32, &str, &str)] = &[
    // Written for Player 1: `robot1` is not in simple.world (its robot is "r0"). Its
    // `position` is read as `position2d` and its `odometry::position:0` (Player 1's
    // `key:port:interface:index`, where Player 3 reads a host "odometry") as a key, with
    // warnings.
    ("amcl-sonar.cfg", 21, "no-such-model", "robot1"),
    ("amcl-sonar.cfg", 21, "no-such-model", "robot1"),
    // Models named twice: "cbr4" is bound by two blocks and "cbb4" by six; every block after
    // the first finds its rangers and position already bound (Stage exits there too).
    ("autolab.cfg", 24, "no-unbound-model", "ranger:0"),
    ("autolab.cfg", 24, "no-unbound-model", "ranger:1"),
    ("autolab.cfg", 24, "no-unbound-model", "position2d:0"),
    ("autolab.cfg", 36, "no-unbound-model", "ranger:0"),
    ("autolab.cfg", 36, "no-unbound-model", "ranger:1"),
    ("autolab.cfg", 36, "no-unbound-model", "position2d:0"),
    ("autolab.cfg", 37, "no-unbound-model", "ranger:0"),
    ("autolab.cfg", 37, "no-unbound-model", "ranger:1"),
    ("autolab.cfg", 37, "no-unbound-model", "position2d:0"),
    ("autolab.cfg", 38, "no-unbound-model", "ranger:0"),
    ("autolab.cfg", 38, "no-unbound-model", "ranger:1"),
    ("autolab.cfg", 38, "no-unbound-model", "position2d:0"),
    ("autolab.cfg", 39, "no-unbound-model", "ranger:0"),
    ("autolab.cfg", 39, "no-unbound-model", "ranger:1"),
    ("autolab.cfg", 39, "no-unbound-model", "position2d:0"),
    ("autolab.cfg", 40, "no-unbound-model", "ranger:0"),
    ("autolab.cfg", 40, "no-unbound-model", "ranger:1"),
    ("autolab.cfg", 40, "no-unbound-model", "position2d:0"),
    // Its vfh requires a ranger; Player 3.0.2's vfh takes a laser or a sonar only (so does ours).
    (
        "autolab.cfg",
        44,
        "driver-failed",
        "exactly one sonar or one laser",
    ),
    // mbicp.world's robot1 is a plain pioneer2dx: one ranger (the sonar ring, taken by
    // `laser:0`), none left for `sonar:0`.
    ("mbicp.cfg", 15, "no-unbound-model", "sonar:0"),
    // test.world is not in Stage's tree.
    ("test.cfg", 12, "world-does-not-load", "test.world"),
    // Its required devices on port 6665 are another server's: recorded, not problems.
    // wavefront.world is not in Stage's tree (its robot's devices are then not checked).
    ("wavefront.cfg", 5, "world-does-not-load", "wavefront.world"),
    // Stage 3's wifi: the worlds load (the wifi models kept as data), the interface is not
    // served.
    ("wifi.cfg", 24, "unsupported-interface", "`wifi`"),
    ("wifi.cfg", 34, "unsupported-interface", "`wifi`"),
    ("wifi/commando.cfg", 22, "unsupported-interface", "`wifi`"),
    ("wifi/commando.cfg", 79, "unsupported-interface", "`wifi`"),
    ("wifi/hosp_wifi.cfg", 19, "unsupported-interface", "`wifi`"),
    ("wifi/hosp_wifi.cfg", 26, "unsupported-interface", "`wifi`"),
    (
        "wifi/hosp_wifi_5.cfg",
        19,
        "unsupported-interface",
        "`wifi`",
    ),
    (
        "wifi/hosp_wifi_5.cfg",
        26,
        "unsupported-interface",
        "`wifi`",
    ),
    (
        "wifi/hosp_wifi_5.cfg",
        34,
        "unsupported-interface",
        "`wifi`",
    ),
    (
        "wifi/hosp_wifi_5.cfg",
        42,
        "unsupported-interface",
        "`wifi`",
    ),
    (
        "wifi/hosp_wifi_5.cfg",
        50,
        "unsupported-interface",
        "`wifi`",
    ),
    ("wifi/wifi.cfg", 22, "unsupported-interface", "`wifi`"),
    ("wifi/wifi.cfg", 32, "unsupported-interface", "`wifi`"),
    ("wifi/wifi.cfg", 40, "unsupported-interface", "`wifi`"),
    ("wifi/wifi_itu.cfg", 14, "unsupported-interface", "`wifi`"),
    ("wifi/wifi_itu.cfg", 24, "unsupported-interface", "`wifi`"),
    ("wifi/wifi_itu.cfg", 32, "unsupported-interface", "`wifi`"),
    (
        "wifi/wifi_logdistance.cfg",
        14,
        "unsupported-interface",
        "`wifi`",
    ),
    (
        "wifi/wifi_logdistance.cfg",
        24,
        "unsupported-interface",
        "`wifi`",
    ),
    (
        "wifi/wifi_logdistance.cfg",
        32,
        "unsupported-interface",
        "`wifi`",
    ),
    // wifi_ray.world's bitmap (cave_f.png) is not in Stage's tree.
    ("wifi/wifi_ray.cfg", 4, "world-does-not-load", "cave_f.png"),
    ("wifi/wifi_ray.cfg", 22, "unsupported-interface", "`wifi`"),
    ("wifi/wifi_ray.cfg", 32, "unsupported-interface", "`wifi`"),
    (
        "wifi/wifi_simple.cfg",
        23,
        "unsupported-interface",
        "`wifi`",
    ),
    (
        "wifi/wifi_simple.cfg",
        33,
        "unsupported-interface",
        "`wifi`",
    ),
    (
        "wifi/wifi_simple.cfg",
        41,
        "unsupported-interface",
        "`wifi`",
    ),
];

/// The line of an origin `path:line:col`.
fn line_of(origin: &str) -> u32 {
    let mut parts = origin.rsplitn(3, ':');
    let _col = parts.next();
    parts
        .next()
        .and_then(|l| l.parse().ok())
        .unwrap_or_else(|| panic!("origin without a line: {origin}"))
}

#[test]
fn player_check_reports_exactly_what_is_missing_in_stages_cfgs() {
    let Some(root) = stage_worlds() else {
        return;
    };
    let names = cfgs(&root);
    assert!(names.len() >= 20, "found only {} cfgs", names.len());
    let listed: BTreeSet<&str> = EXPECTED.iter().map(|e| e.0).collect();
    for name in &listed {
        assert!(
            names.iter().any(|n| n == name),
            "{name} is not in the suite"
        );
    }
    let mut found = Vec::new();
    let mut messages = Vec::new();
    for name in &names {
        let (report, ok, stderr) = check(&root, name);
        let problems = report["problems"].as_array().unwrap();
        assert_eq!(ok, problems.is_empty(), "{name}: exit status\n{stderr}");
        for p in problems {
            let origin = p["origin"]
                .as_str()
                .unwrap_or_else(|| panic!("{name}: a problem without a place: {p}"));
            found.push((
                name.clone(),
                line_of(origin),
                p["kind"].as_str().unwrap().to_string(),
            ));
            messages.push(p["message"].as_str().unwrap().to_string());
        }
    }
    let expected: Vec<(String, u32, String)> = EXPECTED
        .iter()
        .map(|&(cfg, line, kind, _)| (cfg.to_string(), line, kind.to_string()))
        .collect();
    assert_eq!(found, expected, "messages:\n{}", messages.join("\n"));
    for (message, &(cfg, line, _, word)) in messages.iter().zip(EXPECTED) {
        assert!(
            message.contains(word),
            "{cfg}:{line}: `{word}` not in: {message}"
        );
    }
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
    // ranger/position, 3 devices each. (The check also tries the drivers: its `vfh` block,
    // requiring a ranger that 3.0.2's vfh does not take, is the one other problem.)
    let (r, _, _) = check(&root, "autolab.cfg");
    let stage: Vec<String> = problems(&r)
        .into_iter()
        .filter(|p| !p.contains("driver \"vfh\" failed to start"))
        .collect();
    assert_eq!(stage.len(), 3 + 5 * 3, "{stage:#?}");
    assert!(stage.iter().all(|p| p.contains("no unbound")));
    assert_eq!(problems(&r).len(), stage.len() + 1);

    // wavefront.cfg names a worldfile the suite does not have, and asks for `laser`.
    let (r, _, _) = check(&root, "wavefront.cfg");
    assert_eq!(world_models(&r), None);
    assert!(
        problems(&r)
            .iter()
            .any(|p| p.contains("cannot read world file \"wavefront.world\" named at ")),
        "{:?}",
        problems(&r)
    );

    // amcl-sonar.cfg is Player 1 style: `position` is no interface in Player 3, but it is read
    // as `position2d` with a warning naming the line and the fix (it used to be a problem).
    let (r, _, stderr) = check(&root, "amcl-sonar.cfg");
    assert!(
        !problems(&r)
            .iter()
            .any(|p| p.contains("unknown interface `position`")),
        "{:?}",
        problems(&r)
    );
    assert_eq!(
        r["drivers"][1]["devices"][0]["addr"]["interface"],
        "position2d"
    );
    assert!(
        stderr.contains(
            "amcl-sonar.cfg:21:13: warning: interface \"position\" is an older Player's name \
             (Player 1.x's name for code 4, renamed in Player 2.0); serving it as \"position2d\" \
             (write \"position2d:0\")"
        ),
        "{stderr}"
    );

    // wifi/wifi.cfg: the Stage 3 `wifi` interface is not served; `laser` is, on the robots'
    // one-transducer rangers, and `map` on the named model.
    let (r, _, _) = check(&root, "wifi/wifi.cfg");
    assert_eq!(world_models(&r), Some(10));
    assert!(problems(&r).iter().any(|p| p.contains("interface `wifi`")));
    let map = &r["drivers"][1]["devices"][0];
    assert_eq!(
        (&map["addr"]["interface"], &map["binding"]["name"]),
        (&Value::from("map"), &Value::from("cave"))
    );
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
