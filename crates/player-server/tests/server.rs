//! The server end to end over TCP, byte by byte as libplayerc speaks, with the test driver.

mod common;

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{RawClient, bigbob, block, free_listener, start, start_with};
use player_proto::constants::{LOCALHOST_ADDR, PLAYER_DATAMODE_PULL, PLAYER_DATAMODE_PUSH};
use player_proto::{
    AddReplaceRuleReq, Body, CapabilitiesReq, DeviceAddr, DeviceDriverinfo, HEADER_SIZE,
    InterfaceCode, MsgHeader, MsgType, PlayerMsg, PlayerReq, PlayerSynch, Pose2d, Position2dCmd,
    Position2dCmdVel, Position2dData, Position2dMsg, Position2dReq, RangerData, SimulationMsg,
    SimulationPose2dReq, SimulationReq, Text, UniversalMsg, UniversalReq,
};
use player_server::{Driver, DriverBlock, DriverError, Pace, Server, ServerConfig};

const P2D: InterfaceCode = InterfaceCode::POSITION2D;
const RANGER: InterfaceCode = InterfaceCode::RANGER;
const SIM: InterfaceCode = InterfaceCode::SIMULATION;

fn fast_server(
    devices: &[(InterfaceCode, u16)],
    options: &[(&str, &str)],
) -> (player_server::ServerHandle, u32) {
    let b = block("test", 0, devices, options);
    let server = start(&[b], Pace::AsFastAsPossible, Vec::new());
    let port = u32::from(server.ports()[0]);
    (server, port)
}

#[test]
fn banner_then_datamode_ack() {
    let (server, p1, _) = bigbob(false);
    let mut c = RawClient::connect(p1);
    c.send_player(PlayerReq::DataMode(Some(player_proto::DeviceDatamodeReq {
        mode: PLAYER_DATAMODE_PULL,
    })));
    let r = c.recv();
    assert_eq!(r.kind(), MsgType::RespAck);
    assert_eq!(
        r.header.addr,
        DeviceAddr::new(LOCALHOST_ADDR, p1, InterfaceCode::PLAYER, 0)
    );
    assert_eq!((r.header.subtype, r.header.size, r.header.seq), (5, 0, 0));
    drop(server);
}

#[test]
fn devlist_and_driverinfo_per_port() {
    let (_server, p1, p2) = bigbob(false);
    for (port, count) in [(p1, 5usize), (p2, 6)] {
        let mut c = RawClient::connect(port);
        c.send_player(PlayerReq::DevList(None));
        let r = c.recv();
        assert_eq!(r.kind(), MsgType::RespAck);
        assert_eq!(r.header.size as usize, 8 + 16 * count);
        let Body::Player(PlayerMsg::Ack(PlayerReq::DevList(Some(list)))) = r.decode() else {
            panic!()
        };
        assert!(
            list.devices
                .iter()
                .all(|d| d.robot == port && d.host == LOCALHOST_ADDR)
        );
        let first = if port == p1 { SIM } else { P2D };
        assert_eq!(list.devices[0].interf, first, "cfg order");
        for addr in list.devices {
            c.send_player(PlayerReq::DriverInfo(Some(DeviceDriverinfo {
                addr: DeviceAddr::new(0, 0, addr.interf, addr.index),
                driver_name: Text::empty(),
            })));
            let r = c.recv();
            assert_eq!((r.kind(), r.header.size), (MsgType::RespAck, 32));
            let Body::Player(PlayerMsg::Ack(PlayerReq::DriverInfo(Some(info)))) = r.decode() else {
                panic!()
            };
            assert_eq!(info.driver_name.as_bytes(), b"stage\0");
            assert_eq!(info.addr, addr);
        }
    }
}

