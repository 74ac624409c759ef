//! `readlog` (Player 3.0.2 `server/drivers/shell/readlog.cc`): replays a log written by
//! `writelog` (ours or upstream's), serving the recorded devices as if they were live.
//!
//! cfg: `filename` (required), `provides` the devices to replay and optionally one `log`
//! device (SET_READ_STATE, GET_STATE, SET_READ_REWIND, as `playervcr` uses them), `speed`
//! (1.0 = the recorded pace, 2.0 twice as fast; `inf` = as fast as possible, what
//! `player --fast` sets), `autoplay` (1: replay from the first subscription), `autorewind` (0:
//! at the end, stop; 1: start again). A name ending in `.gz` is read gzip-compressed.
//!
//! A line is replayed by the provided device with the same address (host, port, interface,
//! index; host 0 and 127.0.0.1 are the same, as upstream), with its recorded timestamp, at the
//! recorded pace. Reply lines (geometry, ranger config, localize particles) are kept and
//! answer requests of the same subtype to that device; other requests are refused. A line that
//! cannot be read (too short, unknown interface, a count that disagrees with its fields, a
//! field that is not a number) is reported with `file:line` and skipped, and the replay goes
//! on, as upstream's does.
//!
//! A worker thread reads the file and waits for each message's time; the driver publishes
//! what it produced when woken ([`player_server::DriverWaker`]) or at its next step.
//!
//! Differences from upstream: the server clock stays the wall clock (upstream makes the log
//! time the server's time; here only the replayed messages carry it); gzip logs work (upstream
//! 3.0.2's gzip branch never opens the file); a missing file is refused when the cfg is loaded
//! (upstream fails at the first subscription); the pace is kept against the start of the
//! replay rather than message to message, so waiting errors do not add up.

use std::collections::{HashMap, VecDeque};
use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use flate2::read::MultiGzDecoder;
use player_proto::{
    Body, DeviceAddr, InterfaceCode, LogMsg, LogReq, Message, MsgType, PLAYER_LOG_TYPE_READ,
};
use player_server::{Context, Driver, DriverBlock, DriverError, DriverWaker, Reply, WorkerThread};

use super::logformat::{self, Line, LineError};
use super::writelog::is_gzip;
use crate::options;

/// The name cfg files use.
pub const NAME: &str = "readlog";

/// Messages the worker may have ready before it waits for the driver to publish them.
const OUTBOX_LIMIT: usize = 1024;

/// A line of a log that could not be replayed, with where it is.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{file}:{line}: {error}")]
pub struct BadLine {
    /// The log file.
    pub file: String,
    /// Line number, from 1.
    pub line: usize,
    /// What is wrong with it.
    pub error: LineError,
}

/// Opens a log for reading, plain or gzip by its name.
pub fn open_log(path: &Path) -> std::io::Result<Box<dyn BufRead + Send>> {
    let file = File::open(path)?;
    Ok(if is_gzip(path) {
        Box::new(BufReader::with_capacity(
            1 << 16,
            MultiGzDecoder::new(BufReader::new(file)),
        ))
    } else {
        Box::new(BufReader::with_capacity(1 << 16, file))
    })
}

/// Reads a log line by line: messages with their line numbers, and bad lines as [`BadLine`]
/// (the reader goes on after them).
pub struct LogReader {
    file: String,
    input: Box<dyn BufRead + Send>,
    line: usize,
    text: String,
}

impl LogReader {
    /// Opens `path`; the error names it.
    pub fn open(path: &Path) -> Result<LogReader, String> {
        let input = open_log(path)
            .map_err(|e| format!("unable to open log file [{}]: {e}", path.display()))?;
        Ok(LogReader {
            file: path.display().to_string(),
            input,
            line: 0,
            text: String::new(),
        })
    }

    /// The next message line (`Ok`), bad line (`Err`), or `None` at the end. A read error
    /// (e.g. a corrupt gzip stream) ends the log with a warning.
    pub fn next_message(
        &mut self,
    ) -> Option<Result<(usize, logformat::LineHeader, Body), BadLine>> {
        loop {
            self.text.clear();
            match self.input.read_line(&mut self.text) {
                Ok(0) => return None,
                Ok(_) => {}
                Err(e) => {
                    tracing::warn!(
                        "{NAME}: {}:{}: read error, ending replay: {e}",
                        self.file,
                        self.line + 1
                    );
                    return None;
                }
            }
            self.line += 1;
            match logformat::parse_line(&self.text) {
                Ok(Line::Comment) => continue,
                Ok(Line::Message(h, body)) => return Some(Ok((self.line, h, body))),
                Err(error) => {
                    return Some(Err(BadLine {
                        file: self.file.clone(),
                        line: self.line,
                        error,
                    }));
                }
            }
        }
    }
}

