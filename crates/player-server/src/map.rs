//! The `map` interface (42) as Player 3.0.2 serves it: an [`OccupancyGrid`] and the answers to
//! the interface's requests ([`answer`]), shared by every driver that provides a map (`mapfile`,
//! `mapscale`, `mapcspace`, and the `stage` driver for a model).
//!
//! What upstream does, and so what we do (server/drivers/map/mapfile.cc, maptransform.cc,
//! libplayertcp/playertcp.cc, libplayerc/dev_map.c):
//! * GET_INFO (no request body) is answered with `player_map_info_t`: scale (m/cell, a C
//!   `float`), width, height and the pose of cell (0, 0).
//! * GET_DATA asks for a tile (`col`, `row`, `width`, `height`, no cells). The reply repeats the
//!   requested tile exactly and carries its `width × height` cells row by row; cells off the map
//!   are 0 (unknown) — upstream warns and fills, it never refuses. Player 3.0.2 has no
//!   `data_range` member (it came later, with the "extended map interface").
//! * GET_VECTOR and every other request: the grid drivers return -1, so the client gets an empty
//!   NACK. They publish no data (no `PLAYER_MAP_DATA_INFO` either).
//! * The cells of a GET_DATA ACK travel zlib-compressed: upstream's TCP layer (not the driver)
//!   replaces them with `compress()` of the raw cells before encoding and libplayerc
//!   uncompresses. We do the same in the connection's outgoing queue (`tcp_body`), so a driver
//!   reading another driver's map inside the server would see raw cells, as upstream. The
//!   stream is a valid zlib stream of the same cells at the same level, and identical to zlib's
//!   for small tiles (the golden vector); for large tiles its deflate blocks may differ from
//!   zlib 1.2's, as zlib-ng-based systems' do: clients only ever inflate them.
//!
//! A client fetches a map tile by tile as [`MapInfo::tile_requests`] lists them.
//!
//! Where we differ on purpose: a tile of more cells than a message can carry
//! ([`MAX_TILE_CELLS`]), or whose size overflows 32 bits, is refused with a NACK instead of
//! being allocated; the off-map warning is logged once per request, not once per cell.

use player_proto::constants::PLAYERXDR_MAX_MESSAGE_SIZE;
use player_proto::{Body, InterfaceCode, MapInfo, MapMsg, MapReq, MapTile, MsgHeader, MsgType};
use player_proto::{Pose2d, Xdr};

use crate::driver::Reply;

/// Most cells one GET_DATA reply may carry: what fits an XDR message uncompressed.
pub const MAX_TILE_CELLS: usize = PLAYERXDR_MAX_MESSAGE_SIZE - 64;

/// Most cells a grid may have (1 GiB of cells): larger ones are refused when built.
pub const MAX_GRID_CELLS: usize = 1 << 30;

/// An occupancy grid as the map interface defines it.
///
/// Cell (i, j) is column i, row j; row 0 is the lowest (smallest y) and cells are stored row by
/// row (`width × j + i`, libplayerc's `PLAYERC_MAP_INDEX`). The real-world pose of cell (0, 0)
/// is `origin`; `scale` is metres per cell, kept as the C `float` the wire carries, since the
/// map transform drivers compute with the value they read from their source map.
#[derive(Clone, Debug, PartialEq)]
pub struct OccupancyGrid {
    width: u32,
    height: u32,
    scale: f32,
    origin: Pose2d,
    cells: Vec<i8>,
}

impl OccupancyGrid {
    /// Free cell.
    pub const FREE: i8 = -1;
    /// Unknown cell.
    pub const UNKNOWN: i8 = 0;
    /// Occupied cell.
    pub const OCCUPIED: i8 = 1;

    /// A `width × height` grid with every cell `fill`; `None` when it would have more than
    /// [`MAX_GRID_CELLS`] cells.
    pub fn new(
        width: u32,
        height: u32,
        scale: f32,
        origin: Pose2d,
        fill: i8,
    ) -> Option<OccupancyGrid> {
        let n = cell_count(width, height)?;
        Some(OccupancyGrid {
            width,
            height,
            scale,
            origin,
            cells: vec![fill; n],
        })
    }

