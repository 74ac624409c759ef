//! Structural replay of the recorded real sessions (`shared/conformance/sessions/`): every
//! player-interface request a real libplayerc/libplayerc++ client sent (DATAMODE, DEVLIST,
//! DRIVERINFO, DEV, ADD_REPLACE_RULE) is sent again, byte for byte, to a server whose device
//! table mirrors the sessions' `bigbob.cfg`; the replies must equal the recorded ones: type,
//! subtype, interface, index, host, port, size and body (ports mapped to this server's).
//! Device requests and data rounds need the simulated world: the stage driver's tests replay
//! those.

mod common;

use std::collections::HashMap;
use std::path::Path;

use common::{RawClient, bigbob, shared};
use player_proto::{
    Body, DecodeLimits, HEADER_SIZE, InterfaceCode, Message, MsgHeader, MsgType, PlayerMsg,
    PlayerReq,
};
use serde_json::Value as Json;

fn hex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

fn bytes_of(m: &Json) -> Vec<u8> {
    let mut b = hex(m["header_hex"].as_str().unwrap());
    b.extend(hex(m["body_hex"].as_str().unwrap()));
    b
}

fn is_player_request(m: &Json) -> bool {
    m["header"]["addr"]["interf"] == 1 && m["header"]["type"] == 3
}

/// A reply of the player interface other than the REQ_DATA ACK (which belongs to data rounds).
fn is_player_reply(h: &MsgHeader) -> bool {
    matches!(h.kind(), Ok(MsgType::RespAck | MsgType::RespNack))
        && h.addr.interf == InterfaceCode::PLAYER
        && h.subtype != PlayerReq::DATA
}

/// Rewrites every port inside a player-interface body with `map`.
fn map_ports(body: Body, map: &HashMap<u32, u32>) -> Body {
    let port = |p: u32| *map.get(&p).unwrap_or(&p);
    match body {
        Body::Player(PlayerMsg::Ack(PlayerReq::DevList(Some(mut l)))) => {
            for d in &mut l.devices {
                d.robot = port(d.robot);
            }
            Body::Player(PlayerMsg::Ack(PlayerReq::DevList(Some(l))))
        }
        Body::Player(PlayerMsg::Ack(PlayerReq::DriverInfo(Some(mut i)))) => {
            i.addr.robot = port(i.addr.robot);
            Body::Player(PlayerMsg::Ack(PlayerReq::DriverInfo(Some(i))))
        }
        Body::Player(PlayerMsg::Ack(PlayerReq::Dev(Some(mut d)))) => {
            d.addr.robot = port(d.addr.robot);
            Body::Player(PlayerMsg::Ack(PlayerReq::Dev(Some(d))))
        }
        Body::Player(PlayerMsg::Nack(PlayerReq::Dev(Some(mut d)))) => {
            d.addr.robot = port(d.addr.robot);
            Body::Player(PlayerMsg::Nack(PlayerReq::Dev(Some(d))))
        }
        other => other,
    }
}

fn replay(path: &Path) -> usize {
    let name = path.display().to_string();
    let doc: Json = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let (_server, p1, p2) = bigbob(false);
    let map = HashMap::from([(6665, p1), (6666, p2)]);
    let recorded_port = doc["port"].as_u64().unwrap() as u32;
    let mut client = RawClient::connect(map[&recorded_port]);
    let limits = DecodeLimits::default();

    let messages = doc["messages"].as_array().unwrap();
    let mut expected = Vec::new();
    for m in messages {
        if m["dir"] == "s2c" {
            let bytes = bytes_of(m);
            let h = MsgHeader::from_bytes(bytes[..HEADER_SIZE].try_into().unwrap()).unwrap();
            if is_player_reply(&h) {
                expected.push((h, bytes[HEADER_SIZE..].to_vec()));
            }
        }
    }
    let mut got = Vec::new();
    for m in messages.iter().filter(|m| m["dir"] == "c2s") {
        if !is_player_request(m) || m["header"]["subtype"] == PlayerReq::DATA {
            continue;
        }
        client.send_bytes(&bytes_of(m));
        loop {
            let r = client.recv();
            if is_player_reply(&r.header) {
                got.push((r.header, r.body));
                break;
            }
        }
    }
    // When the real server closed first it had crashed (c_capability: Stage dereferences the
    // missing capability body); it answered nothing after that, and we answer the rest.
    let server_died = doc["connection_events"][0]["dir"] == "s2c";
    if server_died {
        assert!(got.len() >= expected.len(), "{name}: number of replies");
        got.truncate(expected.len());
    } else {
        assert_eq!(got.len(), expected.len(), "{name}: number of replies");
    }
    for (i, ((gh, gb), (eh, eb))) in got.iter().zip(&expected).enumerate() {
        let what = format!(
            "{name}: reply #{i} ({} subtype {})",
            eh.msg_type, eh.subtype
        );
        assert_eq!(gh.msg_type, eh.msg_type, "{what}: type");
        assert_eq!(gh.subtype, eh.subtype, "{what}");
        assert_eq!(
            (gh.addr.interf, gh.addr.index),
            (eh.addr.interf, eh.addr.index),
            "{what}"
        );
        assert_eq!(gh.addr.host, eh.addr.host, "{what}: host");
        assert_eq!(gh.addr.robot, map[&eh.addr.robot], "{what}: port");
        assert_eq!(gh.size, eh.size, "{what}: size");
        assert_eq!(gh.seq, eh.seq, "{what}: seq");
        let g = Message::decode(*gh, gb, &limits).unwrap().body;
        let e = map_ports(Message::decode(*eh, eb, &limits).unwrap().body, &map);
        assert_eq!(g, e, "{what}: body");
    }
    got.len()
}

#[test]
fn player_interface_replies_match_the_recordings() {
    let Some(dir) = shared("conformance/sessions") else {
        return;
    };
    let mut total = 0;
    let mut files = 0;
    for sub in [dir.clone(), dir.join("run2")] {
        let mut paths: Vec<_> = std::fs::read_dir(&sub)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "json"))
            .collect();
        paths.sort();
        for path in paths {
            total += replay(&path);
            files += 1;
        }
    }
    println!("{total} player-interface replies from {files} recordings matched");
    assert!(files >= 19 && total > 150, "{files} files, {total} replies");
}

#[test]
fn banners_match_the_recordings() {
    let Some(dir) = shared("conformance/sessions") else {
        return;
    };
    let (_server, p1, _) = bigbob(false);
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "json") {
            let doc: Json = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
            assert_eq!(
                hex(doc["banner_hex"].as_str().unwrap()),
                player_proto::BANNER
            );
        }
    }
    // RawClient::connect checks the banner bytes of this server against the same constant.
    RawClient::connect(p1);
}