#[test]
fn dev_ack_and_nack_bodies_as_recorded() {
    let (_server, p1, _) = bigbob(false);
    let mut c = RawClient::connect(p1);
    let r = c.dev(P2D, 0, 1);
    assert_eq!((r.kind(), r.header.size), (MsgType::RespAck, 36));
    let expect_ack = [
        "0100007f",
        &format!("{p1:08x}"),
        "00000004",
        "00000000",
        "00000001",
        "00000006",
        "00000006",
        "7374616765000000",
    ]
    .concat();
    assert_eq!(hex(&r.body), expect_ack);
    // Absent index and a device of the other port: NACK with a 28-byte body, access 3.
    for (interf, index) in [(RANGER, 5), (InterfaceCode::GRIPPER, 0)] {
        let r = c.dev(interf, index, 1);
        assert_eq!((r.kind(), r.header.size), (MsgType::RespNack, 28));
        let expect = [
            "0100007f".to_string(),
            format!("{p1:08x}"),
            format!("{:08x}", interf.0),
            format!("{index:08x}"),
            "00000003".into(),
            "00000000".into(),
            "00000000".into(),
        ]
        .concat();
        assert_eq!(hex(&r.body), expect);
        assert_eq!(r.header.addr.interf, InterfaceCode::PLAYER);
    }
    let r = c.dev(P2D, 0, 2);
    assert_eq!((r.kind(), r.header.size), (MsgType::RespAck, 36));
    assert_eq!(&r.body[16..20], &[0, 0, 0, 2]);
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

#[test]
fn pull_rounds_ack_first_data_then_synch() {
    let (_server, p1, _) = bigbob(true);
    let mut c = RawClient::connect(p1);
    c.datamode(PLAYER_DATAMODE_PULL);
    c.subscribe(P2D, 0);
    c.subscribe(RANGER, 0);
    let mut last_ts = -1.0;
    for _ in 0..3 {
        let round = c.round();
        assert_eq!(round[0].kind(), MsgType::RespAck);
        assert_eq!(round[0].header.subtype, PlayerReq::DATA);
        assert_eq!(round[0].header.size, 0);
        let synch = round.last().unwrap();
        assert_eq!(
            synch.header.addr,
            DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0)
        );
        assert_eq!(
            (synch.header.subtype, synch.header.size),
            (PlayerSynch::OK, 0)
        );
        let data = &round[1..round.len() - 1];
        assert!(!data.is_empty(), "a round carries at least one DATA");
        assert!(data.iter().all(|m| m.kind() == MsgType::Data));
        for m in data {
            m.decode(); // every body decodes completely
            if m.header.addr.interf == P2D {
                // Simulated time: small, increasing.
                assert!(m.header.timestamp > last_ts && m.header.timestamp < 1.0e6);
                last_ts = m.header.timestamp;
            }
        }
    }
}

#[test]
fn round_waits_for_data_instead_of_an_empty_synch() {
    // A client subscribed only to a silent device: the ACK comes, the SYNCH never does.
    let (_server, port) = fast_server(&[(SIM, 0)], &[]);
    let mut c = RawClient::connect(port);
    c.datamode(PLAYER_DATAMODE_PULL);
    c.subscribe(SIM, 0);
    c.send_player(PlayerReq::Data);
    assert_eq!(c.recv().kind(), MsgType::RespAck);
    assert!(c.recv_within(Duration::from_millis(300)).is_none());
}

#[test]
fn push_mode_streams_data_and_never_synch() {
    let (_server, port) = fast_server(&[(P2D, 0)], &[("step_ms", "10")]);
    let mut c = RawClient::connect(port);
    c.subscribe(P2D, 0);
    for _ in 0..50 {
        let m = c.recv();
        assert_eq!(m.kind(), MsgType::Data);
    }
}

