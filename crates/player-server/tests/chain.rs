//! Drivers that use devices, end to end over TCP: a chain started by one client subscription
//! and stopped by its unsubscribe, requires on a later block, data, requests and deferred
//! answers passing through, and the start-up errors of a cfg's `requires`, each naming its line.

mod common;

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use player_client::{PlayerClient, RangerProxy};
use player_proto::{
    Body, DeviceAddr, InterfaceCode, Message, RangerData, RangerDataRange, RangerGeom, RangerMsg,
    RangerReq,
};
use player_server::{
    Context, Driver, DriverBlock, DriverError, DriverRegistry, Pace, PendingReply, Reply,
    RequestError, RequestTicket, Server, ServerConfig, ServerError, ServerHandle, cfg,
};
use worldfile::{CfgFile, LoadOptions};

/// How often a source's setup and teardown ran: what a chain did to the device at its bottom.
#[derive(Default)]
struct Counts {
    setups: AtomicUsize,
    teardowns: AtomicUsize,
}

/// A ranger that publishes `[1, 2, 3]` every step while set up.
struct Source {
    addr: DeviceAddr,
    counts: Arc<Counts>,
    running: bool,
}

impl Driver for Source {
    fn setup(&mut self, _ctx: &mut Context<'_>) -> Result<(), DriverError> {
        self.counts.setups.fetch_add(1, Ordering::SeqCst);
        self.running = true;
        Ok(())
    }

    fn teardown(&mut self, _ctx: &mut Context<'_>) {
        self.counts.teardowns.fetch_add(1, Ordering::SeqCst);
        self.running = false;
    }

    fn update(&mut self, ctx: &mut Context<'_>) {
        assert!(self.running, "a torn-down driver is never stepped");
        let ranges = vec![1.0, 2.0, 3.0];
        ctx.publish(self.addr, RangerData::Range(RangerDataRange { ranges }));
    }

    fn handle_request(&mut self, _ctx: &mut Context<'_>, request: &Message) -> Reply {
        match &request.body {
            Body::Ranger(RangerMsg::Req(RangerReq::GetGeom(None))) => {
                Reply::ack(RangerReq::GetGeom(Some(RangerGeom {
                    element_poses: vec![Default::default(); 3],
                    element_sizes: vec![Default::default(); 3],
                    ..RangerGeom::default()
                })))
            }
            _ => Reply::NotHandled,
        }
    }

    fn step(&self) -> Option<Duration> {
        Some(Duration::from_millis(10))
    }
}

/// Requires a ranger, provides a ranger whose ranges are `factor` times the input's. It asks
/// its input for geometry at setup, and a GET_GEOM that arrives before that answer is deferred
/// until it comes: the framework's requests, replies and deferred answers in one driver.
struct Scaler {
    input: DeviceAddr,
    output: DeviceAddr,
    factor: f64,
    geom: Option<RangerGeom>,
    asked: Option<RequestTicket>,
    waiting: Vec<PendingReply>,
}

impl Scaler {
    fn from_block(block: &DriverBlock) -> Result<Scaler, DriverError> {
        let input = block.required(InterfaceCode::RANGER, None)?.addr;
        let output = block
            .provides
            .iter()
            .find(|p| p.addr.interf == InterfaceCode::RANGER)
            .ok_or_else(|| DriverError::new("must provide a ranger"))?
            .addr;
        let factor = block.option_parse("factor")?.unwrap_or(2.0);
        Ok(Scaler {
            input,
            output,
            factor,
            geom: None,
            asked: None,
            waiting: Vec::new(),
        })
    }
}

impl Driver for Scaler {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        ctx.subscribe(self.input);
        self.asked = Some(ctx.request(self.input, RangerReq::GetGeom(None)));
        Ok(())
    }

    fn teardown(&mut self, _ctx: &mut Context<'_>) {
        self.geom = None;
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        assert_eq!(data.header.addr.interf, InterfaceCode::RANGER);
        if let Body::Ranger(RangerMsg::Data(RangerData::Range(r))) = &data.body {
            let ranges = r.ranges.iter().map(|x| x * self.factor).collect();
            ctx.publish_at(
                self.output,
                RangerData::Range(RangerDataRange { ranges }),
                data.header.timestamp,
            );
        }
    }

    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        assert_eq!(Some(ticket), self.asked);
        let answer = match reply {
            Ok(Message {
                body: Body::Ranger(RangerMsg::Ack(RangerReq::GetGeom(Some(g)))),
                ..
            }) => {
                self.geom = Some(g.clone());
                Reply::ack(RangerReq::GetGeom(Some(g)))
            }
            _ => Reply::Nack,
        };
        for pending in self.waiting.drain(..) {
            ctx.answer(pending, answer.clone());
        }
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        match (&request.body, &self.geom) {
            (Body::Ranger(RangerMsg::Req(RangerReq::GetGeom(None))), Some(g)) => {
                Reply::ack(RangerReq::GetGeom(Some(g.clone())))
            }
            (Body::Ranger(RangerMsg::Req(RangerReq::GetGeom(None))), None) => match ctx.defer() {
                Some(p) => {
                    self.waiting.push(p);
                    Reply::Deferred
                }
                None => Reply::Nack,
            },
            _ => Reply::NotHandled,
        }
    }
}

