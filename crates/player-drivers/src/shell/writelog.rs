//! `writelog` (Player 3.0.2 `server/drivers/shell/writelog.cc`): records the DATA of the
//! devices it requires to a text log in Player's format ([`super::logformat`]), which
//! `readlog` replays.
//!
//! cfg: `requires` the devices to record, `provides` one `log` device (recording control:
//! SET_WRITE_STATE, GET_STATE, SET_FILENAME). Options as upstream: `filename` (default
//! `writelog_YYYY_MM_DD_HH_MM_SS.log`, built from `basename` (`writelog_`), `timestamp` (1) and
//! `extension` (`.log`)), `log_directory` (`.`, created if missing) and `timestamp_directory`
//! (0), `autorecord` (1: record from the start; upstream's code default, its documentation
//! says 0), `camera_log_images` (1), `camera_save_images` (0: each camera frame also saved as
//! `<stem>_camera_II_NNNNNN.pnm`), `write_particles` (0: after each localize DATA, its
//! GET_PARTICLES reply too). Usually `alwayson 1`.
//!
//! When the file opens (first subscription, or SET_FILENAME) the header is written and the
//! geometry of each laser, sonar, ranger (and its config) and position2d device is requested
//! and written as RESP_ACK lines, before any data, as upstream does (DATA arriving meanwhile
//! is held back, not dropped). A message whose interface has no format is written as a bare
//! header line, with a warning (once per kind), as upstream does.
//!
//! Differences from upstream: a name ending in `.gz` is written gzip-compressed, in whole
//! gzip members of 64 KiB of lines (upstream writes plain text whatever the name); an absolute `filename` is used as is (upstream
//! prefixes `log_directory/` even then); the timestamp of the default name is UTC (upstream:
//! local time); a file that cannot be opened refuses the subscription with the reason
//! (upstream's thread exits with an error message and the driver stays subscribed).

use std::collections::{BTreeSet, HashMap};
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use flate2::Compression;
use flate2::write::GzEncoder;
use player_proto::{
    Body, CameraData, CameraMsg, DeviceAddr, InterfaceCode, LaserReq, LocalizeReq, LogMsg, LogReq,
    Message, MsgType, PLAYER_LOG_TYPE_WRITE, Position2dReq, RangerReq, SonarReq,
};
use player_server::{
    Context, Driver, DriverBlock, DriverError, Reply, RequestError, RequestTicket,
};

use super::logformat::{self, FILE_HEADER, WriteOptions};
use crate::options;

/// The name cfg files use.
pub const NAME: &str = "writelog";

/// Uncompressed bytes of lines gathered into one gzip member before it is written: a gzip
/// log is a series of whole members (a multi-member file, which gzip and `readlog` read as
/// one), so a failed write cuts off a whole member and the file never ends in a stream cut
/// short.
const GZIP_MEMBER_BYTES: usize = 1 << 16;

/// An open log: plain text (each line written to the file as it comes, as upstream flushes
/// after every line) or gzip (lines gathered into members of [`GZIP_MEMBER_BYTES`]).
enum Sink {
    /// `complete` is the length of the file up to the end of its last complete line; `kept`
    /// the lines in it.
    Plain {
        file: File,
        complete: u64,
        kept: u64,
    },
    /// `complete` is the length of the file up to the end of its last whole member, `kept`
    /// the lines in it; `member` compresses the `member_lines` lines since, in memory.
    Gzip {
        file: File,
        complete: u64,
        kept: u64,
        member: GzEncoder<Vec<u8>>,
        member_bytes: usize,
        member_lines: u64,
    },
}

impl Sink {
    fn create(path: &Path) -> std::io::Result<Sink> {
        let file = File::create(path)?;
        Ok(if is_gzip(path) {
            Sink::Gzip {
                file,
                complete: 0,
                kept: 0,
                member: new_member(),
                member_bytes: 0,
                member_lines: 0,
            }
        } else {
            Sink::Plain {
                file,
                complete: 0,
                kept: 0,
            }
        })
    }