#[test]
fn replace_rule_keeps_one_data_per_device_and_subtype() {
    let (_server, port) = fast_server(&[(P2D, 0), (RANGER, 0)], &[("step_ms", "10")]);
    let mut c = RawClient::connect(port);
    c.datamode(PLAYER_DATAMODE_PULL);
    c.send_player(PlayerReq::AddReplaceRule(Some(AddReplaceRuleReq {
        interf: -1,
        index: -1,
        msg_type: 1,
        subtype: -1,
        replace: 1,
    })));
    let (r, _) = c.recv_reply();
    assert_eq!((r.kind(), r.header.size), (MsgType::RespAck, 0));
    c.subscribe(P2D, 0);
    c.subscribe(RANGER, 0);
    std::thread::sleep(Duration::from_millis(100));
    for _ in 0..3 {
        let round = c.round();
        let data: Vec<_> = round
            .iter()
            .filter(|m| m.kind() == MsgType::Data)
            .map(|m| (m.header.addr.interf, m.header.subtype))
            .collect();
        let mut unique = data.clone();
        unique.sort_by_key(|&(i, s)| (i.0, s));
        unique.dedup();
        assert_eq!(data.len(), unique.len(), "{data:?}");
        assert_eq!(
            data.len(),
            3,
            "position2d STATE, ranger RANGE, ranger INTNS"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn overflow_ends_the_next_round_with_synch_overflow() {
    let (_server, port) = fast_server(&[(RANGER, 0)], &[("step_ms", "1")]);
    let mut c = RawClient::connect(port);
    c.datamode(PLAYER_DATAMODE_PULL);
    c.subscribe(RANGER, 0);
    // Fast pace: 2 DATA per step, thousands of steps per second.
    std::thread::sleep(Duration::from_millis(1500));
    let round = c.round();
    let data = round.iter().filter(|m| m.kind() == MsgType::Data).count();
    assert_eq!(data, 1024, "the queue holds 1024 DATA at most");
    let synch = round.last().unwrap();
    assert_eq!(
        (synch.header.subtype, synch.header.size),
        (PlayerSynch::OVERFLOW, 4)
    );
    let Body::Player(PlayerMsg::Synch(PlayerSynch::Overflow(n))) = synch.decode() else {
        panic!()
    };
    assert!(n.value > 0);
}

#[test]
fn unknown_device_requests_are_dropped_and_unhandled_ones_nacked() {
    let (_server, port) = fast_server(&[(P2D, 0), (SIM, 0)], &[]);
    let mut c = RawClient::connect(port);
    // position2d:7 does not exist: no reply at all.
    c.send_device(P2D, 7, Position2dReq::GetGeom(None));
    assert!(c.recv_within(Duration::from_millis(300)).is_none());
    // Unhandled request: empty NACK addressed to the device, request subtype.
    c.send_device(P2D, 0, Position2dReq::SpeedPid(Some(Default::default())));
    let r = c.recv();
    assert_eq!(r.kind(), MsgType::RespNack);
    assert_eq!(r.header.addr, DeviceAddr::new(LOCALHOST_ADDR, port, P2D, 0));
    assert_eq!(
        (r.header.subtype, r.header.size),
        (Position2dReq::SPEED_PID, 0)
    );
    // A handled one: ACK with the geometry body (72 bytes), without subscribing first.
    c.send_device(P2D, 0, Position2dReq::GetGeom(None));
    let r = c.recv();
    assert_eq!((r.kind(), r.header.size), (MsgType::RespAck, 72));
    // Capabilities: simulation pose requests yes, position2d no.
    let cap = |subtype: u8| {
        Body::Universal(UniversalMsg::Req(UniversalReq::Capabilities(Some(
            CapabilitiesReq {
                msg_type: 3,
                subtype: u32::from(subtype),
            },
        ))))
    };
    c.send_device(SIM, 0, cap(SimulationReq::GET_POSE2D));
    let r = c.recv();
    assert_eq!(
        (r.kind(), r.header.subtype, r.header.size),
        (MsgType::RespAck, 255, 0)
    );
    c.send_device(P2D, 0, cap(Position2dReq::GET_GEOM));
    assert_eq!(c.recv().kind(), MsgType::RespNack);
    // A request subtype the table lacks, without body: NACK.
    let h = MsgHeader::new(DeviceAddr::new(0, port, P2D, 0), MsgType::Req, 99, 0.0);
    c.send_bytes(&h.to_bytes());
    let r = c.recv();
    assert_eq!((r.kind(), r.header.subtype), (MsgType::RespNack, 99));
    // Simulation: known model answered, unknown NACKed.
    let get = |name: &str| {
        SimulationReq::GetPose2d(Some(SimulationPose2dReq {
            name: Text::new(name),
            pose: Pose2d::default(),
        }))
    };
    c.send_device(SIM, 0, get("bob1"));
    let r = c.recv();
    assert_eq!((r.kind(), r.header.size), (MsgType::RespAck, 40));
    assert!(matches!(
        r.decode(),
        Body::Simulation(SimulationMsg::Ack(SimulationReq::GetPose2d(Some(_))))
    ));
    c.send_device(SIM, 0, get("nobody"));
    assert_eq!(c.recv().kind(), MsgType::RespNack);
}

#[test]
fn malformed_input_closes_only_that_client() {
    let (_server, port) = fast_server(&[(P2D, 0)], &[("step_ms", "10")]);
    let mut good = RawClient::connect(port);
    good.datamode(PLAYER_DATAMODE_PULL);
    good.subscribe(P2D, 0);

    // A header announcing a body far over the limit.
    let mut bad = RawClient::connect(port);
    let mut h = MsgHeader::new(
        DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0),
        MsgType::Req,
        1,
        0.0,
    );
    h.size = 64 << 20;
    bad.send_bytes(&h.to_bytes());
    assert!(bad.closed_within(Duration::from_secs(2)));

    // A truncated DEV body.
    let mut bad = RawClient::connect(port);
    let h = MsgHeader {
        size: 8,
        ..MsgHeader::new(
            DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0),
            MsgType::Req,
            3,
            0.0,
        )
    };
    let mut bytes = h.to_bytes().to_vec();
    bytes.extend([0u8; 8]);
    bad.send_bytes(&bytes);
    assert!(bad.closed_within(Duration::from_secs(2)));

    // An unknown message type byte.
    let mut bad = RawClient::connect(port);
    let mut bytes = MsgHeader::new(
        DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0),
        MsgType::Req,
        1,
        0.0,
    )
    .to_bytes();
    bytes[19] = 9;
    bad.send_bytes(&bytes);
    assert!(bad.closed_within(Duration::from_secs(2)));

    // The good client is unaffected.
    let round = good.round();
    assert!(round.iter().any(|m| m.kind() == MsgType::Data));
}

