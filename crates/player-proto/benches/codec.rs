//! Codec throughput: encode + decode of typical messages, against a plain copy of the same bytes.
//!
//! `cargo bench -p player-proto --bench codec` prints messages/s and MB/s for
//! * a ranger DATA RANGE with 361 samples (a 180° laser-like ranger at 0.5°),
//! * a camera DATA STATE with a 640×480 RGB888 image,
//! * a position2d DATA STATE,
//!
//! each as encode only, decode only, and encode + decode (one full round trip through the wire
//! format), and a `memcpy` of the encoded message into a preallocated buffer: the physical limit
//! for moving those bytes at all.

use std::hint::black_box;
use std::time::{Duration, Instant};

use player_proto::constants::{LOCALHOST_ADDR, PLAYER_CAMERA_FORMAT_RGB888};
use player_proto::{
    CameraData, CameraDataState, DecodeLimits, DeviceAddr, HEADER_SIZE, InterfaceCode, Message,
    MsgHeader, Pose2d, Position2dData, Position2dDataState, RangerData, RangerDataRange,
    decode_body,
};

/// Runs `f` repeatedly for about `budget` and returns the time per call.
fn time_per_call(budget: Duration, mut f: impl FnMut()) -> Duration {
    // Warm up and size a batch that takes ~10 ms.
    let mut batch = 1u64;
    loop {
        let start = Instant::now();
        for _ in 0..batch {
            f();
        }
        if start.elapsed() >= Duration::from_millis(10) {
            break;
        }
        batch *= 2;
    }
    let start = Instant::now();
    let mut calls = 0u64;
    while start.elapsed() < budget {
        for _ in 0..batch {
            f();
        }
        calls += batch;
    }
    start.elapsed() / u32::try_from(calls).unwrap_or(u32::MAX)
}

fn report(case: &str, op: &str, bytes: usize, per_call: Duration) {
    let secs = per_call.as_secs_f64();
    println!(
        "{case:<28} {op:<16} {:>14.0} msg/s {:>10.1} MB/s {:>10.3} µs/msg",
        1.0 / secs,
        bytes as f64 / secs / 1e6,
        secs * 1e6
    );
}

fn bench(case: &str, msg: &Message, budget: Duration) {
    let limits = DecodeLimits::default();
    let wire = msg.encode().expect("encode");
    let len = wire.len();
    let mut buf = Vec::with_capacity(len);

    let encode = time_per_call(budget, || {
        buf.clear();
        black_box(msg).encode_into(&mut buf).unwrap();
        black_box(&buf);
    });
    let decode = time_per_call(budget, || {
        let bytes = black_box(&wire[..]);
        let header = MsgHeader::from_bytes(bytes[..HEADER_SIZE].try_into().unwrap()).unwrap();
        black_box(decode_body(&header, &bytes[HEADER_SIZE..], &limits).unwrap());
    });
    let round_trip = time_per_call(budget, || {
        buf.clear();
        black_box(msg).encode_into(&mut buf).unwrap();
        let header = MsgHeader::from_bytes(buf[..HEADER_SIZE].try_into().unwrap()).unwrap();
        black_box(decode_body(&header, &buf[HEADER_SIZE..], &limits).unwrap());
    });
    let mut dst = vec![0u8; len];
    let copy = time_per_call(budget, || {
        dst.copy_from_slice(black_box(&wire[..]));
        black_box(&dst);
    });

    println!("{case} ({len} bytes on the wire)");
    report(case, "encode", len, encode);
    report(case, "decode", len, decode);
    report(case, "encode+decode", len, round_trip);
    report(case, "memcpy", len, copy);
    println!(
        "{case:<28} encode+decode takes {:.1}x the time of one memcpy of the same bytes\n",
        round_trip.as_secs_f64() / copy.as_secs_f64()
    );
}

fn main() {
    let budget = Duration::from_millis(
        std::env::var("CODEC_BENCH_MS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(1000),
    );
    let dev = |interf| DeviceAddr::new(LOCALHOST_ADDR, 6665, interf, 0);

    let ranger = Message::new(
        dev(InterfaceCode::RANGER),
        12.3,
        RangerData::Range(RangerDataRange {
            ranges: (0..361).map(|i| 0.5 + f64::from(i) * 0.01).collect(),
        }),
    );
    let camera = Message::new(
        dev(InterfaceCode::CAMERA),
        12.3,
        CameraData::State(CameraDataState {
            width: 640,
            height: 480,
            bpp: 24,
            format: PLAYER_CAMERA_FORMAT_RGB888,
            fdiv: 1,
            compression: 0,
            image: (0..640 * 480 * 3).map(|i| (i % 251) as u8).collect(),
        }),
    );
    let position = Message::new(
        dev(InterfaceCode::POSITION2D),
        12.3,
        Position2dData::State(Position2dDataState {
            pos: Pose2d {
                px: 1.0,
                py: 2.0,
                pa: 0.5,
            },
            vel: Pose2d {
                px: 0.25,
                py: 0.0,
                pa: -0.125,
            },
            stall: 0,
        }),
    );

    bench("ranger RANGE 361 samples", &ranger, budget);
    bench("camera 640x480 RGB888", &camera, budget);
    bench("position2d STATE", &position, budget);
}
