//! Fuzzing the decoder with proptest, bounded so it runs in CI in seconds.
//!
//! Three sources of hostile input: random bytes under every (interface, type, subtype) of the
//! table, valid encodings of generated messages with targeted damage (bit flips, huge length
//! words, truncation, extra bytes), and random byte streams through the framer. The properties:
//! never a panic, never a hang, and whatever is accepted re-encodes to exactly the same bytes
//! (the decoder is strict, so acceptance means canonical).
//!
//! `PROTO_FUZZ_CASES` raises the number of cases for a longer local run.

use proptest::prelude::*;
use proptest::strategy::Union;
use proptest::test_runner::{Config, TestRunner};

use crate::constants::LOCALHOST_ADDR;
use crate::frame::{DecodeLimits, Framer};
use crate::header::{DeviceAddr, HEADER_SIZE, MsgHeader, MsgType};
use crate::interface::InterfaceCode;
use crate::message::{Body, Message, decode_body, message_rows};

fn cases(default: u32) -> u32 {
    std::env::var("PROTO_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

fn runner(n: u32) -> TestRunner {
    TestRunner::new(Config {
        cases: cases(n),
        failure_persistence: None,
        ..Config::default()
    })
}

/// Decodes `body` under `header` and, if accepted, checks it re-encodes byte for byte.
fn decode_and_check(header: MsgHeader, body: &[u8]) {
    let header = MsgHeader {
        size: body.len() as u32,
        ..header
    };
    if let Ok(decoded) = decode_body(&header, body, &DecodeLimits::default()) {
        let msg = Message {
            header,
            body: decoded,
        };
        let bytes = msg.encode().expect("an accepted body must re-encode");
        assert_eq!(
            &bytes[HEADER_SIZE..],
            body,
            "accepted body is not canonical"
        );
    }
}

/// Headers for every table row, as every message type that row can travel as.
fn table_headers() -> Vec<MsgHeader> {
    let mut headers = Vec::new();
    for row in message_rows() {
        let interfs = if row.interface.0 == 0 {
            vec![InterfaceCode::POSITION2D, InterfaceCode(11)]
        } else {
            vec![row.interface]
        };
        let types = if row.msg_type == MsgType::Req {
            vec![MsgType::Req, MsgType::RespAck, MsgType::RespNack]
        } else {
            vec![row.msg_type]
        };
        for interf in interfs {
            for &t in &types {
                let addr = DeviceAddr::new(LOCALHOST_ADDR, 6665, interf, 0);
                headers.push(MsgHeader::new(addr, t, row.subtype, 0.0));
            }
        }
    }
    headers
}

#[test]
fn random_bodies_under_every_row() {
    let headers = table_headers();
    let n = headers.len();
    let strategy = (
        0..n,
        // Mostly small bodies, word-aligned or not, often starting with small counts.
        prop_oneof![
            proptest::collection::vec(any::<u8>(), 0..64),
            proptest::collection::vec(
                prop_oneof![Just(0u8), Just(1), Just(2), any::<u8>()],
                0..256
            ),
        ],
    );
    runner(4000)
        .run(&strategy, |(i, body)| {
            decode_and_check(headers[i], &body);
            Ok(())
        })
        .unwrap();
}

#[derive(Clone, Debug)]
enum Damage {
    Flip { at: usize, mask: u8 },
    Word { at: usize, value: u32 },
    Truncate { len: usize },
    Extend { extra: Vec<u8> },
}

fn damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        (any::<usize>(), 1..=255u8).prop_map(|(at, mask)| Damage::Flip { at, mask }),
        (
            any::<usize>(),
            prop_oneof![
                Just(u32::MAX),
                Just(0x8000_0000),
                Just(0x4000_0000),
                Just(65),
                Just(4097),
                any::<u32>()
            ]
        )
            .prop_map(|(at, value)| Damage::Word { at, value }),
        any::<usize>().prop_map(|len| Damage::Truncate { len }),
        proptest::collection::vec(any::<u8>(), 1..9).prop_map(|extra| Damage::Extend { extra }),
    ]
}

fn apply(body: &mut Vec<u8>, d: &Damage) {
    match d {
        Damage::Flip { at, mask } if !body.is_empty() => {
            let i = at % body.len();
            body[i] ^= mask;
        }
        Damage::Word { at, value } if body.len() >= 4 => {
            let i = (at % (body.len() / 4)) * 4;
            body[i..i + 4].copy_from_slice(&value.to_be_bytes());
        }
        Damage::Truncate { len } => {
            let keep = len % (body.len() + 1);
            body.truncate(keep);
        }
        Damage::Extend { extra } => body.extend_from_slice(extra),
        _ => {}
    }
}

#[test]
fn damaged_valid_messages() {
    let all = Union::new(Body::arbitrary_rows().into_iter().map(|(_, s)| s));
    let strategy = (all, proptest::collection::vec(damage(), 1..4));
    runner(4000)
        .run(&strategy, |(body, damages)| {
            let addr = DeviceAddr::new(
                LOCALHOST_ADDR,
                6665,
                body.interface().unwrap_or(InterfaceCode::RANGER),
                0,
            );
            let msg = Message::new(addr, 0.0, body);
            let bytes = msg.encode().unwrap();
            let mut damaged = bytes[HEADER_SIZE..].to_vec();
            for d in &damages {
                apply(&mut damaged, d);
            }
            decode_and_check(msg.header, &damaged);
            Ok(())
        })
        .unwrap();
}

#[test]
fn random_streams_through_the_framer() {
    let valid = Union::new(Body::arbitrary_rows().into_iter().map(|(_, s)| s));
    let piece = prop_oneof![
        3 => valid.prop_map(|body| {
            let interf = body.interface().unwrap_or(InterfaceCode::SIMULATION);
            Message::new(DeviceAddr::new(0, 6665, interf, 0), 0.0, body).encode().unwrap()
        }),
        1 => proptest::collection::vec(any::<u8>(), 0..80),
    ];
    let strategy = (proptest::collection::vec(piece, 1..6), 1..50usize);
    let limits = DecodeLimits { max_body: 4096 };
    runner(1500)
        .run(&strategy, |(pieces, chunk)| {
            let stream: Vec<u8> = pieces.concat();
            let mut framer = Framer::new(limits);
            let mut consumed = 0;
            'feed: for part in stream.chunks(chunk) {
                framer.push(part);
                loop {
                    match framer.next_frame() {
                        Ok(Some(frame)) => {
                            consumed += HEADER_SIZE + frame.body.len();
                            assert!(consumed <= stream.len());
                            if let Ok(msg) = frame.decode(&limits) {
                                let mut bytes = frame.header.to_bytes().to_vec();
                                bytes.extend_from_slice(&frame.body);
                                assert_eq!(msg.encode().unwrap(), bytes);
                            }
                        }
                        Ok(None) => break,
                        Err(_) => break 'feed,
                    }
                }
            }
            assert!(framer.buffered() <= stream.len());
            Ok(())
        })
        .unwrap();
}
