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

impl MapTile {
    /// The tile as it travels over TCP in a GET_DATA ACK: its cells replaced by their zlib
    /// stream (zlib's `compress()`, level 6) and `data_count` the stream's length, as Player's
    /// TCP layer sends it and libplayerc inflates it. Part of the wire format, so it lives here,
    /// beside the struct.
    pub fn zipped(&self) -> MapTile {
        use std::io::Write;
        let cells: Vec<u8> = self.data.iter().map(|&c| c as u8).collect();
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::new(6));
        // Writing into a Vec cannot fail.
        z.write_all(&cells).expect("compressing into memory");
        let zipped = z.finish().expect("compressing into memory");
        MapTile {
            data: zipped.into_iter().map(|b| b as i8).collect(),
            ..self.clone()
        }
    }

    /// The GET_DATA request for the `width × height` cells from (`col`, `row`): the tile
    /// without its cells, which the reply fills in.
    pub fn request(col: u32, row: u32, width: u32, height: u32) -> MapTile {
        MapTile {
            col,
            row,
            width,
            height,
            data: Vec::new(),
        }
    }

    /// The tile with its zlib-compressed cells inflated (a GET_DATA ACK read from TCP), or
    /// `None` when they do not inflate to exactly `width × height` cells. At most one cell
    /// more is ever read, so a hostile stream cannot make the reader allocate more.
    pub fn unzipped(&self) -> Option<MapTile> {
        use std::io::Read;
        let len = (self.width as usize).checked_mul(self.height as usize)?;
        let bytes: Vec<u8> = self.data.iter().map(|&b| b as u8).collect();
        let mut out = Vec::with_capacity(len);
        flate2::read::ZlibDecoder::new(&bytes[..])
            .take(len as u64 + 1)
            .read_to_end(&mut out)
            .ok()?;
        (out.len() == len).then(|| MapTile {
            data: out.into_iter().map(|b| b as i8).collect(),
            ..self.clone()
        })
    }
}

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
                MapTile::request(
                    col,
                    row,
                    MAP_TILE_SIZE.min(width - col),
                    MAP_TILE_SIZE.min(height - row),
                )
            })
        })
    }
}

#[cfg(test)]
mod zlib_tests {
    use super::*;

    fn tile(width: u32, height: u32, data: Vec<i8>) -> MapTile {
        MapTile {
            col: 0,
            row: 0,
            width,
            height,
            data,
        }
    }

    #[test]
    fn zipped_cells_unzip_to_exactly_the_tile() {
        let cells: Vec<i8> = (0..5000u32)
            .map(|k| [-1i8, 0, 1][(k / 7 % 3) as usize])
            .collect();
        let z = tile(100, 50, cells.clone()).zipped();
        assert!(z.data.len() < cells.len() / 10, "{} bytes", z.data.len());
        assert_eq!(z.unzipped().unwrap().data, cells);
        // One cell more or less than the tile holds, or no zlib stream at all: refused.
        assert_eq!(tile(100, 49, z.data.clone()).unzipped(), None);
        assert_eq!(tile(101, 50, z.data.clone()).unzipped(), None);
        assert_eq!(tile(1, 3, vec![1, 2, 3]).unzipped(), None);
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
