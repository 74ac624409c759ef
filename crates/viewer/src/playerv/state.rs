//! What playerv knows about the server: its devices and, for each subscribed one, the latest
//! data and geometry, as plain values the UI and the scene builder read (the client itself
//! lives on the worker thread, [`super::worker`]).

use std::collections::BTreeMap;

use player_client::DataMode;
use player_proto::InterfaceCode;

/// A device address on the connected port: interface and index.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct DeviceKey {
    /// Interface.
    pub interf: InterfaceCode,
    /// Index.
    pub index: u16,
}

impl std::fmt::Display for DeviceKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.interf.name() {
            Some(n) => write!(f, "{n}:{}", self.index),
            None => write!(f, "{}:{}", self.interf, self.index),
        }
    }
}

impl DeviceKey {
    /// Parses playerv's `interface:index` (index defaults to 0), e.g. `ranger:0`, `laser`.
    pub fn parse(s: &str) -> Option<DeviceKey> {
        let (name, index) = match s.split_once(':') {
            Some((n, i)) => (n, i.parse().ok()?),
            None => (s, 0),
        };
        Some(DeviceKey {
            interf: InterfaceCode::from_name(name)?,
            index,
        })
    }
}

/// A pose in the robot's frame (m, rad).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pose2 {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// Heading (rad).
    pub a: f64,
}

/// One sensor's scan in the robot's frame: where the rays start and where each one ended.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scan {
    /// Origin of the rays.
    pub origin: Pose2,
    /// Bearing of each ray relative to `origin.a` (rad).
    pub bearings: Vec<f64>,
    /// Range of each ray (m).
    pub ranges: Vec<f64>,
    /// Maximum range (m; rays at it hit nothing).
    pub max_range: f64,
    /// Angular width of each ray's cone (rad; 0 for laser-like rays).
    pub cone: f64,
}

/// The latest data of one subscribed device, with the geometry it needs to be drawn.
#[derive(Clone, Debug, PartialEq)]
pub enum DeviceData {
    /// A mobile base.
    Position2d {
        /// Odometry pose.
        pose: Pose2,
        /// Velocity (m/s, m/s, rad/s).
        velocity: Pose2,
        /// Stalled.
        stall: bool,
        /// Body size (length x, width y), m.
        size: [f64; 2],
    },
    /// Ranger, laser or sonar scans.
    Ranges {
        /// One scan per sensor element.
        scans: Vec<Scan>,
    },
    /// A blob finder's image.
    Blobs {
        /// Image size (pixels).
        size: [u32; 2],
        /// Blobs: colour `0x00RRGGBB` and box `[left, top, right, bottom]`.
        blobs: Vec<(u32, [u32; 4])>,
    },
    /// Fiducials seen (robot frame).
    Fiducials {
        /// The finder's pose on the robot.
        origin: Pose2,
        /// Id and pose relative to the finder.
        items: Vec<(i32, Pose2)>,
    },
    /// Gripper state.
    Gripper {
        /// `PLAYER_GRIPPER_STATE_*`.
        state: u8,
        /// Break-beam bits.
        beams: u32,
        /// Gripper pose on the robot.
        pose: Pose2,
        /// Outer size (length x, width y).
        size: [f64; 2],
        /// Number of beams.
        num_beams: u8,
    },
    /// A camera frame as RGBA.
    Camera {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// `width * height * 4` bytes.
        rgba: Vec<u8>,
    },
    /// A device subscribed to but not drawn (or no data yet).
    Other,
}

/// One subscribed device.
#[derive(Clone, Debug, PartialEq)]
pub struct Subscribed {
    /// Driver name the server reported.
    pub driver: String,
    /// Latest data.
    pub data: DeviceData,
    /// Timestamp of the latest data.
    pub datatime: f64,
}

/// How a position2d device is commanded from the canvas (playerv's bull's-eye).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CommandMode {
    /// Not commanded.
    #[default]
    Off,
    /// The target's offset sets the velocity.
    Velocity,
    /// The target is a position goal (odometry frame).
    Position,
}

/// Everything the UI shows (a snapshot the worker publishes after each read).
#[derive(Clone, Debug, PartialEq)]
pub struct PlayervState {
    /// `host:port`.
    pub server: String,
    /// The server's banner.
    pub banner: String,
    /// Connected (false after a fatal error).
    pub connected: bool,
    /// Devices the server offers, with their drivers.
    pub devices: Vec<(DeviceKey, String)>,
    /// Subscribed devices.
    pub subscribed: BTreeMap<DeviceKey, Subscribed>,
    /// Current data mode.
    pub mode: DataMode,
    /// Data rounds per second.
    pub rate_hz: f64,
    /// Latest server time seen.
    pub datatime: f64,
    /// Recent messages (errors, refused subscriptions), newest last.
    pub log: Vec<String>,
}

