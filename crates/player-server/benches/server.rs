//! Server figures over loopback TCP, with the test driver and with the `stage` driver serving
//! the Bigbob world (`worlds/bigbob.cfg`):
//!
//! * request round trips for one client (libplayerc-style: write, wait for the reply): a
//!   player-interface request (DATAMODE, answered by the core) and a device request (position2d
//!   GET_GEOM, answered by the driver); with Stage: position2d GET_GEOM and simulation
//!   GET_POSE2D while the world runs in real time — requests per second, p50 and p99 latency;
//! * DATA fan-out: one ranger publishing as fast as the core steps, 100 PUSH-mode clients
//!   subscribed — messages per second delivered in total; with Stage: Bigbob's sonar and laser
//!   rangers with the world stepped as fast as possible;
//! * memory per connected client: RSS growth over 1000 idle subscribed PULL clients
//!   (`/proc/self/status`; client sockets live in this process too).
//!
//! `cargo bench -p player-server --bench server`

use std::io::{Read, Write};
use std::net::TcpStream;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use player_proto::constants::{LOCALHOST_ADDR, PLAYER_DATAMODE_PULL};
use player_proto::{
    BANNER, DeviceAddr, DeviceDatamodeReq, DeviceReq, HEADER_SIZE, InterfaceCode, Message,
    MsgHeader, PlayerReq, Pose2d, Position2dReq, SimulationPose2dReq, SimulationReq, Text,
};
use player_server::stage::{self, StageOptions};
use player_server::test_driver::TestDriver;
use player_server::{DriverBlock, DriverRegistry, Pace, Server, ServerConfig, ServerHandle};

fn server(devices: &[(InterfaceCode, u16)], options: &[(&str, &str)], pace: Pace) -> ServerHandle {
    let mut registry = DriverRegistry::new();
    TestDriver::register(&mut registry, "test");
    let provides = devices
        .iter()
        .map(|&(interf, index)| DeviceAddr::new(LOCALHOST_ADDR, 0, interf, index));
    let block = DriverBlock::new("test", "bench")
        .providing(provides, "bench")
        .with_options(options);
    let mut s = Server::new(ServerConfig {
        pace,
        ..ServerConfig::default()
    });
    s.add_block(&block, &mut registry).unwrap();
    s.start().unwrap()
}

fn connect(port: u16) -> TcpStream {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_nodelay(true).unwrap();
    let mut banner = [0u8; 32];
    s.read_exact(&mut banner).unwrap();
    assert_eq!(banner, BANNER);
    s
}

fn encode(addr: DeviceAddr, body: impl Into<player_proto::Body>) -> Vec<u8> {
    Message::new(addr, 0.0, body).encode().unwrap()
}

/// Reads one whole message; returns its header.
fn read_msg(s: &mut TcpStream, buf: &mut Vec<u8>) -> MsgHeader {
    let mut head = [0u8; HEADER_SIZE];
    s.read_exact(&mut head).unwrap();
    let h = MsgHeader::from_bytes(&head).unwrap();
    buf.resize(h.size as usize, 0);
    s.read_exact(buf).unwrap();
    h
}

fn player_addr() -> DeviceAddr {
    DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0)
}

/// The player DATAMODE request that puts a connection in PULL mode.
fn pull_mode_request() -> Vec<u8> {
    encode(
        player_addr(),
        PlayerReq::DataMode(Some(DeviceDatamodeReq {
            mode: PLAYER_DATAMODE_PULL,
        })),
    )
}

/// A GET_GEOM request to position2d:0 on `port`.
fn position_geom_request(port: u16) -> Vec<u8> {
    encode(
        DeviceAddr::new(0, u32::from(port), InterfaceCode::POSITION2D, 0),
        Position2dReq::GetGeom(None),
    )
}