/// What the worker and the driver share.
#[derive(Default)]
struct State {
    enabled: bool,
    rewind_requested: bool,
    stop: bool,
    /// Replayed messages not yet published: provided device, body, recorded time.
    outbox: VecDeque<(DeviceAddr, Body, f64)>,
    /// Reply lines by (provided device index, subtype): the answers to requests.
    replies: HashMap<(usize, u8), Body>,
    /// Bad lines seen (for the log and tests).
    bad_lines: Vec<BadLine>,
}

struct Shared {
    state: Mutex<State>,
    changed: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, State> {
        // A worker that panicked leaves the state as it was; keep serving it.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Waits up to `timeout` for a change of the state (a poisoned lock kept, as in `lock`).
    fn wait<'a>(&'a self, st: MutexGuard<'a, State>, timeout: Duration) -> MutexGuard<'a, State> {
        self.changed
            .wait_timeout(st, timeout)
            .map(|(g, _)| g)
            .unwrap_or_else(|e| e.into_inner().0)
    }
}

/// What `player --fast` does to a cfg's `readlog` blocks: replay without waiting between
/// messages (speed infinite), in recorded order.
pub fn replay_fast(blocks: &mut [DriverBlock]) {
    for b in blocks.iter_mut().filter(|b| b.name == NAME) {
        b.options.insert("speed".into(), vec!["inf".into()]);
    }
}

/// The driver. See the module docs.
pub struct ReadLog {
    path: PathBuf,
    speed: f64,
    autoplay: bool,
    autorewind: bool,
    log_addr: Option<DeviceAddr>,
    provided: Vec<DeviceAddr>,
    shared: Arc<Shared>,
    /// The replay thread: its panic is raised in `wake`/`update` (the core reports it).
    worker: Option<WorkerThread>,
}

impl std::fmt::Debug for ReadLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReadLog")
            .field("path", &self.path)
            .field("provided", &self.provided)
            .finish()
    }
}

impl ReadLog {
    /// Builds the driver from its cfg block (see the module docs for the options).
    pub fn from_block(block: &DriverBlock) -> Result<ReadLog, DriverError> {
        let name = block
            .option("filename")
            .ok_or_else(|| DriverError::new("must specify a log file to read from (`filename`)"))?;
        let path = block.resolve_path(name);
        File::open(&path).map_err(|e| {
            DriverError::new(format!("unable to open log file [{}]: {e}", path.display()))
        })?;
        let speed = options::float(block, "speed")?.unwrap_or(1.0);
        if speed.is_nan() || speed <= 0.0 {
            return Err(DriverError::new(format!(
                "option `speed` must be positive (1 = the recorded pace), not {speed}"
            )));
        }
        let mut log_addr = None;
        let mut provided = Vec::new();
        for p in &block.provides {
            if p.addr.interf == InterfaceCode::LOG {
                log_addr = Some(p.addr);
            } else {
                provided.push(p.addr);
            }
        }
        Ok(ReadLog {
            path,
            speed,
            autoplay: options::flag(block, "autoplay")?.unwrap_or(true),
            autorewind: options::flag(block, "autorewind")?.unwrap_or(false),
            log_addr,
            provided,
            shared: Arc::new(Shared {
                state: Mutex::new(State::default()),
                changed: Condvar::new(),
            }),
            worker: None,
        })
    }

    /// The lines the replay could not read so far, each naming file and line.
    pub fn bad_lines(&self) -> Vec<BadLine> {
        self.shared.lock().bad_lines.clone()
    }

    fn stop_worker(&mut self) {
        self.shared.lock().stop = true;
        self.shared.changed.notify_all();
        if let Some(worker) = self.worker.take() {
            worker.join();
        }
    }

    fn publish_ready(&mut self, ctx: &mut Context<'_>) {
        let ready: Vec<_> = self.shared.lock().outbox.drain(..).collect();
        if !ready.is_empty() {
            self.shared.changed.notify_all();
        }
        for (addr, body, time) in ready {
            ctx.publish_at(addr, body, time);
        }
    }
}

/// The worker's side: reads, paces and hands over messages until stopped.
struct Replay {
    path: PathBuf,
    speed: f64,
    autorewind: bool,
    provided: Vec<DeviceAddr>,
    shared: Arc<Shared>,
    waker: Option<DriverWaker>,
}

