//! Property tests: no input, random bytes or random token soup, makes the lexer, parser or
//! resolver panic, hang or grow without bound. Input size is bounded by the strategies; time and
//! memory by [`Limits`].

use std::path::Path;

use proptest::prelude::*;
use worldfile::loader::parse_document;
use worldfile::{CfgFile, Dialect, Limits, LoadOptions, WorldSpec};

fn opts() -> LoadOptions {
    LoadOptions {
        limits: Limits {
            max_entities: 20_000,
            max_parse_steps: 2_000_000,
            ..Limits::default()
        },
        ..LoadOptions::default()
    }
}

/// Runs every entry point on `text`; only panics matter, errors are expected.
fn exercise(text: &[u8]) {
    let o = opts();
    for dialect in [Dialect::World, Dialect::Cfg] {
        let _ = parse_document(Path::new("fuzz.world"), text.to_vec(), dialect, &o);
    }
    if let Ok(s) = std::str::from_utf8(text) {
        if let Ok(w) = WorldSpec::parse(Path::new("fuzz.world"), s, &o) {
            let _ = serde_json::to_string(&w).unwrap();
        }
        let _ = CfgFile::parse(Path::new("fuzz.cfg"), s, &o);
    }
}

const VOCABULARY: &[&str] = &[
    "model",
    "position",
    "ranger",
    "sensor",
    "block",
    "window",
    "gripper",
    "blobfinder",
    "fiducial",
    "camera",
    "actuator",
    "blinkenlight",
    "laser",
    "wifi",
    "map",
    "driver",
    "define",
    "include",
    "plugin",
    "name",
    "pose",
    "size",
    "origin",
    "color",
    "points",
    "point[0]",
    "point[1]",
    "point[2]",
    "z",
    "bitmap",
    "boundary",
    "noblocks",
    "provides",
    "requires",
    "unit_length",
    "unit_angle",
    "test",
    "samples",
    "fov",
    "range",
    "colors",
    "colors_count",
    "paddle_state",
    "type",
    "axis",
    "start_position",
    "m",
    "a",
    "b",
    "yes",
    "(",
    ")",
    "[",
    "]",
    "\n",
    "\r\n",
    " ",
    "\t",
    "# c\n",
    "0",
    "1",
    "-1",
    "1.5",
    "1e3",
    "1.2.3",
    "-",
    "90",
    "1000000",
    "\"\"",
    "\"red\"",
    "\"random\"",
    "\"cm\"",
    "\"ranger:0\"",
    "\"simulation:0\"",
    "\"6665:position2d:0\"",
    "\"foo:0\"",
    "\"zz_missing.inc\"",
    "\"open\"",
    "\"up\"",
    ",",
    "_",
];

fn soup() -> impl Strategy<Value = String> {
    prop::collection::vec(prop::sample::select(VOCABULARY), 0..300).prop_map(|toks| {
        let mut s = String::new();
        for t in toks {
            s.push_str(t);
            s.push(' ');
        }
        s
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, .. ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..2048)) {
        exercise(&bytes);
    }

    #[test]
    fn random_ascii_never_panics(text in "[ -~\t\r\n]{0,1500}") {
        exercise(text.as_bytes());
    }

    #[test]
    fn token_soup_never_panics(text in soup()) {
        exercise(text.as_bytes());
    }

    #[test]
    fn well_formed_models_always_resolve(
        n in 1usize..20,
        x in -100.0f64..100.0,
        a in -720.0f64..720.0,
        sx in 0.01f64..10.0,
    ) {
        let mut src = String::new();
        for i in 0..n {
            src.push_str(&format!(
                "position ( name \"r{i}\" pose [ {x} {i} 0 {a} ] size [ {sx} {sx} 1 ] ranger ( sensor ( samples 3 ) ) )\n"
            ));
        }
        let w = WorldSpec::parse(Path::new("ok.world"), &src, &opts()).unwrap();
        prop_assert_eq!(w.models.len(), 2 * n);
        for m in &w.models {
            prop_assert!(m.pose[3].abs() <= std::f64::consts::PI + 1e-12);
        }
        prop_assert_eq!(w.find_model(&format!("r{}", n - 1)), Some(2 * (n - 1)));
    }
}