    /// Writes `bytes` at the end of `file`, whose first `complete` bytes are whole lines or
    /// members; on failure cuts off the part written, so the file keeps ending there.
    fn append(file: &mut File, complete: &mut u64, bytes: &[u8]) -> std::io::Result<()> {
        match file.write_all(bytes) {
            Ok(()) => {
                *complete += bytes.len() as u64;
                Ok(())
            }
            Err(e) => {
                let cut = file.set_len(*complete);
                Err(match cut {
                    Ok(()) => e,
                    Err(cut) => std::io::Error::new(
                        e.kind(),
                        format!("{e}, and cutting the part written failed too: {cut}"),
                    ),
                })
            }
        }
    }

    /// Writes the gzip member gathered so far (if it holds any line) and starts a new one.
    fn write_member(&mut self) -> std::io::Result<()> {
        let Sink::Gzip {
            file,
            complete,
            kept,
            member,
            member_bytes,
            member_lines,
        } = self
        else {
            return Ok(());
        };
        if *member_lines == 0 {
            return Ok(());
        }
        let done = std::mem::replace(member, new_member()).finish()?;
        Sink::append(file, complete, &done)?;
        *kept += *member_lines;
        *member_lines = 0;
        *member_bytes = 0;
        Ok(())
    }

    /// The lines the file holds whole (a gzip log's lines still gathering in memory are not
    /// counted).
    fn kept(&self) -> u64 {
        match self {
            Sink::Plain { kept, .. } | Sink::Gzip { kept, .. } => *kept,
        }
    }

    /// Writes one line (ending in a newline). When a plain log cannot take the whole line
    /// (a full disk, a file size limit), the part that was written is cut off again: a line
    /// cut short could still read as a message whose last number lost its last digits.
    /// A gzip log gathers the line into its member and writes the member once it holds
    /// [`GZIP_MEMBER_BYTES`]; a member that cannot be written whole is cut off the same way.
    fn write_line(&mut self, line: &str) -> std::io::Result<()> {
        match self {
            Sink::Plain {
                file,
                complete,
                kept,
            } => {
                Sink::append(file, complete, line.as_bytes())?;
                *kept += 1;
                Ok(())
            }
            Sink::Gzip {
                member,
                member_bytes,
                member_lines,
                ..
            } => {
                member.write_all(line.as_bytes())?;
                *member_bytes += line.len();
                *member_lines += 1;
                if *member_bytes >= GZIP_MEMBER_BYTES {
                    self.write_member()?;
                }
                Ok(())
            }
        }
    }

    fn close(mut self) -> std::io::Result<()> {
        self.write_member()?;
        match &mut self {
            Sink::Plain { file, .. } | Sink::Gzip { file, .. } => file.flush(),
        }
    }
}

/// A gzip member in memory, at the default level.
fn new_member() -> GzEncoder<Vec<u8>> {
    GzEncoder::new(Vec::new(), Compression::default())
}

/// Whether `path` names a gzip file (ends in `.gz`, any case, as upstream's readlog tests).
pub fn is_gzip(path: &Path) -> bool {
    path.to_string_lossy().to_ascii_lowercase().ends_with(".gz")
}