/// How a wait for a message's time ended.
enum Waited {
    Due,
    Paused,
    Rewind,
    Stop,
}

impl Replay {
    fn run(self, mut reader: LogReader) {
        // (wall instant, log time) the pace is measured from; reset by pauses and rewinds.
        let mut anchor: Option<(Instant, f64)> = None;
        loop {
            {
                let mut st = self.shared.lock();
                if st.stop {
                    return;
                }
                if st.rewind_requested {
                    st.rewind_requested = false;
                    drop(st);
                    match LogReader::open(&self.path) {
                        Ok(r) => reader = r,
                        Err(e) => tracing::warn!("{NAME}: rewinding: {e}"),
                    }
                    anchor = None;
                    tracing::debug!("{NAME}: log file rewound");
                    continue;
                }
                if !st.enabled {
                    anchor = None;
                    drop(self.shared.wait(st, Duration::from_millis(100)));
                    continue;
                }
            }
            let Some(next) = reader.next_message() else {
                tracing::info!("{NAME}: reached end of log file {}", self.path.display());
                let mut st = self.shared.lock();
                if self.autorewind {
                    st.rewind_requested = true;
                    continue;
                }
                // Stop (clients polling the log device see it), and wait for a rewind.
                st.enabled = false;
                while !st.rewind_requested && !st.stop {
                    st = self.shared.wait(st, Duration::from_millis(100));
                }
                continue;
            };
            let (_, header, body) = match next {
                Ok(m) => m,
                Err(bad) => {
                    tracing::error!("{NAME}: {bad}");
                    self.shared.lock().bad_lines.push(bad);
                    continue;
                }
            };
            let Some(index) = self
                .provided
                .iter()
                .position(|p| p.same_device(&header.addr))
            else {
                tracing::debug!("{NAME}: unhandled message from {}", header.addr);
                continue;
            };
            if header.msg_type == MsgType::RespAck.code() {
                self.shared
                    .lock()
                    .replies
                    .insert((index, header.subtype), body);
                continue;
            }
            if header.msg_type != MsgType::Data.code() {
                tracing::debug!("{NAME}: skipping a message of type {}", header.msg_type);
                continue;
            }
            match self.wait_for(&mut anchor, header.time) {
                Waited::Due => {}
                Waited::Paused => {}
                Waited::Rewind | Waited::Stop => continue,
            }
            self.hand_over(self.provided[index], body, header.time);
        }
    }

    /// Waits until the wall time of a message recorded at `time`.
    fn wait_for(&self, anchor: &mut Option<(Instant, f64)>, time: f64) -> Waited {
        let (wall0, log0) = match *anchor {
            Some((w, t)) if time >= t => (w, t),
            // First message, or the log's time went backwards: measure from here.
            _ => {
                *anchor = Some((Instant::now(), time));
                return Waited::Due;
            }
        };
        if self.speed.is_infinite() {
            return Waited::Due;
        }
        let due = wall0 + Duration::from_secs_f64(((time - log0) / self.speed).min(1e9));
        let mut st = self.shared.lock();
        loop {
            if st.stop {
                return Waited::Stop;
            }
            if st.rewind_requested {
                return Waited::Rewind;
            }
            if !st.enabled {
                // Paused while waiting: this message goes out when replay resumes.
                *anchor = None;
                while !st.enabled && !st.stop && !st.rewind_requested {
                    st = self.shared.wait(st, Duration::from_millis(100));
                }
                if st.enabled {
                    *anchor = Some((Instant::now(), time));
                    return Waited::Paused;
                }
                continue;
            }
            let now = Instant::now();
            if now >= due {
                return Waited::Due;
            }
            st = self.shared.wait(st, due - now);
        }
    }

    fn hand_over(&self, addr: DeviceAddr, body: Body, time: f64) {
        let mut st = self.shared.lock();
        while st.outbox.len() >= OUTBOX_LIMIT && !st.stop {
            if let Some(w) = &self.waker {
                w.wake();
            }
            st = self.shared.wait(st, Duration::from_millis(50));
        }
        st.outbox.push_back((addr, body, time));
        drop(st);
        if let Some(w) = &self.waker {
            w.wake();
        }
    }
}