fn round_trips(label: &str, stream: &mut TcpStream, request: &[u8], n: usize) {
    let mut buf = Vec::new();
    for _ in 0..1000 {
        stream.write_all(request).unwrap();
        read_msg(stream, &mut buf);
    }
    let mut lat = Vec::with_capacity(n);
    let start = Instant::now();
    for _ in 0..n {
        let t = Instant::now();
        stream.write_all(request).unwrap();
        read_msg(stream, &mut buf);
        lat.push(t.elapsed());
    }
    let total = start.elapsed();
    lat.sort();
    let pct = |p: f64| lat[((lat.len() as f64 * p) as usize).min(lat.len() - 1)];
    println!(
        "{label:<44} {:>9.0} req/s   p50 {:>6.1} µs   p99 {:>6.1} µs",
        n as f64 / total.as_secs_f64(),
        pct(0.50).as_secs_f64() * 1e6,
        pct(0.99).as_secs_f64() * 1e6
    );
}

fn bench_round_trips() {
    let s = server(&[(InterfaceCode::POSITION2D, 0)], &[], Pace::default());
    let port = s.ports()[0];
    let mut c = connect(port);
    let datamode = pull_mode_request();
    round_trips(
        "request round trip, player DATAMODE",
        &mut c,
        &datamode,
        20_000,
    );
    let geom = position_geom_request(port);
    round_trips(
        "request round trip, position2d GET_GEOM",
        &mut c,
        &geom,
        20_000,
    );
}

fn subscribe(s: &mut TcpStream, interf: InterfaceCode, index: u16) {
    let req = encode(
        player_addr(),
        PlayerReq::Dev(Some(DeviceReq {
            addr: DeviceAddr::new(0, 0, interf, index),
            access: 1,
            driver_name: Text::empty(),
        })),
    );
    s.write_all(&req).unwrap();
    let mut buf = Vec::new();
    loop {
        let h = read_msg(s, &mut buf);
        if h.msg_type == 4 && h.addr.interf == InterfaceCode::PLAYER {
            return;
        }
    }
}

fn bench_fan_out(clients: usize) {
    // 1 ms steps as fast as possible: the driver publishes RANGE + INTNS (80 bytes each) per
    // step, and every message is copied into each subscriber's queue.
    let s = server(
        &[(InterfaceCode::RANGER, 0)],
        &[("step_ms", "1"), ("samples", "4")],
        Pace::AsFastAsPossible,
    );
    fan_out(
        "DATA fan-out to 100 PUSH clients",
        s.ports()[0],
        (InterfaceCode::RANGER, 0),
        80,
        clients,
    );
}

/// `clients` PUSH clients subscribed to `device`, whose DATA are `msg_bytes` long (header
/// included): messages per second delivered in total.
fn fan_out(label: &str, port: u16, device: (InterfaceCode, u16), msg_bytes: u64, clients: usize) {
    let stop = Arc::new(AtomicBool::new(false));
    let received = Arc::new(AtomicU64::new(0));
    let mut threads = Vec::new();
    for _ in 0..clients {
        let mut c = connect(port);
        subscribe(&mut c, device.0, device.1);
        let stop = stop.clone();
        let received = received.clone();
        c.set_read_timeout(Some(Duration::from_millis(100)))
            .unwrap();
        threads.push(std::thread::spawn(move || {
            let mut buf = vec![0u8; 64 * 1024];
            while !stop.load(Ordering::Relaxed) {
                if let Ok(n) = c.read(&mut buf) {
                    if n == 0 {
                        break;
                    }
                    received.fetch_add(n as u64, Ordering::Relaxed);
                }
            }
        }));
    }
    std::thread::sleep(Duration::from_millis(500));
    let start = Instant::now();
    let before = received.load(Ordering::Relaxed);
    std::thread::sleep(Duration::from_secs(3));
    let msgs = (received.load(Ordering::Relaxed) - before) / msg_bytes;
    let elapsed = start.elapsed();
    stop.store(true, Ordering::Relaxed);
    for t in threads {
        t.join().unwrap();
    }
    println!(
        "{label:<44} {:>9.0} msg/s delivered ({:.0} per client)",
        msgs as f64 / elapsed.as_secs_f64(),
        msgs as f64 / elapsed.as_secs_f64() / clients as f64
    );
}

fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or(0)
}

