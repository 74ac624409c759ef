//! How a `stage`-driver device finds its Stage model (player-cfg.md §8.3, §8.5), and what the
//! driver made of each device it was given — the record `player --check` reports.
//!
//! Each interface's rule is written on its line of the driver's one list of interfaces
//! (`interfaces!` in `stage/mod.rs`): the same rules build drivers and check cfgs.

use std::collections::HashSet;
use std::fmt;

use player_proto::{DeviceAddr, InterfaceCode};
use serde::Serialize;
use worldfile::models::TypeSpec;
use worldfile::{ModelId, ModelSpec, ModelType, WorldSpec};

use super::Served;

/// What a `stage`-driver device binds to, by interface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StageBinding {
    /// `simulation`: the world itself (the first one creates it).
    World,
    /// The first model of this type not yet bound, in the named model's subtree (pre-order),
    /// preferring one of the given ranger shape when there is a choice.
    Model(ModelType, RangerShape),
    /// The named model itself, not marked as bound (`speech`, `graphics2d`, `graphics3d`,
    /// `map`).
    Named,
}

/// Which rangers a legacy interface prefers: Player 2 clients expect a `laser` on a
/// single-transducer ranger and `sonar` on a ring of transducers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RangerShape {
    /// No preference (also every non-ranger type).
    Any,
    /// Prefer rangers with exactly one transducer (laser-like), else any ranger.
    Single,
    /// Prefer rangers with several transducers (sonar-like), else any ranger.
    Multiple,
}

/// How the stage driver binds a device of `interface`, or `None` for interfaces it does not
/// provide. Stage 4.1.1's own set (§8.5) plus the legacy `laser` and `sonar` (on rangers) and
/// `camera` (on camera models) that Stage 4 dropped and that Player 2 clients still use, and
/// `map` (the named model's blocks as a grid).
pub fn stage_binding(interface: InterfaceCode) -> Option<StageBinding> {
    Served::binding_of(interface)
}

/// Why a stage-driver device could not be served.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindErrorKind {
    /// The interface is not one the stage driver serves.
    UnsupportedInterface,
    /// A `simulation` device in a block without a `worldfile` field.
    NoWorldfileField,
    /// The worldfile does not load (missing file, bitmap, syntax error).
    WorldDoesNotLoad,
    /// A model-bound device before any `simulation` block.
    NoWorldYet,
    /// A model-bound device after the `simulation` device failed: nothing to bind to. A
    /// consequence of that failure, not a problem of its own.
    WorldFailed,
    /// A driver option with a value it cannot take (e.g. `usegui maybe`).
    BadOption,
    /// A model-bound device in a block without a `model` field.
    NoModelField,
    /// The `model` field names no model of the world.
    NoSuchModel,
    /// Every model of the interface's type in the named model's subtree is already bound.
    NoUnboundModel,
}

impl BindErrorKind {
    /// The kebab-case name (as in JSON reports).
    pub fn name(self) -> &'static str {
        match self {
            BindErrorKind::UnsupportedInterface => "unsupported-interface",
            BindErrorKind::NoWorldfileField => "no-worldfile-field",
            BindErrorKind::WorldDoesNotLoad => "world-does-not-load",
            BindErrorKind::NoWorldYet => "no-world-yet",
            BindErrorKind::WorldFailed => "world-failed",
            BindErrorKind::BadOption => "bad-option",
            BindErrorKind::NoModelField => "no-model-field",
            BindErrorKind::NoSuchModel => "no-such-model",
            BindErrorKind::NoUnboundModel => "no-unbound-model",
        }
    }
}

/// A device the stage driver refuses, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BindError {
    /// What went wrong.
    pub kind: BindErrorKind,
    /// The explanation, without the cfg location.
    pub message: String,
}

impl BindError {
    pub(super) fn new(kind: BindErrorKind, message: impl Into<String>) -> BindError {
        BindError {
            kind,
            message: message.into(),
        }
    }
}

