//! Interface codes and names (Player 3.0.2's `libplayerinterface/interfaces/NNN_name.def`).
//!
//! The code is what travels on the wire in every device address; the name is what `.cfg` files
//! write in `provides` strings and what tools print. Both come from this one table.

use std::fmt;

/// A Player interface code, as carried in `player_devaddr_t.interf`.
///
/// Kept as a newtype over the raw `u16` rather than a closed enum because peers may send codes we
/// do not know, and those must be representable (to NACK them) rather than rejected at decode time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub struct InterfaceCode(pub u16);

macro_rules! interfaces {
    ($( $konst:ident = $code:literal, $name:literal; )*) => {
        impl InterfaceCode {
            $(
                #[doc = concat!("`", $name, "` (", stringify!($code), ").")]
                pub const $konst: InterfaceCode = InterfaceCode($code);
            )*

            /// Every interface code assigned in Player 3.0.2, with its name, in code order.
            pub const ALL: &'static [(InterfaceCode, &'static str)] = &[
                $( (InterfaceCode($code), $name), )*
            ];
        }
    };
}

interfaces! {
    PLAYER = 1, "player";
    POWER = 2, "power";
    GRIPPER = 3, "gripper";
    POSITION2D = 4, "position2d";
    SONAR = 5, "sonar";
    LASER = 6, "laser";
    BLOBFINDER = 7, "blobfinder";
    PTZ = 8, "ptz";
    AUDIO = 9, "audio";
    FIDUCIAL = 10, "fiducial";
    SPEECH = 12, "speech";
    GPS = 13, "gps";
    BUMPER = 14, "bumper";
    DIO = 20, "dio";
    AIO = 21, "aio";
    IR = 22, "ir";
    WIFI = 23, "wifi";
    LOCALIZE = 25, "localize";
    POSITION3D = 30, "position3d";
    SIMULATION = 31, "simulation";
    BLINKENLIGHT = 33, "blinkenlight";
    CAMERA = 40, "camera";
    MAP = 42, "map";
    PLANNER = 44, "planner";
    LOG = 45, "log";
    JOYSTICK = 49, "joystick";
    SPEECH_RECOGNITION = 50, "speech_recognition";
    OPAQUE = 51, "opaque";
    POSITION1D = 52, "position1d";
    ACTARRAY = 53, "actarray";
    LIMB = 54, "limb";
    GRAPHICS2D = 55, "graphics2d";
    RFID = 56, "rfid";
    WSN = 57, "wsn";
    GRAPHICS3D = 58, "graphics3d";
    HEALTH = 59, "health";
    IMU = 60, "imu";
    POINTCLOUD3D = 61, "pointcloud3d";
    RANGER = 62, "ranger";
    VECTORMAP = 63, "vectormap";
    BLACKBOARD = 64, "blackboard";
    STEREO = 65, "stereo";
}

impl InterfaceCode {
    /// The interface's name, or `None` for a code Player 3.0.2 does not assign.
    pub fn name(self) -> Option<&'static str> {
        Self::ALL
            .iter()
            .find(|(code, _)| *code == self)
            .map(|(_, name)| *name)
    }

    /// Looks an interface up by its exact (lower-case) name, as `.cfg` files spell it.
    pub fn from_name(name: &str) -> Option<InterfaceCode> {
        Self::ALL
            .iter()
            .find(|(_, n)| *n == name)
            .map(|(code, _)| *code)
    }
}

impl fmt::Display for InterfaceCode {
    /// Player's `interf_to_str` spelling: the name, or `nointerfNN` for unassigned codes.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.name() {
            Some(name) => f.write_str(name),
            None => write!(f, "nointerf{}", self.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_codes_round_trip() {
        for &(code, name) in InterfaceCode::ALL {
            assert_eq!(code.name(), Some(name));
            assert_eq!(InterfaceCode::from_name(name), Some(code));
        }
        assert_eq!(InterfaceCode::ALL.len(), 42);
    }

    #[test]
    fn well_known_codes() {
        assert_eq!(InterfaceCode::from_name("ranger"), Some(InterfaceCode(62)));
        assert_eq!(
            InterfaceCode::from_name("simulation"),
            Some(InterfaceCode(31))
        );
        assert_eq!(InterfaceCode::from_name("Ranger"), None);
        assert_eq!(InterfaceCode(11).to_string(), "nointerf11");
        assert_eq!(InterfaceCode::POSITION2D.to_string(), "position2d");
    }
}
