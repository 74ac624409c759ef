//! `writelog` and `readlog` over TCP: a Stage run recorded by writelog while a client watches
//! it, then replayed by readlog to a client, which must see the same DATA messages (type,
//! subtype, device, body as Player's text format keeps it) in the same order, stamped with the
//! recorded times and spaced as they were live; and the log device driven from a client.

mod common;

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use player_client::{PlayerClient, Position2dProxy};
use player_drivers::shell::logformat::{self, Line, WriteOptions};
use player_proto::constants::{LOCALHOST_ADDR, PLAYER_OPEN_MODE};
use player_proto::{
    BANNER, Body, DecodeLimits, DeviceAddr, DeviceReq, Framer, InterfaceCode, LogReq,
    LogSetReadState, LogSetWriteState, Message, MsgHeader, MsgType, PlayerReq, Text,
};
use player_server::{Pace, ServerHandle};

/// A client that keeps every message as it arrives, with its arrival instant.
struct RawClient {
    stream: TcpStream,
    framer: Framer,
    port: u16,
}

struct Seen {
    header: MsgHeader,
    body: Body,
    at: Instant,
}

impl RawClient {
    fn connect(port: u16) -> RawClient {
        let mut stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
        let mut banner = [0u8; BANNER.len()];
        stream.read_exact(&mut banner).unwrap();
        RawClient {
            stream,
            framer: Framer::new(DecodeLimits::default()),
            port,
        }
    }

    fn addr(&self, interf: InterfaceCode, index: u16) -> DeviceAddr {
        DeviceAddr::new(LOCALHOST_ADDR, u32::from(self.port), interf, index)
    }

    fn send(&mut self, to: DeviceAddr, body: impl Into<Body>) {
        let bytes = Message::new(to, 0.0, body).encode().unwrap();
        self.stream.write_all(&bytes).unwrap();
    }

    /// Messages until `until`, DATA kept in `data`; returns the first reply seen.
    fn pump(
        &mut self,
        until: Instant,
        data: &mut Vec<Seen>,
        stop_at_reply: bool,
    ) -> Option<Message> {
        let mut buf = [0u8; 65536];
        loop {
            while let Some(frame) = self.framer.next_frame().unwrap() {
                let msg = frame.decode(&DecodeLimits::default()).unwrap();
                match MsgType::from_u8(msg.header.msg_type) {
                    Some(MsgType::Data) => data.push(Seen {
                        header: msg.header,
                        body: msg.body,
                        at: Instant::now(),
                    }),
                    Some(MsgType::RespAck | MsgType::RespNack) if stop_at_reply => {
                        return Some(msg);
                    }
                    _ => {}
                }
            }
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return None;
            }
            self.stream.set_read_timeout(Some(left)).unwrap();
            match self.stream.read(&mut buf) {
                Ok(0) => return None,
                Ok(n) => self.framer.push(&buf[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                    ) => {}
                Err(e) => panic!("{e}"),
            }
        }
    }

    fn request(&mut self, to: DeviceAddr, body: impl Into<Body>, data: &mut Vec<Seen>) -> Message {
        self.send(to, body);
        self.pump(Instant::now() + Duration::from_secs(5), data, true)
            .expect("a reply")
    }

    fn subscribe(&mut self, interf: InterfaceCode, index: u16, data: &mut Vec<Seen>) {
        let addr = self.addr(interf, index);
        let player = self.addr(InterfaceCode::PLAYER, 0);
        let reply = self.request(
            player,
            PlayerReq::Dev(Some(DeviceReq {
                addr,
                access: PLAYER_OPEN_MODE,
                driver_name: Text::empty(),
            })),
            data,
        );
        let (Body::Player(player_proto::PlayerMsg::Ack(PlayerReq::Dev(Some(granted))))
        | Body::Player(player_proto::PlayerMsg::Req(PlayerReq::Dev(Some(granted))))) = reply.body
        else {
            panic!("DEV reply {reply:?}")
        };
        assert_eq!(granted.access, PLAYER_OPEN_MODE, "subscribed to {addr}");
    }
}

