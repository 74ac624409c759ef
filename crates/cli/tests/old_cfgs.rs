//! Old cfgs and start-up messages, end to end: Player 1's `key:port:interface:index` addresses
//! (Stage's own `amcl-sonar.cfg`), the stage driver's world file found on `STAGEPATH`, a missing
//! world file named as such, and user errors printed without a backtrace.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use player_client::{DataMode, LocalizeProxy, PlayerClient, Position2dProxy};
use test_support::stage_worlds;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cli-old-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `bin` with `args`, headless, with `RUST_BACKTRACE=1` (a user error must still print no
/// backtrace) and `STAGEPATH` as given.
fn run(bin: &str, args: &[&str], stagepath: Option<&Path>) -> Output {
    let mut cmd = Command::new(bin);
    cmd.env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("STAGEPATH")
        .env("RUST_BACKTRACE", "1")
        .args(args)
        .stdin(Stdio::null());
    if let Some(p) = stagepath {
        cmd.env("STAGEPATH", p);
    }
    cmd.output().unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A user error: failure status, the message once, no backtrace and no `{:?}` layout.
fn assert_plain_error(out: &Output, wanted: &str) -> String {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains(wanted), "`{wanted}` not in:\n{err}");
    assert!(
        !err.to_lowercase().contains("backtrace") && !err.contains("Caused by"),
        "{err}"
    );
    err
}

const WORLD: &str = "define bot position ( ranger ( sensor ( ) ) )\nbot ( name \"r0\" )\n";

#[test]
fn user_errors_print_the_message_alone_even_with_rust_backtrace() {
    let dir = scratch("errors");
    std::fs::write(dir.join("bad.world"), "bot ( pose [ 1, 2 ] )\n").unwrap();
    let out = run(
        env!("CARGO_BIN_EXE_stage"),
        &["-g", dir.join("bad.world").to_str().unwrap()],
        None,
    );
    let err = assert_plain_error(&out, "bad.world:1:15: error: illegal character `,`");
    assert!(err.starts_with("error: "), "{err}");

    std::fs::write(
        dir.join("bad.cfg"),
        "driver( name \"nosuch\" provides [\"ranger:0\"] )\n",
    )
    .unwrap();
    let out = run(
        env!("CARGO_BIN_EXE_player"),
        &["-p", "0", dir.join("bad.cfg").to_str().unwrap()],
        None,
    );
    assert_plain_error(&out, "bad.cfg:1:1: couldn't find driver \"nosuch\"");
    let out = run(
        env!("CARGO_BIN_EXE_player"),
        &["--check", dir.join("bad.cfg").to_str().unwrap()],
        None,
    );
    assert_plain_error(&out, "the server would refuse this configuration");

    let out = run(env!("CARGO_BIN_EXE_playerv"), &["--rate", "0"], None);
    assert_plain_error(&out, "--rate must be a positive number");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_missing_world_file_is_named_with_its_place_in_the_cfg() {
    let dir = scratch("missing");
    let cfg = dir.join("m.cfg");
    std::fs::write(
        &cfg,
        "# no such world\n\
         driver( name \"stage\" provides [\"simulation:0\"]\n  worldfile \"nosuch.world\" )\n",
    )
    .unwrap();
    let out = run(
        env!("CARGO_BIN_EXE_player"),
        &["-p", "0", cfg.to_str().unwrap()],
        None,
    );
    let err = assert_plain_error(
        &out,
        &format!(
            "cannot read world file \"nosuch.world\" named at {}:3:3: No such file or directory",
            cfg.display()
        ),
    );
    assert!(!err.contains("failed to parse config file"), "{err}");
    assert!(err.contains("STAGEPATH is not set"), "{err}");

    // --check says the same, as a problem of the block.
    let out = run(
        env!("CARGO_BIN_EXE_player"),
        &["--check", "--json", cfg.to_str().unwrap()],
        None,
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let problem = &report["problems"][0];
    assert_eq!(problem["kind"], "world-does-not-load", "{report}");
    assert!(
        problem["message"]
            .as_str()
            .unwrap()
            .contains("cannot read world file \"nosuch.world\" named at "),
        "{problem}"
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn the_world_file_is_found_on_stagepath() {
    let dir = scratch("stagepath");
    let (cfgs, worlds) = (dir.join("cfgs"), dir.join("worlds"));
    std::fs::create_dir_all(&cfgs).unwrap();
    std::fs::create_dir_all(&worlds).unwrap();
    std::fs::write(worlds.join("w.world"), WORLD).unwrap();
    let cfg = cfgs.join("p.cfg");
    std::fs::write(
        &cfg,
        "driver( name \"stage\" provides [\"simulation:0\"] worldfile \"w.world\" )\n\
         driver( name \"stage\" provides [\"position2d:0\"] model \"r0\" )\n",
    )
    .unwrap();
    let check = |stagepath: Option<&Path>| {
        run(
            env!("CARGO_BIN_EXE_player"),
            &["--check", "--json", cfg.to_str().unwrap()],
            stagepath,
        )
    };
    // Not beside the cfg: refused without STAGEPATH, found through it.
    let out = check(None);
    assert!(!out.status.success());
    let out = check(Some(&worlds));
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let world = &report["drivers"][0]["devices"][0]["binding"];
    assert_eq!(world["kind"], "world", "{report}");
    assert_eq!(
        world["path"].as_str().map(PathBuf::from),
        Some(worlds.join("w.world"))
    );
    let _ = std::fs::remove_dir_all(dir);
}

/// `player` on `cfg`, waiting for its ports.
fn serve(cfg: &Path, stagepath: &Path) -> (Child, u16, BufReader<std::process::ChildStdout>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_player"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env("STAGEPATH", stagepath)
        .args(["-p", "0", "-g"])
        .arg(cfg)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    stdout.read_line(&mut line).unwrap();
    let Some(port) = line
        .trim()
        .strip_prefix("Listening on ports: ")
        .and_then(|p| p.parse().ok())
    else {
        let _ = child.kill();
        let mut err = String::new();
        let _ = child.stderr.take().unwrap().read_to_string(&mut err);
        panic!("start-up line: {line:?}\n{err}");
    };
    (child, port, stdout)
}

#[test]
fn player1_addresses_in_stages_amcl_sonar_cfg() {
    let Some(root) = stage_worlds() else {
        eprintln!("skipping: ../shared/stage-worlds not found (set PLAYERSTAGE_SHARED)");
        return;
    };
    let original = root.join("amcl-sonar.cfg");
    // --check on Stage's file: the Player 1 addresses are no problem, but keys with a warning.
    let out = Command::new(env!("CARGO_BIN_EXE_player"))
        .env("STAGEPATH", &root)
        .args(["--check", "--json"])
        .arg(&original)
        .output()
        .unwrap();
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let err = stderr(&out);
    assert!(
        !report["problems"]
            .as_array()
            .unwrap()
            .iter()
            .any(|p| p["kind"] == "bad-address"),
        "{report}"
    );
    let amcl = &report["drivers"][4];
    assert_eq!(amcl["driver"]["name"], "amcl");
    let keys: Vec<(&str, &str, &str)> = amcl["requires"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| {
            (
                r["addr"]["key"].as_str().unwrap_or("-"),
                r["addr"]["interface"].as_str().unwrap(),
                r["target"]["kind"].as_str().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        keys,
        [
            ("odometry", "position2d", "block"),
            ("-", "sonar", "block"),
            ("sonar", "map", "block")
        ],
        "{amcl}"
    );
    assert!(
        err.contains(
            "amcl-sonar.cfg:48:13: warning: \"odometry::position:0\" is Player 1's \
             `key::interface:index`: reading \"odometry\" as a key"
        ) && err.contains("write \"sonar:::map:0\""),
        "{err}"
    );

    // Served: Stage's cfg as written, but for its model name (simple.world's robot is "r0", the
    // cfg's "robot1" is in no world of Stage's tree), from another folder: simple.world is
    // found on STAGEPATH, the map image beside the cfg.
    let dir = scratch("amcl-sonar");
    let text = std::fs::read_to_string(&original).unwrap();
    assert!(text.contains("model \"robot1\""));
    let cfg = dir.join("amcl-sonar.cfg");
    std::fs::write(&cfg, text.replace("model \"robot1\"", "model \"r0\"")).unwrap();
    std::os::unix::fs::symlink(root.join("bitmaps"), dir.join("bitmaps")).unwrap();
    let (mut child, port, _stdout) = serve(&cfg, &root);
    let client = PlayerClient::connect("localhost", port).unwrap();
    client.set_datamode(DataMode::Push).unwrap();
    let odometry = Position2dProxy::new(&client, 0).unwrap();
    let localize = LocalizeProxy::new(&client, 0).unwrap();
    assert_eq!(localize.driver_name(), "amcl");
    let deadline = Instant::now() + Duration::from_secs(60);
    while localize.best().is_none() {
        assert!(Instant::now() < deadline, "amcl published no hypothesis");
        client.read().unwrap();
    }
    drop((odometry, localize, client));
    let _ = child.kill();
    let _ = child.wait();
    let _ = std::fs::remove_dir_all(dir);
}
