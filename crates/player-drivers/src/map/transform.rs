//! The driver behind `mapscale` and `mapcspace` (Player's `MapTransform` base class): it
//! requires a `map` device and provides one, holding the required map transformed.
//!
//! On its first subscriber it asks the required map for GET_INFO and then every tile (in
//! libplayerc's order, [`MapInfo::tile_requests`]), assembles the grid and transforms it; as
//! upstream, on each setup, so a source that changed between runs is read again. Requests that
//! arrive before the map is ready wait (deferred) and are answered once it is, or NACKed if the
//! source cannot be read; upstream does the fetching inside `Setup` instead, which keeps the
//! subscribing client waiting and the whole server with it.

use player_proto::{Body, DeviceAddr, InterfaceCode, MapInfo, MapMsg, MapReq, Message};
use player_server::map::{self, OccupancyGrid};
use player_server::{
    Context, Driver, DriverBlock, DriverError, DriverRegistry, PendingReply, Reply, RequestError,
    RequestTicket,
};

use super::mapcspace::{self, CspaceOptions};
use super::mapscale::{self, ScaleOptions};
use crate::error::Error;

/// What is done to the source map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Transform {
    /// `mapscale`: resampled to another resolution.
    Scale(ScaleOptions),
    /// `mapcspace`: obstacles grown by the robot's radius.
    Cspace(CspaceOptions),
}

impl Transform {
    fn apply(&self, source: &OccupancyGrid) -> Result<OccupancyGrid, Error> {
        match self {
            Transform::Scale(o) => o.transform(source),
            Transform::Cspace(o) => Ok(o.transform(source)),
        }
    }
}

/// Where the fetch of the source map stands.
#[derive(Debug)]
enum State {
    /// Not set up.
    Idle,
    /// Waiting for GET_INFO.
    Info(RequestTicket),
    /// Tiles asked for, the grid filling up.
    Tiles {
        grid: OccupancyGrid,
        waiting: Vec<RequestTicket>,
    },
    /// The transformed map.
    Ready(OccupancyGrid),
    /// The source could not be read (logged); requests are NACKed until the next setup.
    Failed,
}

/// The driver.
#[derive(Debug)]
pub struct MapTransform {
    name: &'static str,
    addr: DeviceAddr,
    source: DeviceAddr,
    transform: Transform,
    state: State,
    /// Requests that came before the map was ready.
    queued: Vec<(PendingReply, Body)>,
}

impl MapTransform {
    /// Builds the driver named `name` from its cfg block.
    pub fn from_block(
        name: &'static str,
        block: &DriverBlock,
        transform: Transform,
    ) -> Result<MapTransform, DriverError> {
        let addr = block
            .provides
            .iter()
            .find(|p| p.addr.interf == InterfaceCode::MAP)
            .ok_or_else(|| DriverError::new("must provide a map device"))?
            .addr;
        let source = block.required(InterfaceCode::MAP, None)?.addr;
        if source.same_device(&addr) {
            return Err(DriverError::new("requires the map it provides"));
        }
        Ok(MapTransform {
            name,
            addr,
            source,
            transform,
            state: State::Idle,
            queued: Vec::new(),
        })
    }

    /// Answers the queued requests from the current state.
    fn release(&mut self, ctx: &mut Context<'_>) {
        for (pending, body) in std::mem::take(&mut self.queued) {
            let reply = match &self.state {
                State::Ready(grid) => map::answer(grid, &body),
                _ => Reply::Nack,
            };
            ctx.answer(pending, reply);
        }
    }

    fn fail(&mut self, ctx: &mut Context<'_>, why: impl std::fmt::Display) {
        tracing::error!(
            "{}: cannot read map {}: {why}; requests to {} are refused",
            self.name,
            self.source,
            self.addr
        );
        self.state = State::Failed;
        self.release(ctx);
    }

