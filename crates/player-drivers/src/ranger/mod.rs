//! Player's `server/drivers/ranger/` converters: the Player 3 `ranger` interface to and from
//! the Player 2 `laser` and `sonar` interfaces, so that a program written for either sees
//! devices of the other.
//!
//! * [`rangertolaser`] (upstream `FromRanger` + `RangerToLaser`): a ranger read as a laser;
//! * [`lasertoranger`] (`ToRanger` + `LaserToRanger`): a laser read as a ranger;
//! * [`sonartoranger`] (`ToRanger` + `SonarToRanger`): a sonar array read as a ranger.
//!
//! What upstream's two base classes share lives in `crate::forward`: CAPABILITIES answered
//! for the requests a converter handles, and integer/double/string property requests passed
//! to the input device with its answer passed back.

pub mod lasertoranger;
pub mod rangertolaser;
pub mod sonartoranger;

use player_proto::{DeviceAddr, InterfaceCode};
use player_server::{DriverBlock, DriverError};

/// The one device of `interface` a converter block provides (upstream's single-interface
/// `Driver` constructor takes the first `provides` entry of its interface). Any other entry is
/// refused: upstream would silently never create it, leaving a client nothing to talk to.
pub(crate) fn provided(
    block: &DriverBlock,
    interface: InterfaceCode,
) -> Result<DeviceAddr, DriverError> {
    let mut found = None;
    for p in &block.provides {
        if p.addr.interf == interface && found.is_none() {
            found = Some(p.addr);
        } else {
            return Err(DriverError::new(format!(
                "{}: \"{}\" provides one {interface} device only, not {}:{}",
                p.origin, block.name, p.addr.interf, p.addr.index
            )));
        }
    }
    found.ok_or_else(|| {
        DriverError::new(format!(
            "\"{}\" provides a {interface} device (e.g. provides [\"{interface}:0\"])",
            block.name
        ))
    })
}

/// Upstream's `buggy_geom` option (default 0): zero the z, roll and pitch of geometry read from
/// drivers that leave those fields uninitialised.
pub(crate) fn buggy_geom(block: &DriverBlock) -> Result<bool, DriverError> {
    Ok(crate::options::flag(block, "buggy_geom")?.unwrap_or(false))
}