impl fmt::Display for BindError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

/// The world a `simulation` device serves.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BoundWorld {
    /// Worldfile path.
    pub path: String,
    /// Models in it.
    pub models: usize,
}

/// The Stage model a device is bound to.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BoundModel {
    /// Model id in the world.
    pub id: ModelId,
    /// Its name.
    pub name: String,
    /// Its type.
    pub model_type: ModelType,
}

/// What one device of a stage block was bound to, or why it was not.
#[derive(Clone, Debug, PartialEq)]
pub enum DeviceBinding {
    /// The `simulation` device: the world, created from this file (or the one an earlier
    /// block created).
    World(BoundWorld),
    /// A Stage model.
    Model(BoundModel),
    /// Not served.
    Failed(BindError),
}

/// One device a stage block was given, as the driver handled it (see
/// [`StageHandle::devices`](super::StageHandle::devices)).
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceRecord {
    /// The device's address.
    pub addr: DeviceAddr,
    /// Where it is written in the cfg.
    pub origin: String,
    /// What it was bound to.
    pub binding: DeviceBinding,
}

/// Number of transducers of a ranger-like model (a Stage 3 `laser` is one), `None` for others.
fn transducers(m: &ModelSpec) -> Option<usize> {
    match &m.spec {
        TypeSpec::Ranger(r) => Some(r.sensors.len()),
        TypeSpec::Laser(_) => Some(1),
        _ => None,
    }
}

