//! The `map` interface (42).

use super::{Pose2d, Segment};

xdr_struct! {
    /// Map size and placement (GET_INFO reply, DATA INFO).
    pub struct MapInfo = "player_map_info_t" {
        /// Metres per cell.
        scale: f32,
        /// Width (cells).
        width: u32,
        /// Height (cells).
        height: u32,
        /// Real-world pose of cell (0, 0).
        origin: Pose2d,
    }

    /// A tile of cells (GET_DATA request and reply). Upstream servers zlib-compress the cells of
    /// replies; this struct carries whatever bytes travel.
    pub struct MapTile = "player_map_data_t" {
        /// First column.
        col: u32,
        /// First row.
        row: u32,
        /// Tile width (cells).
        width: u32,
        /// Tile height (cells).
        height: u32,
        /// Cells (-1 free, 0 unknown, +1 occupied), or their zlib stream in replies.
        data: Vec<i8>,
    }

    /// Vector map (GET_VECTOR reply).
    pub struct MapDataVector = "player_map_data_vector_t" {
        /// Minimum x (m).
        minx: f32,
        /// Maximum x (m).
        maxx: f32,
        /// Minimum y (m).
        miny: f32,
        /// Maximum y (m).
        maxy: f32,
        /// Line segments.
        segments: Vec<Segment>,
    }
}
