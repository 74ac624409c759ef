//! The ROS 2 messages the bridge speaks, each declared once: its fields in the ROS 2 `.msg`
//! order (the CDR layout follows from the order and types, as serde serialises a struct's fields
//! one after the other) and its package and name ([`RosType`]), from which the DDS type name
//! (`nav_msgs::msg::dds_::Odometry_`) is formed.

use std::fmt;

use serde::de::{self, SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A message type's ROS 2 package and name (`("nav_msgs", "Odometry")`). `Send + Sync`: the
/// publisher thread serialises and writes what the stepping thread built.
pub trait RosType:
    Serialize + serde::de::DeserializeOwned + fmt::Debug + Send + Sync + 'static
{
    /// The ROS 2 package (`nav_msgs`).
    const PACKAGE: &'static str;
    /// The type's name in its package (`Odometry`).
    const NAME: &'static str;
}

/// Declares the [`RosType`] and ros2-client's `Message` of a type.
macro_rules! ros_type {
    ($t:ty, $package:literal, $name:literal) => {
        impl RosType for $t {
            const PACKAGE: &'static str = $package;
            const NAME: &'static str = $name;
        }
        impl ros2_client::Message for $t {}
    };
}

/// builtin_interfaces/Time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds past `sec` (0..1e9).
    pub nanosec: u32,
}

impl Time {
    /// The time of a simulation clock in microseconds (the sim clock starts at 0; ROS 2 time is
    /// the same count, so `/clock`'s 1.3 s is Stage's 1.3 s).
    pub fn from_micros(us: u64) -> Time {
        Time {
            sec: i32::try_from(us / 1_000_000).unwrap_or(i32::MAX),
            nanosec: (us % 1_000_000) as u32 * 1000,
        }
    }

    /// Seconds as a float.
    pub fn seconds(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}
ros_type!(Time, "builtin_interfaces", "Time");

/// std_msgs/Header.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// When the data was taken (sim time).
    pub stamp: Time,
    /// The frame the data is in.
    pub frame_id: String,
}

/// geometry_msgs/Vector3.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// geometry_msgs/Point.
pub type Point = Vector3;

/// geometry_msgs/Quaternion.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    /// The identity rotation (ROS 2's default has w = 1).
    fn default() -> Self {
        Quaternion::from_yaw(0.0)
    }
}

impl Quaternion {
    /// The rotation by `yaw` about z (tf2's `setRPY(0, 0, yaw)`).
    pub fn from_yaw(yaw: f64) -> Quaternion {
        let (s, c) = (yaw * 0.5).sin_cos();
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: s,
            w: c,
        }
    }

    /// The yaw of a rotation (its heading in the plane), for `cmd_pose`.
    pub fn yaw(&self) -> f64 {
        let siny = 2.0 * (self.w * self.z + self.x * self.y);
        let cosy = 1.0 - 2.0 * (self.y * self.y + self.z * self.z);
        siny.atan2(cosy)
    }
}

/// geometry_msgs/Pose.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}
ros_type!(Pose, "geometry_msgs", "Pose");

/// A 6x6 row-major covariance (`float64[36]`): serde derives arrays of up to 32 elements
/// only, and CDR writes a fixed array as its elements without a length, as a tuple.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Default for Covariance {
    fn default() -> Self {
        Covariance([0.0; 36])
    }
}

impl Serialize for Covariance {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(36)?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for Covariance {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Elements;
        impl<'de> Visitor<'de> for Elements {
            type Value = Covariance;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("36 float64")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Covariance, A::Error> {
                let mut out = [0.0; 36];
                for (i, v) in out.iter_mut().enumerate() {
                    *v = seq
                        .next_element()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                Ok(Covariance(out))
            }
        }
        d.deserialize_tuple(36, Elements)
    }
}

/// geometry_msgs/PoseWithCovariance.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Its covariance (Stage gives none: zeros, as stage_ros2).
    pub covariance: Covariance,
}

