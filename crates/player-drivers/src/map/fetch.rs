//! Reading a whole map from a map device, as libplayerc's `playerc_map_get_map` does: GET_INFO,
//! then one GET_DATA per tile ([`MapInfo::tile_requests`]), the cells put into a grid. Drivers
//! that need another device's map (`mapscale`, `mapcspace`, `wavefront`) keep one [`MapFetch`]
//! and hand it every reply; it says when the grid is complete or why it cannot be.

use player_proto::{DeviceAddr, MapInfo, MapReq, Message};
use player_server::map::OccupancyGrid;
use player_server::{Context, RequestError, RequestTicket};

/// A map being read from one device.
#[derive(Debug)]
pub(crate) enum MapFetch {
    /// Waiting for GET_INFO.
    Info(DeviceAddr, RequestTicket),
    /// Tiles asked for, the grid filling up (taken when complete).
    Tiles {
        grid: Option<OccupancyGrid>,
        waiting: Vec<RequestTicket>,
    },
}

/// What a reply did to a [`MapFetch`].
#[derive(Debug)]
pub(crate) enum Fetched {
    /// The reply was not for the fetch: handed back.
    NotMine(Result<Message, RequestError>),
    /// Taken; more tiles are still to come.
    Pending,
    /// The map is complete.
    Done(OccupancyGrid),
    /// The map cannot be read: why.
    Failed(String),
}

impl MapFetch {
    /// Asks `device` for its map's size and place (GET_INFO).
    pub(crate) fn start(ctx: &mut Context<'_>, device: DeviceAddr) -> MapFetch {
        MapFetch::Info(device, ctx.request(device, MapReq::GetInfo(None)))
    }

    /// Takes the reply to `ticket`: the info asks for the tiles, each tile fills the grid.
    /// After [`Fetched::Done`] or [`Fetched::Failed`] the fetch is over and should be dropped.
    pub(crate) fn on_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) -> Fetched {
        match self {
            MapFetch::Info(device, t) if *t == ticket => match reply {
                Ok(msg) => match MapReq::in_reply(&msg.body) {
                    Some(MapReq::GetInfo(Some(info))) => {
                        let device = *device;
                        self.ask_tiles(ctx, device, info)
                    }
                    _ => Fetched::Failed(format!("GET_INFO answered with {}", msg.body.constant())),
                },
                Err(e) => Fetched::Failed(e.to_string()),
            },
            MapFetch::Tiles { grid, waiting, .. } => {
                let Some(k) = waiting.iter().position(|&w| w == ticket) else {
                    return Fetched::NotMine(reply);
                };
                waiting.swap_remove(k);
                let Some(grid) = grid.as_mut() else {
                    return Fetched::Pending;
                };
                let msg = match reply {
                    Ok(msg) => msg,
                    Err(e) => return Fetched::Failed(e.to_string()),
                };
                match MapReq::in_reply(&msg.body) {
                    Some(MapReq::GetData(Some(tile)))
                        if grid.put_tile(
                            tile.col,
                            tile.row,
                            tile.width,
                            tile.height,
                            &tile.data,
                        ) =>
                    {
                        self.done_if_complete()
                    }
                    _ => Fetched::Failed(format!(
                        "GET_DATA answered with an unusable {}",
                        msg.body.constant()
                    )),
                }
            }
            MapFetch::Info(..) => Fetched::NotMine(reply),
        }
    }

    fn ask_tiles(&mut self, ctx: &mut Context<'_>, device: DeviceAddr, info: &MapInfo) -> Fetched {
        let Some(grid) = OccupancyGrid::new(info.width, info.height, info.scale, info.origin, 0)
        else {
            return Fetched::Failed(format!(
                "a {} x {} map is too large",
                info.width, info.height
            ));
        };
        let waiting = info
            .tile_requests()
            .map(|tile| ctx.request(device, MapReq::GetData(Some(tile))))
            .collect();
        *self = MapFetch::Tiles {
            grid: Some(grid),
            waiting,
        };
        // A map of no cells has no tiles: it is complete already.
        self.done_if_complete()
    }

    fn done_if_complete(&mut self) -> Fetched {
        match self {
            MapFetch::Tiles { grid, waiting } if waiting.is_empty() => {
                grid.take().map_or(Fetched::Pending, Fetched::Done)
            }
            _ => Fetched::Pending,
        }
    }
}
