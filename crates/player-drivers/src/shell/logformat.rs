//! Player 3.0.2's text log format, as `writelog` writes it and `readlog` reads it
//! (`server/drivers/shell/writelog.cc` and `readlog.cc`).
//!
//! A log is a header of `##` lines, then one line per message:
//!
//! ```text
//! time           host     robot interface index type subtype payload...
//! 0000000012.300 16777343 6665  laser     00    001  001     0000 -1.5708 ...
//! ```
//!
//! `time` is `%014.3f` seconds, `host` the packed IPv4 address, `robot` the port, `index`
//! `%02u`, `type` and `subtype` `%03u`; the payload is each interface's fields printed with
//! upstream's own `printf` formats (so a value keeps exactly the digits upstream keeps: ranges
//! to the millimetre, poses to the millimetre and milliradian, resolutions to 1e-8). Replies
//! (type 4, RESP_ACK) carry geometry and configuration: a reader keeps them to answer requests,
//! and publishes nothing for them.
//!
//! The interfaces with a format are upstream's: laser, ranger, sonar, position2d, localize,
//! blobfinder, fiducial, camera and actarray among those this server serves. Upstream's
//! `writelog` has none for gripper, simulation, map or planner: it writes such a message as a
//! header without payload (and warns), and `readlog` skips it; this module does the same
//! ([`encode_payload`] returns [`Unsupported`]).
//!
//! Differences from upstream, where upstream's two halves disagree with each other: a
//! RANGESTAMPED/INTNSSTAMPED line has no `have_config` token (the writer never prints it but
//! the reader expects one), so a config is read when exactly its seven values follow the
//! geometry; the fiducial geometry reply is printed with a space between its 5th and 6th values
//! (upstream's format string glues them, which its reader cannot split); laser SCANANGLE lines
//! are read (upstream writes them but its reader refuses them). Numbers are read strictly: a
//! field that is not a number is an error naming the file and line, where C's `atof` reads 0.

use std::fmt::Write as _;

use player_proto::{
    ActarrayActuator, ActarrayData, ActarrayDataState, ActarrayMsg, Bbox2d, Bbox3d, BlobfinderBlob,
    BlobfinderData, BlobfinderDataBlobs, BlobfinderMsg, Body, CameraData, CameraDataState,
    CameraMsg, DeviceAddr, FiducialData, FiducialDataScan, FiducialGeom, FiducialItem, FiducialMsg,
    FiducialReq, InterfaceCode, LaserData, LaserDataScan, LaserDataScanangle, LaserDataScanpose,
    LaserGeom, LaserMsg, LaserReq, LocalizeData, LocalizeDataHypoths, LocalizeGetParticles,
    LocalizeHypoth, LocalizeMsg, LocalizeParticle, LocalizeReq, MsgType, Pose2d, Pose3d,
    Position2dData, Position2dDataState, Position2dGeom, Position2dMsg, Position2dReq,
    RangerConfig, RangerData, RangerDataIntns, RangerDataIntnsstamped, RangerDataRange,
    RangerDataRangestamped, RangerGeom, RangerMsg, RangerReq, SonarData, SonarDataRanges,
    SonarGeom, SonarMsg, SonarReq,
};

/// The header upstream's `writelog` writes at the top of every log (`WriteLog::OpenFile`).
pub const FILE_HEADER: &str = "## Player version 3.0.2 \n\
## File version 0.3.0 \n\
## Format: \n\
## - Messages are newline-separated\n\
## - Common header to each message is:\n\
##   time     host   robot  interface index  type   subtype\n\
##   (double) (uint) (uint) (string)  (uint) (uint) (uint)\n\
## - Following the common header is the message payload \n";

/// Whether the writer has a payload format for any message of `interface`.
pub fn has_format(interface: InterfaceCode) -> bool {
    matches!(
        interface,
        InterfaceCode::LASER
            | InterfaceCode::RANGER
            | InterfaceCode::SONAR
            | InterfaceCode::POSITION2D
            | InterfaceCode::LOCALIZE
            | InterfaceCode::BLOBFINDER
            | InterfaceCode::FIDUCIAL
            | InterfaceCode::CAMERA
            | InterfaceCode::ACTARRAY
    )
}

/// A message upstream's format has no payload for (interface, type, subtype); the line is
/// written with its header only, as upstream does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("no log format for {interface} messages of type {msg_type} subtype {subtype}")]
pub struct Unsupported {
    /// The interface.
    pub interface: InterfaceCode,
    /// The message type code.
    pub msg_type: u8,
    /// The subtype.
    pub subtype: u8,
}

/// How camera images are written (`camera_log_images`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WriteOptions {
    /// Write the image bytes as hex (upstream default); off, the line keeps only the
    /// image's size and format.
    pub camera_images: bool,
}

impl Default for WriteOptions {
    fn default() -> WriteOptions {
        WriteOptions {
            camera_images: true,
        }
    }
}

/// C's `%[+][0]W.Pf` for one value: `plus` the `+` flag, `zero` the `0` flag, `width` the
/// minimum width. Infinities and NaN print as C prints them (`inf`, `-nan`, never zero-padded).
fn cf(out: &mut String, x: f64, plus: bool, zero: bool, width: usize, prec: usize) {
    if !x.is_finite() {
        let body = if x.is_nan() {
            if x.is_sign_negative() { "-nan" } else { "nan" }
        } else if x < 0.0 {
            "-inf"
        } else {
            "inf"
        };
        let sign = if plus && !body.starts_with('-') {
            "+"
        } else {
            ""
        };
        let _ = write!(out, "{:>width$}", format!("{sign}{body}"));
        return;
    }
    let _ = match (plus, zero) {
        (true, true) => write!(out, "{x:+0width$.prec$}"),
        (true, false) => write!(out, "{x:>+width$.prec$}"),
        (false, true) => write!(out, "{x:0width$.prec$}"),
        (false, false) => write!(out, "{x:>width$.prec$}"),
    };
}

/// `%+07.3f` followed by a space, the most common field of upstream's formats.
fn p7_3(out: &mut String, x: f64) {
    cf(out, x, true, true, 7, 3);
    out.push(' ');
}

/// `%.3f` followed by a space (ranges).
fn f3(out: &mut String, x: f64) {
    cf(out, x, false, false, 0, 3);
    out.push(' ');
}

/// `%f` (six decimals) followed by a space.
fn f6(out: &mut String, x: f64) {
    cf(out, x, false, false, 0, 6);
    out.push(' ');
}

