//! Server figures over loopback TCP, with the test driver:
//!
//! * request round trips for one client (libplayerc-style: write, wait for the reply): a
//!   player-interface request (DATAMODE, answered by the core) and a device request (position2d
//!   GET_GEOM, answered by the driver) — requests per second, p50 and p99 latency;
//! * DATA fan-out: one ranger publishing as fast as the core steps, 100 PUSH-mode clients
//!   subscribed — messages per second delivered in total;
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
    MsgHeader, PlayerReq, Position2dReq, Text,
};
use player_server::test_driver::TestDriver;
use player_server::{
    DriverBlock, DriverRegistry, Pace, ProvidedDevice, Server, ServerConfig, ServerHandle,
};

fn server(devices: &[(InterfaceCode, u16)], options: &[(&str, &str)], pace: Pace) -> ServerHandle {
    let mut registry = DriverRegistry::new();
    TestDriver::register(&mut registry, "test");
    let block = DriverBlock {
        name: "test".into(),
        origin: "bench".into(),
        provides: devices
            .iter()
            .map(|&(interf, index)| ProvidedDevice {
                addr: DeviceAddr::new(LOCALHOST_ADDR, 0, interf, index),
                key: None,
                origin: "bench".into(),
            })
            .collect(),
        options: options
            .iter()
            .map(|(k, v)| (k.to_string(), vec![v.to_string()]))
            .collect(),
        ..Default::default()
    };
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
    let datamode = encode(
        player_addr(),
        PlayerReq::DataMode(Some(DeviceDatamodeReq {
            mode: PLAYER_DATAMODE_PULL,
        })),
    );
    round_trips(
        "request round trip, player DATAMODE",
        &mut c,
        &datamode,
        20_000,
    );
    let geom = encode(
        DeviceAddr::new(0, u32::from(port), InterfaceCode::POSITION2D, 0),
        Position2dReq::GetGeom(None),
    );
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
    let port = s.ports()[0];
    let stop = Arc::new(AtomicBool::new(false));
    let received = Arc::new(AtomicU64::new(0));
    let mut threads = Vec::new();
    for _ in 0..clients {
        let mut c = connect(port);
        subscribe(&mut c, InterfaceCode::RANGER, 0);
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
    let msgs = (received.load(Ordering::Relaxed) - before) / 80;
    let elapsed = start.elapsed();
    stop.store(true, Ordering::Relaxed);
    for t in threads {
        t.join().unwrap();
    }
    println!(
        "DATA fan-out to {clients} PUSH clients              {:>9.0} msg/s delivered ({:.0} per client)",
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
    let datamode = encode(
        player_addr(),
        PlayerReq::DataMode(Some(DeviceDatamodeReq {
            mode: PLAYER_DATAMODE_PULL,
        })),
    );
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

fn main() {
    bench_round_trips();
    bench_fan_out(100);
    bench_memory(1000);
}
