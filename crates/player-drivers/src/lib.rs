//! Player 3.0.2's drivers other than `stage`, one module per driver as in Player's
//! `server/drivers/`. Each module exposes a `register` function; [`register_all`] adds every
//! driver of this crate to a [`DriverRegistry`] under its Player name.
//!
//! * [`ranger`] — `rangertolaser`, `lasertoranger`, `sonartoranger`: Player 3's ranger
//!   interface to and from Player 2's laser and sonar;
//! * [`laser`] — `laserposeinterpolator`: scans stamped with the pose they were taken from;
//! * [`position`] — `vfh`, `nd` and `snd`: local navigation (Vector Field Histogram+,
//!   Nearness Diagram, Smooth ND) over a base and a laser and/or sonar; `mbicp`: odometry
//!   corrected by scan matching;
//! * [`map`] — `mapfile` (a map read from an image), `mapscale` (resampled to another
//!   resolution) and `mapcspace` (the configuration space of a round robot);
//! * [`planner`] — `wavefront`: global path planning over a map, driving a position2d
//!   device waypoint by waypoint;
//! * [`shell`] — `passthrough` (devices served under another address, local or remote),
//!   `relay` (clients' opaque messages echoed to every subscriber), and `writelog` /
//!   `readlog` (runs recorded to and replayed from Player's text log format);
//! * [`localization`] — `amcl`: adaptive Monte-Carlo localisation against a map, from
//!   odometry and laser or sonar ranges.
//!
//! These drivers use other devices through the server's bus ([`player_server::Context`]):
//! they subscribe in `setup`, convert the DATA they receive, and answer a client's request by
//! forwarding it, deferring the client's request, and answering it when the reply comes back.

#![warn(missing_docs)]

mod error;
mod forward;
pub mod laser;
pub mod localization;
pub mod map;
mod options;
pub mod planner;
pub mod position;
pub mod ranger;
pub mod shell;
#[cfg(test)]
mod testing;

pub use error::Error;

/// The cores this process may run on (found once; at least 1), for the drivers that share a
/// burst of work between threads (amcl's weighing, wavefront's waypoint search).
pub(crate) fn cores() -> usize {
    static CORES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

use player_server::DriverRegistry;

/// Registers every driver of this crate under its Player 3.0.2 name.
pub fn register_all(registry: &mut DriverRegistry) {
    ranger::rangertolaser::register(registry);
    ranger::lasertoranger::register(registry);
    ranger::sonartoranger::register(registry);
    shell::passthrough::register(registry);
    shell::relay::register(registry);
    shell::writelog::register(registry);
    shell::readlog::register(registry);
    laser::laserposeinterpolator::register(registry);
    map::mapfile::register(registry);
    map::transform::register(registry);
    position::vfh::register(registry);
    position::mbicp::register(registry);
    position::nd::register(registry);
    position::snd::register(registry);
    localization::amcl::register(registry);
    planner::wavefront::register(registry);
}
