//! What one interface of the `stage` driver is: the [`Interface`] trait each interface module
//! implements, the values its methods are handed ([`Bound`], [`Out`], [`Sender`]), and the
//! [`interfaces!`] macro that turns the driver's one list of interfaces (in `stage/mod.rs`)
//! into the `Served` enum every dispatch goes through.
//!
//! A device's interface value is also its own state (a `laser` device's scan configuration, a
//! `map` device's grid): the driver makes one per device, with `Default`, when it binds it.

use std::fmt;
use std::ops::Deref;
use std::sync::RwLockWriteGuard;

use player_proto::{Bbox3d, Body, DeviceAddr, Pose3d};
use stage_sim::{ModelId, Pose, World};
use worldfile::WorldSpec;

use super::graphics::{DrawingKey, SharedDrawings};
use super::{pose3d, size_bbox};
use crate::driver::{ClientId, Context, Reply};

/// What the `stage` driver does for one Player interface: how a device of it publishes data,
/// answers requests, takes commands and forgets a client that unsubscribed. Each method's
/// default is "nothing": no data, every request left to the server's NACK (as Stage does for
/// requests it does not know), every command ignored. Which Player interface it serves and
/// what a device of it binds to are its line in the driver's list (`stage/mod.rs`).
///
/// Subscriptions are the driver's, the same for every interface: the first subscription to a
/// device starts its bound model updating and the last unsubscription stops it.
pub(crate) trait Interface: fmt::Debug + Send {
    /// Publishes the bound model's sample once, when it is new (and again on the first update
    /// after a subscription): the implementation takes it through [`Out::new_sample`] before
    /// publishing. Called every driver update while the device is subscribed; `None` when it
    /// published nothing.
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) -> Option<()> {
        let _ = (b, out);
        None
    }

    /// Answers a request to a device bound to a model.
    fn request(&mut self, b: &mut Writing<'_>, body: &Body) -> Reply {
        let _ = (b, body);
        Reply::NotHandled
    }

    /// Answers a request to a device bound to the world itself
    /// ([`StageBinding::World`](super::StageBinding::World)).
    fn world_request(&mut self, world: &mut World, body: &Body) -> Reply {
        let _ = (world, body);
        Reply::NotHandled
    }

    /// Takes a command to a device bound to a model; false when it is not one this interface
    /// takes (the driver logs it).
    fn command(&mut self, b: &mut Writing<'_>, sender: &Sender<'_>, body: &Body) -> bool {
        let _ = (b, sender, body);
        false
    }

    /// A client unsubscribed from this device: `left` names the client, the device's model and
    /// its interface. Forget what the client left.
    fn client_unsubscribed(&mut self, drawings: &SharedDrawings, left: DrawingKey) {
        let _ = (drawings, left);
    }
}

/// Declares the driver's list of interfaces, one line each:
/// `Variant(module::Type): PLAYER_CODE, binding rule;`, the type implementing [`Interface`]
/// and `Default`, the code an [`InterfaceCode`](player_proto::InterfaceCode) constant, the
/// rule a [`StageBinding`](super::StageBinding). It makes the `Served` enum (a device's
/// interface, with its state) and everything that needs every interface from the list, so
/// nothing else names them: `Served::new` makes the interface of a Player code,
/// `Served::binding_of` finds its rule, `Served::CODES` lists the codes, and
/// `Served::interface_mut` reaches the interface a device is.
macro_rules! interfaces {
    ($($variant:ident($interface:ty): $code:ident, $binding:expr;)+) => {
        /// A device's interface, with its own state.
        #[derive(Debug)]
        enum Served {
            $(
                #[doc = concat!("`", stringify!($code), "`")]
                $variant($interface),
            )+
        }

        impl Served {
            /// The Player interfaces served, in list order.
            #[cfg(test)]
            const CODES: &[InterfaceCode] = &[$(InterfaceCode::$code,)+];

            /// A new device of the Player interface `code`, or `None` when the driver does
            /// not serve it.
            fn new(code: InterfaceCode) -> Option<Served> {
                $(
                    if code == InterfaceCode::$code {
                        return Some(Served::$variant(<$interface>::default()));
                    }
                )+
                None
            }

            /// What a device of the Player interface `code` binds to, or `None` when the
            /// driver does not serve it.
            fn binding_of(code: InterfaceCode) -> Option<StageBinding> {
                $(
                    if code == InterfaceCode::$code {
                        return Some($binding);
                    }
                )+
                None
            }

            fn interface_mut(&mut self) -> &mut dyn Interface {
                match self {
                    $(Served::$variant(i) => i,)+
                }
            }
        }
    };
}
pub(super) use interfaces;

