//! What a cfg file would make the server create (`player --check`): every driver and device,
//! the listening ports, and for the `stage` driver the world it loads and the model each device
//! binds to (player-cfg.md §6–§8).

use std::collections::HashSet;
use std::fmt;

use player_proto::InterfaceCode;
use serde::Serialize;

use crate::cfg::{CfgFile, DeviceAddr, DriverSpec};
use crate::error::Warning;
use crate::loader::LoadOptions;
use crate::models::{ModelType, TypeSpec};
use crate::world::{ModelId, ModelSpec, WorldSpec};

/// What a device is attached to.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Binding {
    /// The device belongs to a driver other than `stage`; not checked further.
    OtherDriver,
    /// The stage driver's `simulation` device: it creates the world from this file.
    World {
        /// Worldfile path.
        path: String,
        /// Models in it.
        models: usize,
    },
    /// Bound to a Stage model.
    Model {
        /// Model id in the world.
        id: ModelId,
        /// Its name.
        name: String,
        /// Its type.
        model_type: ModelType,
    },
    /// The server would fail here; the reason.
    Problem(String),
}

/// One device a driver provides.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DeviceReport {
    /// The address as parsed.
    pub addr: DeviceAddr,
    /// The port it is served on.
    pub port: u16,
    /// The host, printed.
    pub host: String,
    /// What it is attached to.
    pub binding: Binding,
}

/// One driver block.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DriverReport {
    /// The block.
    pub driver: DriverSpec,
    /// Its devices in `provides` order.
    pub devices: Vec<DeviceReport>,
}

/// The whole report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CheckReport {
    /// The cfg path.
    pub cfg: String,
    /// The default port (`-p`).
    pub default_port: u16,
    /// Driver blocks in order.
    pub drivers: Vec<DriverReport>,
    /// Ports the server listens on, in the order first seen.
    pub ports: Vec<u16>,
    /// Reasons the server would refuse to start.
    pub problems: Vec<String>,
    /// Warnings from the cfg and the worldfile.
    pub warnings: Vec<Warning>,
}

/// What a `stage`-driver device binds to (player-cfg.md §8.3, §8.5), by interface.
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
/// `map` (the named model's blocks as a grid, as Stage 2's `p_map` served it; Stage 4.1.1
/// ships that source but does not build it).
pub fn stage_binding(interface: InterfaceCode) -> Option<StageBinding> {
    let model = |t| Some(StageBinding::Model(t, RangerShape::Any));
    match interface {
        InterfaceCode::SIMULATION => Some(StageBinding::World),
        InterfaceCode::POSITION2D => model(ModelType::Position),
        InterfaceCode::RANGER => model(ModelType::Ranger),
        InterfaceCode::FIDUCIAL => model(ModelType::Fiducial),
        InterfaceCode::BLOBFINDER => model(ModelType::Blobfinder),
        InterfaceCode::GRIPPER => model(ModelType::Gripper),
        InterfaceCode::ACTARRAY => model(ModelType::Actuator),
        InterfaceCode::CAMERA => model(ModelType::Camera),
        InterfaceCode::LASER => Some(StageBinding::Model(ModelType::Ranger, RangerShape::Single)),
        InterfaceCode::SONAR => Some(StageBinding::Model(
            ModelType::Ranger,
            RangerShape::Multiple,
        )),
        InterfaceCode::SPEECH
        | InterfaceCode::GRAPHICS2D
        | InterfaceCode::GRAPHICS3D
        | InterfaceCode::MAP => Some(StageBinding::Named),
        _ => None,
    }
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
/// Errors are the reason the server refuses the device.
pub fn bind_stage_model(
    world: &WorldSpec,
    name: &str,
    interface: InterfaceCode,
    bound: &mut HashSet<ModelId>,
) -> Result<ModelId, String> {
    let rule = match stage_binding(interface) {
        Some(StageBinding::World) => {
            return Err("the simulation device is not bound to a model".into());
        }
        Some(rule) => rule,
        None => {
            return Err(format!(
                "the stage driver does not support interface `{interface}`"
            ));
        }
    };
    let named = world
        .find_model(name)
        .ok_or_else(|| format!("no Stage model named \"{name}\""))?;
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
        None => Err(format!(
            "no unbound `{}` model in \"{name}\" or its children",
            wanted.name()
        )),
    }
}

