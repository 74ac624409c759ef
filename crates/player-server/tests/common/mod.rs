//! Test helpers: servers with the test driver on ephemeral ports, a raw byte-level client, and
//! the shared reference material.

#![allow(dead_code)] // each test binary uses a different subset

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::{Duration, Instant};

use player_proto::constants::LOCALHOST_ADDR;
use player_proto::{
    BANNER, Body, DecodeLimits, DeviceAddr, DeviceReq, HEADER_SIZE, InterfaceCode, Message,
    MsgHeader, MsgType, PlayerMsg, PlayerReq, Text,
};
use player_server::test_driver::TestDriver;
use player_server::{DriverBlock, DriverRegistry, Pace, Server, ServerConfig, ServerHandle};

#[allow(unused_imports)] // test binaries each use a different subset
pub use test_support::shared;

/// A free port, kept bound so nobody else takes it before the server does.
pub fn free_listener() -> (u32, TcpListener) {
    let l = TcpListener::bind("0.0.0.0:0").unwrap();
    (u32::from(l.local_addr().unwrap().port()), l)
}

/// A driver block for the test driver (registered as `name`) providing `devices` on `port`.
pub fn block(
    name: &str,
    port: u32,
    devices: &[(InterfaceCode, u16)],
    options: &[(&str, &str)],
) -> DriverBlock {
    let provides = devices
        .iter()
        .map(|&(interf, index)| DeviceAddr::new(LOCALHOST_ADDR, port, interf, index));
    let block = DriverBlock::new(name, "test.cfg:1").providing(provides, "test.cfg:1");
    options.iter().fold(block, |block, (key, values)| {
        block.with_option(key, values.split(' '))
    })
}

/// Starts a server whose blocks are built by the test driver registered as `stage` and `test`.
/// `listeners` supplies pre-bound ports.
pub fn start(
    blocks: &[DriverBlock],
    pace: Pace,
    listeners: Vec<(u32, TcpListener)>,
) -> ServerHandle {
    start_with(
        blocks,
        ServerConfig {
            pace,
            ..ServerConfig::default()
        },
        listeners,
    )
}

/// As [`start`], with a full config.
pub fn start_with(
    blocks: &[DriverBlock],
    config: ServerConfig,
    listeners: Vec<(u32, TcpListener)>,
) -> ServerHandle {
    let mut registry = DriverRegistry::new();
    TestDriver::register(&mut registry, "stage");
    TestDriver::register(&mut registry, "test");
    let mut server = Server::new(config);
    for b in blocks {
        server.add_block(b, &mut registry).unwrap();
    }
    for (port, l) in listeners {
        server.use_listener(port, l);
    }
    server.start().unwrap()
}

/// The devices of the recorded sessions' `bigbob.cfg` (Stage's own interfaces only), on two
/// ports, served by test drivers named `stage`.
pub fn bigbob(sim_clock: bool) -> (ServerHandle, u32, u32) {
    let (p1, l1) = free_listener();
    let (p2, l2) = free_listener();
    let opts: &[(&str, &str)] = if sim_clock {
        &[("sim_clock", "1"), ("models", "bob1 bob2 orange1 carton1")]
    } else {
        &[("models", "bob1 bob2 orange1 carton1")]
    };
    let mut sim = block("stage", p1, &[(InterfaceCode::SIMULATION, 0)], opts);
    sim.alwayson = Some(true);
    let bob1 = block(
        "stage",
        p1,
        &[
            (InterfaceCode::POSITION2D, 0),
            (InterfaceCode::RANGER, 0),
            (InterfaceCode::BLOBFINDER, 0),
            (InterfaceCode::RANGER, 1),
        ],
        &[],
    );
    let bob2 = block(
        "stage",
        p2,
        &[
            (InterfaceCode::POSITION2D, 0),
            (InterfaceCode::RANGER, 0),
            (InterfaceCode::BLOBFINDER, 0),
            (InterfaceCode::RANGER, 1),
            (InterfaceCode::GRIPPER, 0),
            (InterfaceCode::FIDUCIAL, 0),
        ],
        &[],
    );
    let server = start(
        &[sim, bob1, bob2],
        Pace::RealTime { speedup: 1.0 },
        vec![(p1, l1), (p2, l2)],
    );
    (server, p1, p2)
}

/// A received message: header and raw body.
#[derive(Clone, Debug)]
pub struct Raw {
    pub header: MsgHeader,
    pub body: Vec<u8>,
}

impl Raw {
    pub fn kind(&self) -> MsgType {
        self.header.kind().unwrap()
    }

    pub fn decode(&self) -> Body {
        Message::decode(self.header, &self.body, &DecodeLimits::default())
            .unwrap()
            .body
    }
}

/// A byte-level client, as libplayerc would speak (host 0; robot 0 for the player interface).
pub struct RawClient {
    pub stream: TcpStream,
    pub port: u32,
}