/// geometry_msgs/Twist.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity (m/s).
    pub linear: Vector3,
    /// Angular velocity (rad/s).
    pub angular: Vector3,
}
ros_type!(Twist, "geometry_msgs", "Twist");

/// geometry_msgs/TwistStamped (`cmd_vel` with `use_stamped_velocity`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    /// Stamp and frame (ignored).
    pub header: Header,
    /// The command.
    pub twist: Twist,
}
ros_type!(TwistStamped, "geometry_msgs", "TwistStamped");

/// geometry_msgs/TwistWithCovariance.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The velocity.
    pub twist: Twist,
    /// Its covariance (zeros).
    pub covariance: Covariance,
}

/// nav_msgs/Odometry (`odom` and `ground_truth`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp and the pose's frame (odom, or world for ground truth).
    pub header: Header,
    /// The frame of the twist (base_link).
    pub child_frame_id: String,
    /// Pose in `header.frame_id`.
    pub pose: PoseWithCovariance,
    /// Velocity in `child_frame_id`.
    pub twist: TwistWithCovariance,
}
ros_type!(Odometry, "nav_msgs", "Odometry");

/// geometry_msgs/Transform.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// geometry_msgs/TransformStamped.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// Child in parent.
    pub transform: Transform,
}

/// tf2_msgs/TFMessage (`tf` and `tf_static`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}
ros_type!(TfMessage, "tf2_msgs", "TFMessage");

/// sensor_msgs/LaserScan.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LaserScan {
    /// Stamp and the laser's frame.
    pub header: Header,
    /// First ray's angle (rad).
    pub angle_min: f32,
    /// Last ray's angle (rad).
    pub angle_max: f32,
    /// Between rays (rad).
    pub angle_increment: f32,
    /// Between measurements (s): Stage's rays are simultaneous.
    pub time_increment: f32,
    /// Between scans (s).
    pub scan_time: f32,
    /// Shortest valid range (m).
    pub range_min: f32,
    /// Longest valid range (m).
    pub range_max: f32,
    /// Ranges (m).
    pub ranges: Vec<f32>,
    /// Intensities (the hit model's `ranger_return`).
    pub intensities: Vec<f32>,
}
ros_type!(LaserScan, "sensor_msgs", "LaserScan");

/// sensor_msgs/Range (one transducer of a sonar or IR ring).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Range {
    /// Stamp and the transducer's frame.
    pub header: Header,
    /// 0 ultrasound, 1 infrared.
    pub radiation_type: u8,
    /// The cone's full angle (rad).
    pub field_of_view: f32,
    /// Shortest valid range (m).
    pub min_range: f32,
    /// Longest valid range (m).
    pub max_range: f32,
    /// The reading (m).
    pub range: f32,
}
ros_type!(Range, "sensor_msgs", "Range");

/// A `uint8[]` as CDR's sequence of octets, written in one piece (serde's default for a
/// `Vec<u8>` goes byte by byte: slow for camera images).
mod octets {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &[u8], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(v)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<u8>, D::Error> {
        Vec::<u8>::deserialize(d)
    }
}

/// sensor_msgs/Image (a camera's `image` and `depth`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Image {
    /// Stamp and the camera's frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`rgba8`, `32FC1`, `16UC1`).
    pub encoding: String,
    /// 1 when multi-byte pixels are big-endian (ours are little-endian: 0).
    pub is_bigendian: u8,
    /// Bytes per row.
    pub step: u32,
    /// The pixels, row-major from the top-left.
    #[serde(with = "octets")]
    pub data: Vec<u8>,
}
ros_type!(Image, "sensor_msgs", "Image");

/// sensor_msgs/RegionOfInterest (CameraInfo's `roi`; all zero: the full image).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Left edge (pixels).
    pub x_offset: u32,
    /// Top edge (pixels).
    pub y_offset: u32,
    /// Rows (0: the full image).
    pub height: u32,
    /// Columns (0: the full image).
    pub width: u32,
    /// Whether the region is to be rectified.
    pub do_rectify: bool,
}