/// Checks `cfg`: parses its addresses, loads the stage driver's worldfile and binds models.
///
/// Returns the report and the world (if a `simulation` device created one). Everything the
/// server would refuse, a worldfile that fails to load included, is listed in
/// [`CheckReport::problems`].
pub fn check(
    cfg: &CfgFile,
    default_port: u16,
    opts: &LoadOptions,
) -> (CheckReport, Option<WorldSpec>) {
    let mut world: Option<WorldSpec> = None;
    let mut bound: HashSet<ModelId> = HashSet::new();
    let mut problems = Vec::new();
    let mut warnings = cfg.warnings.clone();
    let mut ports: Vec<u16> = Vec::new();
    let mut seen = HashSet::new();
    let mut drivers = Vec::new();
    for driver in &cfg.drivers {
        for e in &driver.address_errors {
            problems.push(format!("driver `{}` would fail: {e}", driver.name));
        }
        let mut devices = Vec::new();
        for addr in &driver.provides {
            let port = addr.port_or(default_port);
            let host = addr
                .host
                .ipv4()
                .map(|ip| ip.to_string())
                .unwrap_or_else(|| format!("{:?}", addr.host));
            let binding = if driver.name == "stage" {
                bind(
                    cfg,
                    driver,
                    addr,
                    &mut world,
                    &mut bound,
                    opts,
                    &mut warnings,
                )
            } else {
                Binding::OtherDriver
            };
            if let Binding::Problem(p) = &binding {
                problems.push(format!("{}: {p}", where_(addr, driver)));
            }
            // Player treats 0.0.0.0 and 127.0.0.1 as the same host.
            let host_key = if addr.host.is_local() {
                "local".to_string()
            } else {
                host.clone()
            };
            if !seen.insert((host_key, port, addr.interface, addr.index)) {
                problems.push(format!(
                    "{}: duplicate device address {}",
                    where_(addr, driver),
                    addr.describe(default_port)
                ));
            }
            if driver.name != "remote" && !ports.contains(&port) {
                ports.push(port);
            }
            devices.push(DeviceReport {
                addr: addr.clone(),
                port,
                host,
                binding,
            });
        }
        if devices.is_empty() && driver.address_errors.is_empty() {
            problems.push(format!(
                "{}: driver `{}` provides no devices",
                driver
                    .location
                    .as_ref()
                    .map(|l| l.to_string())
                    .unwrap_or_default(),
                driver.name
            ));
        }
        drivers.push(DriverReport {
            driver: driver.clone(),
            devices,
        });
    }
    if drivers.iter().all(|d| d.devices.is_empty()) {
        problems.push("no devices in the configuration file".into());
    }
    if let Some(w) = &world {
        warnings.extend(w.warnings.iter().cloned());
    }
    (
        CheckReport {
            cfg: cfg.path.display().to_string(),
            default_port,
            drivers,
            ports,
            problems,
            warnings,
        },
        world,
    )
}

fn where_(addr: &DeviceAddr, driver: &DriverSpec) -> String {
    addr.location
        .as_ref()
        .or(driver.location.as_ref())
        .map(|l| l.to_string())
        .unwrap_or_default()
}

