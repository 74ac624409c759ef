//! How fast `writelog` records and `readlog` replays a 361-sample laser scan (a SICK LMS at
//! half-degree steps), driving each driver's callbacks directly, as the server's core would.
//!
//! * written: `handle_data` of one scan, formatted in Player's text format and written (plain
//!   text flushed per line as upstream, and gzip);
//! * replayed: `readlog` at `speed inf` (what `player --fast` sets): the worker reads, parses
//!   and hands over each line, the driver publishes it; and the parse alone.
//!
//! `cargo bench -p player-drivers --bench log [-- MESSAGES]` (default 20,000).

use std::time::Instant;

use player_drivers::shell::readlog::{LogReader, ReadLog};
use player_drivers::shell::writelog::WriteLog;
use player_proto::constants::LOCALHOST_ADDR;
use player_proto::{DeviceAddr, InterfaceCode, LaserData, LaserDataScan, Message};
use player_server::{Action, Context, Driver, DriverBlock, RequestError};

fn addr(interf: InterfaceCode) -> DeviceAddr {
    DeviceAddr::new(LOCALHOST_ADDR, 6665, interf, 0)
}

fn block(
    name: &str,
    provides: &[DeviceAddr],
    requires: &[DeviceAddr],
    options: &[(&str, &str)],
) -> DriverBlock {
    DriverBlock::new(name, "bench")
        .providing(provides.iter().copied(), "bench")
        .requiring(requires.iter().map(|&addr| (None, addr)), "bench")
        .with_options(options)
}

fn scan(i: usize) -> LaserData {
    let ranges: Vec<f32> = (0..361)
        .map(|k| 0.5 + ((k * 7 + i) % 800) as f32 * 0.01)
        .collect();
    LaserData::Scan(LaserDataScan {
        min_angle: -std::f32::consts::FRAC_PI_2,
        max_angle: std::f32::consts::FRAC_PI_2,
        resolution: std::f32::consts::PI / 360.0,
        max_range: 8.0,
        intensity: vec![0; 361],
        ranges,
        id: i as u32,
    })
}

fn write(path: &std::path::Path, n: usize) -> f64 {
    let laser = addr(InterfaceCode::LASER);
    let b = block(
        "writelog",
        &[addr(InterfaceCode::LOG)],
        &[laser],
        &[("filename", path.to_str().unwrap())],
    );
    let mut driver = WriteLog::from_block(&b).unwrap();
    let mut published = Vec::new();
    let mut ctx = Context::new(0.0, None, &mut published);
    driver.setup(&mut ctx).unwrap();
    let tickets: Vec<_> = ctx
        .actions()
        .iter()
        .filter_map(|a| match a {
            Action::Request(t, ..) => Some(*t),
            _ => None,
        })
        .collect();
    for t in tickets {
        driver.handle_reply(&mut ctx, t, Err(RequestError::Nack));
    }
    let messages: Vec<Message> = (0..64)
        .map(|i| Message::new(laser, i as f64 * 0.1, scan(i)))
        .collect();
    let start = Instant::now();
    for i in 0..n {
        let mut m = messages[i % messages.len()].clone();
        m.header.timestamp = i as f64 * 0.1;
        driver.handle_data(&mut ctx, &m);
    }
    driver.teardown(&mut ctx);
    n as f64 / start.elapsed().as_secs_f64()
}

fn replay(path: &std::path::Path, n: usize) -> f64 {
    let b = block(
        "readlog",
        &[addr(InterfaceCode::LASER)],
        &[],
        &[("filename", path.to_str().unwrap()), ("speed", "inf")],
    );
    let mut driver = ReadLog::from_block(&b).unwrap();
    let mut published = Vec::new();
    let start = Instant::now();
    {
        let mut ctx = Context::new(0.0, None, &mut published);
        driver.setup(&mut ctx).unwrap();
    }
    let mut got = 0;
    while got < n {
        let mut out = Vec::new();
        let mut ctx = Context::new(0.0, None, &mut out);
        driver.update(&mut ctx);
        drop(ctx);
        if out.is_empty() {
            std::thread::yield_now();
        }
        got += out.len();
    }
    let rate = n as f64 / start.elapsed().as_secs_f64();
    let mut ctx = Context::new(0.0, None, &mut published);
    driver.teardown(&mut ctx);
    rate
}

fn parse(path: &std::path::Path, n: usize) -> f64 {
    let start = Instant::now();
    let mut reader = LogReader::open(path).unwrap();
    let mut count = 0;
    while let Some(m) = reader.next_message() {
        m.unwrap();
        count += 1;
    }
    assert_eq!(count, n);
    n as f64 / start.elapsed().as_secs_f64()
}

fn main() {
    let n: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(20_000);
    let dir = std::env::temp_dir().join(format!("log-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["scan.log", "scan.log.gz"] {
        let path = dir.join(name);
        let written = write(&path, n);
        let size = std::fs::metadata(&path).unwrap().len();
        let parsed = parse(&path, n);
        let replayed = replay(&path, n);
        println!(
            "{name:12} {n} 361-sample laser scans: written {written:>8.0} msg/s, parsed {parsed:>8.0} msg/s, replayed {replayed:>8.0} msg/s ({:.0} bytes/scan)",
            size as f64 / n as f64
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
