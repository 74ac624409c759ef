//! Geometry and utility structs of `player.h`, and the universal request bodies.

use crate::xdr::Text;

xdr_struct! {
    /// A point in the plane (m).
    #[derive(Copy)]
    pub struct Point2d = "player_point_2d_t" {
        /// X (m).
        px: f64,
        /// Y (m).
        py: f64,
    }

    /// A point in space (m).
    #[derive(Copy)]
    pub struct Point3d = "player_point_3d_t" {
        /// X (m).
        px: f64,
        /// Y (m).
        py: f64,
        /// Z (m).
        pz: f64,
    }

    /// Roll, pitch, yaw (rad).
    #[derive(Copy)]
    pub struct Orientation3d = "player_orientation_3d_t" {
        /// Roll (rad).
        proll: f64,
        /// Pitch (rad).
        ppitch: f64,
        /// Yaw (rad).
        pyaw: f64,
    }

    /// A planar pose (m, m, rad).
    #[derive(Copy)]
    pub struct Pose2d = "player_pose2d_t" {
        /// X (m).
        px: f64,
        /// Y (m).
        py: f64,
        /// Yaw (rad).
        pa: f64,
    }

    /// A pose in space (m, rad).
    #[derive(Copy)]
    pub struct Pose3d = "player_pose3d_t" {
        /// X (m).
        px: f64,
        /// Y (m).
        py: f64,
        /// Z (m).
        pz: f64,
        /// Roll (rad).
        proll: f64,
        /// Pitch (rad).
        ppitch: f64,
        /// Yaw (rad).
        pyaw: f64,
    }

    /// A 2D bounding box: width first, then length.
    #[derive(Copy)]
    pub struct Bbox2d = "player_bbox2d_t" {
        /// Width (m).
        sw: f64,
        /// Length (m).
        sl: f64,
    }

    /// A 3D bounding box: width, length, height in that order.
    #[derive(Copy)]
    pub struct Bbox3d = "player_bbox3d_t" {
        /// Width (m).
        sw: f64,
        /// Length (m).
        sl: f64,
        /// Height (m).
        sh: f64,
    }

    /// A line segment (map vectors).
    #[derive(Copy)]
    pub struct Segment = "player_segment_t" {
        /// Start X (m).
        x0: f64,
        /// Start Y (m).
        y0: f64,
        /// End X (m).
        x1: f64,
        /// End Y (m).
        y1: f64,
    }

    /// A colour, alpha first; each channel is widened to 4 bytes, so 16 bytes on the wire.
    #[derive(Copy, Eq, Hash)]
    pub struct Color = "player_color_t" {
        /// Alpha (0 = opaque in Stage's graphics mapping).
        alpha: u8,
        /// Red.
        red: u8,
        /// Green.
        green: u8,
        /// Blue.
        blue: u8,
    }

    /// A single unsigned value (the SYNCH OVERFLOW body: dropped-message count).
    #[derive(Copy, Eq, Hash)]
    pub struct Uint32 = "player_uint32_t" {
        /// The value.
        value: u32,
    }

    /// Asks whether a device supports a (type, subtype) (universal request 255).
    #[derive(Copy, Eq, Hash)]
    pub struct CapabilitiesReq = "player_capabilities_req_t" {
        /// Message type asked about.
        msg_type ("type"): u32,
        /// Subtype asked about.
        subtype: u32,
    }

    /// Boolean property get/set. `value` is a C `char`, sign-extended on the wire.
    pub struct BoolPropReq = "player_boolprop_req_t" {
        /// Property name (NUL counted).
        key: Text,
        /// The value.
        value: i8,
    }

    /// Integer property get/set.
    pub struct IntPropReq = "player_intprop_req_t" {
        /// Property name (NUL counted).
        key: Text,
        /// The value.
        value: i32,
    }

    /// Double property get/set.
    pub struct DblPropReq = "player_dblprop_req_t" {
        /// Property name (NUL counted).
        key: Text,
        /// The value.
        value: f64,
    }

    /// String property get/set.
    pub struct StrPropReq = "player_strprop_req_t" {
        /// Property name (NUL counted).
        key: Text,
        /// The value (NUL counted in replies; count 0 in GET requests).
        value: Text,
    }
}
