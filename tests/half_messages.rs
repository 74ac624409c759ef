//! Fault test of issue 41: clients that send half a Player message and vanish, 10,000 times,
//! against the `stage` driver on the Bigbob world served in this process. The server must
//! neither leak (its sockets are closed again, RSS stays bounded) nor let them disturb a
//! well-behaved client that keeps reading the whole time.
//!
//! The server exposes no connection count; it runs in this process, so the test counts this
//! process's open file descriptors (`/proc/self/fd`) instead, and reads `VmRSS` from
//! `/proc/self/status`. Linux only.

mod common;

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::os::fd::AsRawFd;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread;
use std::time::{Duration, Instant};

use common::{Running, root, serve_cfg};
use player_client::{ClientError, PlayerClient, Position2dProxy};
use player_proto::BANNER;
use player_server::Pace;

/// Connections made and dropped before the measurements start (allocator pools, tokio's
/// worker state and the like reach their working size).
const WARM_UP: usize = 1_000;
/// Connections measured.
const ABUSERS: usize = 10_000;
/// Threads sharing the connections: modest, the machine may have 2 busy cores.
const THREADS: usize = 4;
/// Open descriptors allowed above the baseline once the flood is over (a few may belong to
/// the good client's or the runtime's transient work).
const FD_SLACK: usize = 4;
/// RSS growth allowed over the 10,000 connections. One leaked connection costs at least its
/// 4 KiB read buffer and its queue, so 10,000 leaks would be 40+ MiB.
const RSS_BOUND_KIB: u64 = 8 * 1024;
/// Longest the server may take to answer anything (banner, connect, a data round).
const ANSWER: Duration = Duration::from_secs(5);

/// Position2d's interface code.
const POSITION2D: u32 = 4;
/// `PLAYER_MSGTYPE_CMD`.
const MSGTYPE_CMD: u32 = 2;

fn open_fds() -> usize {
    std::fs::read_dir("/proc/self/fd")
        .expect("/proc/self/fd")
        .count()
}

fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .expect("VmRSS in /proc/self/status")
}

/// A Player header (XDR, 40 bytes) for position2d:0 on `port` announcing a body of `size`.
fn header(port: u16, size: u32) -> Vec<u8> {
    let mut h = Vec::with_capacity(40);
    for word in [0, u32::from(port), POSITION2D, 0, MSGTYPE_CMD, 1] {
        h.extend_from_slice(&word.to_be_bytes());
    }
    h.extend_from_slice(&0.0f64.to_be_bytes());
    h.extend_from_slice(&0u32.to_be_bytes());
    h.extend_from_slice(&size.to_be_bytes());
    h
}

/// Makes the close of `s` a reset (`SO_LINGER` with a zero timeout).
fn set_linger_zero(s: &TcpStream) {
    let linger = libc::linger {
        l_onoff: 1,
        l_linger: 0,
    };
    // SAFETY: a valid open socket descriptor, and a pointer to a `linger` of the size given.
    let r = unsafe {
        libc::setsockopt(
            s.as_raw_fd(),
            libc::SOL_SOCKET,
            libc::SO_LINGER,
            (&linger as *const libc::linger).cast(),
            std::mem::size_of::<libc::linger>() as libc::socklen_t,
        )
    };
    assert_eq!(r, 0, "SO_LINGER: {}", std::io::Error::last_os_error());
}