/// The body as Player's text format keeps it: written and read back.
fn as_logged(header: &MsgHeader, body: &Body) -> Body {
    let (line, result) = logformat::encode_line(
        header.timestamp,
        &header.addr,
        header.msg_type,
        body,
        WriteOptions::default(),
    );
    result.unwrap();
    match logformat::parse_line(&line).unwrap() {
        Line::Message(_, b) => b,
        Line::Comment => panic!("{line}"),
    }
}

const DEVICES: [(InterfaceCode, u16); 3] = [
    (InterfaceCode::POSITION2D, 0),
    (InterfaceCode::RANGER, 0),
    (InterfaceCode::BLOBFINDER, 0),
];

/// A fresh scratch folder named for the test (and the process, so parallel runs differ).
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A server recording to `file` once a client starts it (`autorecord 0`), at twice real time.
fn serve_idle_recorder(file: &Path) -> ServerHandle {
    common::serve_cfg(
        &common::worlds(),
        "rec.cfg",
        &record_cfg(file).replace("alwayson 1", "alwayson 1 autorecord 0"),
        Pace::RealTime { speedup: 2.0 },
    )
}

/// A server from the replay cfg `text`, written as `dir/replay.cfg`, at real time.
fn serve_replay(dir: &Path, text: &str) -> ServerHandle {
    common::serve_cfg(dir, "replay.cfg", text, Pace::RealTime { speedup: 1.0 })
}

fn record_cfg(file: &Path) -> String {
    format!(
        r#"
driver( name "stage" provides ["0:simulation:0"] plugin "stageplugin" worldfile "bigbob.world" )
driver( name "stage" provides ["0:position2d:0" "0:ranger:0" "0:blobfinder:0"] model "bob1" )
driver( name "writelog" requires ["0:position2d:0" "0:ranger:0" "0:blobfinder:0"] provides ["0:log:0"]
        alwayson 1 filename "{}" )
"#,
        file.display()
    )
}

