//! Test helpers: finding the shared reference material and converting its JSON.

#![allow(dead_code)] // each test binary uses a different subset

use std::path::Path;

use player_proto::Value;
use serde_json::Value as Json;

#[allow(unused_imports)] // test binaries each use a different subset
pub use test_support::shared_dir;

#[allow(unused_imports)] // test binaries each use a different subset
pub use test_support::shared;

pub fn read_json(path: &Path) -> Json {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

pub fn hex(s: &str) -> Vec<u8> {
    assert!(s.len() % 2 == 0, "odd hex length");
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).expect("hex digit"))
        .collect()
}

/// The conformance files' JSON conventions → a field map: integers, floats (always written with a
/// point or exponent), text as strings of byte-valued characters (NUL included).
pub fn to_value(j: &Json) -> Value {
    match j {
        Json::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => Value::Int(i),
            (None, Some(u)) => Value::Int(i64::try_from(u).expect("integer range")),
            _ => Value::Float(n.as_f64().expect("number")),
        },
        Json::String(s) => Value::Text(
            s.chars()
                .map(|c| u8::try_from(u32::from(c)).expect("byte-valued character"))
                .collect(),
        ),
        Json::Array(items) => Value::List(items.iter().map(to_value).collect()),
        Json::Object(members) => Value::Struct(
            members
                .iter()
                .map(|(k, v)| (k.clone(), to_value(v)))
                .collect(),
        ),
        Json::Bool(_) | Json::Null => panic!("unexpected JSON {j}"),
    }
}

/// A field map → JSON, for comparing with `fields`/`decoded` (order-insensitive objects).
pub fn to_json(v: &Value) -> Json {
    match v {
        Value::Int(i) => Json::from(*i),
        Value::Float(f) if f.is_finite() => Json::from(*f),
        Value::Float(f) => Json::String(format!("{f}")),
        Value::Text(bytes) => Json::String(bytes.iter().map(|&b| char::from(b)).collect()),
        Value::List(items) => Json::Array(items.iter().map(to_json).collect()),
        Value::Struct(members) => Json::Object(
            members
                .iter()
                .map(|(k, v)| (k.clone(), to_json(v)))
                .collect(),
        ),
    }
}