/// Records subscription events, to see what the server tells drivers.
struct Recorder(Arc<Mutex<Vec<String>>>);

impl Driver for Recorder {
    fn subscribe(&mut self, addr: DeviceAddr) -> Result<(), DriverError> {
        self.0.lock().unwrap().push(format!("+{}", addr.interf));
        Ok(())
    }
    fn unsubscribe(&mut self, addr: DeviceAddr) -> Result<(), DriverError> {
        self.0.lock().unwrap().push(format!("-{}", addr.interf));
        Ok(())
    }
}

#[test]
fn vanished_clients_are_unsubscribed_and_others_continue() {
    let events = Arc::new(Mutex::new(Vec::new()));
    let (port, listener) = free_listener();
    let b = block("rec", port, &[(P2D, 0), (RANGER, 0)], &[]);
    let mut server = Server::new(ServerConfig::default());
    server
        .add_driver(&b, Box::new(Recorder(events.clone())))
        .unwrap();
    server.use_listener(port, listener);
    let _server = server.start().unwrap();

    let mut a = RawClient::connect(port);
    a.subscribe(P2D, 0);
    a.subscribe(P2D, 0); // twice: two subscriptions
    a.subscribe(RANGER, 0);
    // Half a header, then gone.
    a.send_bytes(&[0u8; 20]);
    drop(a);
    let deadline = Instant::now() + Duration::from_secs(3);
    while events.lock().unwrap().len() < 6 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
    let mut got = events.lock().unwrap().clone();
    assert_eq!(&got[..3], ["+position2d", "+position2d", "+ranger"]);
    got[3..].sort();
    assert_eq!(&got[3..], ["-position2d", "-position2d", "-ranger"]);

    let mut b = RawClient::connect(port);
    let r = b.dev(P2D, 0, 1);
    assert_eq!(r.kind(), MsgType::RespAck);
}