fn bench_memory(clients: usize) {
    let s = server(
        &[(InterfaceCode::RANGER, 0)],
        &[("step_ms", "100")],
        Pace::default(),
    );
    let port = s.ports()[0];
    // Warm up allocator pools with a few connections first.
    let warm: Vec<TcpStream> = (0..10).map(|_| connect(port)).collect();
    drop(warm);
    std::thread::sleep(Duration::from_millis(200));
    let before = rss_kib();
    let datamode = pull_mode_request();
    let mut conns = Vec::new();
    let mut buf = Vec::new();
    for _ in 0..clients {
        let mut c = connect(port);
        c.write_all(&datamode).unwrap();
        read_msg(&mut c, &mut buf);
        subscribe(&mut c, InterfaceCode::RANGER, 0);
        conns.push(c);
    }
    // Let every queue fill with a few samples.
    std::thread::sleep(Duration::from_millis(500));
    let after = rss_kib();
    println!(
        "memory per connected client ({clients} idle PULL clients) {:>6.1} KiB (RSS {} → {} KiB)",
        (after.saturating_sub(before)) as f64 / clients as f64,
        before,
        after
    );
}

/// Our server with the `stage` driver on `worlds/bigbob.cfg`, its port chosen by the OS.
fn stage_server(pace: Pace) -> ServerHandle {
    let cfg_path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../worlds/bigbob.cfg");
    let cfg = worldfile::CfgFile::load(&cfg_path, &worldfile::LoadOptions::from_env()).unwrap();
    let mut blocks = player_server::cfg::driver_blocks(&cfg, 6665).unwrap();
    for b in &mut blocks {
        for p in &mut b.provides {
            p.addr.robot = 0;
        }
    }
    let mut registry = DriverRegistry::new();
    stage::register(
        &mut registry,
        StageOptions {
            seed: 1,
            usegui: Some(false),
        },
    );
    let mut s = Server::new(ServerConfig {
        pace,
        ..ServerConfig::default()
    });
    for b in &blocks {
        s.add_block(b, &mut registry).unwrap();
    }
    s.start().unwrap()
}

fn bench_stage_round_trips() {
    let s = stage_server(Pace::default());
    let port = s.ports()[0];
    let mut c = connect(port);
    // Subscribed, as a client would be; PULL mode so that data does not interleave.
    let datamode = pull_mode_request();
    c.write_all(&datamode).unwrap();
    read_msg(&mut c, &mut Vec::new());
    let geom = position_geom_request(port);
    round_trips(
        "stage: position2d GET_GEOM round trip",
        &mut c,
        &geom,
        20_000,
    );
    let pose = encode(
        DeviceAddr::new(0, u32::from(port), InterfaceCode::SIMULATION, 0),
        SimulationReq::GetPose2d(Some(SimulationPose2dReq {
            name: Text::new("bob1"),
            pose: Pose2d::default(),
        })),
    );
    round_trips(
        "stage: simulation GET_POSE2D round trip",
        &mut c,
        &pose,
        20_000,
    );
}

fn bench_stage_fan_out(clients: usize) {
    let s = stage_server(Pace::AsFastAsPossible);
    // Sonars: 4 doubles per RANGE/INTNS (40 + 40 bytes).
    fan_out(
        "stage: sonar ranger:0 fan-out, 100 clients",
        s.ports()[0],
        (InterfaceCode::RANGER, 0),
        80,
        clients,
    );
    drop(s);
    let s = stage_server(Pace::AsFastAsPossible);
    // The tooth laser: 180 doubles per RANGE/INTNS (40 + 1448 bytes).
    fan_out(
        "stage: laser ranger:1 fan-out, 100 clients",
        s.ports()[0],
        (InterfaceCode::RANGER, 1),
        1488,
        clients,
    );
}

fn main() {
    let only_stage = std::env::args().any(|a| a == "stage");
    if !only_stage {
        bench_round_trips();
        bench_fan_out(100);
        bench_memory(1000);
    }
    bench_stage_round_trips();
    bench_stage_fan_out(100);
}
