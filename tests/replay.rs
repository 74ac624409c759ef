//! Replays every recorded conformance session (`shared/conformance/sessions/`, real libplayerc,
//! libplayerc++, playerprint and playerv 3.0.2 clients against the real Player 3.0.2 + Stage
//! 4.1.1) against our server running the recorded world, following the procedure of the
//! sessions' README: the client's bytes are sent unchanged, each after as many non-DATA replies
//! as the recording shows before it, and the replies are compared — the non-DATA sequence
//! exactly (type, subtype, interface, index, host, port, size, ACK vs NACK), reply bodies field
//! by field except simulated and uninitialised values, DATA by kind, size and round structure.
//! A fresh server per session; the two-port pair runs concurrently on one server.

mod common;

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use common::{Running, conformance_cfg, serve_cfg, shared};
use player_proto::{
    BANNER, Body, DecodeLimits, FiducialReq, HEADER_SIZE, InterfaceCode, Message, MsgHeader,
    MsgType, PlayerMsg, PlayerReq, Position2dReq, SimulationReq,
};
use player_server::Pace;
use serde_json::Value as Json;

fn hex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

/// One recorded or received message: header and raw body.
#[derive(Clone, Debug)]
struct Raw {
    header: MsgHeader,
    body: Vec<u8>,
}

impl Raw {
    fn from_json(m: &Json) -> Raw {
        let h = hex(m["header_hex"].as_str().unwrap());
        Raw {
            header: MsgHeader::from_bytes(h[..HEADER_SIZE].try_into().unwrap()).unwrap(),
            body: hex(m["body_hex"].as_str().unwrap()),
        }
    }

    fn kind(&self) -> MsgType {
        self.header.kind().unwrap()
    }

    fn is_data(&self) -> bool {
        self.kind() == MsgType::Data
    }

    /// (interface, index, subtype) of a DATA message.
    fn data_kind(&self) -> (u16, u16, u8) {
        let a = &self.header.addr;
        (a.interf.0, a.index, self.header.subtype)
    }

    fn is_req_data_ack(&self) -> bool {
        self.kind() == MsgType::RespAck
            && self.header.addr.interf == InterfaceCode::PLAYER
            && self.header.subtype == PlayerReq::DATA
    }
}

/// A session's connection to our server.
struct Conn {
    stream: TcpStream,
    buf: Vec<u8>,
    closed: bool,
}

impl Conn {
    fn connect(port: u16) -> Conn {
        let mut stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
        stream.set_nodelay(true).unwrap();
        let mut banner = [0u8; 32];
        stream.read_exact(&mut banner).unwrap();
        assert_eq!(banner, BANNER, "banner");
        Conn {
            stream,
            buf: Vec::new(),
            closed: false,
        }
    }

    /// The next message, or `None` at `deadline` or when the server closed.
    fn recv(&mut self, deadline: Instant) -> Option<Raw> {
        loop {
            if self.buf.len() >= HEADER_SIZE {
                let header =
                    MsgHeader::from_bytes(self.buf[..HEADER_SIZE].try_into().unwrap()).unwrap();
                let total = HEADER_SIZE + header.size as usize;
                if self.buf.len() >= total {
                    let body = self.buf[HEADER_SIZE..total].to_vec();
                    self.buf.drain(..total);
                    return Some(Raw { header, body });
                }
            }
            let left = deadline.checked_duration_since(Instant::now())?;
            if self.closed {
                return None;
            }
            self.stream
                .set_read_timeout(Some(left.max(Duration::from_millis(1))))
                .unwrap();
            let mut chunk = [0u8; 65536];
            match self.stream.read(&mut chunk) {
                Ok(0) => self.closed = true,
                Ok(n) => self.buf.extend_from_slice(&chunk[..n]),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    return None;
                }
                Err(_) => self.closed = true,
            }
        }
    }
}

/// What one replay produced.
struct Replayed {
    /// Every message received, in order.
    got: Vec<Raw>,
}