    /// A grid over `cells` (row by row, row 0 lowest); `None` unless there are exactly
    /// `width × height` of them (and at most [`MAX_GRID_CELLS`]).
    pub fn from_cells(
        width: u32,
        height: u32,
        scale: f32,
        origin: Pose2d,
        cells: Vec<i8>,
    ) -> Option<OccupancyGrid> {
        (cell_count(width, height)? == cells.len()).then_some(OccupancyGrid {
            width,
            height,
            scale,
            origin,
            cells,
        })
    }

    /// Columns.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Metres per cell.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// Real-world pose of cell (0, 0).
    pub fn origin(&self) -> Pose2d {
        self.origin
    }

    /// Every cell, row by row from the lowest row.
    pub fn cells(&self) -> &[i8] {
        &self.cells
    }

    /// Every cell, for drivers that compute a map in place.
    pub fn cells_mut(&mut self) -> &mut [i8] {
        &mut self.cells
    }

    /// The metadata GET_INFO answers with.
    pub fn info(&self) -> MapInfo {
        MapInfo {
            scale: self.scale,
            width: self.width,
            height: self.height,
            origin: self.origin,
        }
    }

    /// Index of cell (i, j) in [`OccupancyGrid::cells`], `None` off the map. Signed so that
    /// neighbourhood arithmetic can step off the edges.
    pub fn index(&self, i: i64, j: i64) -> Option<usize> {
        let on_map =
            (0..i64::from(self.width)).contains(&i) && (0..i64::from(self.height)).contains(&j);
        on_map.then(|| (j as usize) * (self.width as usize) + i as usize)
    }

    /// Cell (i, j), `None` off the map.
    pub fn get(&self, i: i64, j: i64) -> Option<i8> {
        self.index(i, j).map(|k| self.cells[k])
    }

    /// Sets cell (i, j); false (and nothing changes) off the map.
    pub fn set(&mut self, i: i64, j: i64, value: i8) -> bool {
        match self.index(i, j) {
            Some(k) => {
                self.cells[k] = value;
                true
            }
            None => false,
        }
    }

    /// The cells of the tile whose lower-left cell is (`col`, `row`), row by row: exactly
    /// `width × height` of them, cells off the map unknown (0), as mapfile fills them. `None`
    /// when the tile has more than [`MAX_TILE_CELLS`] cells.
    pub fn tile(&self, col: u32, row: u32, width: u32, height: u32) -> Option<Vec<i8>> {
        let n = (width as usize).checked_mul(height as usize)?;
        if n > MAX_TILE_CELLS {
            return None;
        }
        let mut out = vec![Self::UNKNOWN; n];
        // The part of the tile on the map, copied a row slice at a time.
        let (c0, r0) = (u64::from(col), u64::from(row));
        let c1 = (c0 + u64::from(width)).min(u64::from(self.width));
        let r1 = (r0 + u64::from(height)).min(u64::from(self.height));
        if c0 < c1 {
            let span = (c1 - c0) as usize;
            for j in r0..r1 {
                let src = (j as usize) * (self.width as usize) + c0 as usize;
                let dst = ((j - r0) as usize) * (width as usize);
                out[dst..dst + span].copy_from_slice(&self.cells[src..src + span]);
            }
        }
        Some(out)
    }

    /// Whether the tile (`col`, `row`, `width`, `height`) reaches off the map.
    pub fn tile_leaves_map(&self, col: u32, row: u32, width: u32, height: u32) -> bool {
        u64::from(col) + u64::from(width) > u64::from(self.width)
            || u64::from(row) + u64::from(height) > u64::from(self.height)
    }

    /// Copies a received tile into the grid (cells off the grid are dropped); false when
    /// `cells` is shorter than `width × height`.
    pub fn put_tile(&mut self, col: u32, row: u32, width: u32, height: u32, cells: &[i8]) -> bool {
        let Some(n) = (width as usize).checked_mul(height as usize) else {
            return false;
        };
        if cells.len() < n {
            return false;
        }
        for j in 0..height {
            for i in 0..width {
                let v = cells[(j as usize) * (width as usize) + i as usize];
                self.set(
                    i64::from(col) + i64::from(i),
                    i64::from(row) + i64::from(j),
                    v,
                );
            }
        }
        true
    }
}

