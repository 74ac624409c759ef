//! A ROS 2 node on a `stage-sim` world, a drop-in for tuw-robotics/stage_ros2: its parameters
//! ([`params`]), its topic, frame and service names ([`names`]), its messages ([`msgs`]) and
//! what it does with those it receives ([`inbound`]), over ros2-client (ROS 2 on RustDDS, pure
//! Rust) configured from ROS 2's environment ([`transport`]). [`Bridge`] is the node; [`run`]
//! steps a world with it.
//!
//! It sits beside `player-server` on the world engine: the bridge reads and commands a
//! `stage_sim::World` between steps, as the stage driver does for Player clients.

pub mod bridge;
pub mod inbound;
pub mod msgs;
pub mod names;
pub mod params;
pub mod transport;

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};

pub use bridge::Bridge;
pub use params::{PARAMETERS, Params, RosArgs};
pub use transport::Discovery;

/// What can go wrong setting the bridge up.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter's value does not parse.
    #[error("parameter `{name}`: {message}")]
    BadParameter {
        /// The parameter.
        name: String,
        /// Why.
        message: String,
    },
    /// A parameter the node does not have.
    #[error("unknown parameter `{0}`")]
    UnknownParameter(String),
    /// A malformed `--ros-args` section.
    #[error("--ros-args: {0}")]
    BadRosArgs(String),
    /// A `--params-file` that cannot be read.
    #[error("parameter file {}{}: {message}", path.display(), if *line > 0 { format!(":{line}") } else { String::new() })]
    ParamsFile {
        /// The file.
        path: PathBuf,
        /// Its line (0: the whole file).
        line: usize,
        /// Why.
        message: String,
    },
    /// An environment variable with a bad value.
    #[error("{variable}: {message}")]
    Environment {
        /// The variable.
        variable: &'static str,
        /// Why.
        message: String,
    },
    /// A topic or node name ROS 2 does not accept (after remapping).
    #[error("`{name}` is not a valid ROS 2 name ({message})")]
    Name {
        /// The name.
        name: String,
        /// ros2-client's reason.
        message: String,
    },
    /// The DDS layer refused something.
    #[error("DDS: {0}")]
    Dds(String),
    /// The world refused a call.
    #[error("simulation: {0}")]
    Sim(stage_sim::Error),
}

/// Steps `world` with `bridge` until the world reaches its `quit_time` or `quit` is set:
/// inbound messages before each step, publications after it, paced at `speedup` times real
/// time (`<= 0`: as fast as possible). Returns the number of steps taken.
pub fn run(world: &mut World, bridge: &mut Bridge, speedup: f64, quit: &AtomicBool) -> u64 {
    let mut pacer = Pacer::new(world.config().interval_sim_us, speedup);
    let mut steps = 0;
    while !quit.load(Ordering::Relaxed) {
        bridge.inbound(world);
        if !world.step() {
            break;
        }
        steps += 1;
        bridge.publish(world);
        pacer.wait();
    }
    steps
}

use stage_sim::World;
use stage_sim::pacing::Pacer;
