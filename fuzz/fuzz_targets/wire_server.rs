//! What a Player server reads from a client: an arbitrary byte stream through the connection's
//! framer (player-proto's `Framer` with the server's 1 MiB body cap) and decoder.
//!
//! Checks beyond "no panic":
//! * framing does not depend on how TCP cut the stream: the input fed in chunks of the size its
//!   first byte picks gives the same frames (and the same error) as fed whole;
//! * the frames are the stream: their bytes, concatenated, are exactly the input's prefix;
//! * the decoder is strict, so every body it accepts re-encodes to exactly the same bytes, and
//!   the header to the same 40 bytes.

#![no_main]

use libfuzzer_sys::fuzz_target;
use player_proto::{DecodeLimits, Frame, Framer, HEADER_SIZE};

/// The server's cap on a client's message body (`ConnectionLimits::default().max_body`).
const SERVER_MAX_BODY: usize = 1 << 20;

fn frames(stream: &[u8], chunk: usize) -> (Vec<Frame>, Option<String>) {
    let mut framer = Framer::new(DecodeLimits {
        max_body: SERVER_MAX_BODY,
    });
    let mut out = Vec::new();
    for piece in stream.chunks(chunk.max(1)) {
        framer.push(piece);
        loop {
            match framer.next_frame() {
                Ok(Some(f)) => out.push(f),
                Ok(None) => break,
                Err(e) => {
                    // sticky: the stream has no known boundary any more
                    framer.push(b"more");
                    assert_eq!(
                        framer.next_frame().err().map(|e| e.to_string()),
                        Some(e.to_string())
                    );
                    return (out, Some(e.to_string()));
                }
            }
        }
    }
    (out, None)
}

fuzz_target!(|data: &[u8]| {
    let Some((&first, stream)) = data.split_first() else {
        return;
    };
    let (whole, whole_err) = frames(stream, stream.len());
    let (chunked, chunked_err) = frames(stream, usize::from(first % 64) + 1);
    // compared as bytes: a header's timestamp may be NaN, which is not equal to itself
    let bytes = |frames: &[Frame]| {
        let mut out = Vec::new();
        for f in frames {
            f.encode_into(&mut out);
            out.push(b'|');
        }
        out
    };
    assert_eq!(
        bytes(&whole),
        bytes(&chunked),
        "framing depends on the chunk size"
    );
    assert_eq!(whole_err, chunked_err);

    let mut rebuilt = Vec::new();
    let limits = DecodeLimits {
        max_body: SERVER_MAX_BODY,
    };
    for frame in &whole {
        frame.encode_into(&mut rebuilt);
        // what the server does with it: the message type, then the typed body
        let _ = frame.header.kind();
        if let Ok(msg) = frame.decode(&limits) {
            let bytes = msg.encode().expect("an accepted message must re-encode");
            assert_eq!(
                bytes[..HEADER_SIZE],
                frame.header.to_bytes(),
                "header not canonical"
            );
            assert_eq!(
                &bytes[HEADER_SIZE..],
                &frame.body[..],
                "accepted body does not re-encode to its bytes"
            );
            let _ = format!("{:?}", msg.body);
        }
    }
    assert_eq!(
        &rebuilt[..],
        &stream[..rebuilt.len()],
        "frames are not the stream"
    );
});
