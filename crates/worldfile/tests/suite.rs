//! Every world and cfg in Stage 4.1.1's own suite (`../shared/stage-worlds`) loads, with counts
//! checked by hand for a few files.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use player_proto::InterfaceCode;
use worldfile::body::BlockOrigin;
use worldfile::{CfgFile, ErrorKind, LoadOptions, ModelType, TypeSpec, WorldSpec};

fn options(root: &Path) -> LoadOptions {
    // As a user with `STAGEPATH` pointing at Stage's worlds folder: the `wifi/` worlds include
    // `pioneer.inc` and name `bitmaps/...` that live one level up.
    LoadOptions {
        stage_path: vec![root.to_path_buf()],
        ..LoadOptions::default()
    }
}

fn files(root: &Path, ext: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for dir in ["", "wifi", "benchmark"] {
        for e in std::fs::read_dir(root.join(dir)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|e| e == ext) {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// Worlds whose bitmap is not in the suite at all (Stage itself exits on them).
const MISSING_BITMAP: &[&str] = &["large.world", "wifi_ray.world"];

#[test]
fn every_world_loads_with_its_bitmaps() {
    let Some(root) = common::stage_worlds() else {
        return;
    };
    let opts = options(&root);
    let worlds = files(&root, "world");
    assert!(worlds.len() >= 25, "found only {} worlds", worlds.len());
    let mut failed = BTreeSet::new();
    for path in &worlds {
        match WorldSpec::load(path, &opts) {
            Ok(world) => {
                assert!(!world.models.is_empty(), "{}", path.display());
                for m in &world.models {
                    if m.common.bitmap.is_some() {
                        let n = m
                            .blocks
                            .iter()
                            .filter(|b| b.origin == BlockOrigin::Bitmap)
                            .count();
                        assert!(
                            n > 0,
                            "{}: bitmap of {} gave no blocks",
                            path.display(),
                            m.name
                        );
                    }
                    for b in &m.blocks {
                        for p in &b.points {
                            assert!(p[0].is_finite() && p[1].is_finite(), "{}", m.name);
                            assert!(p[0].abs() <= m.size[0] / 2.0 + 1e-9);
                            assert!(p[1].abs() <= m.size[1] / 2.0 + 1e-9);
                        }
                        assert!(b.z[0] <= b.z[1] && b.z[1] <= m.size[2] + 1e-9);
                    }
                }
            }
            Err(e) => {
                assert!(
                    matches!(&e.kind, ErrorKind::Io { what: "bitmap", .. }),
                    "{}: {e}",
                    path.display()
                );
                failed.insert(path.file_name().unwrap().to_string_lossy().into_owned());
            }
        }
    }
    let expected: BTreeSet<String> = MISSING_BITMAP.iter().map(|s| s.to_string()).collect();
    assert_eq!(failed, expected);
}

#[test]
fn hand_checked_world_counts() {
    let Some(root) = common::stage_worlds() else {
        return;
    };
    let opts = options(&root);
    let load = |name: &str| WorldSpec::load(&root.join(name), &opts).unwrap();

    // simple.world: the cave floorplan and a pioneer2dx "r0" with its sonar ring and a laser.
    let w = load("simple.world");
    let types: Vec<ModelType> = w.models.iter().map(|m| m.model_type).collect();
    assert_eq!(
        types,
        [
            ModelType::Model,
            ModelType::Position,
            ModelType::Ranger,
            ModelType::Ranger
        ]
    );
    let names: Vec<&str> = w.models.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["cave", "r0", "r0.ranger:0", "r0.ranger:1"]);
    assert_eq!(w.models[2].sensors().unwrap().len(), 16);
    let laser = &w.models[3].sensors().unwrap()[0];
    assert_eq!((laser.samples, laser.range), (180, [0.0, 8.0]));
    assert!((laser.fov - std::f64::consts::PI).abs() < 1e-12);
    assert_eq!(w.settings.quit_time, 3600.0);
    assert!(w.settings.paused);
    assert_eq!(w.window.as_ref().unwrap().size, [635, 666]);
    let r0 = &w.models[1];
    assert_eq!(r0.size, [0.44, 0.38, 0.22]);
    assert_eq!(r0.common.mass, 23.0);
    assert_eq!(r0.common.ctrl, vec!["wander".to_string()]);
    assert_eq!(r0.position().unwrap().localization_origin, [0.0; 4]);
    assert!(w.warnings.is_empty(), "{:?}", w.warnings);

    // everything.world: floorplan, 3 pucks, 8 trickedoutpioneers of 5 models each, a gripper,
    // a blobfinder, a camera, 2 sillies and 4 creates.
    let w = load("everything.world");
    assert_eq!(w.models.len(), 53);
    let count = |t| w.models.iter().filter(|m| m.model_type == t).count();
    assert_eq!(count(ModelType::Position), 8 + 2 + 4);
    assert_eq!(count(ModelType::Ranger), 24);
    assert_eq!(count(ModelType::Fiducial), 8);
    assert_eq!(
        (count(ModelType::Gripper), count(ModelType::Blobfinder)),
        (1, 1)
    );
    assert_eq!(count(ModelType::Camera), 1);
    let blob = w.find_model("robot1.blobfinder:0").unwrap();
    match &w.model(blob).spec {
        TypeSpec::Blobfinder(b) => assert_eq!(b.colors.len(), 6),
        other => panic!("{other:?}"),
    }

    // autolab.world: floorplan, 30 chatterboxes of 6 models, 15 chargers of 6 models.
    assert_eq!(load("autolab.world").models.len(), 1 + 30 * 6 + 15 * 6);

    // benchmark/hospital.world: floorplan and 1000 swarmbots, each a position with a ranger.
    let w = load("benchmark/hospital.world");
    assert_eq!(w.models.len(), 2001);
    assert_eq!(w.settings.threads, 4);
    assert!(
        w.models
            .iter()
            .skip(1)
            .step_by(2)
            .all(|m| m.model_type == ModelType::Position)
    );

    // wifi/wifi.world (Stage 3): a map and three robots, each with a laser and a wifi.
    let w = load("wifi/wifi.world");
    assert_eq!(w.models.len(), 10);
    let count = |t| w.models.iter().filter(|m| m.model_type == t).count();
    assert_eq!((count(ModelType::Laser), count(ModelType::Wifi)), (3, 3));
    assert!(
        w.warnings
            .iter()
            .any(|w| w.message.contains("no `laser` model type"))
    );
}

/// What the server makes of these cfgs (drivers, bindings, `player --check`) is tested where the
/// server is built: `crates/cli/tests/stage_worlds_check.rs`.
#[test]
fn every_cfg_parses() {
    let Some(root) = common::stage_worlds() else {
        return;
    };
    let opts = options(&root);
    let cfgs = files(&root, "cfg");
    assert!(cfgs.len() >= 20, "found only {} cfgs", cfgs.len());
    for path in &cfgs {
        let cfg = CfgFile::load(path, &opts).unwrap_or_else(|e| panic!("{e}"));
        assert!(!cfg.drivers.is_empty(), "{}", path.display());
        for d in &cfg.drivers {
            assert!(
                d.address_errors.is_empty(),
                "{}: {:?}",
                path.display(),
                d.address_errors
            );
        }
    }
    // amcl-sonar.cfg is older than Player 2.0 in places: `position` is read as `position2d`,
    // and Player 1's `key::interface:index` as a key, with a warning at each address that says
    // so.
    let cfg = CfgFile::load(&root.join("amcl-sonar.cfg"), &opts).unwrap();
    assert_eq!(
        cfg.drivers[1].provides[0].interface,
        InterfaceCode::POSITION2D
    );
    let renamed: Vec<u32> = cfg
        .warnings
        .iter()
        .filter(|w| {
            w.message
                .contains("interface \"position\" is an older Player's name")
        })
        .map(|w| w.location.as_ref().unwrap().line)
        .collect();
    assert_eq!(renamed, [21]);
    let keyed: Vec<(u32, bool)> = cfg
        .warnings
        .iter()
        .filter(|w| w.message.contains("is Player 1's `key::interface:index`"))
        .map(|w| {
            (
                w.location.as_ref().unwrap().line,
                w.message.contains("\"position\" as \"position2d\""),
            )
        })
        .collect();
    assert_eq!(keyed, [(48, true), (48, false)]);
    let keys: Vec<Option<&str>> = cfg.drivers[4]
        .requires
        .iter()
        .map(|a| a.key.as_deref())
        .collect();
    assert_eq!(keys, [Some("odometry"), None, Some("sonar")]);
}