#[test]
fn duplicate_subscription_duplicates_data() {
    let (_server, port) = fast_server(&[(P2D, 0)], &[("step_ms", "50"), ("sim_clock", "1")]);
    let mut c = RawClient::connect(port);
    c.subscribe(P2D, 0);
    c.subscribe(P2D, 0);
    // PUSH mode: every sample arrives twice, same bytes.
    for _ in 0..5 {
        let a = c.recv();
        let b = c.recv();
        assert_eq!(a.kind(), MsgType::Data);
        assert_eq!((a.header.timestamp, &a.body), (b.header.timestamp, &b.body));
    }
    // One close removes one copy.
    c.datamode(PLAYER_DATAMODE_PULL);
    let r = c.dev(P2D, 0, 2);
    assert_eq!(&r.body[16..20], &[0, 0, 0, 2]);
    c.round(); // drain what accumulated
    let round = c.round();
    let ts: Vec<f64> = round
        .iter()
        .filter(|m| m.kind() == MsgType::Data)
        .map(|m| m.header.timestamp)
        .collect();
    let mut dedup = ts.clone();
    dedup.dedup();
    assert_eq!(ts, dedup, "no duplicates after one unsubscribe");
}

#[test]
fn two_ports_each_see_their_own_devices() {
    let (_server, p1, p2) = bigbob(false);
    let mut a = RawClient::connect(p1);
    let mut b = RawClient::connect(p2);
    assert_eq!(a.dev(SIM, 0, 1).kind(), MsgType::RespAck);
    assert_eq!(b.dev(SIM, 0, 1).kind(), MsgType::RespNack);
    assert_eq!(
        a.dev(InterfaceCode::GRIPPER, 0, 1).kind(),
        MsgType::RespNack
    );
    assert_eq!(b.dev(InterfaceCode::GRIPPER, 0, 1).kind(), MsgType::RespAck);
    // position2d:0 on each port is a different device: commands reach only their own.
    a.subscribe(P2D, 0);
    b.subscribe(P2D, 0);
    b.send_device(
        P2D,
        0,
        Position2dCmd::Vel(Position2dCmdVel {
            vel: Pose2d {
                px: 1.0,
                py: 0.0,
                pa: 0.0,
            },
            state: 1,
        }),
    );
    std::thread::sleep(Duration::from_millis(400));
    let vx = |c: &mut RawClient| {
        let mut v = None;
        for _ in 0..6 {
            let m = c.recv();
            if let Body::Position2d(Position2dMsg::Data(Position2dData::State(s))) = m.decode() {
                assert_eq!(m.header.addr.robot, c.port);
                v = Some(s.vel.px);
            }
        }
        v.expect("position data")
    };
    assert_eq!(vx(&mut a), 0.0);
    assert_eq!(vx(&mut b), 1.0);
}

#[test]
fn a_client_that_never_reads_is_closed_at_the_hard_limit() {
    let mut config = ServerConfig {
        pace: Pace::AsFastAsPossible,
        ..ServerConfig::default()
    };
    config.limits.queue.hard_len = 64;
    let devices: Vec<(InterfaceCode, u16)> = (0..100).map(|i| (RANGER, i)).collect();
    let server = start_with(
        &[block("test", 0, &devices, &[("silent", "1")])],
        config,
        Vec::new(),
    );
    let port = u32::from(server.ports()[0]);
    let mut hog = RawClient::connect(port);
    let mut other = RawClient::connect(port);
    // DEVLIST replies of 1608 bytes each, never read.
    let req = player_proto::Message::new(
        DeviceAddr::new(0, 0, InterfaceCode::PLAYER, 0),
        0.0,
        PlayerReq::DevList(None),
    )
    .encode()
    .unwrap();
    let burst: Vec<u8> = req
        .iter()
        .copied()
        .cycle()
        .take(req.len() * 20_000)
        .collect();
    hog.stream
        .set_write_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    use std::io::Write;
    let _ = hog.stream.write_all(&burst); // may fail once the server closes
    assert!(hog.closed_within(Duration::from_secs(10)));
    other.send_player(PlayerReq::DevList(None));
    assert_eq!(other.recv().header.size as usize, 8 + 16 * 100);
}