fn cell_count(width: u32, height: u32) -> Option<usize> {
    (width as usize)
        .checked_mul(height as usize)
        .filter(|&n| n <= MAX_GRID_CELLS)
}

/// Answers a request to a map device served from `grid`, as Player's grid map drivers do:
/// GET_INFO and GET_DATA are ACKed, anything else is left unhandled (empty NACK).
pub fn answer(grid: &OccupancyGrid, body: &Body) -> Reply {
    let Body::Map(MapMsg::Req(req)) = body else {
        return Reply::NotHandled;
    };
    match req {
        MapReq::GetInfo(_) => Reply::ack(MapReq::GetInfo(Some(grid.info()))),
        MapReq::GetData(Some(want)) => {
            let (col, row, width, height) = (want.col, want.row, want.width, want.height);
            let Some(data) = grid.tile(col, row, width, height) else {
                tracing::warn!(
                    "map: refusing a {width} x {height} tile: more than {MAX_TILE_CELLS} cells"
                );
                return Reply::Nack;
            };
            if grid.tile_leaves_map(col, row, width, height) {
                tracing::warn!(
                    "map: tile ({col},{row}) {width} x {height} reaches off the {} x {} map; \
                     those cells are unknown",
                    grid.width,
                    grid.height
                );
            }
            Reply::ack(MapReq::GetData(Some(MapTile {
                col,
                row,
                width,
                height,
                data,
            })))
        }
        // No tile to read (upstream would read through a null pointer) or a vector map, which
        // grid drivers do not have.
        MapReq::GetData(None) | MapReq::GetVector(_) => Reply::NotHandled,
    }
}

/// Whether a message with this header is a map GET_DATA ACK, whose cells the TCP layer
/// compresses.
pub(crate) fn is_tile_reply(header: &MsgHeader) -> bool {
    header.addr.interf == InterfaceCode::MAP
        && header.msg_type == MsgType::RespAck as u8
        && header.subtype == MapReq::GET_DATA
}