/// Sends the session's client bytes to `port`, each after as many non-DATA replies as the
/// recording shows before it and not before its recorded time (so the simulation has run as
/// far as it had in the recording); then collects the remaining replies.
fn drive(doc: &Json, port: u16) -> Replayed {
    let mut conn = Conn::connect(port);
    let start = Instant::now();
    let mut got = Vec::new();
    let mut non_data = 0usize;
    let mut recorded_non_data = 0usize;
    let step = Duration::from_secs(10);
    let read_until = |conn: &mut Conn, got: &mut Vec<Raw>, non_data: &mut usize, want: usize| {
        let deadline = Instant::now() + step;
        while *non_data < want {
            let Some(m) = conn.recv(deadline) else { break };
            if !m.is_data() {
                *non_data += 1;
            }
            got.push(m);
        }
    };
    for m in doc["messages"].as_array().unwrap() {
        if m["dir"] == "s2c" {
            if m["type_name"] != "DATA" {
                recorded_non_data += 1;
            }
            continue;
        }
        read_until(&mut conn, &mut got, &mut non_data, recorded_non_data);
        let at = start + Duration::from_secs_f64(m["t"].as_f64().unwrap_or(0.0));
        let deadline = at.max(Instant::now());
        while let Some(m) = conn.recv(deadline) {
            if !m.is_data() {
                non_data += 1;
            }
            got.push(m);
        }
        let mut bytes = hex(m["header_hex"].as_str().unwrap());
        bytes.extend(hex(m["body_hex"].as_str().unwrap()));
        if conn.stream.write_all(&bytes).is_err() {
            break;
        }
    }
    // The recorded replies, and for a session whose server crashed (c_capability) the replies
    // the crash swallowed: one per request sent after it.
    let requests_after_crash = if doc["connection_events"][0]["dir"] == "s2c" {
        requests_after_last_reply(doc)
    } else {
        0
    };
    read_until(
        &mut conn,
        &mut got,
        &mut non_data,
        recorded_non_data + requests_after_crash,
    );
    // Anything else would be a surplus reply: give it a moment to show up.
    let deadline = Instant::now() + Duration::from_millis(200);
    while let Some(m) = conn.recv(deadline) {
        got.push(m);
    }
    Replayed { got }
}

/// REQ messages the client sent after the recording's last reply.
fn requests_after_last_reply(doc: &Json) -> usize {
    let messages = doc["messages"].as_array().unwrap();
    let last_reply = messages
        .iter()
        .rposition(|m| m["dir"] == "s2c" && m["type_name"] != "DATA")
        .unwrap_or(0);
    messages[last_reply..]
        .iter()
        .filter(|m| m["dir"] == "c2s" && m["type_name"] == "REQ")
        .count()
}

/// Rewrites the ports inside player-interface bodies through `map`.
fn map_ports(body: Body, map: &HashMap<u32, u32>) -> Body {
    let port = |p: u32| *map.get(&p).unwrap_or(&p);
    match body {
        Body::Player(PlayerMsg::Ack(PlayerReq::DevList(Some(mut l)))) => {
            for d in &mut l.devices {
                d.robot = port(d.robot);
            }
            Body::Player(PlayerMsg::Ack(PlayerReq::DevList(Some(l))))
        }
        Body::Player(PlayerMsg::Ack(PlayerReq::DriverInfo(Some(mut i)))) => {
            i.addr.robot = port(i.addr.robot);
            Body::Player(PlayerMsg::Ack(PlayerReq::DriverInfo(Some(i))))
        }
        Body::Player(PlayerMsg::Ack(PlayerReq::Dev(Some(mut d)))) => {
            d.addr.robot = port(d.addr.robot);
            Body::Player(PlayerMsg::Ack(PlayerReq::Dev(Some(d))))
        }
        Body::Player(PlayerMsg::Nack(PlayerReq::Dev(Some(mut d)))) => {
            d.addr.robot = port(d.addr.robot);
            Body::Player(PlayerMsg::Nack(PlayerReq::Dev(Some(d))))
        }
        other => other,
    }
}