/// `YYYY_MM_DD_HH_MM_SS` of `secs` since the Unix epoch (UTC).
pub fn timestamp_text(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}_{month:02}_{day:02}_{:02}_{:02}_{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// The `writelog` block `player --record FILE` adds to a cfg: recording, from the start,
/// every device the other blocks provide whose interface has a log format (see
/// [`logformat::has_format`]), to `file`, with a log device of its own on `port` (the
/// first free `log` index). `None` when nothing can be recorded.
pub fn recording_block(blocks: &[DriverBlock], file: &Path, port: u16) -> Option<DriverBlock> {
    let provided: Vec<&player_server::ProvidedDevice> =
        blocks.iter().flat_map(|b| b.provides.iter()).collect();
    let requires: Vec<player_server::RequiredDevice> = provided
        .iter()
        .filter(|p| logformat::has_format(p.addr.interf))
        .map(|p| player_server::RequiredDevice {
            addr: p.addr,
            key: None,
            origin: p.origin.clone(),
        })
        .collect();
    if requires.is_empty() {
        return None;
    }
    let index = (0..=u16::MAX)
        .find(|i| {
            !provided.iter().any(|p| {
                p.addr.interf == InterfaceCode::LOG
                    && p.addr.index == *i
                    && p.addr.robot == u32::from(port)
            })
        })
        .unwrap_or(0);
    let origin = "--record";
    let log = DeviceAddr::new(
        player_proto::constants::LOCALHOST_ADDR,
        u32::from(port),
        InterfaceCode::LOG,
        index,
    );
    let block = DriverBlock::new(NAME, origin)
        .providing([log], origin)
        .with_option("filename", [file.display().to_string()])
        .with_option("autorecord", ["1"]);
    Some(DriverBlock {
        requires,
        alwayson: Some(true),
        ..block
    })
}

/// The driver. See the module docs.
pub struct WriteLog {
    log_addr: DeviceAddr,
    devices: Vec<DeviceAddr>,
    log_directory: PathBuf,
    filestem: String,
    path: PathBuf,
    enable_default: bool,
    enabled: bool,
    options: WriteOptions,
    camera_save_images: bool,
    camera_frames: HashMap<u16, u32>,
    sink: Option<Sink>,
    /// Geometry requests not answered yet, and the device each asked.
    geometry_pending: HashMap<RequestTicket, DeviceAddr>,
    /// Particle requests (`write_particles`) not answered yet, and the device each asked.
    particles_pending: HashMap<RequestTicket, DeviceAddr>,
    write_particles: bool,
    /// Data lines written while geometry requests are pending, in arrival order.
    held: Vec<String>,
    warned: BTreeSet<(u16, u8, u8)>,
    lines_written: u64,
    /// Why the last file stopped being written, if it did.
    failed: Option<String>,
}

impl std::fmt::Debug for WriteLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WriteLog")
            .field("path", &self.path)
            .field("devices", &self.devices)
            .field("enabled", &self.enabled)
            .finish()
    }
}

