//! Player's `server/drivers/position/`: drivers that provide a `position2d` over another one,
//! adding local navigation that drives the base to goals among the obstacles its range
//! sensors see.
//!
//! * [`vfh`] — Vector Field Histogram+;
//! * [`nd`] — Nearness Diagram navigation;
//! * [`snd`] — Smooth Nearness-Diagram navigation (laser only, a round robot);
//! * [`mbicp`] — not navigation: the base's odometry corrected by matching consecutive
//!   laser scans (metric-based ICP).

pub mod mbicp;
pub mod nd;
pub mod snd;
pub mod vfh;

use player_proto::{DeviceAddr, InterfaceCode};
use player_server::{Context, DriverBlock, DriverError};

/// The `output` and `input` position2d devices of a driver that steers a base (nd, wavefront):
/// the one it commands and the one whose odometry it reads (often the same device).
pub(crate) fn output_and_input(
    block: &DriverBlock,
) -> Result<(DeviceAddr, DeviceAddr), DriverError> {
    let keyed = |key| {
        block
            .required(InterfaceCode::POSITION2D, Some(key))
            .map(|r| r.addr)
    };
    Ok((keyed("output")?, keyed("input")?))
}

/// Subscribes to `first`, then to `second` unless it is the same device: a base's output and
/// input position2d are often one device, subscribed once.
pub(crate) fn subscribe_both(ctx: &mut Context<'_>, first: DeviceAddr, second: DeviceAddr) {
    ctx.subscribe(first);
    if !second.same_device(&first) {
        ctx.subscribe(second);
    }
}

/// The range sensors a navigation driver may read, each optional: the first laser and the
/// first sonar it requires (nd and vfh take either; each decides what neither or both mean).
pub(crate) fn laser_and_sonar(
    block: &DriverBlock,
) -> Result<(Option<DeviceAddr>, Option<DeviceAddr>), DriverError> {
    let optional = |interface| {
        block
            .optional_required(interface, None)
            .map(|r| r.map(|r| r.addr))
    };
    Ok((
        optional(InterfaceCode::LASER)?,
        optional(InterfaceCode::SONAR)?,
    ))
}