/// The line's common header, `%014.3f %u %u %s %02u %03u %03u ` as upstream writes it.
pub fn encode_header(out: &mut String, time: f64, addr: &DeviceAddr, msg_type: u8, subtype: u8) {
    cf(out, time, false, true, 14, 3);
    let name = addr.interf.name().unwrap_or("unknown");
    let _ = write!(
        out,
        " {} {} {} {:02} {:03} {:03} ",
        addr.host, addr.robot, name, addr.index, msg_type, subtype
    );
}

/// One whole line (header, payload, newline) for a message of `addr`. A message without a
/// format still gets its line (header only) and the [`Unsupported`] reason, as upstream writes
/// and warns.
///
/// `msg_type` is the message's type code: a reply travels with a request-kind body and the
/// RESP_ACK type in its header (see [`player_server::Reply::ack`]).
pub fn encode_line(
    time: f64,
    addr: &DeviceAddr,
    msg_type: u8,
    body: &Body,
    options: WriteOptions,
) -> (String, Result<(), Unsupported>) {
    let mut line = String::with_capacity(64);
    encode_header(&mut line, time, addr, msg_type, body.subtype());
    let result = encode_payload(&mut line, msg_type, body, options);
    line.push('\n');
    (line, result)
}

/// The payload of `body` in upstream's format, appended to `out`.
/// Only DATA messages and RESP_ACK replies have formats.
pub fn encode_payload(
    out: &mut String,
    msg_type: u8,
    body: &Body,
    options: WriteOptions,
) -> Result<(), Unsupported> {
    let unsupported = || Unsupported {
        interface: body.interface().unwrap_or(InterfaceCode(0)),
        msg_type,
        subtype: body.subtype(),
    };
    let is_data = msg_type == MsgType::Data.code();
    let is_ack = msg_type == MsgType::RespAck.code();
    if is_data != (body.msg_type() == MsgType::Data) || !(is_data || is_ack) {
        return Err(unsupported());
    }
    match body {
        Body::Laser(LaserMsg::Data(LaserData::Scan(s))) => laser_scan(out, s, None),
        Body::Laser(LaserMsg::Data(LaserData::ScanPose(s))) => {
            laser_scan(out, &s.scan, Some(&s.pose))
        }
        Body::Laser(LaserMsg::Data(LaserData::ScanAngle(s))) => {
            // `%04d` of the uint32 id upstream, as for the other scans: read back as an int
            let _ = write!(out, "{:04} ", s.id as i32);
            cf(out, f64::from(s.max_range), true, true, 7, 4);
            let _ = write!(out, " {:04} ", s.ranges.len());
            for (i, r) in s.ranges.iter().enumerate() {
                f3(out, f64::from(*r));
                f3(out, f64::from(s.angles.get(i).copied().unwrap_or(0.0)));
                let _ = write!(out, "{:2} ", s.intensity.get(i).copied().unwrap_or(0));
            }
        }
        Body::Laser(
            LaserMsg::Ack(LaserReq::GetGeom(Some(g))) | LaserMsg::Req(LaserReq::GetGeom(Some(g))),
        ) => {
            // "%+7.3f %+7.3f %7.3f %7.3f %7.3f", no trailing space.
            cf(out, g.pose.px, true, false, 7, 3);
            out.push(' ');
            cf(out, g.pose.py, true, false, 7, 3);
            out.push(' ');
            cf(out, g.pose.pyaw, false, false, 7, 3);
            out.push(' ');
            cf(out, g.size.sl, false, false, 7, 3);
            out.push(' ');
            cf(out, g.size.sw, false, false, 7, 3);
        }
        Body::Ranger(RangerMsg::Data(RangerData::Range(d))) => {
            let _ = write!(out, "{:04} ", d.ranges.len());
            d.ranges.iter().for_each(|r| f3(out, *r));
        }
        Body::Ranger(RangerMsg::Data(RangerData::Intns(d))) => {
            let _ = write!(out, "{:04} ", d.intensities.len());
            d.intensities.iter().for_each(|r| f3(out, *r));
        }
        Body::Ranger(RangerMsg::Data(RangerData::RangeStamped(d))) => {
            let _ = write!(out, "{:04} ", d.data.ranges.len());
            d.data.ranges.iter().for_each(|r| f3(out, *r));
            stamped_tail(out, d.have_geom, &d.geom, d.have_config, &d.config);
        }
        Body::Ranger(RangerMsg::Data(RangerData::IntnsStamped(d))) => {
            let _ = write!(out, "{:04} ", d.data.intensities.len());
            d.data.intensities.iter().for_each(|r| f3(out, *r));
            stamped_tail(out, d.have_geom, &d.geom, d.have_config, &d.config);
        }
        Body::Ranger(
            RangerMsg::Ack(RangerReq::GetGeom(Some(g)))
            | RangerMsg::Req(RangerReq::GetGeom(Some(g))),
        ) => ranger_geom(out, g),
        Body::Ranger(
            RangerMsg::Ack(RangerReq::GetConfig(Some(c)))
            | RangerMsg::Req(RangerReq::GetConfig(Some(c))),
        ) => {
            for v in config_values(c) {
                f6(out, v);
            }
        }
        Body::Sonar(SonarMsg::Data(SonarData::Ranges(d))) => {
            let _ = write!(out, "{} ", d.ranges.len());
            d.ranges.iter().for_each(|r| f3(out, f64::from(*r)));
        }
        Body::Sonar(SonarMsg::Data(SonarData::Geom(g)))
        | Body::Sonar(
            SonarMsg::Ack(SonarReq::GetGeom(Some(g))) | SonarMsg::Req(SonarReq::GetGeom(Some(g))),
        ) => {
            let _ = write!(out, "{} ", g.poses.len());
            for p in &g.poses {
                p7_3(out, p.px);
                p7_3(out, p.py);
                cf(out, p.pyaw, true, true, 7, 4);
                out.push(' ');
            }
        }
        Body::Position2d(Position2dMsg::Data(Position2dData::State(d))) => {
            // "%+07.3f %+07.3f %+04.3f %+07.3f %+07.3f %+07.3f %d"
            p7_3(out, d.pos.px);
            p7_3(out, d.pos.py);
            cf(out, d.pos.pa, true, true, 4, 3);
            out.push(' ');
            p7_3(out, d.vel.px);
            p7_3(out, d.vel.py);
            p7_3(out, d.vel.pa);
            let _ = write!(out, "{}", d.stall);
        }
        Body::Position2d(
            Position2dMsg::Ack(Position2dReq::GetGeom(Some(g)))
            | Position2dMsg::Req(Position2dReq::GetGeom(Some(g))),
        ) => {
            // "%+07.3f %+07.3f %+04.3f %+07.3f %+07.3f"
            p7_3(out, g.pose.px);
            p7_3(out, g.pose.py);
            cf(out, g.pose.pyaw, true, true, 4, 3);
            out.push(' ');
            p7_3(out, g.size.sl);
            cf(out, g.size.sw, true, true, 7, 3);
        }
        Body::Localize(LocalizeMsg::Data(LocalizeData::Hypoths(h))) => {
            let _ = write!(out, "{:10} ", h.pending_count as i32);
            p7_3(out, h.pending_time);
            let _ = write!(out, "{:2} ", h.hypoths.len());
            for hyp in &h.hypoths {
                cf(out, hyp.mean.px, true, false, 7, 3);
                out.push(' ');
                cf(out, hyp.mean.py, true, false, 7, 3);
                out.push(' ');
                for v in [hyp.mean.pa, hyp.cov[0], hyp.cov[1], hyp.cov[2], hyp.alpha] {
                    cf(out, v, false, false, 7, 3);
                    out.push(' ');
                }
            }
        }
        Body::Localize(
            LocalizeMsg::Ack(LocalizeReq::GetParticles(Some(p)))
            | LocalizeMsg::Req(LocalizeReq::GetParticles(Some(p))),
        ) => {
            cf(out, p.mean.px, true, false, 7, 3);
            out.push(' ');
            cf(out, p.mean.py, true, false, 7, 3);
            out.push(' ');
            cf(out, p.mean.pa, false, false, 7, 3);
            out.push(' ');
            cf(out, p.variance, false, false, 7, 3);
            let _ = write!(out, " {:10} ", p.particles.len());
            for part in &p.particles {
                cf(out, part.pose.px, true, false, 7, 3);
                out.push(' ');
                cf(out, part.pose.py, true, false, 7, 3);
                out.push(' ');
                cf(out, part.pose.pa, false, false, 7, 3);
                out.push(' ');
                cf(out, part.alpha, false, false, 7, 3);
                out.push(' ');
            }
        }
        // Upstream logs every blobfinder DATA message this way, whatever its subtype.
        Body::Blobfinder(BlobfinderMsg::Data(BlobfinderData::Blobs(b))) => {
            let _ = write!(
                out,
                "{} {} {}",
                b.width as i32,
                b.height as i32,
                b.blobs.len()
            );
            for blob in &b.blobs {
                let _ = write!(
                    out,
                    " {} {} {} {} {} {} {} {} {} ",
                    blob.id as i32,
                    blob.color as i32,
                    blob.area as i32,
                    blob.x as i32,
                    blob.y as i32,
                    blob.left as i32,
                    blob.right as i32,
                    blob.top as i32,
                    blob.bottom as i32
                );
                cf(out, f64::from(blob.range), false, false, 0, 6);
            }
        }
        Body::Fiducial(FiducialMsg::Data(FiducialData::Scan(d))) => {
            let _ = write!(out, "{}", d.fiducials.len());
            for f in &d.fiducials {
                let _ = write!(out, " {}", f.id);
                for v in pose3d_values(&f.pose)
                    .into_iter()
                    .chain(pose3d_values(&f.upose))
                {
                    out.push(' ');
                    cf(out, v, true, true, 7, 3);
                }
            }
        }
        Body::Fiducial(
            FiducialMsg::Ack(FiducialReq::GetGeom(Some(g)))
            | FiducialMsg::Req(FiducialReq::GetGeom(Some(g))),
        ) => {
            let values = pose3d_values(&g.pose).into_iter().chain([
                g.size.sl,
                g.size.sw,
                g.size.sh,
                g.fiducial_size.sl,
                g.fiducial_size.sw,
            ]);
            for (i, v) in values.enumerate() {
                if i > 0 {
                    out.push(' ');
                }
                cf(out, v, true, false, 7, 3);
            }
        }
        Body::Camera(CameraMsg::Data(CameraData::State(c))) => {
            let _ = write!(
                out,
                "{} {} {} {} {} {} ",
                c.width as i32,
                c.height as i32,
                c.bpp as i32,
                c.format as i32,
                c.compression as i32,
                c.image.len()
            );
            if options.camera_images {
                encode_hex(out, &c.image);
            }
        }
        Body::Actarray(ActarrayMsg::Data(ActarrayData::State(a))) => {
            let _ = write!(out, "{} ", a.actuators.len());
            for act in &a.actuators {
                for v in [act.position, act.speed, act.acceleration, act.current] {
                    f6(out, f64::from(v));
                }
                let _ = write!(out, "{} ", act.state);
            }
            let _ = write!(out, "{} ", a.motor_state);
        }
        _ => return Err(unsupported()),
    }
    Ok(())
}