/// The model a request, command or publication is about, with the world around it.
pub(crate) struct Bound<'a, W> {
    pub world: W,
    pub spec: &'a WorldSpec,
    pub model: ModelId,
}

/// Write access to a bound model.
pub(crate) type Writing<'a> = Bound<'a, RwLockWriteGuard<'a, World>>;

impl<W: Deref<Target = World>> Bound<'_, W> {
    /// The model's resolved worldfile entry (static configuration, as written).
    pub fn model_spec(&self) -> &worldfile::ModelSpec {
        self.spec.model(self.model.index())
    }

    /// The bound model's tree and configuration data.
    pub fn node(&self) -> &stage_sim::node::Node {
        self.world
            .node(self.model)
            .expect("binding checked the model against this world, which never loses one")
    }

    /// The bound model's pose in its parent's frame.
    pub fn pose(&self) -> Pose {
        self.world
            .pose(self.model)
            .expect("binding checked the model against this world, which never loses one")
    }

    /// The bound model's answer to a type-specific world call, or `None` (logged): see
    /// [`super::bound_answer`].
    pub fn answer<T>(&self, answer: stage_sim::Result<T>) -> Option<T> {
        super::bound_answer(self.model, answer)
    }

    /// The model's size `[x y z]`.
    pub fn size(&self) -> [f64; 3] {
        self.node().size
    }

    /// The model's size as Player's bounding box: Stage's `[x y z]` is length, width, height.
    pub fn bbox(&self) -> Bbox3d {
        size_bbox(self.size())
    }

    /// The model's pose in its parent's frame as a Player 3D pose (roll = pitch = 0).
    pub fn local_pose3d(&self) -> Pose3d {
        pose3d(&self.pose())
    }
}

/// Who sent a command, and the drawings a graphics command adds to.
pub(crate) struct Sender<'a> {
    /// The client, when the command came from one.
    pub client: Option<ClientId>,
    /// What clients drew through `graphics2d`/`graphics3d`.
    pub drawings: &'a SharedDrawings,
}

/// Where a device publishes: DATA bodies stamped with the simulated time of the sample they
/// carry.
pub(crate) struct Out<'a, 'c> {
    pub(super) ctx: &'a mut Context<'c>,
    pub(super) addr: DeviceAddr,
    /// Sim time (µs) of the last sample the device published.
    pub(super) published_us: &'a mut u64,
    /// The device was subscribed since its last update: its current sample goes out even when
    /// it is not new, so that the new subscriber has it in its first round (as upstream's
    /// plugin publishes every device's current data), whatever the model's update interval.
    pub(super) resend: bool,
    /// Sim time (s) of the sample being published.
    pub(super) stamp: Option<f64>,
}

impl Out<'_, '_> {
    /// `sample` when it is newer than the last one the device published (`time_us` tells its
    /// simulated time), or, for a device subscribed since its last update, when the model has
    /// made one at all (time above 0): it becomes the one published and stamps the DATA that
    /// follows.
    pub fn new_sample<S>(
        &mut self,
        sample: Option<S>,
        time_us: impl FnOnce(&S) -> u64,
    ) -> Option<S> {
        let sample = sample?;
        let t = time_us(&sample);
        let again = self.resend && t > 0;
        if t <= *self.published_us && !again {
            return None;
        }
        *self.published_us = (*self.published_us).max(t);
        self.stamp = Some(t as f64 * 1e-6);
        Some(sample)
    }

    /// Publishes one DATA body of the sample taken by [`Out::new_sample`].
    pub fn publish(&mut self, body: impl Into<Body>) {
        debug_assert!(
            self.stamp.is_some(),
            "publishing before taking a new sample"
        );
        let stamp = self.stamp.unwrap_or_default();
        self.ctx.publish_at(self.addr, body, stamp);
    }
}