impl RawClient {
    /// Connects and checks the banner.
    pub fn connect(port: u32) -> RawClient {
        let mut stream = TcpStream::connect(("127.0.0.1", port as u16)).unwrap();
        stream.set_nodelay(true).unwrap();
        stream
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        let mut banner = [0u8; 32];
        stream.read_exact(&mut banner).unwrap();
        assert_eq!(banner, BANNER);
        RawClient { stream, port }
    }

    pub fn send_bytes(&mut self, bytes: &[u8]) {
        self.stream.write_all(bytes).unwrap();
    }

    /// Sends a message to the player interface.
    pub fn send_player(&mut self, body: impl Into<Body>) {
        let msg = Message::new(DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0), 1.0, body);
        self.send_bytes(&msg.encode().unwrap());
    }

    /// Sends a message to a device of this port.
    pub fn send_device(&mut self, interf: InterfaceCode, index: u16, body: impl Into<Body>) {
        let addr = DeviceAddr::new(0, self.port, interf, index);
        let msg = Message::new(addr, 1.0, body);
        self.send_bytes(&msg.encode().unwrap());
    }

    /// Reads one message, or `None` if nothing arrives within `timeout` or the server closed.
    pub fn recv_within(&mut self, timeout: Duration) -> Option<Raw> {
        self.stream.set_read_timeout(Some(timeout)).unwrap();
        let mut head = [0u8; HEADER_SIZE];
        match self.stream.read_exact(&mut head) {
            Ok(()) => {}
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                return None;
            }
            Err(e) if e.kind() == ErrorKind::UnexpectedEof => return None,
            Err(e) if e.kind() == ErrorKind::ConnectionReset => return None,
            Err(e) => panic!("{e}"),
        }
        let header = MsgHeader::from_bytes(&head).unwrap();
        let mut body = vec![0u8; header.size as usize];
        self.stream
            .set_read_timeout(Some(Duration::from_secs(5)))
            .unwrap();
        self.stream.read_exact(&mut body).unwrap();
        Some(Raw { header, body })
    }

    /// Reads one message (5 s timeout).
    pub fn recv(&mut self) -> Raw {
        self.recv_within(Duration::from_secs(5))
            .expect("no message within 5 s")
    }

    /// Reads until a non-DATA message; returns it and the DATA seen before it.
    pub fn recv_reply(&mut self) -> (Raw, Vec<Raw>) {
        let mut data = Vec::new();
        loop {
            let m = self.recv();
            if m.kind() == MsgType::Data {
                data.push(m);
            } else {
                return (m, data);
            }
        }
    }

    /// True when the server closed the connection (EOF) within `timeout`, skipping anything
    /// it sends before.
    pub fn closed_within(&mut self, timeout: Duration) -> bool {
        let end = Instant::now() + timeout;
        let mut buf = [0u8; 4096];
        while Instant::now() < end {
            self.stream
                .set_read_timeout(Some(Duration::from_millis(50)))
                .unwrap();
            match self.stream.read(&mut buf) {
                Ok(0) => return true,
                Ok(_) => {}
                Err(e) if e.kind() == ErrorKind::ConnectionReset => return true,
                Err(_) => {}
            }
        }
        false
    }

    /// DATAMODE request, expecting its ACK.
    pub fn datamode(&mut self, mode: u8) {
        self.send_player(PlayerReq::DataMode(Some(player_proto::DeviceDatamodeReq {
            mode,
        })));
        let (r, _) = self.recv_reply();
        assert_eq!(r.kind(), MsgType::RespAck);
        assert_eq!(r.header.subtype, PlayerReq::DATAMODE);
    }

    /// DEV request; returns the reply.
    pub fn dev(&mut self, interf: InterfaceCode, index: u16, access: u8) -> Raw {
        self.send_player(PlayerReq::Dev(Some(DeviceReq {
            addr: DeviceAddr::new(0, 0, interf, index),
            access,
            driver_name: Text::empty(),
        })));
        self.recv_reply().0
    }

    /// Subscribes, asserting the ACK with access 1.
    pub fn subscribe(&mut self, interf: InterfaceCode, index: u16) {
        let r = self.dev(interf, index, 1);
        assert_eq!(r.kind(), MsgType::RespAck, "subscribe {interf}:{index}");
        let Body::Player(PlayerMsg::Ack(PlayerReq::Dev(Some(d)))) = r.decode() else {
            panic!()
        };
        assert_eq!(d.access, 1);
    }

    /// One REQ_DATA round: the ACK, then everything up to and including the SYNCH.
    pub fn round(&mut self) -> Vec<Raw> {
        self.send_player(PlayerReq::Data);
        let mut out = Vec::new();
        loop {
            let m = self.recv();
            let done = m.kind() == MsgType::Synch;
            out.push(m);
            if done {
                return out;
            }
        }
    }
}