fn laser_scan(out: &mut String, s: &LaserDataScan, pose: Option<&Pose2d>) {
    let _ = write!(out, "{:04} ", s.id as i32);
    if let Some(p) = pose {
        for v in [p.px, p.py, p.pa] {
            p7_3(out, v);
        }
    }
    // "%+07.4f %+07.4f %+.8f %+07.4f %04d "
    cf(out, f64::from(s.min_angle), true, true, 7, 4);
    out.push(' ');
    cf(out, f64::from(s.max_angle), true, true, 7, 4);
    out.push(' ');
    cf(out, f64::from(s.resolution), true, false, 0, 8);
    out.push(' ');
    cf(out, f64::from(s.max_range), true, true, 7, 4);
    let _ = write!(out, " {:04} ", s.ranges.len());
    for (i, r) in s.ranges.iter().enumerate() {
        f3(out, f64::from(*r));
        let _ = write!(out, "{:2} ", s.intensity.get(i).copied().unwrap_or(0));
    }
}

fn pose3d_values(p: &Pose3d) -> [f64; 6] {
    [p.px, p.py, p.pz, p.proll, p.ppitch, p.pyaw]
}

fn config_values(c: &RangerConfig) -> [f64; 7] {
    [
        c.min_angle,
        c.max_angle,
        c.angular_res,
        c.min_range,
        c.max_range,
        c.range_res,
        c.frequency,
    ]
}

fn ranger_geom(out: &mut String, g: &RangerGeom) {
    for v in pose3d_values(&g.pose) {
        p7_3(out, v);
    }
    for v in [g.size.sw, g.size.sl, g.size.sh] {
        p7_3(out, v);
    }
    let _ = write!(out, "{:04} ", g.element_poses.len());
    for p in &g.element_poses {
        for v in pose3d_values(p) {
            p7_3(out, v);
        }
    }
    let _ = write!(out, "{:04} ", g.element_sizes.len());
    for s in &g.element_sizes {
        for v in [s.sw, s.sl, s.sh] {
            p7_3(out, v);
        }
    }
}

