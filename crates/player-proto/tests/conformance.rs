//! Every golden vector of `shared/conformance/xdr/` both ways: decode(bytes) == fields and
//! encode(fields) == bytes, byte for byte; headers and complete messages through the framer.

mod common;

use common::{hex, read_json, shared, to_json, to_value};
use player_proto::{
    Body, DecodeLimits, DeviceAddr, Framer, HEADER_SIZE, InterfaceCode, Message, MessageKey,
    MsgHeader, MsgType, Xdr, decode_body, lookup,
};
use serde_json::Value as Json;

fn key(v: &Json, interf: u16) -> MessageKey {
    MessageKey {
        interf: InterfaceCode(interf),
        msg_type: v["msg_type"].as_u64().unwrap() as u8,
        subtype: v["subtype"].as_u64().unwrap() as u8,
    }
}

fn header_for(key: MessageKey, size: usize) -> MsgHeader {
    MsgHeader {
        addr: DeviceAddr::new(0, 0, key.interf, 0),
        msg_type: key.msg_type,
        subtype: key.subtype,
        timestamp: 0.0,
        seq: 0,
        size: size as u32,
    }
}

/// Checks one body vector under `key`; returns the decoded body.
fn check_body(id: &str, key: MessageKey, v: &Json) -> Body {
    let bytes = hex(v["body_hex"].as_str().unwrap());
    assert_eq!(bytes.len() as u64, v["body_len"].as_u64().unwrap(), "{id}");
    let limits = DecodeLimits::default();

    // Decode: all bytes consumed (decode_body refuses leftovers), the struct upstream's table
    // selects, and exactly the listed field values.
    let body = decode_body(&header_for(key, bytes.len()), &bytes, &limits)
        .unwrap_or_else(|e| panic!("{id}: decode: {e}"));
    assert_eq!(body.carried_struct(), v["struct"].as_str(), "{id}: struct");
    let fields = body.to_value().expect("vector has a body");
    assert_eq!(to_json(&fields), v["fields"], "{id}: fields");

    // Encode: build from the listed fields, compare byte for byte.
    let built = Body::from_value(key, Some(&to_value(&v["fields"])))
        .unwrap_or_else(|e| panic!("{id}: from fields: {e}"));
    assert_eq!(built, body, "{id}: built != decoded");
    assert_eq!(built.encode().unwrap(), bytes, "{id}: encode");

    // The lookup table agrees with the vector's struct.
    let row = lookup(key.interf, key.msg_type, key.subtype)
        .unwrap_or_else(|| panic!("{id}: no table row"));
    assert_eq!(row.body, v["struct"].as_str(), "{id}: lookup");
    body
}