/// Replies whose bodies hold simulated values or upstream's uninitialised memory (README:
/// "varies"): compared by size only.
fn body_varies(h: &MsgHeader) -> bool {
    let (i, s) = (h.addr.interf, h.subtype);
    (i == InterfaceCode::POSITION2D && s == Position2dReq::GET_GEOM)
        || (i == InterfaceCode::FIDUCIAL && s == FiducialReq::GET_GEOM)
        || (i == InterfaceCode::SIMULATION
            && (s == SimulationReq::GET_POSE2D || s == SimulationReq::GET_POSE3D))
}

/// Checks one replay against its recording; `map` takes recorded ports to ours.
fn check(name: &str, doc: &Json, replayed: &Replayed, map: &HashMap<u32, u32>) {
    let limits = DecodeLimits::default();
    let recorded: Vec<Raw> = doc["messages"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["dir"] == "s2c")
        .map(Raw::from_json)
        .collect();
    let expected: Vec<&Raw> = recorded.iter().filter(|m| !m.is_data()).collect();
    let got: Vec<&Raw> = replayed.got.iter().filter(|m| !m.is_data()).collect();
    let crashed = doc["connection_events"][0]["dir"] == "s2c";
    if crashed {
        // c_capability: the recorded prefix, then ACK for the simulation capability request
        // (Stage's evident intent) and an answer to everything after it.
        assert_eq!(
            got.len(),
            expected.len() + requests_after_last_reply(doc),
            "{name}: replies"
        );
        let cap = got[expected.len()];
        assert_eq!(cap.header.addr.interf, InterfaceCode::SIMULATION, "{name}");
        assert_eq!(cap.kind(), MsgType::RespAck, "{name}: capability ACK");
    } else {
        assert_eq!(
            got.len(),
            expected.len(),
            "{name}: number of non-DATA messages: got {:?}",
            got.iter()
                .map(|m| (m.kind(), m.header.addr.interf.0, m.header.subtype))
                .collect::<Vec<_>>()
        );
    }
    for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
        let (gh, eh) = (&g.header, &e.header);
        let what = format!(
            "{name}: non-DATA #{i} ({:?} {}:{} subtype {})",
            e.kind(),
            eh.addr.interf,
            eh.addr.index,
            eh.subtype
        );
        assert_eq!(gh.msg_type, eh.msg_type, "{what}: type");
        assert_eq!(gh.subtype, eh.subtype, "{what}: subtype");
        assert_eq!(
            (gh.addr.interf, gh.addr.index),
            (eh.addr.interf, eh.addr.index),
            "{what}: device"
        );
        assert_eq!(gh.addr.host, eh.addr.host, "{what}: host");
        let port = if e.kind() == MsgType::Synch {
            0
        } else {
            map[&eh.addr.robot]
        };
        assert_eq!(gh.addr.robot, port, "{what}: port");
        assert_eq!(gh.size, eh.size, "{what}: size");
        if e.kind() == MsgType::Synch || body_varies(eh) {
            continue;
        }
        let gb = Message::decode(*gh, &g.body, &limits)
            .unwrap_or_else(|err| panic!("{what}: our body does not decode: {err}"))
            .body;
        let eb = map_ports(Message::decode(*eh, &e.body, &limits).unwrap().body, map);
        assert_eq!(gb, eb, "{what}: body");
    }
    check_data(name, doc, &recorded, replayed);
}