fn stamped_tail(
    out: &mut String,
    have_geom: u8,
    geom: &RangerGeom,
    have_config: u8,
    config: &RangerConfig,
) {
    let _ = write!(out, "{} ", have_geom);
    if have_geom != 0 {
        ranger_geom(out, geom);
    }
    if have_config != 0 {
        for v in config_values(config) {
            cf(out, v, false, false, 0, 4);
            out.push(' ');
        }
    }
}

/// Upstream's `EncodeHex`: two upper-case hex digits per byte.
fn encode_hex(out: &mut String, bytes: &[u8]) {
    const HEX: &[u8; 16] = b"0123456789ABCDEF";
    out.reserve(bytes.len() * 2);
    for b in bytes {
        out.push(HEX[usize::from(b >> 4)] as char);
        out.push(HEX[usize::from(b & 15)] as char);
    }
}

/// Why a line of a log could not be replayed. The reader names the file and line.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LineError {
    /// Fewer than the seven header fields.
    #[error("invalid line: {0} fields, a message line has at least 7")]
    ShortHeader(usize),
    /// The interface name is not one Player knows.
    #[error("unknown interface name \"{0}\"")]
    UnknownInterface(String),
    /// A header field is not a number.
    #[error("invalid {field} \"{text}\" in the header")]
    BadHeader {
        /// Which field.
        field: &'static str,
        /// What is written there.
        text: String,
    },
    /// The payload ends before the fields its counts announce.
    #[error("incomplete line: {what} needs {needed} fields after the header, found {found}")]
    Incomplete {
        /// The message.
        what: String,
        /// Fields the counts require.
        needed: usize,
        /// Fields present.
        found: usize,
    },
    /// More fields than the counts announce (a count that disagrees with its list).
    #[error("{what}: count mismatch, {expected} fields expected after the header, found {found}")]
    CountMismatch {
        /// The message.
        what: String,
        /// Fields the counts require.
        expected: usize,
        /// Fields present.
        found: usize,
    },
    /// A payload field is not a number of its type.
    #[error("{what}: field {index} \"{text}\" is not a valid {kind}")]
    BadField {
        /// The message.
        what: String,
        /// Position in the payload (0 = first field after the header).
        index: usize,
        /// The text.
        text: String,
        /// What was expected.
        kind: &'static str,
    },
    /// The interface has no log format for this message (upstream's "unknown ... subtype").
    #[error("no log format for {interface} messages of type {msg_type} subtype {subtype}")]
    NoFormat {
        /// Interface name.
        interface: String,
        /// Message type.
        msg_type: u8,
        /// Subtype.
        subtype: u8,
    },
}

/// The common header of a message line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineHeader {
    /// Log time (seconds).
    pub time: f64,
    /// The device that sent it, as recorded (host, port, interface, index).
    pub addr: DeviceAddr,
    /// Message type code (1 DATA, 4 RESP_ACK, ...).
    pub msg_type: u8,
    /// Subtype.
    pub subtype: u8,
}

/// What one line of a log holds.
// Returned by value once per line and matched at once; boxing the body would add an allocation.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Line {
    /// Blank, a `#` comment or a `##` header line.
    Comment,
    /// A message: DATA to publish, or a reply (geometry, config) to keep for requests.
    Message(LineHeader, Body),
}

/// Splits a line into fields on whitespace, as upstream's tokenizer does.
pub fn fields(line: &str) -> Vec<&str> {
    line.split_ascii_whitespace().collect()
}

/// Parses the header of a tokenized message line.
pub fn parse_header(tokens: &[&str]) -> Result<LineHeader, LineError> {
    if tokens.len() < 7 {
        return Err(LineError::ShortHeader(tokens.len()));
    }
    let interf = InterfaceCode::from_name(tokens[3])
        .ok_or_else(|| LineError::UnknownInterface(tokens[3].to_string()))?;
    fn num<T: std::str::FromStr>(field: &'static str, text: &str) -> Result<T, LineError> {
        text.parse().map_err(|_| LineError::BadHeader {
            field,
            text: text.to_string(),
        })
    }
    let time: f64 = num("time", tokens[0])?;
    Ok(LineHeader {
        time,
        addr: DeviceAddr::new(
            num("host", tokens[1])?,
            num("robot", tokens[2])?,
            interf,
            num("index", tokens[4])?,
        ),
        msg_type: num("type", tokens[5])?,
        subtype: num("subtype", tokens[6])?,
    })
}

/// Parses one line of a log. Comments and blank lines are [`Line::Comment`].
pub fn parse_line(line: &str) -> Result<Line, LineError> {
    let tokens = fields(line);
    match tokens.first() {
        None => return Ok(Line::Comment),
        Some(t) if t.starts_with('#') => return Ok(Line::Comment),
        Some(_) => {}
    }
    let header = parse_header(&tokens)?;
    let body = parse_payload(&header, &tokens[7..])?;
    Ok(Line::Message(header, body))
}

/// Reads payload fields one after another, with errors naming the message and field.
struct Fields<'a> {
    what: String,
    tokens: &'a [&'a str],
    at: usize,
}