impl WriteLog {
    /// Builds the driver from its cfg block (see the module docs for the options).
    pub fn from_block(block: &DriverBlock) -> Result<WriteLog, DriverError> {
        let log_addr = block.provided(InterfaceCode::LOG)?;
        if let Some(other) = block
            .provides
            .iter()
            .find(|p| p.addr.interf != InterfaceCode::LOG)
        {
            return Err(DriverError::new(format!(
                "{}: writelog provides only a log device, not {}",
                other.origin, other.addr.interf
            )));
        }
        let devices: Vec<DeviceAddr> = block.requires.iter().map(|r| r.addr).collect();
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0);
        let stamp = timestamp_text(now);
        let flag = |key: &str, default: i64| -> Result<bool, DriverError> {
            Ok(options::int(block, key)?.unwrap_or(default) > 0)
        };
        let basename = block.option("basename").unwrap_or("writelog_");
        let extension = block.option("extension").unwrap_or(".log");
        let filestem = format!(
            "{basename}{}",
            if flag("timestamp", 1)? {
                stamp.as_str()
            } else {
                ""
            }
        );
        let default_name = format!("{filestem}{extension}");
        let name = block.option("filename").unwrap_or(&default_name);
        let mut dir = block.option("log_directory").unwrap_or("").to_string();
        if flag("timestamp_directory", 0)? {
            dir.push_str(&stamp);
        }
        if dir.is_empty() {
            dir.push('.');
        }
        let log_directory = PathBuf::from(dir);
        let path = log_directory.join(name);
        let enable_default = flag("autorecord", 1)?;
        Ok(WriteLog {
            log_addr,
            devices,
            log_directory,
            filestem,
            path,
            enable_default,
            enabled: enable_default,
            options: WriteOptions {
                camera_images: flag("camera_log_images", 1)?,
            },
            camera_save_images: flag("camera_save_images", 0)?,
            camera_frames: HashMap::new(),
            sink: None,
            geometry_pending: HashMap::new(),
            particles_pending: HashMap::new(),
            write_particles: flag("write_particles", 0)?,
            held: Vec::new(),
            warned: BTreeSet::new(),
            lines_written: 0,
            failed: None,
        })
    }

    /// The file written to (or to be written to at the next setup).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether data is being recorded.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Opens the file, writes the header and asks for the geometries.
    fn open(&mut self, ctx: &mut Context<'_>) -> Result<(), String> {
        self.close();
        if !self.log_directory.as_os_str().is_empty() {
            // Upstream's mkdir; an existing directory is fine, a failure shows when opening.
            let _ = std::fs::create_dir_all(&self.log_directory);
        }
        let mut sink = Sink::create(&self.path)
            .map_err(|e| format!("unable to open [{}]: {e}", self.path.display()))?;
        sink.write_line(FILE_HEADER)
            .map_err(|e| format!("writing {}: {e}", self.path.display()))?;
        self.sink = Some(sink);
        self.failed = None;
        self.lines_written = 0;
        tracing::info!("{NAME}: logging to {}", self.path.display());
        for dev in self.devices.clone() {
            let bodies: Vec<Body> = match dev.interf {
                InterfaceCode::SONAR => vec![SonarReq::GetGeom(None).into()],
                InterfaceCode::LASER => vec![LaserReq::GetGeom(None).into()],
                InterfaceCode::RANGER => vec![
                    RangerReq::GetGeom(None).into(),
                    RangerReq::GetConfig(None).into(),
                ],
                InterfaceCode::POSITION2D => vec![Position2dReq::GetGeom(None).into()],
                _ => vec![],
            };
            for body in bodies {
                let ticket = ctx.request(dev, body);
                self.geometry_pending.insert(ticket, dev);
            }
        }
        Ok(())
    }

    fn close(&mut self) {
        self.flush_held();
        self.geometry_pending.clear();
        if let Some(sink) = self.sink.take()
            && let Err(e) = sink.close()
        {
            tracing::error!("{NAME}: closing {}: {e}", self.path.display());
        }
    }

    /// Writes a line. A write that fails (a full disk, a file size limit) stops the
    /// recording with one error naming the file and the cause, instead of one per message:
    /// the log keeps every line before it, complete, and clients see the log device stopped
    /// (GET_STATE) until they give it a new file name.
    fn write(&mut self, line: &str) {
        let Some(sink) = self.sink.as_mut() else {
            return;
        };
        match sink.write_line(line) {
            Ok(()) => self.lines_written += 1,
            Err(e) => {
                // the header's line is not a message line
                self.lines_written = sink.kept().saturating_sub(1);
                tracing::error!(
                    "{NAME}: writing {} failed: {e}; recording stopped after {} message \
                     lines (the log ends with its last complete line); give the log device a \
                     new file name (PLAYER_LOG_REQ_SET_FILENAME) to record again",
                    self.path.display(),
                    self.lines_written
                );
                // (a gzip sink's lines not yet in a member written are dropped with it: the
                // file ends with its last whole member)
                self.sink = None;
                self.enabled = false;
                self.held.clear();
                self.failed = Some(e.to_string());
            }
        }
    }

    fn flush_held(&mut self) {
        for line in std::mem::take(&mut self.held) {
            self.write(&line);
        }
    }

    /// Formats one message of `device` and writes (or holds) its line.
    /// Records `device`'s ACK to the driver's own request for its `what` (geometry,
    /// particles), or warns that it gave none; `hold` as in [`WriteLog::record`].
    fn record_answer(
        &mut self,
        device: &DeviceAddr,
        reply: Result<Message, RequestError>,
        what: &str,
        hold: bool,
    ) {
        match reply {
            Ok(msg) => self.record(
                device,
                MsgType::RespAck.code(),
                &msg.body,
                msg.header.timestamp,
                hold,
            ),
            Err(e) => tracing::warn!("{NAME}: unable to get the {what} of {device}: {e}"),
        }
    }

    fn record(&mut self, device: &DeviceAddr, msg_type: u8, body: &Body, time: f64, hold: bool) {
        let (line, result) = logformat::encode_line(time, device, msg_type, body, self.options);
        if let Err(why) = result
            && self
                .warned
                .insert((why.interface.0, why.msg_type, why.subtype))
        {
            tracing::warn!("{NAME}: not logging the payload of a message: {why}");
        }
        if hold && !self.geometry_pending.is_empty() {
            self.held.push(line);
        } else {
            self.write(&line);
        }
    }

    fn save_camera_image(&mut self, device: &DeviceAddr, body: &Body) {
        let Body::Camera(CameraMsg::Data(CameraData::State(c))) = body else {
            return;
        };
        let frame = self.camera_frames.entry(device.index).or_insert(0);
        let (ext, header) = match (c.compression, c.format) {
            // PLAYER_CAMERA_COMPRESS_RAW with RGB888 (5) or MONO8 (1).
            (0, 5) => ("pnm", Some(format!("P6\n{} {}\n255\n", c.width, c.height))),
            (0, 1) => ("pnm", Some(format!("P5\n{} {}\n255\n", c.width, c.height))),
            (0, _) => ("pnm", None),
            (1, _) => ("jpg", Some(String::new())),
            _ => {
                tracing::warn!("{NAME}: unsupported camera compression {}", c.compression);
                return;
            }
        };
        let name = format!(
            "{}_camera_{:02}_{:06}.{ext}",
            self.filestem, device.index, frame
        );
        *frame += 1;
        let path = self.log_directory.join(name);
        let written = File::create(&path).and_then(|mut f| {
            if let Some(h) = &header {
                f.write_all(h.as_bytes())?;
                f.write_all(&c.image)?;
            }
            Ok(())
        });
        if header.is_none() {
            tracing::warn!("{NAME}: unsupported camera image format {}", c.format);
        }
        if let Err(e) = written {
            tracing::error!("{NAME}: saving {}: {e}", path.display());
        }
    }
}

