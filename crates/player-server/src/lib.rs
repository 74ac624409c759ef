//! The Player 3.0.2 device server: TCP sessions, the device table, and the machinery drivers
//! plug into.
//!
//! * [`driver`] — the [`Driver`] trait, the cfg [`DriverBlock`] a driver is built from, and the
//!   [`DriverRegistry`] of factories by driver name;
//! * [`cfg`](mod@cfg) — cfg `driver` blocks ([`worldfile::CfgFile`]) to [`DriverBlock`]s;
//! * [`check`] — what a cfg makes of the server, built as start-up builds it but never started
//!   (`player --check`);
//! * [`device`] — the [`DeviceTable`] (cfg order, duplicate check, ports);
//! * [`queue`] — the per-connection outgoing queue with upstream's exact PUSH/PULL, replace-rule
//!   and SYNCH semantics;
//! * [`remote`] — [`remote::RemoteLink`], a client link to one device on another Player server,
//!   for drivers whose required devices live there;
//! * [`map`] — the `map` interface: the [`map::OccupancyGrid`] map drivers serve and the answers
//!   to its requests;
//! * [`clock`] — the server clock and the schedule drivers are stepped on ([`Pace`]);
//! * [`server`] — [`Server`] (assembling) and [`ServerHandle`] (running);
//! * [`stage`] — the `stage` driver: Player devices on an embedded Stage world;
//! * [`test_driver`] — a small driver for tests and manual checks.
//!
//! Connection tasks do the I/O and answer the player interface's own requests; one core task
//! owns the drivers and subscriptions, so drivers are plain synchronous objects.

#![warn(missing_docs)]

pub mod cfg;
pub mod check;
pub mod clock;
mod connection;
mod core;
pub mod device;
pub mod driver;
mod error;
pub mod map;
mod player_iface;
pub mod queue;
pub mod remote;
pub mod remote_device;
pub mod server;
pub mod stage;
pub mod test_driver;
pub mod worker;

pub use clock::{Pace, ServerClock};
pub use connection::ConnectionLimits;
pub use device::{Device, DeviceIndex, DeviceTable, DriverId};
pub use driver::{
    Action, ClientId, Context, Driver, DriverBlock, DriverError, DriverRegistry, DriverWaker,
    PendingReply, ProvidedDevice, Publication, Reply, RequestError, RequestTicket, RequiredDevice,
};
pub use error::ServerError;
pub use server::{REMOTE_DRIVER_NAME, RemoteFactory, Server, ServerConfig, ServerHandle};
pub use worker::WorkerThread;