fn registry(counts: &Arc<Counts>) -> DriverRegistry {
    let mut registry = DriverRegistry::new();
    let counts = counts.clone();
    registry.register("source", move |block: &DriverBlock| {
        Ok(Box::new(Source {
            addr: block.provides[0].addr,
            counts: counts.clone(),
            running: false,
        }) as Box<dyn Driver>)
    });
    registry.register("scaler", |block: &DriverBlock| {
        Ok(Box::new(Scaler::from_block(block)?) as Box<dyn Driver>)
    });
    registry
}

/// Builds a server from cfg text the way `player` does; the error is the first start-up error.
fn build(text: &str, counts: &Arc<Counts>) -> Result<Server, ServerError> {
    let cfgfile =
        CfgFile::parse(Path::new("chain.cfg"), text, &LoadOptions::default()).expect("cfg parses");
    let mut registry = registry(counts);
    let mut server = Server::new(ServerConfig {
        pace: Pace::default(),
        ..ServerConfig::default()
    });
    for block in cfg::driver_blocks(&cfgfile, 6665)? {
        server.add_block(&block, &mut registry)?;
    }
    server.resolve_requires()?;
    Ok(server)
}

fn serve(text: &str, counts: &Arc<Counts>) -> (ServerHandle, u16) {
    let server = build(text, counts).unwrap();
    let handle = server.start().unwrap();
    let port = handle.ports()[0];
    (handle, port)
}

