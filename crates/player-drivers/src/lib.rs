//! Player 3.0.2's drivers other than `stage`, one module per driver as in Player's
//! `server/drivers/`. Each module names its driver (`NAME`) and builds it from a cfg block
//! (`from_block`); [`register_all`] adds every driver of this crate to a [`DriverRegistry`]
//! under its Player name.
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
//!   odometry and laser or sonar ranges;
//! * [`blackboard`] — `localbb`: entries shared between clients, kept in the server's memory.
//!
//! These drivers use other devices through the server's bus ([`player_server::Context`]):
//! they subscribe in `setup`, convert the DATA they receive, and answer a client's request by
//! forwarding it, deferring the client's request, and answering it when the reply comes back.

#![warn(missing_docs)]

pub mod blackboard;
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

/// Registers every driver of this crate under its Player 3.0.2 name (each module's `NAME`),
/// built by its type's `from_block`.
pub fn register_all(registry: &mut DriverRegistry) {
    use blackboard::localbb;
    use laser::laserposeinterpolator;
    use localization::amcl;
    use map::mapfile;
    use planner::wavefront;
    use position::{mbicp, nd, snd, vfh};
    use ranger::{lasertoranger, rangertolaser, sonartoranger};
    use shell::{passthrough, readlog, relay, writelog};

    registry.register_driver(
        rangertolaser::NAME,
        rangertolaser::RangerToLaser::from_block,
    );
    registry.register_driver(
        lasertoranger::NAME,
        lasertoranger::LaserToRanger::from_block,
    );
    registry.register_driver(
        sonartoranger::NAME,
        sonartoranger::SonarToRanger::from_block,
    );
    registry.register_driver(passthrough::NAME, passthrough::Passthrough::from_block);
    registry.register_driver(relay::NAME, relay::Relay::from_block);
    registry.register_driver(writelog::NAME, writelog::WriteLog::from_block);
    registry.register_driver(readlog::NAME, readlog::ReadLog::from_block);
    registry.register_driver(
        laserposeinterpolator::NAME,
        laserposeinterpolator::LaserPoseInterpolator::from_block,
    );
    registry.register_driver(mapfile::NAME, mapfile::MapFile::from_block);
    map::transform::register(registry);
    registry.register_driver(vfh::NAME, vfh::VfhDriver::from_block);
    registry.register_driver(mbicp::NAME, mbicp::Mbicp::from_block);
    registry.register_driver(nd::NAME, nd::Nd::from_block);
    registry.register_driver(snd::NAME, snd::Snd::from_block);
    registry.register_driver(amcl::NAME, amcl::Amcl::from_block);
    registry.register_driver(wavefront::NAME, wavefront::Wavefront::from_block);
    registry.register_driver(localbb::NAME, localbb::LocalBb::from_block);
}
