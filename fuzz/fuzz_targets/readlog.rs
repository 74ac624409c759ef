//! A Player text log from anyone, through `readlog`'s reader (the file read line by line, each
//! line parsed into a message), and the writelog/readlog round trip.
//!
//! Checks beyond "no panic": every message line read is written again with `writelog`'s format;
//! that line reads back, and written again is the same text, byte for byte (a log `writelog`
//! wrote reads and writes back unchanged, as upstream's lines do in the crate's tests).

#![no_main]

use libfuzzer_sys::fuzz_target;
use player_drivers::shell::logformat::{Line, WriteOptions, encode_line, parse_line};
use player_drivers::shell::readlog::LogReader;
use playerstage_fuzz::scratch;

fn written(line: &str) -> Option<String> {
    match parse_line(line) {
        Ok(Line::Message(h, body)) => {
            let (text, _) =
                encode_line(h.time, &h.addr, h.msg_type, &body, WriteOptions::default());
            Some(text)
        }
        _ => None,
    }
}

/// The round trip of one message line `readlog` accepted.
fn check_round_trip(line: &str) {
    let Ok(Line::Message(h, body)) = parse_line(line) else {
        return;
    };
    let (first, unsupported) =
        encode_line(h.time, &h.addr, h.msg_type, &body, WriteOptions::default());
    if unsupported.is_err() {
        return;
    }
    let second = written(&first)
        .unwrap_or_else(|| panic!("writelog wrote a line readlog refuses: {first:?}"));
    assert_eq!(
        first, second,
        "a line writelog wrote does not read and write back unchanged"
    );
}

fuzz_target!(|data: &[u8]| {
    // Most inputs are read in memory line by line, as the reader does (a line that is not
    // UTF-8 ends the replay): a file per input costs more CPU than the parsing. One input in
    // eight goes through the reader itself, from a file.
    if data.first().is_some_and(|b| b % 8 == 0) {
        let path = scratch().join("input.log");
        std::fs::write(&path, data).expect("write the log");
        let mut reader = LogReader::open(&path).expect("open the log");
        let mut lines = 0;
        while let Some(item) = reader.next_message() {
            lines += 1;
            if lines > 10_000 {
                break;
            }
            if let Ok((_, h, body)) = item {
                let (line, _) =
                    encode_line(h.time, &h.addr, h.msg_type, &body, WriteOptions::default());
                check_round_trip(&line);
            }
        }
        return;
    }
    for raw in data.split_inclusive(|&b| b == b'\n') {
        let Ok(line) = std::str::from_utf8(raw) else {
            break;
        };
        check_round_trip(line);
    }
});
