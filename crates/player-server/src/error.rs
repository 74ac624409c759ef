//! The crate's one error type: everything that stops a server from starting or running.

use std::io;

use player_proto::DeviceAddr;

use crate::driver::DriverError;

/// Why a server could not be built or started.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    /// A cfg `driver` block names a driver nobody registered.
    #[error("{origin}: couldn't find driver \"{name}\" (known drivers: {known})")]
    UnknownDriver {
        /// The driver name as written.
        name: String,
        /// Where the block is (`file:line`).
        origin: String,
        /// The registered names, comma separated.
        known: String,
    },
    /// A driver's factory refused its block (bad option, unsupported interface, ...).
    #[error("{origin}: driver \"{name}\" failed to start: {source}")]
    DriverFailed {
        /// The driver name.
        name: String,
        /// Where the block is.
        origin: String,
        /// The driver's reason.
        source: DriverError,
    },
    /// A cfg driver block the server cannot use (malformed address, unresolvable host).
    #[error("{origin}: {message}")]
    Config {
        /// Where (`file:line:col`).
        origin: String,
        /// What is wrong.
        message: String,
    },
    /// A driver block provides no device at all.
    #[error("{origin}: driver \"{name}\" has no (usable) interfaces")]
    NoInterfaces {
        /// The driver name.
        name: String,
        /// Where the block is.
        origin: String,
    },
    /// Two `provides` entries name the same device.
    #[error("{origin}: duplicate device addr {addr} (already provided at {first})")]
    DuplicateDevice {
        /// The address.
        addr: DeviceAddr,
        /// Where the second one is.
        origin: String,
        /// Where the first one is.
        first: String,
    },
    /// A `requires` entry names a device of this server that no block provides.
    #[error("{origin}: driver \"{driver}\" requires {addr}, which no driver provides")]
    RequiresMissing {
        /// Where the entry is written.
        origin: String,
        /// The address.
        addr: DeviceAddr,
        /// The requiring driver.
        driver: String,
    },
    /// Blocks require each other in a circle.
    #[error("{origin}: cycle of requires: {chain}")]
    RequiresCycle {
        /// Where the first block of the cycle is.
        origin: String,
        /// The blocks, in order.
        chain: String,
    },
    /// The configuration yields no device: there is nothing to serve.
    #[error("no devices read in the configuration")]
    NoDevices,
    /// An alwayson driver refused its start-up subscription.
    #[error("initial subscription failed for device {addr}: {source}")]
    AlwaysOnFailed {
        /// The device.
        addr: DeviceAddr,
        /// The driver's reason.
        source: DriverError,
    },
    /// A listening socket could not be opened.
    #[error("failed to listen on TCP port {port}: {source}")]
    Listen {
        /// The port asked for (0 = any).
        port: u32,
        /// The OS error.
        source: io::Error,
    },
    /// A port number that TCP cannot have.
    #[error("device port {0} is not a valid TCP port")]
    BadPort(u32),
    /// Starting the runtime failed.
    #[error("failed to start the server threads: {0}")]
    Runtime(io::Error),
}