impl Driver for ReadLog {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        let reader = LogReader::open(&self.path).map_err(DriverError::new)?;
        {
            let mut st = self.shared.lock();
            *st = State {
                enabled: self.autoplay,
                ..State::default()
            };
        }
        let replay = Replay {
            path: self.path.clone(),
            speed: self.speed,
            autorewind: self.autorewind,
            provided: self.provided.clone(),
            shared: self.shared.clone(),
            waker: ctx.waker(),
        };
        let worker = WorkerThread::spawn("readlog", ctx.waker(), move || replay.run(reader))
            .map_err(|e| DriverError::new(format!("cannot start the replay thread: {e}")))?;
        self.worker = Some(worker);
        Ok(())
    }

    fn teardown(&mut self, _ctx: &mut Context<'_>) {
        self.stop_worker();
    }

    fn shutdown(&mut self) {
        self.stop_worker();
    }

    fn wake(&mut self, ctx: &mut Context<'_>) {
        if let Some(w) = &mut self.worker {
            w.check();
        }
        self.publish_ready(ctx);
    }

    fn update(&mut self, ctx: &mut Context<'_>) {
        if let Some(w) = &mut self.worker {
            w.check();
        }
        self.publish_ready(ctx);
    }

    fn handle_request(&mut self, _ctx: &mut Context<'_>, request: &Message) -> Reply {
        let to = request.header.addr;
        if self.log_addr.is_some_and(|l| l.same_device(&to)) {
            let Body::Log(LogMsg::Req(req)) = &request.body else {
                return Reply::NotHandled;
            };
            let mut st = self.shared.lock();
            let reply = match req {
                LogReq::SetReadState(Some(s)) => {
                    super::switch_state(NAME, &mut st.enabled, s.state, "playback");
                    Reply::ack(LogReq::SetReadState(None))
                }
                LogReq::GetState(_) => super::state_reply(PLAYER_LOG_TYPE_READ, st.enabled),
                LogReq::SetReadRewind => {
                    st.rewind_requested = true;
                    Reply::ack(LogReq::SetReadRewind)
                }
                _ => Reply::Nack,
            };
            drop(st);
            self.shared.changed.notify_all();
            return reply;
        }
        let Some(index) = self.provided.iter().position(|p| p.same_device(&to)) else {
            return Reply::NotHandled;
        };
        if request.body.msg_type() != MsgType::Req {
            return Reply::NotHandled;
        }
        match self
            .shared
            .lock()
            .replies
            .get(&(index, request.body.subtype()))
        {
            Some(body) => Reply::Ack(Some(body.clone())),
            None => Reply::Nack,
        }
    }
}