#[test]
fn many_clients_on_one_device() {
    let b = block("test", 0, &[(RANGER, 0)], &[("step_ms", "20")]);
    let server = start(&[b], Pace::RealTime { speedup: 1.0 }, Vec::new());
    let port = u32::from(server.ports()[0]);
    let mut clients: Vec<RawClient> = (0..20).map(|_| RawClient::connect(port)).collect();
    for c in &mut clients {
        c.datamode(PLAYER_DATAMODE_PULL);
        c.subscribe(RANGER, 0);
    }
    for c in &mut clients {
        let round = c.round();
        let ranges = round
            .iter()
            .filter(|m| {
                matches!(
                    m.decode(),
                    Body::Ranger(player_proto::RangerMsg::Data(RangerData::Range(_)))
                )
            })
            .count();
        assert!(ranges >= 1);
    }
}

#[test]
fn simulated_clock_stamps_replies_and_data() {
    let (server, port) = fast_server(&[(P2D, 0)], &[("sim_clock", "1"), ("step_ms", "100")]);
    let mut c = RawClient::connect(port);
    c.subscribe(P2D, 0);
    let m = c.recv();
    assert!(
        m.header.timestamp > 0.0 && m.header.timestamp < 1.0e5,
        "{}",
        m.header.timestamp
    );
    // Samples are one step apart.
    let n = c.recv();
    let step = n.header.timestamp - m.header.timestamp;
    assert!((step - 0.1).abs() < 1e-9, "{step}");
    assert!(server.clock().is_simulated());
    let _ = HEADER_SIZE;
}

#[test]
fn start_up_errors_name_the_cfg_place() {
    let mut registry = player_server::DriverRegistry::new();
    player_server::test_driver::TestDriver::register(&mut registry, "test");
    let mut server = Server::new(ServerConfig::default());
    let mut b = block("stage", 0, &[(P2D, 0)], &[]);
    b.origin = "bigbob.cfg:7".into();
    let err = server.add_block(&b, &mut registry).unwrap_err().to_string();
    assert_eq!(
        err,
        "bigbob.cfg:7: couldn't find driver \"stage\" (known drivers: test)"
    );
    let ok = block("test", 0, &[(P2D, 0)], &[]);
    server.add_block(&ok, &mut registry).unwrap();
    let dup = block("test", 0, &[(RANGER, 0), (P2D, 0)], &[]);
    let err = server
        .add_block(&dup, &mut registry)
        .unwrap_err()
        .to_string();
    assert!(err.contains("duplicate device addr"), "{err}");
    assert_eq!(server.table().len(), 1, "a refused block adds nothing");
    let bad = block("test", 0, &[(RANGER, 0)], &[("step_ms", "fast")]);
    let err = server
        .add_block(&bad, &mut registry)
        .unwrap_err()
        .to_string();
    assert_eq!(
        err,
        "test.cfg:1: driver \"test\" failed to start: option `step_ms` has an invalid value \"fast\""
    );
    let empty = DriverBlock {
        name: "test".into(),
        origin: "x.cfg:2".into(),
        ..Default::default()
    };
    let err = server
        .add_block(&empty, &mut registry)
        .unwrap_err()
        .to_string();
    assert_eq!(err, "x.cfg:2: driver \"test\" has no (usable) interfaces");
    let _ = PLAYER_DATAMODE_PUSH;
}
