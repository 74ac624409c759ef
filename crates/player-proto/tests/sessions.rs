//! Every message of every recorded real-client session (`shared/conformance/sessions/`, both
//! runs): framed from the byte stream as it travelled, decoded completely, equal to upstream's
//! own decoding, and re-encoded to the identical bytes.

mod common;

use std::path::PathBuf;

use common::{hex, read_json, shared, to_json};
use player_proto::{BANNER, DecodeLimits, Framer, Message};
use serde_json::Value as Json;

fn session_files() -> Option<Vec<PathBuf>> {
    let dir = shared("conformance/sessions")?;
    let mut files = Vec::new();
    for sub in [dir.clone(), dir.join("run2")] {
        for entry in std::fs::read_dir(&sub).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "json") {
                files.push(path);
            }
        }
    }
    files.sort();
    Some(files)
}

/// Checks one direction of a session: the concatenated bytes, cut by the framer in `chunk`-byte
/// pieces, give exactly the recorded messages.
fn check_direction(name: &str, dir: &str, messages: &[&Json], chunk: usize) -> usize {
    let limits = DecodeLimits::default();
    let stream: Vec<u8> = messages
        .iter()
        .flat_map(|m| {
            let mut b = hex(m["header_hex"].as_str().unwrap());
            b.extend(hex(m["body_hex"].as_str().unwrap()));
            b
        })
        .collect();
    let mut framer = Framer::new(limits);
    let mut frames = Vec::new();
    for piece in stream.chunks(chunk) {
        framer.push(piece);
        while let Some(frame) = framer.next_frame().unwrap() {
            frames.push(frame);
        }
    }
    assert_eq!(framer.buffered(), 0, "{name} {dir}");
    assert_eq!(frames.len(), messages.len(), "{name} {dir}");

    for (i, (frame, m)) in frames.iter().zip(messages).enumerate() {
        let what = format!("{name} {dir} #{i} ({})", m["subtype_name"]);
        let msg: Message = frame
            .decode(&limits)
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert_eq!(
            to_json(&player_proto::Xdr::to_value(&msg.header)),
            m["header"],
            "{what}"
        );
        assert_eq!(msg.body.carried_struct(), m["struct"].as_str(), "{what}");
        assert_eq!(
            msg.body.constant(),
            m["subtype_name"].as_str().unwrap(),
            "{what}"
        );
        let decoded = msg
            .body
            .to_value()
            .map(|v| to_json(&v))
            .unwrap_or(Json::Null);
        assert_eq!(decoded, m["decoded"], "{what}");
        let mut bytes = hex(m["header_hex"].as_str().unwrap());
        bytes.extend(hex(m["body_hex"].as_str().unwrap()));
        assert_eq!(msg.encode().unwrap(), bytes, "{what}: re-encode");
    }
    frames.len()
}

#[test]
fn every_session_message_decodes_and_reencodes() {
    let Some(files) = session_files() else {
        return;
    };
    assert!(!files.is_empty());
    let mut total = 0;
    for (n, path) in files.iter().enumerate() {
        let name = path.display().to_string();
        let doc = read_json(path);
        assert_eq!(hex(doc["banner_hex"].as_str().unwrap()), BANNER, "{name}");
        let messages = doc["messages"].as_array().unwrap();
        assert_eq!(
            messages.len() as u64,
            doc["message_count"].as_u64().unwrap()
        );
        let chunk = [1, 5, 13, 64, 1500, 65536][n % 6];
        for dir in ["c2s", "s2c"] {
            let ms: Vec<&Json> = messages.iter().filter(|m| m["dir"] == dir).collect();
            total += check_direction(&name, dir, &ms, chunk);
        }
    }
    println!(
        "checked {total} session messages from {} recordings",
        files.len()
    );
    assert!(total > 6000, "only {total} messages");
}
