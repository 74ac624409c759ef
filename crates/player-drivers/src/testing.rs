//! Unit-test support: drives one driver by hand, as the server's core would, with tickets and
//! request tokens that keep counting across calls, and shows what each call asked for.

use player_proto::constants::LOCALHOST_ADDR;
use player_proto::{Body, DeviceAddr, InterfaceCode, Message, Pose2d};
use player_server::{
    Action, Context, Driver, DriverBlock, PendingReply, Publication, Reply, RequestError,
    RequestTicket,
};

/// A device address on the test port.
pub(crate) fn addr(interf: InterfaceCode, index: u16) -> DeviceAddr {
    DeviceAddr::new(LOCALHOST_ADDR, 6665, interf, index)
}

/// A Player 2D pose: x and y (m), heading (rad).
pub(crate) fn pose(px: f64, py: f64, pa: f64) -> Pose2d {
    Pose2d { px, py, pa }
}

/// A block named `name` providing and requiring these devices, with `options` (a value with
/// spaces is a tuple of the words between them).
pub(crate) fn block(
    name: &str,
    provides: &[DeviceAddr],
    requires: &[DeviceAddr],
    options: &[(&str, &str)],
) -> DriverBlock {
    let block = DriverBlock::new(name, "test.cfg:1")
        .providing(provides.iter().copied(), "test.cfg:2")
        .requiring(requires.iter().map(|&addr| (None, addr)), "test.cfg:3");
    options.iter().fold(block, |block, (key, values)| {
        block.with_option(key, values.split(' '))
    })
}

/// What one call produced.
#[derive(Debug, Default)]
pub(crate) struct Outcome {
    pub actions: Vec<Action>,
    pub published: Vec<Publication>,
}

impl Outcome {
    /// The requests sent, in order.
    pub fn requests(&self) -> Vec<(RequestTicket, DeviceAddr, Body)> {
        self.actions
            .iter()
            .filter_map(|a| match a {
                Action::Request(t, addr, body) => Some((*t, *addr, body.clone())),
                _ => None,
            })
            .collect()
    }

    /// The deferred requests answered, in order.
    pub fn answers(&self) -> Vec<(PendingReply, Reply)> {
        self.actions
            .iter()
            .filter_map(|a| match a {
                Action::Answer(p, r) => Some((*p, r.clone())),
                _ => None,
            })
            .collect()
    }

    /// The devices subscribed to, in order.
    pub fn subscriptions(&self) -> Vec<DeviceAddr> {
        self.actions
            .iter()
            .filter_map(|a| match a {
                Action::Subscribe(addr) => Some(*addr),
                _ => None,
            })
            .collect()
    }

    /// The published bodies, in order.
    pub fn bodies(&self) -> Vec<Body> {
        self.published.iter().map(|p| p.body.clone()).collect()
    }
}

/// One driver and the counters the core would keep for it.
pub(crate) struct Harness<D: Driver> {
    pub driver: D,
    next_ticket: u64,
    next_token: u64,
    pub now: f64,
}

impl<D: Driver> Harness<D> {
    pub fn new(driver: D) -> Harness<D> {
        Harness {
            driver,
            next_ticket: 1,
            next_token: 1000,
            now: 1.0,
        }
    }

    fn call<R>(
        &mut self,
        request: Option<PendingReply>,
        f: impl FnOnce(&mut D, &mut Context<'_>) -> R,
    ) -> (R, Outcome) {
        let mut published = Vec::new();
        let (r, actions) = {
            let mut ctx = Context::new(self.now, None, &mut published)
                .with_request(self.next_ticket, request);
            let r = f(&mut self.driver, &mut ctx);
            (r, ctx.actions().to_vec())
        };
        let sent = actions
            .iter()
            .filter(|a| matches!(a, Action::Request(..)))
            .count();
        self.next_ticket += sent as u64;
        (r, Outcome { actions, published })
    }

    pub fn setup(&mut self) -> Outcome {
        let (r, out) = self.call(None, |d, ctx| d.setup(ctx));
        r.expect("setup");
        out
    }

    /// A client's request to `to`; the reply, the token it was given, and what it caused.
    pub fn request(
        &mut self,
        to: DeviceAddr,
        body: impl Into<Body>,
    ) -> (Reply, PendingReply, Outcome) {
        let token = PendingReply(self.next_token);
        self.next_token += 1;
        let msg = Message::new(to, self.now, body);
        let (reply, out) = self.call(Some(token), |d, ctx| d.handle_request(ctx, &msg));
        (reply, token, out)
    }

    /// The ACK of request `ticket`, from `from`, carrying `body`.
    pub fn ack(
        &mut self,
        ticket: RequestTicket,
        from: DeviceAddr,
        body: impl Into<Body>,
    ) -> Outcome {
        let msg = Message::new(from, self.now, body);
        self.call(None, |d, ctx| d.handle_reply(ctx, ticket, Ok(msg)))
            .1
    }

    /// A NACK of request `ticket`.
    pub fn nack(&mut self, ticket: RequestTicket) -> Outcome {
        self.call(None, |d, ctx| {
            d.handle_reply(ctx, ticket, Err(RequestError::Nack))
        })
        .1
    }

    /// DATA from `from`, stamped `at`.
    pub fn data(&mut self, from: DeviceAddr, body: impl Into<Body>, at: f64) -> Outcome {
        let msg = Message::new(from, at, body);
        self.call(None, |d, ctx| d.handle_data(ctx, &msg)).1
    }

    /// A command to `to`.
    pub fn command(&mut self, to: DeviceAddr, body: impl Into<Body>) -> Outcome {
        let msg = Message::new(to, self.now, body);
        self.call(None, |d, ctx| d.handle_command(ctx, &msg)).1
    }

    /// One scheduled step of the driver.
    pub fn update(&mut self) -> Outcome {
        self.call(None, |d, ctx| d.update(ctx)).1
    }

    /// The driver's wake-up.
    pub fn wake(&mut self) -> Outcome {
        self.call(None, |d, ctx| d.wake(ctx)).1
    }
}
