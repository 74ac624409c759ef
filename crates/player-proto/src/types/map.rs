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

/// The side of the square tiles a client fetches a grid map in: libplayerc's
/// `playerc_map_get_map` and Player's map transform drivers (maptransform.cc) both ask for
/// 640 × 640 cells at a time.
pub const MAP_TILE_SIZE: u32 = 640;

impl MapInfo {
    /// The GET_DATA requests (tiles without cells) that fetch this whole map, in the order
    /// libplayerc sends them: [`MAP_TILE_SIZE`] squares, smaller at the right and top edges,
    /// across the lowest band of rows first, then the next band up.
    pub fn tile_requests(&self) -> impl Iterator<Item = MapTile> + use<> {
        let (width, height) = (self.width, self.height);
        let cols = width.div_ceil(MAP_TILE_SIZE);
        let rows = height.div_ceil(MAP_TILE_SIZE);
        (0..rows).flat_map(move |r| {
            (0..cols).map(move |c| {
                let (col, row) = (c * MAP_TILE_SIZE, r * MAP_TILE_SIZE);
                MapTile {
                    col,
                    row,
                    width: MAP_TILE_SIZE.min(width - col),
                    height: MAP_TILE_SIZE.min(height - row),
                    data: Vec::new(),
                }
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(width: u32, height: u32) -> MapInfo {
        MapInfo {
            scale: 0.1,
            width,
            height,
            origin: Pose2d::default(),
        }
    }

    #[test]
    fn tiles_go_band_by_band_as_playerc_map_get_map_asks() {
        let tiles: Vec<_> = info(1000, 700)
            .tile_requests()
            .map(|t| (t.col, t.row, t.width, t.height))
            .collect();
        assert_eq!(
            tiles,
            [
                (0, 0, 640, 640),
                (640, 0, 360, 640),
                (0, 640, 640, 60),
                (640, 640, 360, 60)
            ]
        );
        assert_eq!(info(640, 640).tile_requests().count(), 1);
        assert_eq!(info(0, 5).tile_requests().count(), 0);
        assert_eq!(info(5, 0).tile_requests().count(), 0);
        assert!(info(3, 2).tile_requests().all(|t| t.data.is_empty()));
    }
}