/// One client that sends part of a message and vanishes; `i` picks the variant: with or
/// without reading the banner, half a header, a header and part of its body, or a header
/// alone, closed normally or reset.
fn half_message(addr: SocketAddr, i: usize) {
    let mut s = TcpStream::connect_timeout(&addr, ANSWER)
        .unwrap_or_else(|e| panic!("connection {i}: the server stopped accepting: {e}"));
    s.set_read_timeout(Some(ANSWER)).unwrap();
    s.set_write_timeout(Some(ANSWER)).unwrap();
    let read_banner = i % 2 == 0;
    if read_banner {
        let mut banner = [0u8; BANNER.len()];
        s.read_exact(&mut banner)
            .unwrap_or_else(|e| panic!("connection {i}: no banner: {e}"));
        assert_eq!(banner, BANNER, "connection {i}");
    }
    let port = addr.port();
    let body = 16 + (i % 500) as u32;
    let bytes = match (i / 2) % 4 {
        // Half a header.
        0 => header(port, body)[..20].to_vec(),
        // A header and part of its body.
        1 => {
            let mut m = header(port, body);
            m.extend(std::iter::repeat_n(0xA5, body as usize / 2));
            m
        }
        // A header announcing a body that never comes.
        2 => header(port, body),
        // All but the last byte of a header.
        _ => header(port, body)[..39].to_vec(),
    };
    // The server may already have reset a connection it did not like; that is its right.
    let _ = s.write_all(&bytes);
    if (i / 8) % 2 == 1 {
        set_linger_zero(&s);
    }
}

/// `count` half-message clients from `THREADS` threads; returns connections per second, the
/// slowest one and how many took over half a second (a SYN retransmitted after 1 s).
fn flood(addr: SocketAddr, first: usize, count: usize) -> (f64, Duration, usize) {
    let start = Instant::now();
    let (slowest, slow) = thread::scope(|scope| {
        let workers: Vec<_> = (0..THREADS)
            .map(|t| {
                scope.spawn(move || {
                    let (mut slowest, mut slow) = (Duration::ZERO, 0);
                    for i in (first + t..first + count).step_by(THREADS) {
                        let one = Instant::now();
                        half_message(addr, i);
                        let took = one.elapsed();
                        slowest = slowest.max(took);
                        slow += usize::from(took > Duration::from_millis(500));
                    }
                    (slowest, slow)
                })
            })
            .collect();
        workers
            .into_iter()
            .map(|w| w.join().expect("a half-message thread failed"))
            .fold((Duration::ZERO, 0), |(m, n), (w, k)| (m.max(w), n + k))
    });
    (count as f64 / start.elapsed().as_secs_f64(), slowest, slow)
}

/// Waits (bounded) until this process has at most `limit` descriptors open; returns the count.
fn settle_fds(limit: usize) -> usize {
    let start = Instant::now();
    loop {
        let n = open_fds();
        if n <= limit || start.elapsed() > ANSWER {
            return n;
        }
        thread::sleep(Duration::from_millis(20));
    }
}

/// What the well-behaved client saw.
struct GoodReport {
    reads: u64,
    longest_gap: Duration,
    first_time: f64,
    last_time: f64,
}

/// A client subscribed to position2d:0 that reads data rounds until `stop`; any error other
/// than an empty round fails the test (the read timeout turns a hung server into an error).
fn good_client(port: u16, stop: Arc<AtomicBool>, reads: Arc<AtomicU64>) -> GoodReport {
    let c = PlayerClient::connect("localhost", port).expect("good client connects");
    c.set_read_timeout(Some(ANSWER));
    c.set_request_timeout(ANSWER);
    let _pos = Position2dProxy::new(&c, 0).expect("good client subscribes to position2d:0");
    let mut first_time = None;
    let mut last = Instant::now();
    let mut longest_gap = Duration::ZERO;
    while !stop.load(Ordering::Relaxed) {
        match c.read() {
            Ok(()) | Err(ClientError::NoData | ClientError::Overflow { .. }) => {}
            Err(e) => panic!("the good client's read failed during the flood: {e}"),
        }
        let now = Instant::now();
        longest_gap = longest_gap.max(now - last);
        last = now;
        first_time.get_or_insert(c.datatime());
        reads.fetch_add(1, Ordering::Relaxed);
        thread::sleep(Duration::from_millis(5));
    }
    GoodReport {
        reads: reads.load(Ordering::Relaxed),
        longest_gap,
        first_time: first_time.unwrap_or_default(),
        last_time: c.datatime(),
    }
}