impl<'a> Fields<'a> {
    fn new(header: &LineHeader, tokens: &'a [&'a str]) -> Fields<'a> {
        let name = header.addr.interf.name().unwrap_or("unknown");
        Fields {
            what: format!("{name} {}:{}", header.msg_type, header.subtype),
            tokens,
            at: 0,
        }
    }

    /// Fails unless `n` more fields are present.
    fn need(&self, n: usize) -> Result<(), LineError> {
        // a count read from the line can be anything: saturate rather than wrap or panic
        let needed = self.at.saturating_add(n);
        if self.tokens.len() < needed {
            return Err(LineError::Incomplete {
                what: self.what.clone(),
                needed,
                found: self.tokens.len(),
            });
        }
        Ok(())
    }

    fn next_text(&mut self) -> Result<&'a str, LineError> {
        self.need(1)?;
        let t = self.tokens[self.at];
        self.at += 1;
        Ok(t)
    }

    fn parse<T: std::str::FromStr>(&mut self, kind: &'static str) -> Result<T, LineError> {
        let index = self.at;
        let text = self.next_text()?;
        text.parse().map_err(|_| LineError::BadField {
            what: self.what.clone(),
            index,
            text: text.to_string(),
            kind,
        })
    }

    fn f64(&mut self) -> Result<f64, LineError> {
        self.parse("number")
    }

    fn f32(&mut self) -> Result<f32, LineError> {
        self.parse("number")
    }

    fn i32(&mut self) -> Result<i32, LineError> {
        self.parse("integer")
    }

    /// A uint32 field upstream writes with `%d` and reads with `atoi` (every uint32 its log
    /// format has: ids, widths, counts): signed text stands for the same 32 bits (`-1277517296`
    /// is 3017450000), and unsigned text is read as it is.
    fn c_u32(&mut self) -> Result<u32, LineError> {
        let index = self.at;
        let text = self.next_text()?;
        match text.parse::<i64>() {
            Ok(n) if (i64::from(i32::MIN)..=i64::from(u32::MAX)).contains(&n) => Ok(n as u32),
            _ => Err(LineError::BadField {
                what: self.what.clone(),
                index,
                text: text.to_string(),
                kind: "32-bit integer",
            }),
        }
    }

    fn u8(&mut self) -> Result<u8, LineError> {
        self.parse("small integer (0-255)")
    }

    /// A count whose `per`-field items must fit in the rest of the line.
    fn count(&mut self, per: usize) -> Result<usize, LineError> {
        let n: usize = self.parse("count")?;
        self.need(n.saturating_mul(per))?;
        Ok(n)
    }

    /// A count, then that many items of `per` fields each, each read by `item`.
    fn list<T>(
        &mut self,
        per: usize,
        mut item: impl FnMut(&mut Self) -> Result<T, LineError>,
    ) -> Result<Vec<T>, LineError> {
        let n = self.count(per)?;
        (0..n).map(|_| item(self)).collect()
    }

    /// Fails when fields remain (a count smaller than its list).
    fn end(&self) -> Result<(), LineError> {
        if self.at != self.tokens.len() {
            return Err(LineError::CountMismatch {
                what: self.what.clone(),
                expected: self.at,
                found: self.tokens.len(),
            });
        }
        Ok(())
    }

    fn remaining(&self) -> usize {
        self.tokens.len() - self.at
    }
}

fn pose2d(f: &mut Fields<'_>) -> Result<Pose2d, LineError> {
    Ok(Pose2d {
        px: f.f64()?,
        py: f.f64()?,
        pa: f.f64()?,
    })
}

fn pose3d(f: &mut Fields<'_>) -> Result<Pose3d, LineError> {
    Ok(Pose3d {
        px: f.f64()?,
        py: f.f64()?,
        pz: f.f64()?,
        proll: f.f64()?,
        ppitch: f.f64()?,
        pyaw: f.f64()?,
    })
}

fn bbox_wlh(f: &mut Fields<'_>) -> Result<Bbox3d, LineError> {
    Ok(Bbox3d {
        sw: f.f64()?,
        sl: f.f64()?,
        sh: f.f64()?,
    })
}

fn ranger_geom_fields(f: &mut Fields<'_>) -> Result<RangerGeom, LineError> {
    let pose = pose3d(f)?;
    let size = bbox_wlh(f)?;
    let element_poses = f.list(6, pose3d)?;
    let element_sizes = f.list(3, bbox_wlh)?;
    Ok(RangerGeom {
        pose,
        size,
        element_poses,
        element_sizes,
    })
}

fn ranger_config_fields(f: &mut Fields<'_>) -> Result<RangerConfig, LineError> {
    Ok(RangerConfig {
        min_angle: f.f64()?,
        max_angle: f.f64()?,
        angular_res: f.f64()?,
        min_range: f.f64()?,
        max_range: f.f64()?,
        range_res: f.f64()?,
        frequency: f.f64()?,
    })
}

/// The geometry and config that follow a stamped ranger line's values.
fn stamped_fields(f: &mut Fields<'_>) -> Result<(u8, RangerGeom, u8, RangerConfig), LineError> {
    let have_geom = f.u8()?;
    let geom = if have_geom != 0 {
        ranger_geom_fields(f)?
    } else {
        RangerGeom::default()
    };
    // Upstream's writer prints no have_config flag: the seven config values follow or not.
    let (have_config, config) = if f.remaining() == 7 {
        (1, ranger_config_fields(f)?)
    } else {
        (0, RangerConfig::default())
    };
    Ok((have_geom, geom, have_config, config))
}

fn laser_scan_fields(
    f: &mut Fields<'_>,
    with_pose: bool,
) -> Result<(LaserDataScan, Pose2d), LineError> {
    let id = f.c_u32()?;
    let pose = if with_pose {
        pose2d(f)?
    } else {
        Pose2d::default()
    };
    let min_angle = f.f32()?;
    let max_angle = f.f32()?;
    let resolution = f.f32()?;
    let max_range = f.f32()?;
    let n = f.count(2)?;
    let mut ranges = Vec::with_capacity(n);
    let mut intensity = Vec::with_capacity(n);
    for _ in 0..n {
        ranges.push(f.f32()?);
        intensity.push(f.u8()?);
    }
    Ok((
        LaserDataScan {
            min_angle,
            max_angle,
            resolution,
            max_range,
            ranges,
            intensity,
            id,
        },
        pose,
    ))
}

/// Upstream's `DecodeHex` of a camera image, refusing odd lengths and non-hex digits.
fn decode_hex(f: &Fields<'_>, index: usize, text: &str) -> Result<Vec<u8>, LineError> {
    let bad = || LineError::BadField {
        what: f.what.clone(),
        index,
        // the first 16 characters (not bytes: the field may hold any UTF-8)
        text: match text.char_indices().nth(16) {
            Some((cut, _)) => format!("{}...", &text[..cut]),
            None => text.to_string(),
        },
        kind: "hex image",
    };
    if text.len() % 2 != 0 {
        return Err(bad());
    }
    let digit = |c: u8| -> Option<u8> { (c as char).to_digit(16).map(|d| d as u8) };
    text.as_bytes()
        .chunks(2)
        .map(|pair| Some((digit(pair[0])? << 4) | digit(pair[1])?))
        .collect::<Option<Vec<u8>>>()
        .ok_or_else(bad)
}

