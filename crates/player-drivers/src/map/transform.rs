//! The driver behind `mapscale` and `mapcspace` (Player's `MapTransform` base class): it
//! requires a `map` device and provides one, holding the required map transformed.
//!
//! On its first subscriber it asks the required map for GET_INFO and then every tile (in
//! libplayerc's order, [`MapInfo::tile_requests`](player_proto::MapInfo::tile_requests)),
//! assembles the grid and transforms it; as upstream, on each setup, so a source that changed
//! between runs is read again. Requests that arrive before the map is ready wait (deferred) and
//! are answered once it is, or NACKed if the source cannot be read; upstream does the fetching
//! inside `Setup` instead, which keeps the subscribing client waiting and the whole server with
//! it.

use player_proto::{Body, DeviceAddr, InterfaceCode, MapMsg, Message};
use player_server::map::{self, OccupancyGrid};
use player_server::{
    Context, Driver, DriverBlock, DriverError, DriverRegistry, PendingReply, Reply, RequestError,
    RequestTicket,
};

use super::fetch::{Fetched, MapFetch};
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
    /// Reading the source map.
    Fetching(MapFetch),
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
        let addr = block.provided(InterfaceCode::MAP)?;
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

    /// The source map is read: transformed, it answers the requests that waited.
    fn finish(&mut self, ctx: &mut Context<'_>, grid: &OccupancyGrid) {
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
        self.state = State::Fetching(MapFetch::start(ctx, self.source));
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
            State::Fetching(_) => match ctx.defer() {
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
        // Answers for an earlier setup, or after a failure: nothing waits for them.
        let State::Fetching(fetch) = &mut self.state else {
            return;
        };
        match fetch.on_reply(ctx, ticket, reply) {
            Fetched::NotMine(_) | Fetched::Pending => {}
            Fetched::Done(grid) => self.finish(ctx, &grid),
            Fetched::Failed(why) => self.fail(ctx, why),
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