/// DATA: every body decodes, the kinds are the recording's, fixed sizes match, PULL rounds are
/// ACK, ≥ 1 DATA, SYNCH (one DATA per kind with the replace rule), no SYNCH in PUSH mode.
fn check_data(name: &str, doc: &Json, recorded: &[Raw], replayed: &Replayed) {
    let limits = DecodeLimits::default();
    let mut recorded_sizes: BTreeMap<(u16, u16, u8), BTreeSet<u32>> = BTreeMap::new();
    for m in recorded.iter().filter(|m| m.is_data()) {
        recorded_sizes
            .entry(m.data_kind())
            .or_default()
            .insert(m.header.size);
    }
    let mut kinds = BTreeSet::new();
    for m in replayed.got.iter().filter(|m| m.is_data()) {
        Message::decode(m.header, &m.body, &limits)
            .unwrap_or_else(|e| panic!("{name}: DATA {:?} does not decode: {e}", m.data_kind()));
        let k = m.data_kind();
        kinds.insert(k);
        let Some(sizes) = recorded_sizes.get(&k) else {
            panic!("{name}: DATA {k:?} never recorded");
        };
        // Kinds of one size in the recording are fixed-size (position, ranges, gripper).
        let fixed = k.0 != InterfaceCode::BLOBFINDER.0 && k.0 != InterfaceCode::FIDUCIAL.0;
        if fixed && sizes.len() == 1 {
            assert!(
                sizes.contains(&m.header.size),
                "{name}: DATA {k:?} size {} (recorded {sizes:?})",
                m.header.size
            );
        }
    }
    let recorded_kinds: BTreeSet<_> = recorded_sizes.keys().copied().collect();
    assert_eq!(kinds, recorded_kinds, "{name}: DATA kinds");

    let push = doc["calls"].as_array().is_some_and(|c| {
        c.iter()
            .any(|c| c.as_str().is_some_and(|s| s.contains("PUSH")))
    });
    let replace_rule = doc["messages"].as_array().unwrap().iter().any(|m| {
        m["dir"] == "c2s"
            && m["header"]["addr"]["interf"] == 1
            && m["header"]["subtype"] == PlayerReq::ADD_REPLACE_RULE
    });
    let mut round: Option<Vec<(u16, u16, u8)>> = None;
    let mut rounds = 0;
    for m in &replayed.got {
        if m.is_req_data_ack() {
            assert!(round.is_none(), "{name}: round inside a round");
            round = Some(Vec::new());
        } else if m.kind() == MsgType::Synch {
            assert!(!push, "{name}: SYNCH in PUSH mode");
            let r = round
                .take()
                .unwrap_or_else(|| panic!("{name}: SYNCH outside a round"));
            assert!(!r.is_empty(), "{name}: a PULL round without DATA");
            if replace_rule {
                let distinct: BTreeSet<_> = r.iter().collect();
                assert_eq!(distinct.len(), r.len(), "{name}: one DATA per kind: {r:?}");
            }
            assert_eq!(m.header.subtype, 1, "{name}: SYNCH OK");
            assert_eq!((m.header.addr.host, m.header.addr.robot), (0, 0));
            assert_eq!(m.header.size, 0);
            rounds += 1;
        } else if m.is_data() {
            if let Some(r) = round.as_mut() {
                r.push(m.data_kind());
            }
        } else {
            assert!(round.is_none(), "{name}: a reply inside a round");
        }
    }
    if !push {
        let recorded_rounds = recorded
            .iter()
            .filter(|m| m.kind() == MsgType::Synch)
            .count();
        assert_eq!(rounds, recorded_rounds, "{name}: PULL rounds");
    }
}

fn sessions() -> Option<(Vec<PathBuf>, PathBuf)> {
    let dir = shared("conformance/sessions")?;
    let cfg = conformance_cfg()?;
    let mut paths = Vec::new();
    for sub in [dir.clone(), dir.join("run2")] {
        for e in std::fs::read_dir(&sub).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "json") {
                paths.push(p);
            }
        }
    }
    paths.sort();
    Some((paths, cfg))
}