/// sensor_msgs/CameraInfo: a camera's pinhole model (`camera_info`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Stamp and the camera's frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// The distortion model's name (stage_ros2 leaves it empty).
    pub distortion_model: String,
    /// Distortion parameters.
    pub d: Vec<f64>,
    /// Intrinsic matrix, row-major.
    pub k: [f64; 9],
    /// Rectification matrix, row-major.
    pub r: [f64; 9],
    /// Projection matrix (3x4), row-major.
    pub p: [f64; 12],
    /// Horizontal binning (0: none).
    pub binning_x: u32,
    /// Vertical binning (0: none).
    pub binning_y: u32,
    /// Region of interest (zero: the full image).
    pub roi: RegionOfInterest,
}
ros_type!(CameraInfo, "sensor_msgs", "CameraInfo");

/// rosgraph_msgs/Clock.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Clock {
    /// The simulation time.
    pub clock: Time,
}
ros_type!(Clock, "rosgraph_msgs", "Clock");

/// std_msgs/Bool (`stalled`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Bool {
    /// The value.
    pub data: bool,
}
ros_type!(Bool, "std_msgs", "Bool");

/// std_srvs/Empty's request and response: ROS 2 gives an empty structure one `uint8` member
/// (`structure_needs_at_least_one_member`), and Cyclone drops replies without it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct EmptyMessage {
    /// The placeholder byte.
    pub structure_needs_at_least_one_member: u8,
}
impl ros2_client::Message for EmptyMessage {}

/// std_srvs/Empty's request as Fast DDS sends it (ros2-client's `Enhanced` mapping): the one
/// byte and nothing else. Cyclone's request of the same type starts with a 16-byte header; a
/// server in each mapping reads both, and this type makes the Fast DDS server refuse Cyclone's
/// (so the Cyclone client is not sent a reply it cannot read, nor the robots reset twice).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct PlainEmptyRequest {
    /// The placeholder byte.
    pub structure_needs_at_least_one_member: u8,
}
impl ros2_client::Message for PlainEmptyRequest {}

impl<'de> Deserialize<'de> for PlainEmptyRequest {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        /// Bytes past the member that show a header in front (CDR pads to 4, so up to 3 are
        /// padding).
        const MORE: usize = 4;
        struct Bytes;
        impl<'de> Visitor<'de> for Bytes {
            type Value = PlainEmptyRequest;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("std_srvs/Empty's one byte")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let member: u8 = seq
                    .next_element()?
                    .ok_or_else(|| de::Error::invalid_length(0, &self))?;
                for _ in 0..MORE {
                    // the end of the data is the answer we want
                    match seq.next_element::<u8>() {
                        Ok(Some(_)) => {}
                        Ok(None) | Err(_) => {
                            return Ok(PlainEmptyRequest {
                                structure_needs_at_least_one_member: member,
                            });
                        }
                    }
                }
                Err(de::Error::custom(
                    "a request with a header in front (Cyclone's mapping), not Fast DDS's",
                ))
            }
        }
        d.deserialize_tuple(1 + MORE, Bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_round_trips_through_a_quaternion() {
        for yaw in [0.0, 0.5, -1.2, 3.0, -3.0] {
            let q = Quaternion::from_yaw(yaw);
            assert!((q.yaw() - yaw).abs() < 1e-12, "{yaw}: {}", q.yaw());
            assert!((q.w * q.w + q.z * q.z - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn sim_time_becomes_ros_time() {
        assert_eq!(
            Time::from_micros(1_300_000),
            Time {
                sec: 1,
                nanosec: 300_000_000
            }
        );
        assert_eq!(
            Time::from_micros(100),
            Time {
                sec: 0,
                nanosec: 100_000
            }
        );
        assert!((Time::from_micros(2_500_000).seconds() - 2.5).abs() < 1e-12);
    }
}