impl Drop for ReadLog {
    fn drop(&mut self) {
        self.stop_worker();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Harness, addr, block};
    use player_proto::{LaserReq, LogGetState, LogSetReadState, Position2dData};

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        std::fs::create_dir_all(dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn tmp(tag: &str) -> PathBuf {
        std::env::temp_dir().join(format!("readlog-{tag}-{}", std::process::id()))
    }

    const POS: &str = "0000000001.000 16777343 6665 position2d 00 001 001 +01.000 -02.000 +0.500 +00.000 +00.000 +00.000 0\n";

    #[test]
    fn bad_lines_name_file_and_line_and_the_rest_is_read() {
        let dir = tmp("bad");
        let text = format!(
            "## Player version 3.0.2 \n{POS}\
             0000000001.100 16777343 6665 position2d 00 001 001 +01.000 -02.000\n\
             0000000001.200 16777343 6665 teleporter 00 001 001 1 2 3\n\
             0000000001.300 16777343 6665 laser 00 001 001 0001 -1.5 +1.5 +0.1 +8.0 0003 1.0 0 2.0 0\n\
             0000000001.400 16777343 6665 ranger 00 001 001 0002 1.0 2.0 3.0\n\
             0000000001.500 16777343 6665 ranger 00 001 001 0002 1.0 x\n\
             0000000001.600 16777343\n\
             {POS}"
        );
        let p = write(&dir, "bad.log", &text);
        let mut r = LogReader::open(&p).unwrap();
        let mut good = Vec::new();
        let mut bad = Vec::new();
        while let Some(m) = r.next_message() {
            match m {
                Ok((line, ..)) => good.push(line),
                Err(b) => bad.push(b.to_string()),
            }
        }
        assert_eq!(good, vec![2, 9]);
        let f = p.display().to_string();
        assert_eq!(bad.len(), 6, "{bad:#?}");
        assert!(
            bad[0].starts_with(&format!("{f}:3: incomplete line")),
            "{}",
            bad[0]
        );
        assert_eq!(
            bad[1],
            format!("{f}:4: unknown interface name \"teleporter\"")
        );
        assert!(
            bad[2].starts_with(&format!("{f}:5: incomplete line")),
            "{}",
            bad[2]
        );
        assert!(
            bad[3].starts_with(&format!("{f}:6: ranger 1:1: count mismatch")),
            "{}",
            bad[3]
        );
        assert!(
            bad[4].contains(":7: ranger 1:1: field 2 \"x\" is not a valid number"),
            "{}",
            bad[4]
        );
        assert!(bad[5].contains(":8: invalid line: 2 fields"), "{}", bad[5]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_missing_file_is_an_error_naming_it() {
        let b = block(
            NAME,
            &[addr(InterfaceCode::POSITION2D, 0)],
            &[],
            &[("filename", "/nonexistent/run.log")],
        );
        let e = ReadLog::from_block(&b).unwrap_err().to_string();
        assert!(
            e.contains("/nonexistent/run.log") && e.contains("unable to open"),
            "{e}"
        );
        let b = block(NAME, &[addr(InterfaceCode::POSITION2D, 0)], &[], &[]);
        assert!(
            ReadLog::from_block(&b)
                .unwrap_err()
                .to_string()
                .contains("filename")
        );
    }

    #[test]
    fn replays_answers_geometry_and_obeys_the_log_device() {
        let dir = tmp("replay");
        let text = format!(
            "0000000000.500 16777343 6665 laser 00 004 001  +0.100  +0.000   0.000   0.150   0.100\n{POS}{}",
            POS.replace("0000000001.000", "0000000001.050")
        );
        let p = write(&dir, "r.log", &text);
        let laser = addr(InterfaceCode::LASER, 0);
        let pos = addr(InterfaceCode::POSITION2D, 0);
        let log = addr(InterfaceCode::LOG, 0);
        let b = block(
            NAME,
            &[pos, laser, log],
            &[],
            &[("filename", p.to_str().unwrap()), ("autoplay", "0")],
        );
        let mut h = Harness::new(ReadLog::from_block(&b).unwrap());
        h.setup();
        let (reply, _, _) = h.request(log, LogReq::GetState(None));
        assert_eq!(
            reply,
            Reply::ack(LogReq::GetState(Some(LogGetState {
                log_type: PLAYER_LOG_TYPE_READ,
                state: 0
            })))
        );
        std::thread::sleep(Duration::from_millis(150));
        assert!(h.update().published.is_empty(), "autoplay 0 waits");
        h.request(
            log,
            LogReq::SetReadState(Some(LogSetReadState { state: 1 })),
        );
        let start = Instant::now();
        let mut got = Vec::new();
        while got.len() < 2 && start.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(5));
            got.extend(h.update().published);
        }
        assert_eq!(got.len(), 2);
        assert!(got.iter().all(|p| p.addr == pos));
        assert_eq!(got[0].timestamp, Some(1.0));
        assert_eq!(got[1].timestamp, Some(1.05));
        assert!(matches!(got[0].body, Body::Position2d(_)));
        let Body::Position2d(player_proto::Position2dMsg::Data(Position2dData::State(s))) =
            &got[0].body
        else {
            panic!()
        };
        assert_eq!((s.pos.px, s.pos.py, s.pos.pa), (1.0, -2.0, 0.5));
        // The geometry line answers GET_GEOM; nothing answers what the log lacks.
        let (reply, _, _) = h.request(laser, LaserReq::GetGeom(None));
        let Reply::Ack(Some(Body::Laser(player_proto::LaserMsg::Req(LaserReq::GetGeom(Some(g)))))) =
            reply
        else {
            panic!("{reply:?}")
        };
        assert_eq!((g.pose.px, g.size.sl, g.size.sw), (0.1, 0.15, 0.1));
        let (reply, _, _) = h.request(pos, player_proto::Position2dReq::GetGeom(None));
        assert_eq!(reply, Reply::Nack);
        // At the end the replay stops; a rewind and a start replay it again.
        let start = Instant::now();
        loop {
            let (reply, _, _) = h.request(log, LogReq::GetState(None));
            if reply
                == Reply::ack(LogReq::GetState(Some(LogGetState {
                    log_type: 1,
                    state: 0,
                })))
            {
                break;
            }
            assert!(start.elapsed() < Duration::from_secs(5));
            std::thread::sleep(Duration::from_millis(10));
        }
        h.request(log, LogReq::SetReadRewind);
        h.request(
            log,
            LogReq::SetReadState(Some(LogSetReadState { state: 1 })),
        );
        let mut again = Vec::new();
        while again.len() < 2 && start.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(5));
            again.extend(h.update().published);
        }
        assert_eq!(again.len(), 2);
        drop(h);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
