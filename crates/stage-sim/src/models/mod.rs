//! Per-type model behaviour and the data each type publishes: one module per Stage model type,
//! each owning its description (with `desc_from_spec`, its conversion from the worldfile
//! crate's properties, and its defaults), its state (with `start`, the state on load), and the
//! state's `ModelKind` impl: its update, what its last unsubscription shuts down, its digest.
//! The one `model_kinds!` list below registers the modules (one line a type): it generates
//! [`KindDesc`], the crate's `KindState`, their `match` dispatch (no `dyn`: each step's update
//! is a direct call) and `KindDesc::from_spec`, the mapping from the worldfile crate's
//! [`TypeSpec`].

pub use actuator::ActuatorDesc;
pub use blinkenlight::BlinkenlightDesc;
pub use blobfinder::BlobfinderDesc;
pub use camera::CameraDesc;
pub use fiducial::FiducialDesc;
pub use gripper::GripperDesc;
pub use position::PositionDesc;
pub use ranger::SensorDesc;

use worldfile::models::{ModelType, TypeSpec};
use worldfile::world::ModelSpec;

use crate::block::BlockDesc;
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::view::View;

/// What a model type's module implements for its state: the type's behaviour in the step. The
/// defaults are what most types do (nothing of their own).
pub(crate) trait ModelKind {
    /// The body the type builds itself instead of the worldfile's (the gripper's base and
    /// paddles for a model of `size`); `None` keeps the described blocks.
    fn own_blocks(&self, _size: [f64; 3]) -> Option<Vec<BlockDesc>> {
        None
    }

    /// Whether the model updates once without being subscribed (Stage starts cameras and
    /// blinkenlights itself).
    fn starts_itself(&self) -> bool {
        false
    }

    /// About how many rays one update casts: decides whether a step's updates are worth
    /// spreading over threads.
    fn ray_cost(&self) -> usize {
        0
    }

    /// One update of model `m` against the view of the previous step's end (phase 1); `local`
    /// is its pose in the parent frame, `node` its static data, `rng` its own stream.
    fn update(&mut self, v: &View, m: ModelId, local: &Pose, node: &Node, rng: &mut SimRng);

    /// What the last unsubscription does (position models stop, actuators drop their goal,
    /// sensors clear their data).
    fn shutdown(&mut self) {}

    /// Feeds the type's whole state to the determinism digest ([`crate::World::state_digest`]).
    fn digest(&self, _d: &mut Digest) {}
}

/// A large state kept behind a pointer (so `KindState` stays small) behaves as the state.
impl<K: ModelKind> ModelKind for Box<K> {
    fn own_blocks(&self, size: [f64; 3]) -> Option<Vec<BlockDesc>> {
        (**self).own_blocks(size)
    }

    fn starts_itself(&self) -> bool {
        (**self).starts_itself()
    }

    fn ray_cost(&self) -> usize {
        (**self).ray_cost()
    }

    #[inline]
    fn update(&mut self, v: &View, m: ModelId, local: &Pose, node: &Node, rng: &mut SimRng) {
        (**self).update(v, m, local, node, rng)
    }

    fn shutdown(&mut self) {
        (**self).shutdown()
    }

    fn digest(&self, d: &mut Digest) {
        (**self).digest(d)
    }
}

/// `impl Default` for a description: the module's `desc_from_spec` of the worldfile crate's
/// default properties, so Stage's defaults are written once (in the worldfile property tables).
macro_rules! default_from_spec {
    ($desc:ty) => {
        impl Default for $desc {
            /// Stage's defaults, from the worldfile crate's property table.
            fn default() -> Self {
                desc_from_spec(&Default::default(), &mut $crate::rng::SimRng::new(0, 0))
            }
        }
    };
}

