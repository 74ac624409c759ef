//! A Rust client for Player 3.0.2 servers, in the spirit of libplayerc++.
//!
//! ```no_run
//! use player_client::{PlayerClient, Position2dProxy, RangerProxy};
//!
//! let client = PlayerClient::connect("localhost", 6665)?;
//! let base = Position2dProxy::new(&client, 0)?;
//! let sonar = RangerProxy::new(&client, 0)?;
//! for _ in 0..10 {
//!     client.read()?;
//!     let turn = if sonar.ranges().iter().any(|&r| r < 0.5) { 0.5 } else { 0.0 };
//!     base.set_speed(0.3, 0.0, turn)?;
//! }
//! # Ok::<(), player_client::ClientError>(())
//! ```
//!
//! The client is synchronous (blocking `std::net`), sets `TCP_NODELAY`, and follows
//! libplayerc's session rules: PULL mode after connecting, one data round per
//! [`PlayerClient::read`], requests matched to their reply by interface, index and subtype.
//! Proxies subscribe on creation and unsubscribe when dropped.

#![warn(missing_docs)]

mod client;
mod error;
mod proxy;

pub use client::{DEFAULT_PORT, DEFAULT_REQUEST_TIMEOUT, DataMode, DeviceInfo, PlayerClient};
pub use error::ClientError;
pub use proxy::{
    ActArrayProxy, BlackboardProxy, BlobfinderProxy, CameraProxy, ClientProxy, FiducialProxy,
    Graphics2dProxy, GripperProxy, LaserProxy, LocalizeProxy, LogProxy, LogState, MapProxy,
    OccupancyMap, PlannerProxy, Position2dProxy, RangerProxy, SimulationProxy, SonarProxy,
    SpeechProxy,
};
