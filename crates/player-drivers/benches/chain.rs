//! What a local chain of drivers adds to a request: the round trip of a ranger GET_CONFIG from
//! a TCP client (the Rust client library, libplayerc-style: write, wait for the reply) to
//! the test driver's `ranger:0` directly, against the same request to `ranger:2`, a
//! `passthrough` of a `passthrough` of `ranger:0` (each hop defers the client's request,
//! forwards it over the core's bus and answers when the reply comes back).
//!
//! The two kinds of request alternate, so both see the same machine load. Prints the median,
//! p90 and p99 of each and the difference of the medians (the target: under 20 µs
//! added by a two-driver chain).
//!
//! `cargo bench -p player-drivers --bench chain [-- ROUNDS]` (default 20,000 rounds).

use std::time::{Duration, Instant};

use player_client::{PlayerClient, RangerProxy};
use player_proto::constants::LOCALHOST_ADDR;
use player_proto::{DeviceAddr, InterfaceCode};
use player_server::test_driver::{TEST_DRIVER_NAME, TestDriver};
use player_server::{DriverBlock, DriverRegistry, Server, ServerConfig, ServerHandle};

fn ranger(port: u32, index: u16) -> DeviceAddr {
    DeviceAddr::new(LOCALHOST_ADDR, port, InterfaceCode::RANGER, index)
}

fn block(name: &str, provides: DeviceAddr, requires: Option<DeviceAddr>) -> DriverBlock {
    let options: &[(&str, &str)] = if name == TEST_DRIVER_NAME {
        &[("silent", "1"), ("step_ms", "1000")]
    } else {
        &[]
    };
    DriverBlock::new(name, "bench")
        .providing([provides], "bench")
        .requiring(requires.map(|addr| (None, addr)), "bench")
        .with_options(options)
}

/// The test driver's `ranger:0` and the chain `ranger:2` -> `ranger:1` -> `ranger:0`.
fn server(port: u32, listener: std::net::TcpListener) -> ServerHandle {
    let mut registry = DriverRegistry::new();
    TestDriver::register(&mut registry, TEST_DRIVER_NAME);
    player_drivers::register_all(&mut registry);
    let mut server = Server::new(ServerConfig::default());
    for b in [
        block("passthrough", ranger(port, 2), Some(ranger(port, 1))),
        block("passthrough", ranger(port, 1), Some(ranger(port, 0))),
        block(TEST_DRIVER_NAME, ranger(port, 0), None),
    ] {
        server.add_block(&b, &mut registry).expect("bench block");
    }
    server.use_listener(port, listener);
    server.start().expect("server")
}

fn micros(d: Duration) -> f64 {
    d.as_secs_f64() * 1e6
}

/// (median, p90, p99) in µs.
fn quantiles(samples: &mut [Duration]) -> (f64, f64, f64) {
    samples.sort_unstable();
    let at = |q: f64| micros(samples[((samples.len() - 1) as f64 * q).round() as usize]);
    (at(0.5), at(0.9), at(0.99))
}

fn main() {
    let rounds: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(20_000);
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    let port = listener.local_addr().expect("port").port();
    let handle = server(u32::from(port), listener);
    let client = PlayerClient::connect("127.0.0.1", port).expect("connect");
    let bare = RangerProxy::new(&client, 0).expect("subscribe ranger:0");
    let chained = RangerProxy::new(&client, 2).expect("subscribe ranger:2");
    assert_eq!(chained.driver_name(), "passthrough");
    assert_eq!(
        bare.request_config().expect("bare"),
        chained.request_config().expect("chained"),
        "the chain answers with the device's own reply"
    );

    for _ in 0..rounds / 10 {
        bare.request_config().expect("warm-up");
        chained.request_config().expect("warm-up");
    }
    let mut direct = Vec::with_capacity(rounds);
    let mut through = Vec::with_capacity(rounds);
    let started = Instant::now();
    for _ in 0..rounds {
        let t = Instant::now();
        bare.request_config().expect("bare request");
        direct.push(t.elapsed());
        let t = Instant::now();
        chained.request_config().expect("chained request");
        through.push(t.elapsed());
    }
    let total = started.elapsed();
    let (d50, d90, d99) = quantiles(&mut direct);
    let (c50, c90, c99) = quantiles(&mut through);
    println!(
        "request round trip, ranger GET_CONFIG over loopback TCP, {rounds} rounds ({:.1} s)",
        total.as_secs_f64()
    );
    println!(
        "  ranger:0 (test driver)           p50 {d50:7.1} µs  p90 {d90:7.1} µs  p99 {d99:7.1} µs"
    );
    println!(
        "  ranger:2 (passthrough x2 -> 0)   p50 {c50:7.1} µs  p90 {c90:7.1} µs  p99 {c99:7.1} µs"
    );
    println!(
        "  added by the two-driver chain: {:.1} µs at the median ({:.1} µs per hop; target < 20 µs)",
        c50 - d50,
        (c50 - d50) / 2.0
    );
    drop((bare, chained, client));
    handle.shutdown();
}