/// Builds the message body of a line from its payload fields.
pub fn parse_payload(header: &LineHeader, tokens: &[&str]) -> Result<Body, LineError> {
    let mut f = Fields::new(header, tokens);
    let data = header.msg_type == MsgType::Data.code();
    let ack = header.msg_type == MsgType::RespAck.code();
    let (interf, sub) = (header.addr.interf, header.subtype);
    let body: Body = match (interf, data, ack, sub) {
        (InterfaceCode::LASER, true, _, 1) => {
            LaserData::Scan(laser_scan_fields(&mut f, false)?.0).into()
        }
        (InterfaceCode::LASER, true, _, 2) => {
            let (scan, pose) = laser_scan_fields(&mut f, true)?;
            LaserData::ScanPose(LaserDataScanpose { scan, pose }).into()
        }
        (InterfaceCode::LASER, true, _, 3) => {
            let id = f.c_u32()?;
            let max_range = f.f32()?;
            let n = f.count(3)?;
            let mut d = LaserDataScanangle {
                max_range,
                id,
                ..Default::default()
            };
            for _ in 0..n {
                d.ranges.push(f.f32()?);
                d.angles.push(f.f32()?);
                d.intensity.push(f.u8()?);
            }
            LaserData::ScanAngle(d).into()
        }
        (InterfaceCode::LASER, _, true, 1) => {
            let mut g = LaserGeom::default();
            g.pose.px = f.f64()?;
            g.pose.py = f.f64()?;
            g.pose.pyaw = f.f64()?;
            g.size.sl = f.f64()?;
            g.size.sw = f.f64()?;
            ack_body(LaserReq::GetGeom(Some(g)))
        }
        (InterfaceCode::RANGER, true, _, 1) => {
            let ranges = f.list(1, Fields::f64)?;
            RangerData::Range(RangerDataRange { ranges }).into()
        }
        (InterfaceCode::RANGER, true, _, 3) => {
            let intensities = f.list(1, Fields::f64)?;
            RangerData::Intns(RangerDataIntns { intensities }).into()
        }
        (InterfaceCode::RANGER, true, _, 2) => {
            let ranges = f.list(1, Fields::f64)?;
            let (have_geom, geom, have_config, config) = stamped_fields(&mut f)?;
            RangerData::RangeStamped(RangerDataRangestamped {
                data: RangerDataRange { ranges },
                have_geom,
                geom,
                have_config,
                config,
            })
            .into()
        }
        (InterfaceCode::RANGER, true, _, 4) => {
            let intensities = f.list(1, Fields::f64)?;
            let (have_geom, geom, have_config, config) = stamped_fields(&mut f)?;
            RangerData::IntnsStamped(RangerDataIntnsstamped {
                data: RangerDataIntns { intensities },
                have_geom,
                geom,
                have_config,
                config,
            })
            .into()
        }
        (InterfaceCode::RANGER, _, true, 1) => {
            ack_body(RangerReq::GetGeom(Some(ranger_geom_fields(&mut f)?)))
        }
        (InterfaceCode::RANGER, _, true, 5) => {
            ack_body(RangerReq::GetConfig(Some(ranger_config_fields(&mut f)?)))
        }
        (InterfaceCode::SONAR, true, _, 1) => {
            let ranges = f.list(1, Fields::f32)?;
            SonarData::Ranges(SonarDataRanges { ranges }).into()
        }
        (InterfaceCode::SONAR, true, _, 2) => SonarData::Geom(sonar_geom(&mut f)?).into(),
        (InterfaceCode::SONAR, _, true, 1) => {
            ack_body(SonarReq::GetGeom(Some(sonar_geom(&mut f)?)))
        }
        (InterfaceCode::POSITION2D, true, _, 1) => {
            let pos = pose2d(&mut f)?;
            let vel = pose2d(&mut f)?;
            let stall = f.u8()?;
            Position2dData::State(Position2dDataState { pos, vel, stall }).into()
        }
        (InterfaceCode::POSITION2D, _, true, 1) => {
            let mut g = Position2dGeom::default();
            g.pose.px = f.f64()?;
            g.pose.py = f.f64()?;
            g.pose.pyaw = f.f64()?;
            g.size.sl = f.f64()?;
            g.size.sw = f.f64()?;
            ack_body(Position2dReq::GetGeom(Some(g)))
        }
        (InterfaceCode::LOCALIZE, true, _, 1) => {
            let pending_count = f.c_u32()?;
            let pending_time = f.f64()?;
            let hypoths = f.list(7, |f| {
                Ok(LocalizeHypoth {
                    mean: pose2d(f)?,
                    cov: [f.f64()?, f.f64()?, f.f64()?],
                    alpha: f.f64()?,
                })
            })?;
            LocalizeData::Hypoths(LocalizeDataHypoths {
                pending_count,
                pending_time,
                hypoths,
            })
            .into()
        }
        (InterfaceCode::LOCALIZE, _, true, 2) => {
            let mean = pose2d(&mut f)?;
            let variance = f.f64()?;
            let particles = f.list(4, |f| {
                Ok(LocalizeParticle {
                    pose: pose2d(f)?,
                    alpha: f.f64()?,
                })
            })?;
            ack_body(LocalizeReq::GetParticles(Some(LocalizeGetParticles {
                mean,
                variance,
                particles,
            })))
        }
        (InterfaceCode::BLOBFINDER, true, _, 1) => {
            let width = f.c_u32()?;
            let height = f.c_u32()?;
            let blobs = f.list(10, |f| {
                Ok(BlobfinderBlob {
                    id: f.c_u32()?,
                    color: f.c_u32()?,
                    area: f.c_u32()?,
                    x: f.c_u32()?,
                    y: f.c_u32()?,
                    left: f.c_u32()?,
                    right: f.c_u32()?,
                    top: f.c_u32()?,
                    bottom: f.c_u32()?,
                    range: f.f32()?,
                })
            })?;
            BlobfinderData::Blobs(BlobfinderDataBlobs {
                width,
                height,
                blobs,
            })
            .into()
        }
        (InterfaceCode::FIDUCIAL, true, _, 1) => {
            let fiducials = f.list(13, |f| {
                Ok(FiducialItem {
                    id: f.i32()?,
                    pose: pose3d(f)?,
                    upose: pose3d(f)?,
                })
            })?;
            FiducialData::Scan(FiducialDataScan { fiducials }).into()
        }
        (InterfaceCode::FIDUCIAL, _, true, 1) => {
            let pose = pose3d(&mut f)?;
            let size = Bbox3d {
                sl: f.f64()?,
                sw: f.f64()?,
                sh: f.f64()?,
            };
            let fiducial_size = Bbox2d {
                sl: f.f64()?,
                sw: f.f64()?,
            };
            ack_body(FiducialReq::GetGeom(Some(FiducialGeom {
                pose,
                size,
                fiducial_size,
            })))
        }
        (InterfaceCode::CAMERA, true, _, 1) => {
            let width = f.c_u32()?;
            let height = f.c_u32()?;
            let bpp = f.c_u32()?;
            let format = f.c_u32()?;
            let compression = f.c_u32()?;
            let count: usize = f.parse("count")?;
            let index = f.at;
            let hex = f.next_text()?;
            let image = decode_hex(&f, index, hex)?;
            if image.len() != count {
                return Err(LineError::CountMismatch {
                    what: f.what.clone(),
                    expected: count.saturating_mul(2),
                    found: hex.len(),
                });
            }
            CameraData::State(CameraDataState {
                width,
                height,
                bpp,
                format,
                fdiv: 0,
                compression,
                image,
            })
            .into()
        }
        (InterfaceCode::ACTARRAY, true, _, 1) => {
            let actuators = f.list(5, |f| {
                Ok(ActarrayActuator {
                    position: f.f32()?,
                    speed: f.f32()?,
                    acceleration: f.f32()?,
                    current: f.f32()?,
                    state: f.u8()?,
                })
            })?;
            let motor_state = f.u8()?;
            ActarrayData::State(ActarrayDataState {
                actuators,
                motor_state,
            })
            .into()
        }
        _ => {
            return Err(LineError::NoFormat {
                interface: interf.name().unwrap_or("unknown").to_string(),
                msg_type: header.msg_type,
                subtype: sub,
            });
        }
    };
    f.end()?;
    Ok(body)
}