#[test]
fn a_recorded_run_replays_the_same_messages_at_the_same_pace() {
    let dir = scratch("log-roundtrip");
    let file = dir.join("run.log");

    // Record: a client watches live while writelog records, and the robot drives.
    let server = common::serve_cfg(
        &common::worlds(),
        "rec.cfg",
        &record_cfg(&file),
        Pace::RealTime { speedup: 1.0 },
    );
    let port = server.ports()[0];
    let driver = PlayerClient::connect("localhost", port).unwrap();
    let base = Position2dProxy::new(&driver, 0).unwrap();
    base.set_speed(0.3, 0.0, 0.4).unwrap();
    let mut live_client = RawClient::connect(port);
    let mut live = Vec::new();
    for (i, n) in DEVICES {
        live_client.subscribe(i, n, &mut live);
    }
    live.clear();
    live_client.pump(
        Instant::now() + Duration::from_millis(1500),
        &mut live,
        false,
    );
    drop(live_client);
    drop(base);
    drop(driver);
    std::thread::sleep(Duration::from_millis(300));
    server.shutdown();
    assert!(live.len() > 20, "{} live messages", live.len());

    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.starts_with(logformat::FILE_HEADER));
    let geometry = text.lines().filter(|l| l.contains(" 004 ")).count();
    assert_eq!(
        geometry, 3,
        "position2d geometry, ranger geometry and config:\n{text}"
    );

    // Replay on the recording's port (addresses must match, as upstream's).
    let replay_cfg = format!(
        r#"driver( name "readlog" filename "{}" provides ["{port}:position2d:0" "{port}:ranger:0" "{port}:blobfinder:0" "{port}:log:0"] )"#,
        file.display()
    );
    let replay = serve_replay(&dir, &replay_cfg);
    let mut client = RawClient::connect(port);
    let mut replayed = Vec::new();
    for (i, n) in DEVICES {
        client.subscribe(i, n, &mut replayed);
    }
    // Geometry comes from the log, whose geometry lines come before its data: readlog holds
    // them once it has replayed data (asked sooner, it NACKs, as upstream's does).
    let deadline = Instant::now() + Duration::from_secs(10);
    while replayed.is_empty() && Instant::now() < deadline {
        client.pump(
            Instant::now() + Duration::from_millis(100),
            &mut replayed,
            false,
        );
    }
    let mut ignore = Vec::new();
    let geom = client.request(
        client.addr(InterfaceCode::POSITION2D, 0),
        player_proto::Position2dReq::GetGeom(None),
        &mut ignore,
    );
    assert_eq!(geom.header.msg_type, MsgType::RespAck.code());
    replayed.extend(ignore);
    let last = live.last().unwrap().header.timestamp;
    let deadline = Instant::now() + Duration::from_secs(20);
    while replayed
        .last()
        .is_none_or(|m| m.header.timestamp < last + 0.05)
        && Instant::now() < deadline
    {
        client.pump(
            Instant::now() + Duration::from_millis(200),
            &mut replayed,
            false,
        );
    }
    drop(client);
    replay.shutdown();

    // The live messages are a run of the replayed ones: same order, kind, device, body.
    let key = |s: &Seen| {
        (
            s.header.addr.interf,
            s.header.addr.index,
            s.header.subtype,
            (s.header.timestamp * 1000.0).round() as i64,
        )
    };
    let first = replayed
        .iter()
        .position(|r| key(r) == key(&live[0]))
        .expect("the first live message is in the replay");
    assert!(replayed.len() >= first + live.len(), "replay too short");
    for (l, r) in live.iter().zip(&replayed[first..]) {
        assert_eq!(key(l), key(r));
        assert_eq!(r.header.msg_type, l.header.msg_type);
        assert_eq!(r.header.addr, l.header.addr);
        assert_eq!(
            r.body,
            as_logged(&l.header, &l.body),
            "body of {:?}",
            key(l)
        );
    }
    // Relative timing: each message arrives as long after the first as it did live.
    let (l0, r0) = (live[0].at, replayed[first].at);
    let mut worst = 0.0f64;
    for (l, r) in live.iter().zip(&replayed[first..]) {
        let dl = l.at.duration_since(l0).as_secs_f64();
        let dr = r.at.duration_since(r0).as_secs_f64();
        worst = worst.max((dl - dr).abs());
    }
    println!(
        "{} messages compared; worst arrival-time difference {:.1} ms",
        live.len(),
        worst * 1000.0
    );
    assert!(worst < 0.1, "arrival times differ by up to {worst:.3} s");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_log_devices_start_stop_and_rewind() {
    let dir = scratch("log-device");
    let file = dir.join("ctl.log.gz");
    let server = serve_idle_recorder(&file);
    let port = server.ports()[0];
    let mut c = RawClient::connect(port);
    let mut data = Vec::new();
    let log = c.addr(InterfaceCode::LOG, 0);
    c.subscribe(InterfaceCode::LOG, 0, &mut data);
    let state = |c: &mut RawClient, data: &mut Vec<Seen>| {
        let m = c.request(log, LogReq::GetState(None), data);
        match m.body {
            Body::Log(player_proto::LogMsg::Ack(LogReq::GetState(Some(s))))
            | Body::Log(player_proto::LogMsg::Req(LogReq::GetState(Some(s)))) => {
                (s.log_type, s.state)
            }
            other => panic!("{other:?}"),
        }
    };
    assert_eq!(state(&mut c, &mut data), (2, 0));
    let m = c.request(
        log,
        LogReq::SetWriteState(Some(LogSetWriteState { state: 1 })),
        &mut data,
    );
    assert_eq!(m.header.msg_type, MsgType::RespAck.code());
    assert_eq!(state(&mut c, &mut data), (2, 1));
    c.pump(
        Instant::now() + Duration::from_millis(700),
        &mut data,
        false,
    );
    c.request(
        log,
        LogReq::SetWriteState(Some(LogSetWriteState { state: 0 })),
        &mut data,
    );
    drop(c);
    server.shutdown();

    // The gzip log replays; the read side's log device pauses and rewinds it.
    let replay_cfg = format!(
        r#"driver( name "readlog" filename "{}" autoplay 0 provides ["{port}:position2d:0" "{port}:log:0"] )"#,
        file.display()
    );
    let replay = serve_replay(&dir, &replay_cfg);
    let mut c = RawClient::connect(port);
    let mut data = Vec::new();
    c.subscribe(InterfaceCode::LOG, 0, &mut data);
    c.subscribe(InterfaceCode::POSITION2D, 0, &mut data);
    assert_eq!(state(&mut c, &mut data), (1, 0));
    c.pump(
        Instant::now() + Duration::from_millis(300),
        &mut data,
        false,
    );
    assert!(data.is_empty(), "autoplay 0: nothing before SET_READ_STATE");
    c.request(
        log,
        LogReq::SetReadState(Some(LogSetReadState { state: 1 })),
        &mut data,
    );
    assert_eq!(state(&mut c, &mut data), (1, 1));
    c.pump(
        Instant::now() + Duration::from_millis(2500),
        &mut data,
        false,
    );
    assert!(data.len() > 3, "{} messages", data.len());
    // The log is about 0.35 s of real time (recorded at twice real time): the replay ended.
    assert_eq!(state(&mut c, &mut data), (1, 0));
    let first = data[0].header.timestamp;
    data.clear();
    c.request(log, LogReq::SetReadRewind, &mut data);
    c.request(
        log,
        LogReq::SetReadState(Some(LogSetReadState { state: 1 })),
        &mut data,
    );
    c.pump(
        Instant::now() + Duration::from_millis(500),
        &mut data,
        false,
    );
    assert!(
        !data.is_empty() && data[0].header.timestamp == first,
        "replayed from the start"
    );
    drop(c);
    replay.shutdown();
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_rust_log_proxy_drives_recording_and_replay() {
    use player_client::LogProxy;
    let dir = scratch("log-proxy");
    let first = dir.join("first.log");
    let second = dir.join("second.log");
    let server = serve_idle_recorder(&first);
    let client = PlayerClient::connect("localhost", server.ports()[0]).unwrap();
    let log = LogProxy::new(&client, 0).unwrap();
    let st = log.get_state().unwrap();
    assert_eq!((st.log_type, st.state), (2, false));
    log.set_write_state(true).unwrap();
    assert!(log.get_state().unwrap().state);
    assert!(
        log.set_filename(second.to_str().unwrap()).is_err(),
        "no new file while recording"
    );
    log.set_write_state(false).unwrap();
    log.set_filename(second.to_str().unwrap()).unwrap();
    log.set_write_state(true).unwrap();
    std::thread::sleep(Duration::from_millis(500));
    log.set_write_state(false).unwrap();
    assert!(log.rewind().is_err(), "writelog refuses a rewind");
    drop(log);
    drop(client);
    server.shutdown();
    let text = std::fs::read_to_string(&second).unwrap();
    assert!(
        text.lines()
            .filter(|l| l.contains(" position2d 00 001 001 "))
            .count()
            >= 3,
        "{text}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// libplayerc's own log proxy (`examples/c/log_control.c`, built with its Makefile) drives a
/// writelog and then a readlog device of our server. Skipped, with a message, when
/// `pkg-config` finds no `playerc`.
#[test]
fn libplayerc_log_proxy_drives_recording_and_replay() {
    use std::process::Command;
    if !test_support::pkg_config_finds(&["playerc"], "the libplayerc log proxy test") {
        return;
    }
    let dir = scratch("log-libplayerc");
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/c");
    let status = Command::new("make")
        .arg("-s")
        .arg("-C")
        .arg(&examples)
        .arg(format!("OUT={}", dir.display()))
        .status()
        .expect("running make");
    assert!(status.success(), "building examples/c");
    let program = dir.join("log_control");
    let run = |port: u16, args: &[&str]| {
        let out = Command::new(&program)
            .arg("localhost")
            .arg(port.to_string())
            .args(args)
            .output()
            .unwrap();
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            out.status.success() && text.contains("log_control: ok"),
            "{text}"
        );
        text
    };

    let first = dir.join("first.log");
    let second = dir.join("second.log");
    let server = serve_idle_recorder(&first);
    let port = server.ports()[0];
    run(port, &["write", second.to_str().unwrap()]);
    server.shutdown();
    let text = std::fs::read_to_string(&second).unwrap();
    assert!(
        text.lines()
            .filter(|l| l.contains(" position2d 00 001 001 "))
            .count()
            >= 3,
        "{text}"
    );

    let replay_cfg = format!(
        r#"driver( name "readlog" filename "{}" autorewind 1 provides ["{port}:position2d:0" "{port}:log:0"] )"#,
        second.display()
    );
    let replay = serve_replay(&dir, &replay_cfg);
    let out = run(port, &["read"]);
    assert!(out.contains("replayed pose"), "{out}");
    replay.shutdown();
    std::fs::remove_dir_all(&dir).unwrap();
}