/// Binds one stage-driver device of `interface` in `world` to a model (player-cfg.md §8.3):
/// the model called `name` itself for `speech`/`graphics*`/`map`, else the first model of the
/// required type in its subtree (pre-order) that is not in `bound`, which it is added to.
pub fn bind_stage_model(
    world: &WorldSpec,
    name: &str,
    interface: InterfaceCode,
    bound: &mut HashSet<ModelId>,
) -> Result<ModelId, BindError> {
    let rule = match stage_binding(interface) {
        Some(StageBinding::World) => {
            return Err(BindError::new(
                BindErrorKind::UnsupportedInterface,
                "the simulation device is not bound to a model",
            ));
        }
        Some(rule) => rule,
        None => {
            return Err(BindError::new(
                BindErrorKind::UnsupportedInterface,
                format!("the stage driver does not support interface `{interface}`"),
            ));
        }
    };
    let named = world.find_model(name).ok_or_else(|| {
        BindError::new(
            BindErrorKind::NoSuchModel,
            format!("no Stage model named \"{name}\""),
        )
    })?;
    let StageBinding::Model(wanted, shape) = rule else {
        return Ok(named);
    };
    let fits = |id: &ModelId| {
        let m = world.model(*id);
        let type_ok = m.model_type == wanted
            || (wanted == ModelType::Ranger && m.model_type == ModelType::Laser);
        type_ok && !bound.contains(id)
    };
    let candidates: Vec<ModelId> = world.subtree(named).into_iter().filter(fits).collect();
    let preferred = candidates.iter().copied().find(|id| {
        let n = transducers(world.model(*id));
        match shape {
            RangerShape::Any => true,
            RangerShape::Single => n == Some(1),
            RangerShape::Multiple => n.is_some_and(|n| n > 1),
        }
    });
    match preferred.or(candidates.first().copied()) {
        Some(id) => {
            bound.insert(id);
            Ok(id)
        }
        None => Err(BindError::new(
            BindErrorKind::NoUnboundModel,
            format!(
                "no unbound `{}` model in \"{name}\" or its children",
                wanted.name()
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;
    use worldfile::LoadOptions;

    fn world(text: &str) -> WorldSpec {
        WorldSpec::parse(Path::new("t.world"), text, &LoadOptions::default()).unwrap()
    }

    fn names(w: &WorldSpec, ids: &[Result<ModelId, BindError>]) -> Vec<String> {
        ids.iter()
            .map(|r| match r {
                Ok(id) => w.model(*id).name.clone(),
                Err(e) => format!("error: {e}"),
            })
            .collect()
    }

    #[test]
    fn devices_bind_unbound_models_in_preorder() {
        // r0: a 2-transducer sonar ring first, then a one-transducer laser.
        let w = world(
            "define sonars ranger ( sensor ( pose [0 0 0 0] ) sensor ( pose [0 0 0 90] ) )\n\
             define laser1 ranger ( sensor ( samples 180 ) )\n\
             position ( name \"r0\" sonars ( ) laser1 ( ) gripper ( ) )\n",
        );
        let mut bound = HashSet::new();
        let mut bind = |i| bind_stage_model(&w, "r0", i, &mut bound);
        let got = [
            bind(InterfaceCode::POSITION2D),
            bind(InterfaceCode::LASER),
            bind(InterfaceCode::SONAR),
            bind(InterfaceCode::SPEECH),
            bind(InterfaceCode::MAP),
            bind(InterfaceCode::GRIPPER),
            bind(InterfaceCode::RANGER),
            bind(InterfaceCode::FIDUCIAL),
            bind(InterfaceCode::WIFI),
        ];
        assert_eq!(
            names(&w, &got),
            [
                "r0",
                "r0.ranger:1",
                "r0.ranger:0",
                "r0",
                "r0",
                "r0.gripper:0",
                "error: no unbound `ranger` model in \"r0\" or its children",
                "error: no unbound `fiducial` model in \"r0\" or its children",
                "error: the stage driver does not support interface `wifi`",
            ]
        );
        let kinds: Vec<Option<BindErrorKind>> = got
            .iter()
            .map(|r| r.as_ref().err().map(|e| e.kind))
            .collect();
        assert_eq!(
            kinds[6..],
            [
                Some(BindErrorKind::NoUnboundModel),
                Some(BindErrorKind::NoUnboundModel),
                Some(BindErrorKind::UnsupportedInterface)
            ]
        );
        // Rangers in order of appearance; a laser falls back to a multi-transducer ranger.
        let mut bound = HashSet::new();
        let got = [
            bind_stage_model(&w, "r0", InterfaceCode::RANGER, &mut bound),
            bind_stage_model(&w, "r0", InterfaceCode::LASER, &mut bound),
            bind_stage_model(&w, "nobody", InterfaceCode::LASER, &mut bound),
        ];
        assert_eq!(
            names(&w, &got),
            [
                "r0.ranger:0",
                "r0.ranger:1",
                "error: no Stage model named \"nobody\""
            ]
        );
        assert_eq!(
            got[2].as_ref().unwrap_err().kind,
            BindErrorKind::NoSuchModel
        );
        let mut bound = HashSet::new();
        let got = [
            bind_stage_model(&w, "r0", InterfaceCode::SONAR, &mut bound),
            bind_stage_model(&w, "r0", InterfaceCode::SONAR, &mut bound),
        ];
        assert_eq!(names(&w, &got), ["r0.ranger:0", "r0.ranger:1"]);
    }

    #[test]
    fn binding_rules_by_interface() {
        assert_eq!(
            stage_binding(InterfaceCode::SIMULATION),
            Some(StageBinding::World)
        );
        assert_eq!(
            stage_binding(InterfaceCode::SONAR),
            Some(StageBinding::Model(
                ModelType::Ranger,
                RangerShape::Multiple
            ))
        );
        assert_eq!(
            stage_binding(InterfaceCode::GRAPHICS2D),
            Some(StageBinding::Named)
        );
        assert_eq!(
            stage_binding(InterfaceCode::ACTARRAY),
            Some(StageBinding::Model(ModelType::Actuator, RangerShape::Any))
        );
        assert_eq!(stage_binding(InterfaceCode::WIFI), None);
        assert_eq!(stage_binding(InterfaceCode::MAP), Some(StageBinding::Named));
    }
}