fn sonar_geom(f: &mut Fields<'_>) -> Result<SonarGeom, LineError> {
    let poses = f.list(3, |f| {
        Ok(Pose3d {
            px: f.f64()?,
            py: f.f64()?,
            pyaw: f.f64()?,
            ..Default::default()
        })
    })?;
    Ok(SonarGeom { poses })
}

/// A request kind as the ACK body a device answers with.
fn ack_body<R>(req: R) -> Body
where
    Body: From<R>,
{
    Body::from(req)
}

#[cfg(test)]
mod tests {
    use super::*;
    use player_proto::constants::LOCALHOST_ADDR;

    /// Lines the original Player 3.0.2 `writelog` wrote on Stage's simple.cfg (position2d
    /// geometry, ranger geometry and config, then position2d state, ranges and intensities).
    const UPSTREAM_LINES: [&str; 6] = [
        "0000000000.100 16777343 7001 position2d 00 004 001 -00.040 +00.000 +0.000 +00.440 +00.380",
        "0000000000.300 16777343 7001 ranger 00 004 005 -0.130900 0.130900 0.261799 0.000000 5.000000 0.020000 10.000000 ",
        "0000000000.400 16777343 7001 ranger 01 004 001 +00.000 +00.000 +00.000 +00.000 +00.000 +00.000 +00.155 +00.156 +00.000 0001 +00.000 +00.000 +00.100 +00.000 +00.000 +00.000 0001 +00.020 +00.020 +00.020 ",
        "0000000016.500 16777343 7001 position2d 00 001 001 -02.077 -04.546 -0.065 +00.050 +00.000 -00.500 0",
        "0000000016.500 16777343 7001 ranger 00 001 001 0016 5.000 1.081 0.828 5.000 5.000 5.000 3.986 3.338 3.364 4.871 5.000 5.000 5.000 1.928 2.864 5.000 ",
        "0000000016.500 16777343 7001 ranger 00 001 003 0016 0.000 0.500 0.500 0.000 0.000 0.000 0.500 0.500 0.500 0.500 0.000 0.000 0.000 0.500 0.500 0.000 ",
    ];

    fn round_trip(line: &str) -> String {
        let Line::Message(h, body) = parse_line(line).unwrap() else {
            panic!("{line}")
        };
        let (text, result) =
            encode_line(h.time, &h.addr, h.msg_type, &body, WriteOptions::default());
        result.unwrap();
        text.trim_end_matches('\n').to_string()
    }

    /// Found by fuzzing the reader: a count near `usize::MAX` overflowed the read position
    /// (ranger) and the expected hex length (camera); a bad hex field cut inside a UTF-8
    /// character for its message. Each is now an error naming the field, not a panic.
    #[test]
    fn huge_counts_and_non_ascii_hex_are_errors_not_panics() {
        let max = usize::MAX;
        let lines = [
            format!("0000000016.500 16777343 7001 ranger 00 001 001 {max} 1.0"),
            format!("0000000016.500 16777343 7001 ranger 00 001 001 {} 1.0", max / 2 + 1),
            format!("0000000001.000 16777343 7001 camera 00 001 001 1 1 8 1 0 {max} 00"),
            "0000000001.000 16777343 7001 camera 00 001 001 1 1 8 1 0 1 aaaaaaaaaaaaaaa\u{e9}"
                .to_string(),
            "0000000001.000 16777343 7001 camera 00 001 001 1 1 8 1 0 9 \u{e9}\u{e9}\u{e9}\u{e9}\u{e9}\u{e9}\u{e9}\u{e9}\u{e9}"
                .to_string(),
        ];
        for line in &lines {
            let got = std::panic::catch_unwind(|| parse_line(line));
            let Ok(result) = got else {
                panic!("panicked on {line:?}")
            };
            let err = result.err().unwrap_or_else(|| panic!("accepted {line:?}"));
            assert!(!err.to_string().is_empty(), "{line:?}");
        }
    }

    /// Found by the readlog fuzz target: a scanangle id of -1 was read (as Player's `atoi`
    /// does) into the uint32 id and written back as 4294967295, which the reader refused; it
    /// is written as upstream's `%04d` prints it, as the other laser scans' ids are.
    #[test]
    fn a_negative_scanangle_id_writes_back_as_it_was_read() {
        let line = "0000000002.000 167 7001 laser 00 001 003 -001 +8.0000 0001 1.000 2.000  0 ";
        assert_eq!(round_trip(line), line);
        assert_eq!(round_trip(&round_trip(line)), line);
    }

    /// Found by the readlog fuzz target: a camera width of 3017450000 was read (a uint32, as
    /// upstream's `atoi` reads it) and written with upstream's `%d` as -1277517296, which the
    /// reader refused as a negative unsigned field: the five uint32 fields now read both forms.
    #[test]
    fn a_camera_field_beyond_i32_writes_back_signed_and_reads_again() {
        let line = "0000000001.000 7343 7001 camera 00 001 001 3017450000 1 0 0 2 1 00";
        let written = round_trip(line);
        assert_eq!(
            written,
            "0000000001.000 7343 7001 camera 00 001 001 -1277517296 1 0 0 2 1 00"
        );
        assert_eq!(round_trip(&written), written);
    }

    /// The camera's fix, for the other uint32 fields upstream prints with `%d` (laser ids,
    /// blobfinder width, height and blob fields, localize pending count): unsigned text beyond
    /// i32 is read, written back signed as upstream writes it, and that reads again.
    #[test]
    fn uint32_fields_beyond_i32_write_back_signed_and_read_again() {
        let cases = [
            (
                "0000000002.000 167 7001 laser 00 001 003 3017450000 +8.0000 0001 1.000 2.000  0 ",
                "0000000002.000 167 7001 laser 00 001 003 -1277517296 +8.0000 0001 1.000 2.000  0 ",
            ),
            (
                "0000000002.000 167 7001 blobfinder 00 001 001 3017450000 4294967295 1 3017450000 2 3 4 5 6 7 8 4294967294 1.500000",
                "0000000002.000 167 7001 blobfinder 00 001 001 -1277517296 -1 1 -1277517296 2 3 4 5 6 7 8 -2 1.500000",
            ),
        ];
        for (read, written) in cases {
            assert_eq!(round_trip(read), written);
            assert_eq!(round_trip(written), written);
        }
        let localize = "0000000002.000 167 7001 localize 00 001 001 3017450000 +01.000  0 ";
        let written = round_trip(localize);
        assert!(written.contains(" -1277517296 "), "{written}");
        assert_eq!(round_trip(&written), written);
    }

