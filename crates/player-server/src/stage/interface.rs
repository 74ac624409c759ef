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

use player_proto::{Bbox3d, Body, DeviceAddr, InterfaceCode, Pose3d};
use stage_sim::{ModelId, World};
use worldfile::WorldSpec;

use super::binding::StageBinding;
use super::graphics::SharedDrawings;
use super::{pose3d, size_bbox};
use crate::driver::{ClientId, Context, Reply};

/// Everything the `stage` driver does for one Player interface: which interface it is, what a
/// device of it binds to, and how it publishes data, answers requests, takes commands and
/// forgets a client that unsubscribed. Only [`Interface::code`] and [`Interface::binding`]
/// must be written; each other method's default is "nothing": no data, every request left to
/// the server's NACK (as Stage does for requests it does not know), every command ignored.
///
/// Subscriptions are the driver's, the same for every interface: the first subscription to a
/// device starts its bound model updating and the last unsubscription stops it.
pub(crate) trait Interface: fmt::Debug + Send {
    /// The Player interface this serves.
    fn code(&self) -> InterfaceCode;

    /// What a device of this interface binds to (player-cfg.md §8.3, §8.5): the rule both the
    /// driver and `player --check` use.
    fn binding(&self) -> StageBinding;

    /// Simulated time (µs) of the bound model's newest sample: the driver publishes (with
    /// [`Interface::publish`]) each time it grows. `None`: nothing to publish.
    fn sample_time(&self, world: &World, model: ModelId) -> Option<u64> {
        let _ = (world, model);
        None
    }

    /// Publishes the bound model's newest sample (called once per new sample time, only while
    /// the device is subscribed).
    fn publish(&mut self, b: &Bound<'_, &World>, out: &mut Out<'_, '_>) {
        let _ = (b, out);
    }

    /// Answers a request to a device bound to a model.
    fn request(&mut self, b: &mut Writing<'_>, body: &Body) -> Reply {
        let _ = (b, body);
        Reply::NotHandled
    }

    /// Answers a request to a device bound to the world itself ([`StageBinding::World`]).
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

    /// A client unsubscribed from this device (bound to `model`): forget what it left.
    fn client_unsubscribed(&mut self, drawings: &SharedDrawings, model: ModelId, client: ClientId) {
        let _ = (drawings, model, client);
    }
}

/// Declares the driver's list of interfaces: one `Variant(module::Type)` line per interface,
/// each type implementing [`Interface`] and `Default`. It makes the `Served` enum (a device's
/// interface and state) and everything that needs every interface from the list, so nothing
/// else names them: `Served::new` finds the interface of a Player interface code,
/// `Served::all` lists them, `Served::interface` and `Served::interface_mut` reach the one a
/// device is.
macro_rules! interfaces {
    ($($variant:ident($interface:ty),)+) => {
        /// A device's interface, with its own state.
        #[derive(Debug)]
        enum Served {
            $(
                #[doc = concat!("`", stringify!($interface), "`")]
                $variant($interface),
            )+
        }

        impl Served {
            /// Every interface the driver serves, each as a new device would have it.
            fn all() -> Vec<Served> {
                vec![$(Served::$variant(<$interface>::default()),)+]
            }

            /// A new device of the Player interface `code`, or `None` when the driver does
            /// not serve it.
            fn new(code: InterfaceCode) -> Option<Served> {
                Served::all()
                    .into_iter()
                    .find(|s| s.interface().code() == code)
            }

            fn interface(&self) -> &dyn Interface {
                match self {
                    $(Served::$variant(i) => i,)+
                }
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

    /// The model's size `[x y z]`.
    pub fn size(&self) -> [f64; 3] {
        self.world.node(self.model).size
    }

    /// The model's size as Player's bounding box: Stage's `[x y z]` is length, width, height.
    pub fn bbox(&self) -> Bbox3d {
        size_bbox(self.size())
    }

    /// The model's pose in its parent's frame as a Player 3D pose (roll = pitch = 0).
    pub fn local_pose3d(&self) -> Pose3d {
        pose3d(&self.world.pose(self.model))
    }
}

/// Who sent a command, and the drawings a graphics command adds to.
pub(crate) struct Sender<'a> {
    /// The client, when the command came from one.
    pub client: Option<ClientId>,
    /// What clients drew through `graphics2d`/`graphics3d`.
    pub drawings: &'a SharedDrawings,
}

/// A publication: DATA bodies stamped with the sample's simulated time.
pub(crate) struct Out<'a, 'c> {
    pub(super) ctx: &'a mut Context<'c>,
    pub(super) addr: DeviceAddr,
    pub(super) stamp: f64,
}

impl Out<'_, '_> {
    /// Publishes one DATA body.
    pub fn publish(&mut self, body: impl Into<Body>) {
        self.ctx.publish_at(self.addr, body, self.stamp);
    }
}