fn bind(
    cfg: &CfgFile,
    driver: &DriverSpec,
    addr: &DeviceAddr,
    world: &mut Option<WorldSpec>,
    bound: &mut HashSet<ModelId>,
    opts: &LoadOptions,
    warnings: &mut Vec<Warning>,
) -> Binding {
    if addr.interface == InterfaceCode::SIMULATION {
        let Some(path) = cfg.worldfile_path(driver) else {
            return Binding::Problem(
                "the simulation device needs a `worldfile` in its driver block".into(),
            );
        };
        if let Some(w) = world {
            warnings.push(Warning::general(format!(
                "a second simulation device: Stage keeps one world ({})",
                w.path
            )));
            return Binding::World {
                path: w.path.clone(),
                models: w.models.len(),
            };
        }
        let w = match WorldSpec::load(&path, opts) {
            Ok(w) => w,
            Err(e) => return Binding::Problem(format!("the worldfile does not load:\n{e}")),
        };
        let b = Binding::World {
            path: path.display().to_string(),
            models: w.models.len(),
        };
        *world = Some(w);
        return b;
    }
    let Some(w) = world.as_ref() else {
        return Binding::Problem(
            "no world yet: the block providing `simulation` must come first".into(),
        );
    };
    if stage_binding(addr.interface).is_none() {
        return Binding::Problem(format!(
            "the stage driver does not support interface `{}`",
            addr.interface
        ));
    }
    let Some(name) = driver.model.as_deref() else {
        return Binding::Problem("the driver block has no `model` to bind this device to".into());
    };
    match bind_stage_model(w, name, addr.interface, bound) {
        Ok(id) => {
            let m = w.model(id);
            Binding::Model {
                id,
                name: m.name.clone(),
                model_type: m.model_type,
            }
        }
        Err(p) => Binding::Problem(p),
    }
}

impl fmt::Display for CheckReport {
    /// The text `player --check` prints.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "cfg: {}", self.cfg)?;
        for (i, d) in self.drivers.iter().enumerate() {
            let at = d
                .driver
                .location
                .as_ref()
                .map(|l| format!(" ({l})"))
                .unwrap_or_default();
            write!(f, "driver {i}: \"{}\"{at}", d.driver.name)?;
            if let Some(p) = &d.driver.plugin {
                write!(f, " plugin \"{p}\"")?;
            }
            if let Some(m) = &d.driver.model {
                write!(f, " model \"{m}\"")?;
            }
            writeln!(f)?;
            for dev in &d.devices {
                let key = dev
                    .addr
                    .key
                    .as_deref()
                    .map(|k| format!(" key {k}"))
                    .unwrap_or_default();
                write!(
                    f,
                    "  provides \"{}\": host {} port {} interface {} ({}) index {}{key}",
                    dev.addr.text,
                    dev.host,
                    dev.port,
                    dev.addr.interface,
                    dev.addr.interface.0,
                    dev.addr.index
                )?;
                match &dev.binding {
                    Binding::OtherDriver => writeln!(f)?,
                    Binding::World { path, models } => {
                        writeln!(f, " -> world {path} ({models} models)")?
                    }
                    Binding::Model {
                        name, model_type, ..
                    } => writeln!(f, " -> model \"{name}\" ({})", model_type.name())?,
                    Binding::Problem(p) => writeln!(f, " -> PROBLEM: {p}")?,
                }
            }
            for r in &d.driver.requires {
                writeln!(f, "  requires \"{}\"", r.text)?;
            }
        }
        let ports: Vec<String> = self.ports.iter().map(|p| p.to_string()).collect();
        writeln!(f, "listening ports: {}", ports.join(" "))?;
        if self.problems.is_empty() {
            write!(f, "ok: no problems found")
        } else {
            write!(f, "{} problem(s):", self.problems.len())?;
            for p in &self.problems {
                write!(f, "\n  {p}")?;
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn world(text: &str) -> WorldSpec {
        WorldSpec::parse(Path::new("t.world"), text, &LoadOptions::default()).unwrap()
    }

    fn names(w: &WorldSpec, ids: &[Result<ModelId, String>]) -> Vec<String> {
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
        let mut bound = HashSet::new();
        let got = [
            bind_stage_model(&w, "r0", InterfaceCode::SONAR, &mut bound),
            bind_stage_model(&w, "r0", InterfaceCode::SONAR, &mut bound),
        ];
        assert_eq!(names(&w, &got), ["r0.ranger:0", "r0.ranger:1"]);
    }
}