#[test]
fn body_vectors() {
    let Some(dir) = shared("conformance/xdr") else {
        return;
    };
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .filter(|p| p.file_name().is_some_and(|n| n != "header.json"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no vector files in {}", dir.display());

    let mut checked = 0;
    let mut ids = std::collections::BTreeSet::new();
    for file in &files {
        for v in read_json(file).as_array().unwrap() {
            let id = v["id"].as_str().unwrap();
            assert!(ids.insert(id.to_owned()), "duplicate id {id}");
            let code = v["interface_code"].as_u64().unwrap() as u16;
            let k = key(v, code);
            let body = check_body(id, k, v);
            assert_eq!(body.constant(), v["subtype_name"].as_str().unwrap(), "{id}");
            assert_eq!(
                MsgType::from_u8(k.msg_type).unwrap().short_name(),
                v["msg_type_name"].as_str().unwrap(),
                "{id}"
            );

            // ACK/NACK bodies use the REQ row: the same bytes are valid as all three.
            let t = MsgType::from_u8(k.msg_type).unwrap();
            if matches!(t, MsgType::Req | MsgType::RespAck | MsgType::RespNack) {
                for other in [MsgType::Req, MsgType::RespAck, MsgType::RespNack] {
                    let k2 = MessageKey {
                        msg_type: other.code(),
                        ..k
                    };
                    check_body(id, k2, v);
                }
            }
            // Universal rows match every interface code.
            if code == 0 {
                for interf in [
                    InterfaceCode::POSITION2D,
                    InterfaceCode::SIMULATION,
                    InterfaceCode::RANGER,
                    InterfaceCode::GPS,
                ] {
                    check_body(id, key(v, interf.0), v);
                }
            }
            checked += 1;
        }
    }
    println!(
        "checked {checked} body vectors from {} files both ways",
        files.len()
    );
    assert_eq!(checked, 259, "the README lists 259 body vectors");
}

#[test]
fn header_vectors() {
    let Some(path) = shared("conformance/xdr/header.json") else {
        return;
    };
    let doc = read_json(&path);
    let mut checked = 0;
    for v in doc["headers"].as_array().unwrap() {
        let id = v["id"].as_str().unwrap();
        let bytes: [u8; HEADER_SIZE] = hex(v["hex"].as_str().unwrap()).try_into().unwrap();
        let h = MsgHeader::from_bytes(&bytes).unwrap_or_else(|e| panic!("{id}: {e}"));
        assert_eq!(to_json(&h.to_value()), v["fields"], "{id}");
        let built = MsgHeader::from_value(&to_value(&v["fields"])).unwrap();
        assert_eq!(built.to_bytes(), bytes, "{id}");
        checked += 1;
    }
    println!("checked {checked} header vectors both ways");
    assert_eq!(checked, 7);
}

#[test]
fn complete_messages() {
    let Some(path) = shared("conformance/xdr/header.json") else {
        return;
    };
    let doc = read_json(&path);
    let limits = DecodeLimits::default();
    let mut checked = 0;
    for v in doc["messages"].as_array().unwrap() {
        let id = v["id"].as_str().unwrap();
        let bytes = hex(v["message_hex"].as_str().unwrap());
        assert_eq!(bytes.len() as u64, v["message_len"].as_u64().unwrap());

        // Frame it from a stream delivered in awkward pieces.
        let mut framer = Framer::new(limits);
        let mut frames = Vec::new();
        for piece in bytes.chunks(7) {
            framer.push(piece);
            while let Some(f) = framer.next_frame().unwrap() {
                frames.push(f);
            }
        }
        assert_eq!(frames.len(), 1, "{id}");
        let msg = frames[0]
            .decode(&limits)
            .unwrap_or_else(|e| panic!("{id}: {e}"));
        assert_eq!(to_json(&msg.header.to_value()), v["header"], "{id}: header");
        assert_eq!(
            msg.body.carried_struct(),
            v["struct"].as_str(),
            "{id}: struct"
        );
        let fields = msg
            .body
            .to_value()
            .map(|f| to_json(&f))
            .unwrap_or(Json::Null);
        assert_eq!(fields, v["fields"], "{id}: fields");

        // Encode from the listed header and fields.
        let header = MsgHeader::from_value(&to_value(&v["header"])).unwrap();
        let body_fields = (!v["fields"].is_null()).then(|| to_value(&v["fields"]));
        let body = Body::from_value(header.key(), body_fields.as_ref())
            .unwrap_or_else(|e| panic!("{id}: {e}"));
        let built = Message { header, body };
        assert_eq!(built.encode().unwrap(), bytes, "{id}: encode");
        checked += 1;
    }
    println!("checked {checked} complete messages both ways");
    assert_eq!(checked, 13);
}

/// The message table equals the one the conformance README lists per interface (generated from
/// the 3.0.2 `.def` files), `NULL` rows included: same rows, constants and body structs.
#[test]
fn table_matches_the_readme() {
    let Some(path) = shared("conformance/README.md") else {
        return;
    };
    let text = std::fs::read_to_string(path).unwrap();
    let mut listed = std::collections::BTreeSet::new();
    let mut code: Option<u16> = None;
    for line in text.lines() {
        if let Some(title) = line.strip_prefix("**") {
            // "**position2d (4)**" or "**universal (interface code 0 in the codec table)**"
            code = if title.starts_with("universal") {
                Some(0)
            } else {
                title.split(['(', ')']).nth(1).and_then(|n| n.parse().ok())
            };
            continue;
        }
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let (Some(code), [_, ty, sub, constant, body, ..]) = (code, cells.as_slice()) else {
            continue;
        };
        let Some(t) = MsgType::ALL.into_iter().find(|t| t.short_name() == *ty) else {
            continue;
        };
        let body = body.strip_prefix('`').and_then(|b| b.strip_suffix('`'));
        listed.insert((
            code,
            t.code(),
            sub.parse::<u8>().unwrap(),
            constant.trim_matches('`').to_owned(),
            body.map(str::to_owned),
        ));
    }
    let ours: std::collections::BTreeSet<_> = player_proto::message_rows()
        .into_iter()
        .map(|r| {
            (
                r.interface.0,
                r.msg_type.code(),
                r.subtype,
                r.constant.to_owned(),
                r.body.map(str::to_owned),
            )
        })
        .collect();
    // Interfaces the README's list does not cover, each row as its 3.0.2 `.def` file declares
    // it: libplayerinterface/interfaces/051_opaque.def (DATA STATE, CMD DATA and REQ DATA, all
    // carrying player_opaque_data_t) and 044_planner.def (DATA STATE player_planner_data_t, CMD
    // GOAL player_planner_cmd_t, REQ GET_WAYPOINTS player_planner_waypoints_req_t, REQ ENABLE
    // player_planner_enable_req_t), 045_log.def (REQ SET_WRITE_STATE, SET_READ_STATE,
    // GET_STATE, SET_READ_REWIND without a body, SET_FILENAME) and 064_blackboard.def (DATA
    // UPDATE and six REQs, all carrying player_blackboard_entry_t).
    let beyond_the_readme = [
        (
            51,
            MsgType::Data,
            1,
            "PLAYER_OPAQUE_DATA_STATE",
            Some("player_opaque_data_t"),
        ),
        (
            51,
            MsgType::Cmd,
            1,
            "PLAYER_OPAQUE_CMD_DATA",
            Some("player_opaque_data_t"),
        ),
        (
            51,
            MsgType::Req,
            1,
            "PLAYER_OPAQUE_REQ_DATA",
            Some("player_opaque_data_t"),
        ),
        (
            44,
            MsgType::Data,
            1,
            "PLAYER_PLANNER_DATA_STATE",
            Some("player_planner_data_t"),
        ),
        (
            44,
            MsgType::Cmd,
            1,
            "PLAYER_PLANNER_CMD_GOAL",
            Some("player_planner_cmd_t"),
        ),
        (
            44,
            MsgType::Req,
            1,
            "PLAYER_PLANNER_REQ_GET_WAYPOINTS",
            Some("player_planner_waypoints_req_t"),
        ),
        (
            44,
            MsgType::Req,
            2,
            "PLAYER_PLANNER_REQ_ENABLE",
            Some("player_planner_enable_req_t"),
        ),
        (
            45,
            MsgType::Req,
            1,
            "PLAYER_LOG_REQ_SET_WRITE_STATE",
            Some("player_log_set_write_state_t"),
        ),
        (
            45,
            MsgType::Req,
            2,
            "PLAYER_LOG_REQ_SET_READ_STATE",
            Some("player_log_set_read_state_t"),
        ),
        (
            45,
            MsgType::Req,
            3,
            "PLAYER_LOG_REQ_GET_STATE",
            Some("player_log_get_state_t"),
        ),
        (45, MsgType::Req, 4, "PLAYER_LOG_REQ_SET_READ_REWIND", None),
        (
            45,
            MsgType::Req,
            5,
            "PLAYER_LOG_REQ_SET_FILENAME",
            Some("player_log_set_filename_t"),
        ),
        (
            64,
            MsgType::Data,
            1,
            "PLAYER_BLACKBOARD_DATA_UPDATE",
            Some("player_blackboard_entry_t"),
        ),
        (
            64,
            MsgType::Req,
            1,
            "PLAYER_BLACKBOARD_REQ_SUBSCRIBE_TO_KEY",
            Some("player_blackboard_entry_t"),
        ),
        (
            64,
            MsgType::Req,
            2,
            "PLAYER_BLACKBOARD_REQ_UNSUBSCRIBE_FROM_KEY",
            Some("player_blackboard_entry_t"),
        ),
        (
            64,
            MsgType::Req,
            3,
            "PLAYER_BLACKBOARD_REQ_SET_ENTRY",
            Some("player_blackboard_entry_t"),
        ),
        (
            64,
            MsgType::Req,
            4,
            "PLAYER_BLACKBOARD_REQ_SUBSCRIBE_TO_GROUP",
            Some("player_blackboard_entry_t"),
        ),
        (
            64,
            MsgType::Req,
            5,
            "PLAYER_BLACKBOARD_REQ_UNSUBSCRIBE_FROM_GROUP",
            Some("player_blackboard_entry_t"),
        ),
        (
            64,
            MsgType::Req,
            6,
            "PLAYER_BLACKBOARD_REQ_GET_ENTRY",
            Some("player_blackboard_entry_t"),
        ),
    ];
    for code in [51, 44, 45, 64] {
        assert!(
            !listed.iter().any(|r| r.0 == code),
            "the README now lists interface {code}: drop it from beyond_the_readme"
        );
    }
    for (code, t, sub, constant, body) in beyond_the_readme {
        listed.insert((
            code,
            t.code(),
            sub,
            constant.to_owned(),
            body.map(str::to_owned),
        ));
    }
    println!(
        "README lists {} table rows (with {} beyond it); the crate declares {}",
        listed.len(),
        beyond_the_readme.len(),
        ours.len()
    );
    assert_eq!(ours, listed);
}