    fn got_info(&mut self, ctx: &mut Context<'_>, info: MapInfo) {
        let Some(grid) = OccupancyGrid::new(info.width, info.height, info.scale, info.origin, 0)
        else {
            return self.fail(
                ctx,
                format!("a {} x {} map is too large", info.width, info.height),
            );
        };
        let waiting: Vec<RequestTicket> = info
            .tile_requests()
            .map(|tile| ctx.request(self.source, MapReq::GetData(Some(tile))))
            .collect();
        self.state = State::Tiles { grid, waiting };
        // A map of no cells has no tiles: it is complete already.
        self.finish_if_complete(ctx);
    }

    fn finish_if_complete(&mut self, ctx: &mut Context<'_>) {
        let State::Tiles { grid, waiting } = &self.state else {
            return;
        };
        if !waiting.is_empty() {
            return;
        }
        match self.transform.apply(grid) {
            Ok(out) => {
                tracing::debug!(
                    "{}: map {} ready ({} x {} at {} m)",
                    self.name,
                    self.addr,
                    out.width(),
                    out.height(),
                    out.scale()
                );
                self.state = State::Ready(out);
                self.release(ctx);
            }
            Err(e) => self.fail(ctx, e),
        }
    }
}

impl Driver for MapTransform {
    fn setup(&mut self, ctx: &mut Context<'_>) -> Result<(), DriverError> {
        // Subscribed, as upstream: a source that is itself a transform sets up only then.
        ctx.subscribe(self.source);
        self.state = State::Info(ctx.request(self.source, MapReq::GetInfo(None)));
        Ok(())
    }

    fn teardown(&mut self, ctx: &mut Context<'_>) {
        self.state = State::Idle;
        self.release(ctx);
    }

    fn handle_request(&mut self, ctx: &mut Context<'_>, request: &Message) -> Reply {
        if !matches!(request.body, Body::Map(MapMsg::Req(_))) {
            return Reply::NotHandled;
        }
        match &self.state {
            State::Ready(grid) => map::answer(grid, &request.body),
            State::Info(_) | State::Tiles { .. } => match ctx.defer() {
                Some(pending) => {
                    self.queued.push((pending, request.body.clone()));
                    Reply::Deferred
                }
                None => Reply::Nack,
            },
            State::Idle | State::Failed => Reply::Nack,
        }
    }

    fn handle_reply(
        &mut self,
        ctx: &mut Context<'_>,
        ticket: RequestTicket,
        reply: Result<Message, RequestError>,
    ) {
        match (&mut self.state, reply) {
            (State::Info(t), Ok(msg)) if *t == ticket => match msg.body {
                Body::Map(MapMsg::Ack(MapReq::GetInfo(Some(info)))) => self.got_info(ctx, info),
                other => self.fail(ctx, format!("GET_INFO answered with {}", other.constant())),
            },
            (State::Info(t), Err(e)) if *t == ticket => self.fail(ctx, e),
            (State::Tiles { grid, waiting }, reply) => {
                let Some(k) = waiting.iter().position(|&w| w == ticket) else {
                    return;
                };
                waiting.swap_remove(k);
                match reply {
                    Ok(Message {
                        body: Body::Map(MapMsg::Ack(MapReq::GetData(Some(tile)))),
                        ..
                    }) if grid.put_tile(
                        tile.col,
                        tile.row,
                        tile.width,
                        tile.height,
                        &tile.data,
                    ) =>
                    {
                        self.finish_if_complete(ctx);
                    }
                    Ok(msg) => self.fail(
                        ctx,
                        format!("GET_DATA answered with an unusable {}", msg.body.constant()),
                    ),
                    Err(e) => self.fail(ctx, e),
                }
            }
            // Answers for an earlier setup, or after a failure: nothing waits for them.
            _ => {}
        }
    }
}

/// Registers `mapscale` and `mapcspace`.
pub fn register(registry: &mut DriverRegistry) {
    registry.register(mapscale::NAME, |block: &DriverBlock| {
        let t = Transform::Scale(ScaleOptions::from_block(block)?);
        Ok(Box::new(MapTransform::from_block(mapscale::NAME, block, t)?) as Box<dyn Driver>)
    });
    registry.register(mapcspace::NAME, |block: &DriverBlock| {
        let t = Transform::Cspace(CspaceOptions::from_block(block)?);
        Ok(Box::new(MapTransform::from_block(mapcspace::NAME, block, t)?) as Box<dyn Driver>)
    });
}
