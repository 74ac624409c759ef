//! A Stage worldfile from anyone: lexer, parser, includes (the input is a small tree of files,
//! see `write_tree`), macros (`define`), resolution into a `WorldSpec`, bitmaps (small images
//! under the usual names), and the stage-sim world built from it and stepped.
//!
//! Checks beyond "no panic":
//! * loading the file and parsing its text as that file give the same spec (one reader);
//! * the spec serialises (what `stage --dump` prints) to JSON, and the JSON reads back as JSON;
//! * every model's parent lists it among its children, parents come before children.
//!
//! There is no worldfile writer in the project, so "dump and re-parse to the same spec" is
//! the JSON dump's well-formedness here, not a second parse.
//!
//! The world is built only when the spec's sizes are within a bound (models, sample counts,
//! extents against the resolution): a world that asks for gigabytes by design is not a bug of
//! the loader, and the target should find bugs rather than measure out-of-memory.

#![no_main]

use libfuzzer_sys::fuzz_target;
use playerstage_fuzz::{load_options, top_part, write_bitmaps, write_tree};
use worldfile::WorldSpec;

/// Whether the world is small enough to build: every number in its dump is bounded
/// (sample counts, sizes, poses, ranges, resolutions as integers), and the grid has at most
/// a few million cells per model extent.
fn buildable(spec: &WorldSpec, dump: &serde_json::Value) -> bool {
    fn numbers_bounded(v: &serde_json::Value) -> bool {
        match v {
            serde_json::Value::Number(n) => n.as_f64().is_some_and(|x| x.abs() <= 1000.0),
            serde_json::Value::Array(a) => a.iter().all(numbers_bounded),
            serde_json::Value::Object(o) => o.values().all(numbers_bounded),
            _ => true,
        }
    }
    let res = spec.settings.resolution;
    spec.models.len() <= 50
        && res.is_finite()
        && res >= 0.01
        && spec.models.iter().all(|m| {
            m.size
                .iter()
                .all(|s| s.is_finite() && s.abs() / res <= 4000.0)
                && m.blocks.iter().map(|b| b.points.len()).sum::<usize>() <= 2000
        })
        && numbers_bounded(dump)
}

fuzz_target!(|data: &[u8]| {
    write_bitmaps();
    let top = write_tree(data, "main.world");
    let opts = load_options();
    let loaded = WorldSpec::load(&top, &opts);
    if let Ok(text) = std::str::from_utf8(top_part(data)) {
        let parsed = WorldSpec::parse(&top, text, &opts);
        match (&loaded, &parsed) {
            (Ok(a), Ok(b)) => assert_eq!(a, b, "load and parse disagree"),
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
            _ => panic!(
                "load and parse disagree: {:?} vs {:?}",
                loaded.as_ref().err().map(|e| e.to_string()),
                parsed.as_ref().err().map(|e| e.to_string())
            ),
        }
    }
    let spec = match loaded {
        Ok(spec) => spec,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            return;
        }
    };
    for m in &spec.models {
        if let Some(p) = m.parent {
            assert!(p < m.id, "parent after child");
            assert!(spec.models[p].children.contains(&m.id));
        }
    }
    let json = serde_json::to_string(&spec).expect("a spec serialises");
    let dump: serde_json::Value = serde_json::from_str(&json).expect("the dump is JSON");
    if !buildable(&spec, &dump) {
        return;
    }
    if let Ok(mut world) = stage_sim::World::from_spec(&spec, 1) {
        for _ in 0..3 {
            world.step();
        }
    }
});