    #[test]
    fn upstream_lines_read_and_write_back_byte_for_byte() {
        for line in UPSTREAM_LINES {
            assert_eq!(round_trip(line), line);
        }
    }

    #[test]
    fn c_number_formats() {
        let mut s = String::new();
        cf(&mut s, -0.04, true, true, 7, 3);
        s.push('|');
        cf(&mut s, 12.5, false, true, 14, 3);
        s.push('|');
        cf(&mut s, 0.1, true, false, 7, 3);
        s.push('|');
        cf(&mut s, f64::INFINITY, true, true, 7, 3);
        s.push('|');
        cf(&mut s, f64::NAN, false, false, 0, 3);
        assert_eq!(s, "-00.040|0000000012.500| +0.100|   +inf|nan");
    }

    #[test]
    fn every_format_reads_back_what_it_wrote() {
        let addr = |i| DeviceAddr::new(LOCALHOST_ADDR, 6665, i, 2);
        let bodies: Vec<(InterfaceCode, u8, Body)> = vec![
            (
                InterfaceCode::LASER,
                1,
                LaserData::ScanPose(LaserDataScanpose {
                    scan: LaserDataScan {
                        min_angle: -1.5,
                        max_angle: 1.5,
                        resolution: 0.25,
                        max_range: 8.0,
                        ranges: vec![1.0, 2.0],
                        intensity: vec![1, 0],
                        id: 3,
                    },
                    pose: Pose2d {
                        px: 1.0,
                        py: 2.0,
                        pa: 0.5,
                    },
                })
                .into(),
            ),
            (
                InterfaceCode::SONAR,
                1,
                SonarData::Ranges(SonarDataRanges {
                    ranges: vec![0.5, 1.25],
                })
                .into(),
            ),
            (
                InterfaceCode::LOCALIZE,
                1,
                LocalizeData::Hypoths(LocalizeDataHypoths {
                    pending_count: 2,
                    pending_time: 1.5,
                    hypoths: vec![LocalizeHypoth {
                        mean: Pose2d {
                            px: 1.0,
                            py: -1.0,
                            pa: 0.25,
                        },
                        cov: [0.5, 0.25, 0.125],
                        alpha: 0.75,
                    }],
                })
                .into(),
            ),
            (
                InterfaceCode::BLOBFINDER,
                1,
                BlobfinderData::Blobs(BlobfinderDataBlobs {
                    width: 80,
                    height: 60,
                    blobs: vec![BlobfinderBlob {
                        id: 1,
                        color: 0xff0000,
                        area: 12,
                        x: 3,
                        y: 4,
                        left: 1,
                        right: 5,
                        top: 2,
                        bottom: 6,
                        range: 2.5,
                    }],
                })
                .into(),
            ),
            (
                InterfaceCode::FIDUCIAL,
                1,
                FiducialData::Scan(FiducialDataScan {
                    fiducials: vec![FiducialItem {
                        id: 7,
                        pose: Pose3d {
                            px: 1.0,
                            py: 0.5,
                            pyaw: 0.25,
                            ..Default::default()
                        },
                        upose: Pose3d::default(),
                    }],
                })
                .into(),
            ),
            (
                InterfaceCode::CAMERA,
                1,
                CameraData::State(CameraDataState {
                    width: 2,
                    height: 1,
                    bpp: 24,
                    format: 5,
                    fdiv: 0,
                    compression: 0,
                    image: vec![0, 0x7f, 0xff, 1, 2, 0xab],
                })
                .into(),
            ),
            (
                InterfaceCode::RANGER,
                1,
                RangerData::RangeStamped(RangerDataRangestamped {
                    data: RangerDataRange {
                        ranges: vec![1.0, 2.0],
                    },
                    have_geom: 1,
                    geom: RangerGeom {
                        element_poses: vec![Pose3d::default()],
                        element_sizes: vec![Bbox3d {
                            sw: 0.5,
                            sl: 0.25,
                            sh: 0.0,
                        }],
                        ..Default::default()
                    },
                    have_config: 1,
                    config: RangerConfig {
                        max_range: 5.0,
                        frequency: 10.0,
                        ..Default::default()
                    },
                })
                .into(),
            ),
            (
                InterfaceCode::ACTARRAY,
                1,
                ActarrayData::State(ActarrayDataState {
                    actuators: vec![ActarrayActuator {
                        position: 0.5,
                        speed: 0.25,
                        acceleration: 0.0,
                        current: 1.5,
                        state: 2,
                    }],
                    motor_state: 1,
                })
                .into(),
            ),
        ];
        for (interf, msg_type, body) in bodies {
            let (line, result) =
                encode_line(4.5, &addr(interf), msg_type, &body, WriteOptions::default());
            result.unwrap();
            let Line::Message(h, back) = parse_line(&line).unwrap() else {
                panic!()
            };
            assert_eq!(
                (h.time, h.addr, h.subtype),
                (4.5, addr(interf), body.subtype())
            );
            assert_eq!(back, body, "{line}");
        }
        // A camera line without image bytes (camera_log_images 0) is incomplete to a reader.
        let cam = CameraData::State(CameraDataState {
            image: vec![1, 2],
            ..Default::default()
        });
        let (line, _) = encode_line(
            0.0,
            &addr(InterfaceCode::CAMERA),
            1,
            &cam.into(),
            WriteOptions {
                camera_images: false,
            },
        );
        assert!(
            matches!(parse_line(&line), Err(LineError::Incomplete { .. })),
            "{line}"
        );
    }

    #[test]
    fn messages_without_a_format_are_written_as_bare_headers() {
        let addr = DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::GRIPPER, 0);
        let body: Body = player_proto::GripperData::State(Default::default()).into();
        let (line, result) = encode_line(1.0, &addr, 1, &body, WriteOptions::default());
        assert_eq!(line, "0000000001.000 16777343 6665 gripper 00 001 001 \n");
        assert!(result.is_err());
        assert!(matches!(parse_line(&line), Err(LineError::NoFormat { .. })));
    }
}