fn load(path: &Path) -> Json {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A fresh server on the recorded world, free running (roughly as fast as the recording's).
fn fresh_server(cfg: &Path) -> Running {
    serve_cfg(cfg, Pace::RealTime { speedup: 10.0 })
}

fn port_map(server: &Running) -> HashMap<u32, u32> {
    server
        .ports
        .iter()
        .map(|(&cfg, &real)| (cfg, u32::from(real)))
        .collect()
}

/// Replays one session on its own fresh server.
fn replay_alone(path: &Path, cfg: &Path) {
    let name = path.display().to_string();
    let doc = load(path);
    let server = fresh_server(cfg);
    let port = server.port(doc["port"].as_u64().unwrap() as u32);
    let replayed = drive(&doc, port);
    check(&name, &doc, &replayed, &port_map(&server));
}

/// Replays the two-port pair at the same time on one server.
fn replay_pair(a: &Path, b: &Path, cfg: &Path) {
    let server = fresh_server(cfg);
    let map = port_map(&server);
    let docs = [load(a), load(b)];
    let ports: Vec<u16> = docs
        .iter()
        .map(|d| server.port(d["port"].as_u64().unwrap() as u32))
        .collect();
    let results: Vec<Replayed> = std::thread::scope(|s| {
        let handles: Vec<_> = docs
            .iter()
            .zip(&ports)
            .map(|(d, &p)| s.spawn(move || drive(d, p)))
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for ((path, doc), r) in [a, b].iter().zip(&docs).zip(&results) {
        check(&path.display().to_string(), doc, r, &map);
    }
}

/// Replays the sessions whose file name passes `filter` and returns how many it replayed; with
/// the recordings present it fails unless that is every such session and at least one, so a
/// filter or loop that silently skips sessions cannot pass. `None` when the recordings are
/// absent (`shared` has said why).
fn replay_named(filter: impl Fn(&str) -> bool) -> Option<usize> {
    let (paths, cfg) = sessions()?;
    let file_name = |p: &Path| p.file_name().unwrap().to_string_lossy().to_string();
    let expected = paths.iter().filter(|p| filter(&file_name(p))).count();
    assert!(
        expected > 0,
        "no recorded session matches this test's files"
    );
    let mut n = 0;
    let mut pairs: BTreeMap<PathBuf, Vec<PathBuf>> = BTreeMap::new();
    for p in paths {
        let file = file_name(&p);
        if !filter(&file) {
            continue;
        }
        if file.starts_with("two_ports_") {
            pairs
                .entry(p.parent().unwrap().to_path_buf())
                .or_default()
                .push(p);
        } else {
            replay_alone(&p, &cfg);
            n += 1;
        }
    }
    for (_, pair) in pairs {
        assert_eq!(pair.len(), 2, "{pair:?}");
        replay_pair(&pair[0], &pair[1], &cfg);
        n += 2;
    }
    assert_eq!(n, expected, "sessions replayed vs recorded");
    Some(n)
}

fn libplayerc_files(f: &str) -> bool {
    f.starts_with("c_") || f == "gripper.json" || f == "fiducial.json"
}

fn libplayerc_plus_plus_files(f: &str) -> bool {
    f == "cpp_bigbob.json"
}

fn utility_files(f: &str) -> bool {
    f == "playerprint.json" || f == "playerv.json"
}

fn two_port_files(f: &str) -> bool {
    f.starts_with("two_ports_")
}

#[test]
fn every_recorded_session_belongs_to_one_replay_test() {
    let Some((paths, _)) = sessions() else {
        return;
    };
    let groups = [
        libplayerc_files,
        libplayerc_plus_plus_files,
        utility_files,
        two_port_files,
    ];
    for p in &paths {
        let f = p.file_name().unwrap().to_string_lossy();
        let n = groups.iter().filter(|g| g(&f)).count();
        assert_eq!(n, 1, "{}: replayed by {n} tests", p.display());
    }
    println!(
        "{} recorded sessions, each replayed by one test",
        paths.len()
    );
}

#[test]
fn libplayerc_sessions_replay() {
    if let Some(n) = replay_named(libplayerc_files) {
        println!("{n} libplayerc sessions replayed");
    }
}

#[test]
fn libplayerc_plus_plus_bigbob_session_replays() {
    if let Some(n) = replay_named(libplayerc_plus_plus_files) {
        println!("{n} libplayerc++ sessions replayed");
    }
}

#[test]
fn playerprint_and_playerv_sessions_replay() {
    if let Some(n) = replay_named(utility_files) {
        println!("{n} utility sessions replayed");
    }
}

#[test]
fn two_port_sessions_replay_concurrently() {
    if let Some(n) = replay_named(two_port_files) {
        println!("{n} two-port sessions replayed");
    }
}