/// Builds [`KindDesc`], `KindState` and their dispatch from the list of type modules.
///
/// A line of `kinds` is `module: Variant => State` for a type without a description of its own
/// (`KindDesc::Variant`), or `module: Variant(Desc) => State` for one with
/// (`KindDesc::Variant(Desc)`). `Variant` is the worldfile crate's `ModelType` and `TypeSpec`
/// variant, `State` the module's type implementing [`ModelKind`] (in a `Box` when it is large).
/// The module provides `start(&Desc, global: &Pose, rng: &mut SimRng) -> State` (`&()` for a
/// type without a description; an unboxed state) and, for a type with a description,
/// `desc_from_spec(&Spec, rng: &mut SimRng) -> Desc` from its `TypeSpec` content.
/// A line of `aliases` is `Variant => convert`: a worldfile type simulated as another kind, by
/// `convert(&spec, rng) -> (KindDesc, why)`, whose `why` becomes a warning naming the model.
macro_rules! model_kinds {
    (
        kinds {
            $( $(#[$doc:meta])* $module:ident : $variant:ident $( ($desc:ty) )? => $state:ty , )*
        }
        aliases {
            $( $alias:ident => $convert:path , )*
        }
    ) => {
        $( pub mod $module; )*

        /// The type of a model and its type-specific configuration.
        #[derive(Clone, Debug, PartialEq)]
        pub enum KindDesc {
            $( $(#[$doc])* $variant $( ($desc) )?, )*
        }

        impl KindDesc {
            /// The worldfile crate's model type (whose table holds the per-type defaults).
            pub fn model_type(&self) -> ModelType {
                match self {
                    $( KindDesc::$variant { .. } => ModelType::$variant, )*
                }
            }

            /// The description of a resolved worldfile model's type; the types simulated as
            /// another kind add a warning naming the model.
            pub(crate) fn from_spec(
                m: &ModelSpec,
                warnings: &mut Vec<String>,
                rng: &mut SimRng,
            ) -> KindDesc {
                match &m.spec {
                    $(
                        variant_of!(TypeSpec, $variant, spec $(, $desc)?) =>
                            desc_of!($variant, $module, spec, rng $(, $desc)?),
                    )*
                    $(
                        TypeSpec::$alias(spec) => {
                            let (kind, why) = $convert(spec, rng);
                            warnings.push(format!("model {}: {why}", m.name));
                            kind
                        }
                    )*
                }
            }
        }

        /// Type-specific mutable state: each variant holds its module's [`ModelKind`].
        #[derive(Clone, Debug)]
        pub(crate) enum KindState {
            $( $variant($state), )*
        }

        impl KindState {
            /// The state a model of this description starts in (its module's `start`); `global`
            /// is its pose at load and `rng` its own stream (position models draw their
            /// odometry error from it, spec §7.7).
            pub(crate) fn new(kind: &KindDesc, global: &Pose, rng: &mut SimRng) -> KindState {
                match kind {
                    $(
                        variant_of!(KindDesc, $variant, desc $(, $desc)?) => KindState::$variant(
                            $module::start(desc_ref!(desc $(, $desc)?), global, rng).into(),
                        ),
                    )*
                }
            }

            /// [`ModelKind::own_blocks`].
            pub(crate) fn own_blocks(&self, size: [f64; 3]) -> Option<Vec<BlockDesc>> {
                match self {
                    $( KindState::$variant(s) => <$state as ModelKind>::own_blocks(s, size), )*
                }
            }

            /// [`ModelKind::starts_itself`].
            pub(crate) fn starts_itself(&self) -> bool {
                match self {
                    $( KindState::$variant(s) => <$state as ModelKind>::starts_itself(s), )*
                }
            }

            /// The type this state simulates (a Stage 3 `laser` runs as a `ranger`).
            pub(crate) fn model_type(&self) -> ModelType {
                match self {
                    $( KindState::$variant(_) => ModelType::$variant, )*
                }
            }

            /// [`ModelKind::ray_cost`].
            pub(crate) fn ray_cost(&self) -> usize {
                match self {
                    $( KindState::$variant(s) => <$state as ModelKind>::ray_cost(s), )*
                }
            }

            /// [`ModelKind::update`].
            #[inline]
            pub(crate) fn update(
                &mut self,
                v: &View,
                m: ModelId,
                local: &Pose,
                node: &Node,
                rng: &mut SimRng,
            ) {
                match self {
                    $(
                        KindState::$variant(s) =>
                            <$state as ModelKind>::update(s, v, m, local, node, rng),
                    )*
                }
            }

            /// [`ModelKind::shutdown`].
            pub(crate) fn shutdown(&mut self) {
                match self {
                    $( KindState::$variant(s) => <$state as ModelKind>::shutdown(s), )*
                }
            }

            /// [`ModelKind::digest`].
            pub(crate) fn digest(&self, d: &mut Digest) {
                match self {
                    $( KindState::$variant(s) => <$state as ModelKind>::digest(s, d), )*
                }
            }
        }
    };
}

/// The pattern of `Enum::Variant`, binding its content to `$bind` when the type has a
/// description.
macro_rules! variant_of {
    ($enum:ident, $variant:ident, $bind:ident) => {
        $enum::$variant
    };
    ($enum:ident, $variant:ident, $bind:ident, $desc:ty) => {
        $enum::$variant($bind)
    };
}

/// A `KindDesc` from the worldfile spec bound to `$spec`, by the module's `desc_from_spec`.
macro_rules! desc_of {
    ($variant:ident, $module:ident, $spec:ident, $rng:ident) => {
        KindDesc::$variant
    };
    ($variant:ident, $module:ident, $spec:ident, $rng:ident, $desc:ty) => {
        KindDesc::$variant($module::desc_from_spec($spec, $rng))
    };
}

/// The description bound to `$bind`, or `&()` for a type without one.
macro_rules! desc_ref {
    ($bind:ident) => {
        &()
    };
    ($bind:ident, $desc:ty) => {
        $bind
    };
}

model_kinds! {
    kinds {
        /// A plain `model` (walls, boxes, pucks, floorplans).
        model: Model => model::Plain,
        /// A mobile base.
        position: Position(PositionDesc) => Box<position::PositionModel>,
        /// A ranger with its transducers (laser-like with one many-sample sensor, sonar-like with
        /// many single-sample ones).
        ranger: Ranger(Vec<SensorDesc>) => ranger::RangerData,
        /// A colour blob finder.
        blobfinder: Blobfinder(BlobfinderDesc) => Box<blobfinder::BlobfinderModel>,
        /// A fiducial finder.
        fiducial: Fiducial(FiducialDesc) => fiducial::FiducialModel,
        /// A paddle gripper.
        gripper: Gripper(GripperDesc) => Box<gripper::GripperModel>,
        /// A colour + depth camera.
        camera: Camera(CameraDesc) => Box<camera::CameraModel>,
        /// An actuator joint.
        actuator: Actuator(ActuatorDesc) => actuator::ActuatorModel,
        /// A blinking light.
        blinkenlight: Blinkenlight(BlinkenlightDesc) => blinkenlight::Blinkenlight,
        /// A light indicator (on/off from the API).
        lightindicator: Lightindicator => lightindicator::Lightindicator,
    }
    aliases {
        Laser => ranger::laser_as_ranger,
        Wifi => model::wifi_as_plain,
    }
}

impl KindDesc {
    /// The Stage type word.
    pub fn type_name(&self) -> &'static str {
        self.model_type().name()
    }
}
