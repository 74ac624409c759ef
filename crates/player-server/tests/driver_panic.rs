//! Fault test of issue 41: a driver that panics. The fault is injected by a driver defined in
//! this test (nothing in the server or the `player` binary can be told to panic): one device
//! panics in its scheduled `update` once a client commands it, another in `handle_request`.
//! The server must log the panic naming the driver and its devices, drop the subscriptions to
//! them (no more data, a request NACKed, a new subscription refused), answer the request that
//! panicked with a NACK rather than leave it to time out, and keep serving every other device
//! and client: before the fix the panic ended the core task and with it the whole server.

mod common;

use std::io::Write;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use common::{block, free_listener};
use player_client::{ClientError, PlayerClient, Position2dProxy, RangerProxy};
use player_proto::{
    InterfaceCode, Pose2d, Position2dData, Position2dDataState, Position2dGeom, Position2dReq,
};
use player_server::test_driver::TestDriver;
use player_server::{
    Context, Driver, DriverBlock, DriverRegistry, Pace, Reply, Server, ServerConfig, ServerHandle,
};

/// Longest the server may take to answer anything (libplayerc's request timeout).
const ANSWER: Duration = Duration::from_secs(5);

/// The injected fault: publishes a pose every step; panics in `update` once commanded
/// (`panic_in` "update"), or in `handle_request` on RESET_ODOM (`panic_in` "request").
struct Faulty {
    addr: player_proto::DeviceAddr,
    steps: u64,
    armed: bool,
}

impl Driver for Faulty {
    fn update(&mut self, ctx: &mut Context<'_>) {
        if self.armed {
            panic!("injected fault in update after {} steps", self.steps);
        }
        self.steps += 1;
        publish_steps(ctx, self.addr, self.steps);
    }

    fn handle_command(&mut self, _ctx: &mut Context<'_>, _command: &player_proto::Message) {
        self.armed = true;
    }

    fn handle_request(&mut self, _ctx: &mut Context<'_>, request: &player_proto::Message) -> Reply {
        match &request.body {
            player_proto::Body::Position2d(player_proto::Position2dMsg::Req(
                Position2dReq::ResetOdom,
            )) => panic!("injected fault in handle_request"),
            player_proto::Body::Position2d(player_proto::Position2dMsg::Req(
                Position2dReq::GetGeom(_),
            )) => Reply::ack(Position2dReq::GetGeom(Some(Position2dGeom::default()))),
            _ => Reply::NotHandled,
        }
    }

    fn step(&self) -> Option<Duration> {
        Some(Duration::from_millis(20))
    }
}

/// Everything the server logs, kept for the assertions (the server runs in this process).
fn captured_log() -> &'static Arc<Mutex<Vec<u8>>> {
    static LOG: OnceLock<Arc<Mutex<Vec<u8>>>> = OnceLock::new();
    LOG.get_or_init(|| {
        let log = Arc::new(Mutex::new(Vec::new()));
        let writer = {
            let log = log.clone();
            move || LogWriter(log.clone())
        };
        tracing_subscriber::fmt()
            .with_writer(writer)
            .with_ansi(false)
            .with_max_level(tracing::Level::WARN)
            .init();
        log
    })
}

struct LogWriter(Arc<Mutex<Vec<u8>>>);

impl Write for LogWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn log_text() -> String {
    String::from_utf8_lossy(&captured_log().lock().unwrap()).into_owned()
}

/// Publishes a pose whose x counts the driver's steps (so a client sees data still coming).
fn publish_steps(ctx: &mut Context<'_>, addr: player_proto::DeviceAddr, steps: u64) {
    let state = Position2dDataState {
        pos: Pose2d {
            px: steps as f64,
            ..Pose2d::default()
        },
        ..Position2dDataState::default()
    };
    ctx.publish(addr, Position2dData::State(state));
}

/// Starts a real-time server on `listener` with `blocks`, failing the test on a refused block.
fn serve(
    registry: &mut DriverRegistry,
    port: u32,
    listener: std::net::TcpListener,
    blocks: &[&DriverBlock],
) -> ServerHandle {
    let mut server = Server::new(ServerConfig {
        pace: Pace::RealTime { speedup: 1.0 },
        ..ServerConfig::default()
    });
    for b in blocks {
        server
            .add_block(b, registry)
            .unwrap_or_else(|e: player_server::ServerError| panic!("{e}"));
    }
    server.use_listener(port, listener);
    server.start().unwrap()
}

/// A client with libplayerc's timeouts ([`ANSWER`]) for requests and reads.
fn connect(port: u16) -> PlayerClient {
    let client = PlayerClient::connect("localhost", port).unwrap();
    client.set_request_timeout(ANSWER);
    client.set_read_timeout(Some(ANSWER));
    client
}

