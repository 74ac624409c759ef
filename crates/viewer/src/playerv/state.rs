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

impl Pose2 {
    /// The same pose as a frame of the shared pose arithmetic (at height 0).
    pub fn frame(self) -> pose::Pose {
        pose::Pose {
            x: self.x,
            y: self.y,
            z: 0.0,
            a: self.a,
        }
    }

    /// The planar part of a frame.
    pub fn of_frame(f: pose::Pose) -> Pose2 {
        Pose2 {
            x: f.x,
            y: f.y,
            a: f.a,
        }
    }
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
    /// An occupancy grid, fetched once when subscribed.
    Map(std::sync::Arc<MapGrid>),
    /// A planner's state and its plan.
    Planner(PlannerView),
    /// A localiser's hypotheses (and its particles, when asked for).
    Localize {
        /// Hypotheses, heaviest first.
        hypotheses: Vec<Hypothesis>,
        /// Particles (map frame) with their weights; empty unless particles are shown.
        particles: Vec<(Pose2, f64)>,
    },
    /// A log device (writelog or readlog): whether it records or replays, and whether it is
    /// doing so now (GET_STATE, polled about once a second: the log interface has no data).
    Log {
        /// `true` for a replay (readlog), `false` for a recording (writelog).
        reading: bool,
        /// Recording or replaying now.
        active: bool,
    },
    /// A device subscribed to but not drawn (or no data yet).
    Other,
}

/// A map device's occupancy grid, with its cells grouped into runs for drawing (a
/// 1,000 x 1,000 map is a few thousand runs, not a million cells).
#[derive(Clone, Debug, PartialEq)]
pub struct MapGrid {
    /// Cells across (x) and up (y).
    pub width: u32,
    /// Cells up.
    pub height: u32,
    /// Cell size (m).
    pub scale: f64,
    /// World position of the lower-left corner of cell (0, 0) (m).
    pub origin: [f64; 2],
    /// Runs of equal non-free cells along each row: (row, first column, length, value: 0
    /// unknown, +1 occupied). Free cells (-1) are not listed.
    pub runs: Vec<(u32, u32, u32, i8)>,
}

impl MapGrid {
    /// Groups a Player map's cells (row-major from the lower left; -1 free, 0 unknown, +1
    /// occupied) into runs; `None` when the cell count does not match the size.
    pub fn new(
        width: u32,
        height: u32,
        scale: f64,
        origin: [f64; 2],
        cells: &[i8],
    ) -> Option<MapGrid> {
        if (width as usize).checked_mul(height as usize)? != cells.len() {
            return None;
        }
        let mut runs = Vec::new();
        for j in 0..height {
            let row = &cells[(j * width) as usize..((j + 1) * width) as usize];
            let mut i = 0usize;
            while i < row.len() {
                let v = row[i].signum();
                let start = i;
                while i < row.len() && row[i].signum() == v {
                    i += 1;
                }
                if v >= 0 {
                    runs.push((j, start as u32, (i - start) as u32, v));
                }
            }
        }
        Some(MapGrid {
            width,
            height,
            scale,
            origin,
            runs,
        })
    }

    /// The world point of the upper-right corner of the map.
    pub fn far_corner(&self) -> [f64; 2] {
        [
            self.origin[0] + f64::from(self.width) * self.scale,
            self.origin[1] + f64::from(self.height) * self.scale,
        ]
    }
}

/// What a planner device shows: its state and the waypoints of its plan (map frame).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlannerView {
    /// A path was found.
    pub valid: bool,
    /// The robot has arrived.
    pub done: bool,
    /// The robot's pose as the planner knows it.
    pub pos: Pose2,
    /// The goal.
    pub goal: Pose2,
    /// The waypoint being driven to.
    pub waypoint: Pose2,
    /// Its index, negative when none.
    pub waypoint_idx: i32,
    /// The plan's waypoints (GET_WAYPOINTS, fetched when the plan changes).
    pub waypoints: Vec<[f64; 2]>,
}

/// One localisation hypothesis: a mean pose with the variances of x, y and the heading.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Hypothesis {
    /// Mean pose (map frame).
    pub mean: Pose2,
    /// Variances of x (m²), y (m²) and heading (rad²).
    pub cov: [f64; 3],
    /// Weight.
    pub weight: f64,
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
    /// Whether localize devices' particles are fetched (GET_PARTICLES about once a second).
    pub particles: bool,
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
            particles: false,
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

    /// Whether any subscribed device lives in a map frame (map, planner, localize): the view
    /// is then the map's, with the robot placed where it is believed to be.
    pub fn map_frame(&self) -> bool {
        self.subscribed.values().any(|s| {
            matches!(
                s.data,
                DeviceData::Map(_) | DeviceData::Planner(_) | DeviceData::Localize { .. }
            )
        })
    }

    /// Where the robot is believed to be in the map frame: the heaviest localize hypothesis,
    /// else the planner's pose, else the base's odometry; `None` outside the map frame (the
    /// view is then the robot's own, the robot at the origin).
    pub fn robot_in_map(&self) -> Option<Pose2> {
        if !self.map_frame() {
            return None;
        }
        let from_localize = self.subscribed.values().find_map(|s| match &s.data {
            DeviceData::Localize { hypotheses, .. } => hypotheses
                .iter()
                .max_by(|a, b| a.weight.total_cmp(&b.weight))
                .map(|h| h.mean),
            _ => None,
        });
        let from_planner = || {
            self.subscribed.values().find_map(|s| match &s.data {
                DeviceData::Planner(p) if s.datatime > 0.0 => Some(p.pos),
                _ => None,
            })
        };
        let from_odometry = || {
            self.base().and_then(|(_, s)| match &s.data {
                DeviceData::Position2d { pose, .. } => Some(*pose),
                _ => None,
            })
        };
        Some(
            from_localize
                .or_else(from_planner)
                .or_else(from_odometry)
                .unwrap_or_default(),
        )
    }

    /// The first subscribed device of `interf`.
    pub fn first(&self, interf: InterfaceCode) -> Option<(DeviceKey, &Subscribed)> {
        self.subscribed
            .iter()
            .find(|(k, _)| k.interf == interf)
            .map(|(k, s)| (*k, s))
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
    fn map_cells_group_into_runs_of_unknown_and_occupied() {
        // 4 x 2, row 0 at the bottom: free, occ, occ, unknown / unknown, unknown, free, occ.
        let g = MapGrid::new(4, 2, 0.5, [-1.0, -0.5], &[-1, 1, 1, 0, 0, 0, -1, 100]).unwrap();
        assert_eq!(
            g.runs,
            vec![(0, 1, 2, 1), (0, 3, 1, 0), (1, 0, 2, 0), (1, 3, 1, 1)]
        );
        assert_eq!(g.far_corner(), [1.0, 0.5]);
        assert!(MapGrid::new(4, 2, 0.5, [0.0, 0.0], &[0; 7]).is_none());
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