impl Driver for WriteLog {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        for dev in &self.devices {
            ctx.subscribe(*dev);
        }
        self.enabled = self.enable_default;
        self.open(ctx).map_err(DriverError::new)
    }

    fn teardown(&mut self, _ctx: &mut Context<'_>) {
        self.close();
    }

    fn shutdown(&mut self) {
        self.close();
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        if !request.header.addr.same_device(&self.log_addr) {
            return Reply::NotHandled;
        }
        let Body::Log(LogMsg::Req(req)) = &request.body else {
            return Reply::NotHandled;
        };
        match req {
            LogReq::SetWriteState(Some(s)) if s.state != 0 && self.sink.is_none() => {
                let why = self.failed.as_deref().unwrap_or("it could not be opened");
                tracing::warn!(
                    "{NAME}: cannot record to {}: {why}; set a new file name first",
                    self.path.display()
                );
                Reply::Nack
            }
            LogReq::SetWriteState(Some(s)) => {
                super::switch_state(NAME, &mut self.enabled, s.state, "logging");
                Reply::ack(LogReq::SetWriteState(None))
            }
            LogReq::GetState(_) => super::state_reply(PLAYER_LOG_TYPE_WRITE, self.enabled),
            LogReq::SetFilename(Some(f)) => {
                if self.enabled {
                    tracing::warn!("{NAME}: tried to switch filenames while logging");
                    return Reply::Nack;
                }
                self.path = PathBuf::from(f.filename.to_str_lossy().into_owned());
                match self.open(ctx) {
                    Ok(()) => Reply::ack(LogReq::SetFilename(None)),
                    Err(e) => {
                        tracing::warn!("{NAME}: {e}");
                        Reply::Nack
                    }
                }
            }
            _ => Reply::Nack,
        }
    }

    fn handle_reply(
        &mut self,
        _ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        if let Some(device) = self.particles_pending.remove(&ticket) {
            self.record_answer(&device, reply, "particles", true);
            return;
        }
        let Some(device) = self.geometry_pending.remove(&ticket) else {
            return;
        };
        self.record_answer(&device, reply, "geometry", false);
        if self.geometry_pending.is_empty() {
            self.flush_held();
        }
    }

    fn handle_data(&mut self, ctx: &mut Context<'_>, data: &Message) {
        if !self.enabled || self.sink.is_none() {
            return;
        }
        let Some(device) = self
            .devices
            .iter()
            .find(|d| d.same_device(&data.header.addr))
            .copied()
        else {
            return;
        };
        self.record(
            &device,
            MsgType::Data.code(),
            &data.body,
            data.header.timestamp,
            true,
        );
        if self.camera_save_images && device.interf == InterfaceCode::CAMERA {
            self.save_camera_image(&device, &data.body);
        }
        // Upstream's write_particles: after each localize DATA, its particle set.
        if self.write_particles && device.interf == InterfaceCode::LOCALIZE {
            let ticket = ctx.request(device, LocalizeReq::GetParticles(None));
            self.particles_pending.insert(ticket, device);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{Harness, addr, block};
    use player_proto::{
        LaserData, LaserDataScan, LaserGeom, LogGetState, LogSetFilename, LogSetWriteState, Pose2d,
        Position2dData, Position2dDataState, Text,
    };

    fn log0() -> DeviceAddr {
        addr(InterfaceCode::LOG, 0)
    }

    #[test]
    fn record_flag_block_records_every_loggable_device() {
        let stage = block(
            "stage",
            &[
                addr(InterfaceCode::SIMULATION, 0),
                addr(InterfaceCode::POSITION2D, 0),
                addr(InterfaceCode::RANGER, 1),
                addr(InterfaceCode::LOG, 0),
            ],
            &[],
            &[],
        );
        let b = recording_block(&[stage], Path::new("/tmp/r.log"), 6665).unwrap();
        let req: Vec<_> = b.requires.iter().map(|r| r.addr).collect();
        assert_eq!(
            req,
            vec![
                addr(InterfaceCode::POSITION2D, 0),
                addr(InterfaceCode::RANGER, 1)
            ]
        );
        assert_eq!(b.provides[0].addr, addr(InterfaceCode::LOG, 1));
        assert_eq!(b.option("filename"), Some("/tmp/r.log"));
        assert_eq!(b.alwayson, Some(true));
        assert!(WriteLog::from_block(&b).unwrap().enabled());
        let sim = block("stage", &[addr(InterfaceCode::SIMULATION, 0)], &[], &[]);
        assert!(recording_block(&[sim], Path::new("x.log"), 6665).is_none());
    }

    #[test]
    fn write_particles_asks_for_the_particle_set_after_each_hypothesis() {
        let dir = std::env::temp_dir().join(format!("writelog-amcl-{}", std::process::id()));
        let loc = addr(InterfaceCode::LOCALIZE, 0);
        let b = block(
            NAME,
            &[log0()],
            &[loc],
            &[
                ("log_directory", dir.to_str().unwrap()),
                ("filename", "p.log"),
                ("write_particles", "1"),
            ],
        );
        let mut h = Harness::new(WriteLog::from_block(&b).unwrap());
        assert!(h.setup().requests().is_empty(), "no geometry for localize");
        let out = h.data(
            loc,
            player_proto::LocalizeData::Hypoths(Default::default()),
            2.0,
        );
        let reqs = out.requests();
        assert_eq!(reqs.len(), 1);
        assert_eq!(reqs[0].2, LocalizeReq::GetParticles(None).into());
        h.ack(
            reqs[0].0,
            loc,
            LocalizeReq::GetParticles(Some(player_proto::LocalizeGetParticles {
                particles: vec![Default::default()],
                ..Default::default()
            })),
        );
        let text = std::fs::read_to_string(dir.join("p.log")).unwrap();
        let lines: Vec<&str> = text.lines().filter(|l| !l.starts_with("##")).collect();
        assert_eq!(
            lines,
            vec![
                "0000000002.000 16777343 6665 localize 00 001 001          0 +00.000  0 ",
                "0000000001.000 16777343 6665 localize 00 004 002  +0.000  +0.000   0.000   0.000          1  +0.000  +0.000   0.000   0.000 ",
            ]
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_default_name_is_timestamped_like_upstream() {
        assert_eq!(timestamp_text(0), "1970_01_01_00_00_00");
        assert_eq!(timestamp_text(1_764_125_135), "2025_11_26_02_45_35");
        let b = block(NAME, &[log0()], &[addr(InterfaceCode::LASER, 0)], &[]);
        let d = WriteLog::from_block(&b).unwrap();
        let name = d.path().file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            name.starts_with("writelog_") && name.ends_with(".log") && name.len() == 32,
            "{name}"
        );
        assert!(d.enabled(), "autorecord defaults to 1 in upstream's code");
        let b = block(NAME, &[addr(InterfaceCode::LASER, 1)], &[], &[]);
        assert!(WriteLog::from_block(&b).is_err());
    }

    #[test]
    fn records_geometry_first_then_data_and_obeys_the_log_device() {
        let dir = std::env::temp_dir().join(format!("writelog-unit-{}", std::process::id()));
        let laser = addr(InterfaceCode::LASER, 0);
        let pos = addr(InterfaceCode::POSITION2D, 0);
        let file = dir.join("w.log");
        let b = block(
            NAME,
            &[log0()],
            &[laser, pos],
            &[
                ("log_directory", dir.to_str().unwrap()),
                ("filename", "w.log"),
            ],
        );
        let mut h = Harness::new(WriteLog::from_block(&b).unwrap());
        let out = h.setup();
        assert_eq!(out.subscriptions(), vec![laser, pos]);
        let reqs = out.requests();
        assert_eq!(reqs.len(), 2, "laser and position2d geometry");
        // Data before the geometry answers is held back, then written after them.
        let scan = LaserDataScan {
            min_angle: -1.5,
            max_angle: 1.5,
            resolution: 1.5,
            max_range: 8.0,
            ranges: vec![1.0, 2.5, 3.25],
            intensity: vec![0, 1, 0],
            id: 7,
        };
        h.data(laser, LaserData::Scan(scan.clone()), 12.25);
        h.ack(
            reqs[0].0,
            laser,
            LaserReq::GetGeom(Some(LaserGeom::default())),
        );
        h.nack(reqs[1].0);
        let state = Position2dDataState {
            pos: Pose2d {
                px: 1.0,
                py: -2.0,
                pa: 0.5,
            },
            ..Default::default()
        };
        h.data(pos, Position2dData::State(state.clone()), 12.5);
        // Stopped: nothing recorded.
        let (reply, _, _) = h.request(
            log0(),
            LogReq::SetWriteState(Some(LogSetWriteState { state: 0 })),
        );
        assert_eq!(reply, Reply::ack(LogReq::SetWriteState(None)));
        h.data(pos, Position2dData::State(state.clone()), 13.0);
        let (reply, _, _) = h.request(log0(), LogReq::GetState(None));
        assert_eq!(
            reply,
            Reply::ack(LogReq::GetState(Some(LogGetState {
                log_type: PLAYER_LOG_TYPE_WRITE,
                state: 0
            })))
        );
        // A new file while stopped; refused while recording.
        let other = dir.join("second.log");
        let (reply, _, _) = h.request(
            log0(),
            LogReq::SetFilename(Some(LogSetFilename {
                filename: Text::new(other.to_str().unwrap()),
            })),
        );
        assert_eq!(reply, Reply::ack(LogReq::SetFilename(None)));
        let text = std::fs::read_to_string(&file).unwrap();
        let lines: Vec<&str> = text.lines().filter(|l| !l.starts_with("##")).collect();
        assert_eq!(
            lines,
            vec![
                "0000000001.000 16777343 6665 laser 00 004 001  +0.000  +0.000   0.000   0.000   0.000",
                "0000000012.250 16777343 6665 laser 00 001 001 0007 -1.5000 +1.5000 +1.50000000 +8.0000 0003 1.000  0 2.500  1 3.250  0 ",
                "0000000012.500 16777343 6665 position2d 00 001 001 +01.000 -02.000 +0.500 +00.000 +00.000 +00.000 0",
            ]
        );
        assert!(text.starts_with(FILE_HEADER));
        h.request(
            log0(),
            LogReq::SetWriteState(Some(LogSetWriteState { state: 1 })),
        );
        let (reply, _, _) = h.request(
            log0(),
            LogReq::SetFilename(Some(LogSetFilename {
                filename: Text::new("x.log"),
            })),
        );
        assert_eq!(reply, Reply::Nack);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