fn wait_for(what: &str, mut ok: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(5);
    while !ok() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Reads until the proxy has ranges (the first rounds may predate the chain's first data).
fn ranges_of(client: &PlayerClient, proxy: &RangerProxy) -> Vec<f64> {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        client.read().unwrap();
        let r = proxy.ranges();
        if !r.is_empty() {
            return r;
        }
        assert!(Instant::now() < deadline, "no ranges arrived");
    }
}

#[test]
fn a_chain_starts_with_its_first_subscriber_and_stops_with_its_last() {
    let counts = Arc::new(Counts::default());
    // The top of the chain is written first: its requires name devices of later blocks.
    let (handle, port) = serve(
        "driver( name \"scaler\" provides [\"0:ranger:2\"] requires [\"0:ranger:1\"] factor 10 )\n\
         driver( name \"scaler\" provides [\"0:ranger:1\"] requires [\"0:ranger:0\"] )\n\
         driver( name \"source\" provides [\"0:ranger:0\"] )\n",
        &counts,
    );
    assert_eq!(
        counts.setups.load(Ordering::SeqCst),
        0,
        "nothing runs before a client"
    );

    let client = PlayerClient::connect("localhost", port).unwrap();
    let top = RangerProxy::new(&client, 2).unwrap();
    assert_eq!(
        counts.setups.load(Ordering::SeqCst),
        1,
        "one subscription started the chain"
    );
    // GET_GEOM travelled down the chain: each scaler asked the one below at setup and
    // answered (possibly deferred) once that answer came back.
    let geom = top.request_geom().unwrap();
    assert_eq!(geom.element_poses.len(), 3);
    assert_eq!(ranges_of(&client, &top), [20.0, 40.0, 60.0]);

    // A second client on the middle of the chain shares the running source.
    let other = PlayerClient::connect("localhost", port).unwrap();
    let middle = RangerProxy::new(&other, 1).unwrap();
    assert_eq!(ranges_of(&other, &middle), [2.0, 4.0, 6.0]);
    assert_eq!(counts.setups.load(Ordering::SeqCst), 1);

    drop(top);
    drop(client);
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(
        counts.teardowns.load(Ordering::SeqCst),
        0,
        "the middle still has a client"
    );
    drop(middle);
    wait_for("the source's teardown", || {
        counts.teardowns.load(Ordering::SeqCst) == 1
    });

    // And it starts again for a new subscriber.
    let top = RangerProxy::new(&other, 2).unwrap();
    assert_eq!(ranges_of(&other, &top), [20.0, 40.0, 60.0]);
    assert_eq!(counts.setups.load(Ordering::SeqCst), 2);
    drop(top);
    drop(other);
    wait_for("the second teardown", || {
        counts.teardowns.load(Ordering::SeqCst) == 2
    });
    handle.shutdown();
}

#[test]
fn alwayson_starts_the_chain_below_it() {
    let counts = Arc::new(Counts::default());
    let (handle, port) = serve(
        "driver( name \"source\" provides [\"0:ranger:0\"] )\n\
         driver( name \"scaler\" provides [\"0:ranger:1\"] requires [\"0:ranger:0\"] alwayson 1 )\n",
        &counts,
    );
    assert_eq!(counts.setups.load(Ordering::SeqCst), 1);
    let client = PlayerClient::connect("localhost", port).unwrap();
    let r = RangerProxy::new(&client, 1).unwrap();
    assert_eq!(ranges_of(&client, &r), [2.0, 4.0, 6.0]);
    drop(r);
    drop(client);
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(
        counts.teardowns.load(Ordering::SeqCst),
        0,
        "alwayson never stops"
    );
    handle.shutdown();
}

fn start_error(text: &str) -> String {
    match build(text, &Arc::new(Counts::default())) {
        Ok(_) => panic!("expected a start-up error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn start_up_errors_name_the_cfg_line() {
    // Nothing provides what is required (on a port this server serves).
    let e = start_error(
        "driver( name \"source\" provides [\"ranger:0\"] )\n\
         driver( name \"scaler\" provides [\"ranger:1\"] requires [\"ranger:5\"] )\n",
    );
    assert!(e.starts_with("chain.cfg:2"), "{e}");
    assert!(e.contains("requires") && e.contains("ranger:5"), "{e}");

    // A cycle.
    let e = start_error(
        "driver( name \"scaler\" provides [\"ranger:1\"] requires [\"ranger:2\"] )\n\
         driver( name \"scaler\" provides [\"ranger:2\"] requires [\"ranger:1\"] )\n",
    );
    assert!(e.starts_with("chain.cfg:1") && e.contains("cycle"), "{e}");
    assert!(e.contains("chain.cfg:2"), "{e}");

    // A required device of the wrong interface (the driver needs a ranger).
    let e = start_error(
        "driver( name \"source\" provides [\"laser:0\"] )\n\
         driver( name \"scaler\" provides [\"ranger:1\"] requires [\"laser:0\"] )\n",
    );
    assert!(e.starts_with("chain.cfg:2"), "{e}");
    assert!(e.contains("requires a ranger device"), "{e}");

    // An unknown driver.
    let e = start_error("driver( name \"vfh\" provides [\"position2d:0\"] )\n");
    assert!(
        e.starts_with("chain.cfg:1") && e.contains("couldn't find driver \"vfh\""),
        "{e}"
    );

    // An option of the wrong type.
    let e = start_error(
        "driver( name \"source\" provides [\"ranger:0\"] )\n\
         driver( name \"scaler\" provides [\"ranger:1\"] requires [\"ranger:0\"] factor \"big\" )\n",
    );
    assert!(e.starts_with("chain.cfg:2") && e.contains("factor"), "{e}");

    // A device on another server, with no way to reach it configured.
    let cfgfile = CfgFile::parse(
        Path::new("chain.cfg"),
        "driver( name \"scaler\" provides [\"ranger:1\"] requires [\"192.0.2.1:7000:ranger:0\"] )\n",
        &LoadOptions::default(),
    )
    .unwrap();
    let mut server = Server::new(ServerConfig::default());
    server.set_remote_factory(None);
    for block in cfg::driver_blocks(&cfgfile, 6665).unwrap() {
        server
            .add_block(&block, &mut registry(&Arc::new(Counts::default())))
            .unwrap();
    }
    let e = server.resolve_requires().unwrap_err().to_string();
    assert!(e.starts_with("chain.cfg:1") && e.contains("7000"), "{e}");
}

#[test]
fn remote_devices_are_listed_but_open_no_port() {
    let server = build(
        "driver( name \"scaler\" provides [\"ranger:1\"] requires [\"192.0.2.1:7000:ranger:0\"] )\n",
        &Arc::new(Counts::default()),
    )
    .unwrap();
    let remote: Vec<_> = server
        .table()
        .devices()
        .iter()
        .filter(|d| d.driver_name == "remote")
        .map(|d| (d.addr.robot, d.addr.interf, d.origin.clone()))
        .collect();
    assert_eq!(remote.len(), 1);
    assert_eq!(remote[0].0, 7000);
    assert_eq!(remote[0].1, InterfaceCode::RANGER);
    assert!(remote[0].2.starts_with("chain.cfg:1"), "{:?}", remote[0]);
    assert_eq!(server.table().ports(), [6665]);
}