#[test]
fn ten_thousand_half_messages_leak_nothing_and_disturb_no_one() {
    let server: Running = serve_cfg(
        &root().join("worlds/bigbob.cfg"),
        Pace::RealTime { speedup: 5.0 },
    );
    let port = server.port(6665);
    let addr = SocketAddr::from(([127, 0, 0, 1], port));

    let stop = Arc::new(AtomicBool::new(false));
    let reads = Arc::new(AtomicU64::new(0));
    let good = {
        let (stop, reads) = (stop.clone(), reads.clone());
        thread::spawn(move || good_client(port, stop, reads))
    };
    // The good client is connected and reading before the flood starts.
    let start = Instant::now();
    while reads.load(Ordering::Relaxed) < 3 {
        assert!(!good.is_finished(), "the good client ended early");
        assert!(start.elapsed() < ANSWER, "the good client got no data");
        thread::sleep(Duration::from_millis(10));
    }
    let fds_start = open_fds();

    let (warm_rate, warm_slowest, warm_slow) = flood(addr, 0, WARM_UP);
    let fds_before = settle_fds(fds_start);
    let rss_before = rss_kib();
    let reads_before = reads.load(Ordering::Relaxed);

    let (rate, slowest, slow) = flood(addr, WARM_UP, ABUSERS);
    let fds_after = settle_fds(fds_before);
    let rss_after = rss_kib();
    let reads_during = reads.load(Ordering::Relaxed) - reads_before;

    stop.store(true, Ordering::Relaxed);
    let report = good.join().expect("the good client failed");

    // A new client connects, subscribes and gets data.
    let fresh = PlayerClient::connect("localhost", port).expect("a new client connects");
    fresh.set_read_timeout(Some(ANSWER));
    let fresh_pos = Position2dProxy::new(&fresh, 0).expect("a new client subscribes");
    let start = Instant::now();
    while fresh_pos.state().is_none() {
        match fresh.read() {
            Ok(()) | Err(ClientError::NoData | ClientError::Overflow { .. }) => {}
            Err(e) => panic!("the new client's read failed: {e}"),
        }
        assert!(start.elapsed() < ANSWER, "the new client got no data");
    }
    drop(fresh_pos);
    drop(fresh);

    println!(
        "half messages: warm-up {WARM_UP} at {warm_rate:.0} conn/s (slowest {warm_slowest:?}, {warm_slow} over 0.5 s), \
         then {ABUSERS} at {rate:.0} conn/s (slowest {slowest:?}, {slow} over 0.5 s, {THREADS} threads); fds {fds_start} at start, {fds_before} before, {fds_after} \
         after; RSS {rss_before} KiB before, {rss_after} KiB after ({:+} KiB); good client: {} \
         reads ({reads_during} during the measured flood), longest gap {:?}, sim time {:.2} -> \
         {:.2} s",
        rss_after as i64 - rss_before as i64,
        report.reads,
        report.longest_gap,
        report.first_time,
        report.last_time,
    );

    assert!(
        fds_after <= fds_before + FD_SLACK,
        "connections leaked: {fds_before} descriptors open before the flood, {fds_after} after"
    );
    assert!(
        fds_before <= fds_start + FD_SLACK,
        "connections leaked in the warm-up: {fds_start} descriptors at start, {fds_before} after"
    );
    assert!(
        rss_after.saturating_sub(rss_before) < RSS_BOUND_KIB,
        "RSS grew from {rss_before} KiB to {rss_after} KiB over {ABUSERS} half messages"
    );
    assert!(
        reads_during > 0,
        "the good client read nothing during the flood"
    );
    assert!(
        report.longest_gap < Duration::from_secs(2),
        "the good client waited {:?} for a round during the flood",
        report.longest_gap
    );
    assert!(
        report.last_time > report.first_time,
        "the good client's data did not advance: {} -> {}",
        report.first_time,
        report.last_time
    );
}