/// Reads until `done` holds, failing after [`ANSWER`].
fn read_until(client: &PlayerClient, what: &str, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < ANSWER, "timed out waiting for {what}");
        match client.read() {
            Ok(()) | Err(ClientError::NoData | ClientError::Overflow { .. }) => {}
            Err(e) => panic!("reading while waiting for {what}: {e}"),
        }
    }
}

/// Waits until the captured log contains `text`.
fn wait_for_log(text: &str) -> String {
    let start = Instant::now();
    loop {
        let log = log_text();
        if log.contains(text) {
            return log;
        }
        assert!(start.elapsed() < ANSWER, "no {text:?} in the log:\n{log}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn a_panicking_driver_is_taken_out_of_service_and_the_server_carries_on() {
    captured_log();
    let (port, listener) = free_listener();
    let mut registry = DriverRegistry::new();
    TestDriver::register(&mut registry, "test");
    registry.register("faulty", |b: &DriverBlock| {
        let addr = b.provided(InterfaceCode::POSITION2D)?;
        Ok(Box::new(Faulty {
            addr,
            steps: 0,
            armed: false,
        }) as Box<dyn Driver>)
    });
    let healthy = block(
        "test",
        port,
        &[(InterfaceCode::POSITION2D, 0), (InterfaceCode::RANGER, 0)],
        &[("step_ms", "20")],
    );
    let mut in_update = block("faulty", port, &[(InterfaceCode::POSITION2D, 1)], &[]);
    in_update.provides[0].origin = "faulty.cfg:7".into();
    let in_request = block("faulty", port, &[(InterfaceCode::POSITION2D, 2)], &[]);
    let handle = serve(
        &mut registry,
        port,
        listener,
        &[&healthy, &in_update, &in_request],
    );
    let port = port as u16;

    // Client A uses a healthy device and both faulty ones; client B only the healthy one.
    let a = connect(port);
    let a_base = Position2dProxy::new(&a, 0).unwrap();
    let a_faulty = Position2dProxy::new(&a, 1).unwrap();
    let a_other = Position2dProxy::new(&a, 2).unwrap();
    let b = connect(port);
    let b_base = Position2dProxy::new(&b, 0).unwrap();
    let b_ranger = RangerProxy::new(&b, 0).unwrap();
    read_until(&a, "data from the device that will fail", || {
        a_faulty.state().is_some_and(|s| s.pos.px >= 2.0)
    });
    assert!(a_faulty.request_geom().is_ok());

    // The fault: a command arms it, its next update panics.
    a_faulty.set_speed(0.1, 0.0, 0.0).unwrap();
    let log = wait_for_log("panicked in update");
    assert!(
        log.contains(
            "driver \"faulty\" (faulty.cfg:7) panicked in update: injected fault in update"
        ),
        "{log}"
    );
    assert!(log.contains(&format!("{port}:position2d:1")), "{log}");
    assert!(log.contains("out of service"), "{log}");

    // Its subscriber gets no more of its data, and a NACK for a request to it.
    match a_faulty.request_geom() {
        Err(ClientError::Nack { .. }) => {}
        other => panic!("a request to the failed device: {other:?}"),
    }
    // (Data that arrived while the client waited for that reply is handled by its next
    // reads: read some rounds before taking the failed device's last value.)
    let healthy_rounds = |count: u32| {
        let mut rounds = 0;
        a_base.not_fresh();
        read_until(&a, "rounds of client A's healthy device", || {
            if a_base.is_fresh() {
                rounds += 1;
                a_base.not_fresh();
            }
            rounds >= count
        });
    };
    healthy_rounds(5);
    let last = a_faulty.state().unwrap().pos.px;
    healthy_rounds(20);
    assert_eq!(
        a_faulty.state().unwrap().pos.px,
        last,
        "data after the panic"
    );

    // A request that panics is answered (NACK) at once, not left to time out.
    let asked = Instant::now();
    match a_other.reset_odometry() {
        Err(ClientError::Nack { .. }) => {}
        other => panic!("the request that panicked: {other:?}"),
    }
    assert!(
        asked.elapsed() < Duration::from_secs(2),
        "{:?}",
        asked.elapsed()
    );
    let log = wait_for_log("panicked in handle_request");
    assert!(log.contains(&format!("{port}:position2d:2")), "{log}");

    // Client B never noticed: data keeps coming, requests are answered.
    let b_steps = b.datatime();
    read_until(&b, "client B's data to go on", || {
        b.datatime() > b_steps + 0.1 && !b_ranger.ranges().is_empty()
    });
    b_base.request_geom().unwrap();
    a_base.request_geom().unwrap();

    // A new client: the failed devices refuse it, the healthy ones serve it.
    let c = connect(port);
    match Position2dProxy::new(&c, 1) {
        Err(ClientError::Subscribe { index: 1, .. }) => {}
        other => panic!("subscribing to the failed device: {other:?}"),
    }
    let c_base = Position2dProxy::new(&c, 0).unwrap();
    read_until(&c, "the new client's data", || c_base.state().is_some());

    // Closing the failed devices is quietly accepted; so is leaving.
    drop((a_faulty, a_other));
    a_base.request_geom().unwrap();
    drop((a_base, b_base, b_ranger, c_base));
    drop((a, b, c));
    handle.shutdown();
}

/// The injected fault in a driver's own thread: the driver hands every command to its worker
/// thread (as amcl, wavefront and readlog hand their work to theirs), which panics on it.
struct Threaded {
    addr: player_proto::DeviceAddr,
    jobs: Option<std::sync::mpsc::Sender<()>>,
    worker: Option<player_server::WorkerThread>,
    steps: u64,
}

impl Driver for Threaded {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), player_server::DriverError> {
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let worker =
            player_server::WorkerThread::spawn("threaded-worker", ctx.waker(), move || {
                if rx.recv().is_ok() {
                    panic!("injected fault in a worker thread");
                }
            })
            .map_err(|e| player_server::DriverError::new(e.to_string()))?;
        self.jobs = Some(tx);
        self.worker = Some(worker);
        Ok(())
    }

    fn wake(&mut self, _ctx: &mut Context<'_>) {
        if let Some(w) = &mut self.worker {
            w.check();
        }
    }

    fn update(&mut self, ctx: &mut Context<'_>) {
        if let Some(w) = &mut self.worker {
            w.check();
        }
        self.steps += 1;
        publish_steps(ctx, self.addr, self.steps);
    }

    fn handle_command(&mut self, _ctx: &mut Context<'_>, _command: &player_proto::Message) {
        if let Some(jobs) = &self.jobs {
            let _ = jobs.send(());
        }
    }

    fn handle_request(&mut self, _ctx: &mut Context<'_>, request: &player_proto::Message) -> Reply {
        match &request.body {
            player_proto::Body::Position2d(player_proto::Position2dMsg::Req(
                Position2dReq::GetGeom(_),
            )) => Reply::ack(Position2dReq::GetGeom(Some(Position2dGeom::default()))),
            _ => Reply::NotHandled,
        }
    }

    fn step(&self) -> Option<Duration> {
        // slow on purpose: the worker's end must be noticed through the waker, not an update
        Some(Duration::from_secs(3600))
    }
}

#[test]
fn a_panic_in_a_drivers_own_thread_takes_it_out_of_service_and_the_server_carries_on() {
    captured_log();
    let (port, listener) = free_listener();
    let mut registry = DriverRegistry::new();
    TestDriver::register(&mut registry, "test");
    registry.register("threaded", |b: &DriverBlock| {
        let addr = b.provided(InterfaceCode::POSITION2D)?;
        Ok(Box::new(Threaded {
            addr,
            jobs: None,
            worker: None,
            steps: 0,
        }) as Box<dyn Driver>)
    });
    let healthy = block(
        "test",
        port,
        &[(InterfaceCode::POSITION2D, 0)],
        &[("step_ms", "20")],
    );
    let mut threaded = block("threaded", port, &[(InterfaceCode::POSITION2D, 1)], &[]);
    threaded.provides[0].origin = "threaded.cfg:3".into();
    let handle = serve(&mut registry, port, listener, &[&healthy, &threaded]);
    let port = port as u16;

    let a = connect(port);
    let a_base = Position2dProxy::new(&a, 0).unwrap();
    let a_threaded = Position2dProxy::new(&a, 1).unwrap();
    assert!(a_threaded.request_geom().is_ok());

    // The fault: a command reaches the worker, which panics; the driver is woken and the
    // panic raised in its `wake`, where the core catches it.
    a_threaded.set_speed(0.1, 0.0, 0.0).unwrap();
    let log = wait_for_log("panicked in wake");
    assert!(
        log.contains(
            "driver \"threaded\" (threaded.cfg:3) panicked in wake: its worker thread \
             \"threaded-worker\" panicked: injected fault in a worker thread"
        ),
        "{log}"
    );
    assert!(log.contains(&format!("{port}:position2d:1")), "{log}");

    // Its client gets a NACK, a new subscription is refused; the healthy device serves on.
    match a_threaded.request_geom() {
        Err(ClientError::Nack { .. }) => {}
        other => panic!("a request to the failed device: {other:?}"),
    }
    let steps = a.datatime();
    read_until(&a, "the healthy device's data to go on", || {
        a.datatime() > steps + 0.1
    });
    a_base.request_geom().unwrap();
    let c = PlayerClient::connect("localhost", port).unwrap();
    c.set_request_timeout(ANSWER);
    match Position2dProxy::new(&c, 1) {
        Err(ClientError::Subscribe { index: 1, .. }) => {}
        other => panic!("subscribing to the failed device: {other:?}"),
    }
    drop((a_base, a_threaded));
    drop((a, c));
    handle.shutdown();
}