/// The body a map GET_DATA ACK has on the wire: the XDR body `raw` (a `player_map_data_t`
/// with raw cells) with its cells replaced by their zlib stream (`compress()`, level 6) and
/// `data_count` set to the stream's length, as upstream's `PlayerTCP::WriteClient` sends it.
/// `None` when `raw` is not such a body (it is then sent unchanged).
pub(crate) fn tcp_body(raw: &[u8]) -> Option<Vec<u8>> {
    let mut r = player_proto::xdr::Reader::new(raw);
    let tile = MapTile::decode(&mut r).ok()?;
    if !r.is_empty() {
        return None;
    }
    let wire = tile.zipped();
    let mut out = Vec::with_capacity(raw.len().min(64 + wire.data.len()));
    wire.encode(&mut out).ok()?;
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(px: f64, py: f64) -> Pose2d {
        Pose2d { px, py, pa: 0.0 }
    }

    /// 3 × 2: row 0 = [-1, 0, 1], row 1 = [1, 1, -1].
    fn small() -> OccupancyGrid {
        OccupancyGrid::from_cells(3, 2, 0.5, pose(-1.0, -2.0), vec![-1, 0, 1, 1, 1, -1]).unwrap()
    }

    fn ack_tile(reply: Reply) -> MapTile {
        match reply {
            Reply::Ack(Some(Body::Map(MapMsg::Req(MapReq::GetData(Some(t)))))) => t,
            other => panic!("not a tile ACK: {other:?}"),
        }
    }

    fn get_data(col: u32, row: u32, width: u32, height: u32) -> Body {
        Body::from(MapReq::GetData(Some(MapTile {
            col,
            row,
            width,
            height,
            data: Vec::new(),
        })))
    }

    #[test]
    fn grid_indexing_is_row_major_from_the_lowest_row() {
        let mut g = small();
        assert_eq!(g.index(2, 1), Some(5));
        assert_eq!(g.get(0, 0), Some(-1));
        assert_eq!(g.get(2, 0), Some(1));
        assert_eq!(g.get(0, 1), Some(1));
        assert_eq!(g.get(3, 0), None);
        assert_eq!(g.get(-1, 0), None);
        assert_eq!(g.get(0, 2), None);
        assert!(g.set(1, 1, 0));
        assert!(!g.set(1, 2, 0));
        assert_eq!(g.cells(), [-1, 0, 1, 1, 0, -1]);
        assert!(OccupancyGrid::from_cells(3, 2, 0.5, pose(0.0, 0.0), vec![0; 5]).is_none());
        assert!(OccupancyGrid::new(u32::MAX, u32::MAX, 1.0, pose(0.0, 0.0), 0).is_none());
        let info = g.info();
        assert_eq!((info.width, info.height, info.scale), (3, 2, 0.5));
        assert_eq!((info.origin.px, info.origin.py), (-1.0, -2.0));
    }

    #[test]
    fn get_info_answers_the_metadata() {
        let reply = answer(&small(), &Body::from(MapReq::GetInfo(None)));
        assert_eq!(reply, Reply::ack(MapReq::GetInfo(Some(small().info()))));
    }

    #[test]
    fn tiles_repeat_the_request_and_fill_off_map_cells_with_unknown() {
        let g = small();
        // The whole map.
        let t = ack_tile(answer(&g, &get_data(0, 0, 3, 2)));
        assert_eq!((t.col, t.row, t.width, t.height), (0, 0, 3, 2));
        assert_eq!(t.data, g.cells());
        // An inner tile.
        let t = ack_tile(answer(&g, &get_data(1, 1, 2, 1)));
        assert_eq!(t.data, [1, -1]);
        // An edge tile running off the right and top: the request is repeated, the missing
        // cells are 0.
        let t = ack_tile(answer(&g, &get_data(2, 1, 3, 2)));
        assert_eq!((t.col, t.row, t.width, t.height), (2, 1, 3, 2));
        assert_eq!(t.data, [-1, 0, 0, 0, 0, 0]);
        // Entirely off the map.
        let t = ack_tile(answer(&g, &get_data(10, 10, 2, 2)));
        assert_eq!(t.data, [0; 4]);
        // Far off, where col + width overflows 32 bits.
        let t = ack_tile(answer(&g, &get_data(u32::MAX, 0, 2, 1)));
        assert_eq!(t.data, [0; 2]);
        // Empty tiles are answered with no cells.
        let t = ack_tile(answer(&g, &get_data(0, 0, 0, 5)));
        assert!(t.data.is_empty());
    }

    #[test]
    fn oversized_tiles_and_other_requests_are_refused() {
        let g = small();
        assert_eq!(answer(&g, &get_data(0, 0, 100_000, 100_000)), Reply::Nack);
        assert_eq!(answer(&g, &get_data(0, 0, u32::MAX, u32::MAX)), Reply::Nack);
        assert_eq!(
            answer(&g, &Body::from(MapReq::GetData(None))),
            Reply::NotHandled
        );
        assert_eq!(
            answer(&g, &Body::from(MapReq::GetVector(None))),
            Reply::NotHandled
        );
        let other = Body::from(player_proto::Position2dReq::GetGeom(None));
        assert_eq!(answer(&g, &other), Reply::NotHandled);
    }

    #[test]
    fn a_map_fetched_tile_by_tile_is_the_map() {
        let mut g = OccupancyGrid::new(700, 650, 0.1, pose(0.0, 0.0), 0).unwrap();
        for (k, c) in g.cells_mut().iter_mut().enumerate() {
            *c = (k % 3) as i8 - 1;
        }
        let mut copy = OccupancyGrid::new(700, 650, 0.1, pose(0.0, 0.0), 0).unwrap();
        for t in g.info().tile_requests() {
            let (col, row, width, height) = (t.col, t.row, t.width, t.height);
            let cells = ack_tile(answer(&g, &Body::from(MapReq::GetData(Some(t))))).data;
            assert!(copy.put_tile(col, row, width, height, &cells));
        }
        assert_eq!(copy, g);
        assert!(!copy.put_tile(0, 0, 2, 2, &[0; 3]));
    }

    #[test]
    fn tcp_body_is_the_golden_zlib_reply() {
        // player-protocol.md §6.14 / conformance map.RESP_ACK.GET_DATA.raw and .zlib: the raw
        // reply a driver makes and what an upstream server puts on the wire for it.
        let raw = hex("000000020000000100000003000000020000000600000006ffff000101ff0000");
        let wire =
            hex("000000020000000100000003000000020000000e0000000e789cfbff9f8191f13f000bff03000000");
        assert_eq!(tcp_body(&raw).unwrap(), wire);
        // Not a tile body: left alone.
        assert_eq!(tcp_body(&raw[..8]), None);
    }

    #[test]
    fn only_map_get_data_acks_are_tile_replies() {
        use player_proto::DeviceAddr;
        let addr = |interf| DeviceAddr::new(0, 6665, interf, 0);
        let h = |interf, kind, sub| MsgHeader::new(addr(interf), kind, sub, 0.0);
        assert!(is_tile_reply(&h(InterfaceCode::MAP, MsgType::RespAck, 2)));
        assert!(!is_tile_reply(&h(InterfaceCode::MAP, MsgType::RespAck, 1)));
        assert!(!is_tile_reply(&h(InterfaceCode::MAP, MsgType::Req, 2)));
        assert!(!is_tile_reply(&h(InterfaceCode::MAP, MsgType::RespNack, 2)));
        assert!(!is_tile_reply(&h(
            InterfaceCode::LASER,
            MsgType::RespAck,
            2
        )));
    }

    #[test]
    fn tile_replies_are_compressed_on_their_way_to_a_client() {
        use crate::queue::Outgoing;
        use player_proto::{DecodeLimits, DeviceAddr, Frame, HEADER_SIZE, Message};
        let addr = DeviceAddr::new(0, 6665, InterfaceCode::MAP, 0);
        let cells: Vec<i8> = (0..4000)
            .map(|k| (k % 5 == 0) as i8 - (k % 7 == 0) as i8)
            .collect();
        let tile = MapTile {
            col: 3,
            row: 4,
            width: 80,
            height: 50,
            data: cells.clone(),
        };
        let msg = Message::new(addr, 1.5, MapMsg::Ack(MapReq::GetData(Some(tile))));
        let by_frame = Outgoing::from_frame(&Frame::try_from(&msg).unwrap());
        let by_message = Outgoing::from_message(&msg).unwrap();
        assert_eq!(by_frame, by_message);
        let header =
            MsgHeader::from_bytes(by_frame.bytes[..HEADER_SIZE].try_into().unwrap()).unwrap();
        assert_eq!(header.size as usize, by_frame.bytes.len() - HEADER_SIZE);
        let frame = Frame::new(header, by_frame.bytes[HEADER_SIZE..].to_vec()).unwrap();
        let Body::Map(MapMsg::Ack(MapReq::GetData(Some(wire)))) =
            frame.decode(&DecodeLimits::default()).unwrap().body
        else {
            panic!("not a tile reply");
        };
        assert_eq!(
            (wire.col, wire.row, wire.width, wire.height),
            (3, 4, 80, 50)
        );
        assert!(wire.data.len() < 400, "{} bytes", wire.data.len());
        assert_eq!(wire.unzipped().unwrap().data, cells);
        // Other map replies are sent as they are.
        let info = Message::new(
            addr,
            1.5,
            MapMsg::Ack(MapReq::GetInfo(Some(small().info()))),
        );
        assert_eq!(
            Outgoing::from_message(&info).unwrap().bytes,
            info.encode().unwrap()
        );
    }

    fn hex(s: &str) -> Vec<u8> {
        (0..s.len())
            .step_by(2)
            .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
            .collect()
    }
}
