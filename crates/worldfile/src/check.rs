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
use crate::models::ModelType;
use crate::world::{ModelId, WorldSpec};

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

/// The model type a stage-driver interface binds, `Ok(None)` for interfaces bound to the named
/// model itself, `Err` for interfaces the 4.1.1 driver does not provide (player-cfg.md §8.5).
fn required_type(interface: InterfaceCode) -> Result<Option<ModelType>, ()> {
    Ok(Some(match interface {
        InterfaceCode::POSITION2D => ModelType::Position,
        InterfaceCode::RANGER => ModelType::Ranger,
        InterfaceCode::FIDUCIAL => ModelType::Fiducial,
        InterfaceCode::BLOBFINDER => ModelType::Blobfinder,
        InterfaceCode::GRIPPER => ModelType::Gripper,
        InterfaceCode::ACTARRAY => ModelType::Actuator,
        InterfaceCode::SPEECH | InterfaceCode::GRAPHICS2D | InterfaceCode::GRAPHICS3D => {
            return Ok(None);
        }
        _ => return Err(()),
    }))
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
    let Ok(wanted) = required_type(addr.interface) else {
        return Binding::Problem(format!(
            "the stage driver (Stage 4.1.1) does not support interface `{}`",
            addr.interface
        ));
    };
    let Some(w) = world.as_ref() else {
        return Binding::Problem(
            "no world yet: the block providing `simulation` must come first".into(),
        );
    };
    let Some(name) = driver.model.as_deref() else {
        return Binding::Problem("the driver block has no `model` to bind this device to".into());
    };
    let Some(named) = w.find_model(name) else {
        return Binding::Problem(format!("no Stage model named \"{name}\""));
    };
    let Some(wanted) = wanted else {
        let m = w.model(named);
        return Binding::Model {
            id: named,
            name: m.name.clone(),
            model_type: m.model_type,
        };
    };
    // The first model of the right type not yet bound, in the named model's subtree, pre-order.
    let found = w
        .subtree(named)
        .into_iter()
        .find(|id| w.model(*id).model_type == wanted && !bound.contains(id));
    match found {
        Some(id) => {
            bound.insert(id);
            let m = w.model(id);
            Binding::Model {
                id,
                name: m.name.clone(),
                model_type: m.model_type,
            }
        }
        None => Binding::Problem(format!(
            "no unbound `{}` model in \"{name}\" or its children",
            wanted.name()
        )),
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
