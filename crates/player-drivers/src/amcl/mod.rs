//! `amcl`: adaptive Monte-Carlo localisation, as Player 3.0.2's driver.
//!
//! The robot's pose is tracked by a particle filter ([`pf`]) whose particle count adapts by
//! KLD-sampling: many particles while the pose is uncertain, few once it is known. Odometry
//! moves the particles ([`models::OdometryModel`]); laser scans and sonar ranges, compared
//! with a map by ray casting, weigh them ([`models::LaserModel`], [`models::SonarModel`]).

pub mod histogram;
pub mod map;
pub mod models;
pub mod pdf;
pub mod pf;
pub mod pose;

/// What can go wrong while the driver builds its map.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AmclError {
    /// The map is bigger than [`map::MAX_CELLS`].
    #[error("the map is {width} x {height} cells, more than this driver accepts")]
    MapTooLarge {
        /// Width in cells.
        width: usize,
        /// Height in cells.
        height: usize,
    },
    /// The map's scale is not a positive number.
    #[error("the map's scale {0} is not a positive length")]
    MapScale(f64),
    /// A GET_DATA answer does not fit the tile asked for.
    #[error(
        "a map tile at column {col}, row {row} of {width} x {height} cells came with {cells} cells"
    )]
    BadTile {
        /// First column.
        col: usize,
        /// First row.
        row: usize,
        /// Tile width.
        width: usize,
        /// Tile height.
        height: usize,
        /// Cells received.
        cells: usize,
    },
}