impl PlayervState {
    /// An empty state for `server`.
    pub fn new(server: &str, mode: DataMode, rate_hz: f64) -> PlayervState {
        PlayervState {
            server: server.to_string(),
            banner: String::new(),
            connected: false,
            devices: Vec::new(),
            subscribed: BTreeMap::new(),
            mode,
            rate_hz,
            datatime: 0.0,
            log: Vec::new(),
        }
    }

    /// Adds a log line (keeping the last 50).
    pub fn note(&mut self, msg: impl Into<String>) {
        let msg = msg.into();
        tracing::info!("{msg}");
        self.log.push(msg);
        if self.log.len() > 50 {
            self.log.remove(0);
        }
    }

    /// The first subscribed position2d device: the robot everything is drawn around.
    pub fn base(&self) -> Option<(DeviceKey, &Subscribed)> {
        self.subscribed
            .iter()
            .find(|(k, _)| k.interf == InterfaceCode::POSITION2D)
            .map(|(k, s)| (*k, s))
    }
}

/// Converts a camera frame to RGBA (raw 8-bit mono, RGB565, RGB888, or JPEG-compressed);
/// `None` for a format it does not know or a size that does not match the data.
pub fn camera_rgba(c: &player_proto::CameraDataState) -> Option<(u32, u32, Vec<u8>)> {
    use player_proto::constants::*;
    let (w, h) = (c.width, c.height);
    if w == 0 || h == 0 || w > 8192 || h > 8192 {
        return None;
    }
    let n = (w * h) as usize;
    if c.compression == PLAYER_CAMERA_COMPRESS_JPEG {
        let img = image::load_from_memory_with_format(&c.image, image::ImageFormat::Jpeg).ok()?;
        let rgba = img.to_rgba8();
        return Some((rgba.width(), rgba.height(), rgba.into_raw()));
    }
    let rgba = match (c.format, c.bpp) {
        (PLAYER_CAMERA_FORMAT_MONO8, 8) if c.image.len() >= n => {
            c.image[..n].iter().flat_map(|&v| [v, v, v, 255]).collect()
        }
        (PLAYER_CAMERA_FORMAT_RGB888, 24) if c.image.len() >= 3 * n => c.image[..3 * n]
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect(),
        (PLAYER_CAMERA_FORMAT_RGB565, 16) if c.image.len() >= 2 * n => c.image[..2 * n]
            .chunks_exact(2)
            .flat_map(|p| {
                let v = u16::from_le_bytes([p[0], p[1]]);
                let (r, g, b) = ((v >> 11) & 31, (v >> 5) & 63, v & 31);
                [
                    (r * 255 / 31) as u8,
                    (g * 255 / 63) as u8,
                    (b * 255 / 31) as u8,
                    255,
                ]
            })
            .collect(),
        _ => return None,
    };
    Some((w, h, rgba))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_keys_parse_like_playerv_flags() {
        assert_eq!(
            DeviceKey::parse("ranger:1"),
            Some(DeviceKey {
                interf: InterfaceCode::RANGER,
                index: 1
            })
        );
        assert_eq!(
            DeviceKey::parse("position2d").map(|k| k.to_string()),
            Some("position2d:0".to_string())
        );
        assert_eq!(DeviceKey::parse("nosuch:0"), None);
        assert_eq!(DeviceKey::parse("ranger:x"), None);
    }

    #[test]
    fn camera_frames_convert_to_rgba() {
        use player_proto::constants::*;
        let mut c = player_proto::CameraDataState {
            width: 2,
            height: 1,
            bpp: 24,
            format: PLAYER_CAMERA_FORMAT_RGB888,
            fdiv: 0,
            compression: PLAYER_CAMERA_COMPRESS_RAW,
            image: vec![1, 2, 3, 4, 5, 6],
        };
        assert_eq!(
            camera_rgba(&c),
            Some((2, 1, vec![1, 2, 3, 255, 4, 5, 6, 255]))
        );
        c.image.truncate(4);
        assert_eq!(camera_rgba(&c), None);
        c.format = PLAYER_CAMERA_FORMAT_MONO8;
        c.bpp = 8;
        assert_eq!(
            camera_rgba(&c),
            Some((2, 1, vec![1, 1, 1, 255, 2, 2, 2, 255]))
        );
    }
}
