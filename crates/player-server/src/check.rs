//! What a cfg file makes of the server, without starting it (`player --check`).
//!
//! [`check`] builds the server exactly as start-up does — the same registry, [`driver_block`]
//! and [`Server::add_block`] for every block, then [`Server::resolve_all_requires`] — on a
//! [`Server::for_check`] that binds no port, with a remote factory that only records the
//! devices of other servers instead of connecting to them. Where start-up stops at the first
//! failing block, the check goes on and reports them all, each with its cfg line. A refused
//! block still counts as providing its devices, so the blocks that require them are not
//! reported as well: the report lists what is wrong, not its consequences.
//!
//! The stage driver's own record of each device ([`StageHandle::devices`]) supplies the model
//! every device is bound to, and, for a refused stage block, one problem per refused device.

use std::fmt;
use std::net::Ipv4Addr;
use std::sync::{Arc, Mutex};

use serde::{Serialize, Serializer};
use worldfile::{CfgFile, DeviceAddr, DriverSpec, Warning};

use crate::cfg::driver_block;
use crate::device::DriverId;
use crate::driver::{Driver, DriverRegistry, RequiredDevice};
use crate::error::ServerError;
use crate::server::{REMOTE_DRIVER_NAME, Server, ServerConfig};
use crate::stage::{
    BindErrorKind, BoundModel, BoundWorld, DeviceBinding, DeviceRecord, STAGE_DRIVER_NAME,
    StageHandle,
};

/// What a device is attached to.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Binding {
    /// The device belongs to a driver other than `stage` (or to a block that was refused as a
    /// whole, e.g. an unknown driver).
    OtherDriver,
    /// The stage driver's `simulation` device: the world, created from this file.
    World(BoundWorld),
    /// Bound to a Stage model.
    Model(BoundModel),
    /// The server refuses this device.
    Problem {
        /// Why.
        reason: String,
    },
    /// Could not be checked because of an earlier problem (no world to bind to).
    Unchecked {
        /// Why.
        reason: String,
    },
}

/// One device a driver block provides.
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

/// Where a `requires` entry leads.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Target {
    /// A device of this server, provided by this driver block (index into
    /// [`CheckReport::drivers`]).
    Block {
        /// The providing block's index.
        index: usize,
        /// Its driver name.
        name: String,
    },
    /// A device of another Player server (its host or port is not served here).
    Remote,
    /// Nothing (the problem is in [`CheckReport::problems`]).
    Missing,
}

/// One `requires` entry of a block.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RequireReport {
    /// The address as parsed.
    pub addr: DeviceAddr,
    /// Where it leads.
    pub target: Target,
}

/// One driver block.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DriverReport {
    /// The block.
    pub driver: DriverSpec,
    /// Its devices in `provides` order.
    pub devices: Vec<DeviceReport>,
    /// Its `requires` entries in order.
    pub requires: Vec<RequireReport>,
    /// Why the server refuses the block, when it does (the server's message).
    pub refused: Option<String>,
}

/// A device of another server that some block requires (listed, never connected to).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RemoteReport {
    /// `host:port:interface:index`.
    pub addr: String,
    /// Where the first `requires` naming it is written.
    pub origin: String,
}

/// What kind of problem a [`Problem`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProblemKind {
    /// A malformed `provides`/`requires` address or a host that does not resolve.
    BadAddress,
    /// No driver of that name (Player: `couldn't find driver`).
    UnknownDriver,
    /// The driver refused its block.
    DriverFailed,
    /// A block with no device.
    NoInterfaces,
    /// Two blocks provide the same address.
    DuplicateDevice,
    /// A `requires` names a device of this server that nothing provides.
    RequiresMissing,
    /// Blocks require each other in a circle.
    RequiresCycle,
    /// The cfg yields no device at all.
    NoDevices,
    /// A stage-driver device the driver refuses, and why.
    Stage(BindErrorKind),
    /// Anything else the server reports.
    Other,
}

impl ProblemKind {
    /// The kebab-case name (JSON reports, tests).
    pub fn name(self) -> &'static str {
        match self {
            ProblemKind::BadAddress => "bad-address",
            ProblemKind::UnknownDriver => "unknown-driver",
            ProblemKind::DriverFailed => "driver-failed",
            ProblemKind::NoInterfaces => "no-interfaces",
            ProblemKind::DuplicateDevice => "duplicate-device",
            ProblemKind::RequiresMissing => "requires-missing",
            ProblemKind::RequiresCycle => "requires-cycle",
            ProblemKind::NoDevices => "no-devices",
            ProblemKind::Stage(kind) => kind.name(),
            ProblemKind::Other => "other",
        }
    }
}

impl Serialize for ProblemKind {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// One reason the server would refuse the configuration.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Problem {
    /// Where in the cfg (`file:line:col`), when the problem has a place.
    pub origin: Option<String>,
    /// What kind of problem.
    pub kind: ProblemKind,
    /// The message, place included, as the server prints it.
    pub message: String,
}

impl Problem {
    fn from_error(e: &ServerError) -> Problem {
        let (origin, kind) = match e {
            ServerError::Config { origin, .. } => (Some(origin), ProblemKind::BadAddress),
            ServerError::UnknownDriver { origin, .. } => (Some(origin), ProblemKind::UnknownDriver),
            ServerError::DriverFailed { origin, .. } => (Some(origin), ProblemKind::DriverFailed),
            ServerError::NoInterfaces { origin, .. } => (Some(origin), ProblemKind::NoInterfaces),
            ServerError::DuplicateDevice { origin, .. } => {
                (Some(origin), ProblemKind::DuplicateDevice)
            }
            ServerError::RequiresMissing { origin, .. } => {
                (Some(origin), ProblemKind::RequiresMissing)
            }
            ServerError::RequiresCycle { origin, .. } => (Some(origin), ProblemKind::RequiresCycle),
            ServerError::NoDevices => (None, ProblemKind::NoDevices),
            _ => (None, ProblemKind::Other),
        };
        Problem {
            origin: origin.cloned(),
            kind,
            message: e.to_string(),
        }
    }
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
    /// Devices of other servers the blocks require, in order of first mention.
    pub remote: Vec<RemoteReport>,
    /// Ports the server listens on, in the order first seen.
    pub ports: Vec<u16>,
    /// Reasons the server would refuse to start, in cfg order.
    pub problems: Vec<Problem>,
    /// Warnings from the cfg, the worldfile and the check.
    pub warnings: Vec<Warning>,
}

/// A driver that is never run: stands in for remote devices (the check connects nowhere) and
/// for refused blocks (so that what they provide still satisfies other blocks' `requires`).
struct NotStarted;

impl Driver for NotStarted {}

/// Checks `cfg` as the server would start it: `registry` holds every driver the server can
/// build (the stage driver's included, registered with `stage`), `default_port` is `-p`.
pub fn check(
    cfg: &CfgFile,
    default_port: u16,
    registry: &mut DriverRegistry,
    stage: &StageHandle,
) -> CheckReport {
    let mut server = Server::for_check(ServerConfig::default());
    let remote: Arc<Mutex<Vec<RequiredDevice>>> = Arc::default();
    let recorded = remote.clone();
    server.set_remote_factory(Some(Box::new(move |r: &RequiredDevice| {
        recorded
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(r.clone());
        Ok(Box::new(NotStarted) as Box<dyn Driver>)
    })));

    let mut problems = Vec::new();
    let mut warnings = cfg.warnings.clone();
    let mut drivers = Vec::new();
    // The cfg block each server driver came from.
    let mut block_of: Vec<(DriverId, usize)> = Vec::new();
    let mut built_blocks = Vec::new();
    for (index, spec) in cfg.drivers.iter().enumerate() {
        let block = match driver_block(cfg, spec, default_port) {
            Ok(block) => block,
            Err(e) => {
                // Nothing to build from this block, but whether its driver exists is known.
                problems.push(Problem::from_error(&e));
                if !registry.names().contains(&spec.name.as_str()) {
                    problems.push(Problem::from_error(&ServerError::UnknownDriver {
                        name: spec.name.clone(),
                        origin: spec
                            .location
                            .as_ref()
                            .map(|l| l.to_string())
                            .unwrap_or_else(|| cfg.path.display().to_string()),
                        known: registry.names().join(", "),
                    }));
                }
                drivers.push(DriverReport {
                    driver: spec.clone(),
                    devices: device_reports(spec, default_port, &[]),
                    requires: Vec::new(),
                    refused: Some(e.to_string()),
                });
                continue;
            }
        };
        let seen = stage.devices().len();
        let result = server.add_block(&block, registry);
        let records: Vec<DeviceRecord> = stage.devices().split_off(seen);
        let mut refused = None;
        match result {
            Ok(id) => block_of.push((id, index)),
            Err(e) => {
                let device_problems = stage_problems(&records, &mut warnings);
                match (&e, device_problems) {
                    // The stage driver said why, device by device.
                    (ServerError::DriverFailed { .. }, Some(found)) => problems.extend(found),
                    _ => problems.push(Problem::from_error(&e)),
                }
                refused = Some(e.to_string());
                // A block that was built but whose devices clash is not added again; one that
                // could not be built stands in as a placeholder.
                if matches!(
                    e,
                    ServerError::UnknownDriver { .. } | ServerError::DriverFailed { .. }
                ) {
                    match server.add_driver(&block, Box::new(NotStarted)) {
                        Ok(id) => block_of.push((id, index)),
                        Err(e) => problems.push(Problem::from_error(&e)),
                    }
                }
            }
        }
        let is_stage = spec.name == STAGE_DRIVER_NAME;
        let bindings: Vec<Binding> = block
            .provides
            .iter()
            .map(|p| match records.iter().find(|r| r.addr == p.addr) {
                Some(r) => binding_of(&r.binding),
                None if is_stage && refused.is_some() => Binding::Unchecked {
                    reason: "the stage driver refused the block before reaching this device".into(),
                },
                None => Binding::OtherDriver,
            })
            .collect();
        drivers.push(DriverReport {
            driver: spec.clone(),
            devices: device_reports(spec, default_port, &bindings),
            requires: Vec::new(),
            refused,
        });
        built_blocks.push((index, block));
    }

    let resolved = server.resolve_all_requires();
    problems.extend(resolved.iter().map(Problem::from_error));
    if server.table().is_empty() {
        problems.push(Problem::from_error(&ServerError::NoDevices));
    }

    // Where each `requires` leads, now that every block is in the table.
    for (index, block) in &built_blocks {
        let spec = &cfg.drivers[*index];
        drivers[*index].requires = spec
            .requires
            .iter()
            .zip(&block.requires)
            .map(|(addr, r)| {
                let target = match server.table().find(&r.addr) {
                    Some(i) => {
                        let device = server.table().get(i);
                        if device.driver_name == REMOTE_DRIVER_NAME {
                            Target::Remote
                        } else {
                            match block_of.iter().find(|(id, _)| *id == device.driver) {
                                Some(&(_, b)) => Target::Block {
                                    index: b,
                                    name: cfg.drivers[b].name.clone(),
                                },
                                None => Target::Missing,
                            }
                        }
                    }
                    None => Target::Missing,
                };
                RequireReport {
                    addr: addr.clone(),
                    target,
                }
            })
            .collect();
    }

    let worlds = stage
        .devices()
        .iter()
        .filter(|r| matches!(r.binding, DeviceBinding::World(_)))
        .count();
    if worlds > 1 {
        warnings.push(Warning::general(
            "more than one simulation device: Stage keeps one world, the first one's",
        ));
    }
    if let Some(spec) = stage.world_spec() {
        warnings.extend(spec.warnings.iter().cloned());
    }
    let remote = remote
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .iter()
        .map(|r| RemoteReport {
            addr: format!(
                "{}:{}:{}:{}",
                Ipv4Addr::from(r.addr.host.to_le_bytes()),
                r.addr.robot,
                r.addr.interf,
                r.addr.index
            ),
            origin: r.origin.clone(),
        })
        .collect();
    CheckReport {
        cfg: cfg.path.display().to_string(),
        default_port,
        drivers,
        remote,
        ports: server
            .table()
            .ports()
            .into_iter()
            .filter_map(|p| u16::try_from(p).ok())
            .collect(),
        problems,
        warnings,
    }
}

/// The problems of a refused stage block, one per refused device (`None` when the driver
/// refused it without a device record, e.g. a bad option). Devices that could not be bound
/// only because an earlier block failed to create the world are warnings, not problems.
fn stage_problems(records: &[DeviceRecord], warnings: &mut Vec<Warning>) -> Option<Vec<Problem>> {
    let mut problems = Vec::new();
    let mut any = false;
    for r in records {
        let DeviceBinding::Failed(e) = &r.binding else {
            continue;
        };
        any = true;
        let message = format!("{}: {e}", r.origin);
        if e.kind == BindErrorKind::WorldFailed {
            warnings.push(Warning::general(format!("not checked: {message}")));
        } else {
            problems.push(Problem {
                origin: Some(r.origin.clone()),
                kind: ProblemKind::Stage(e.kind),
                message,
            });
        }
    }
    any.then_some(problems)
}

fn binding_of(b: &DeviceBinding) -> Binding {
    match b {
        DeviceBinding::World(world) => Binding::World(world.clone()),
        DeviceBinding::Model(model) => Binding::Model(model.clone()),
        DeviceBinding::Failed(e) if e.kind == BindErrorKind::WorldFailed => Binding::Unchecked {
            reason: e.message.clone(),
        },
        DeviceBinding::Failed(e) => Binding::Problem {
            reason: e.message.clone(),
        },
    }
}

/// The devices of `spec` with their bindings (`OtherDriver` where none is given).
fn device_reports(spec: &DriverSpec, default_port: u16, bindings: &[Binding]) -> Vec<DeviceReport> {
    spec.provides
        .iter()
        .enumerate()
        .map(|(i, addr)| DeviceReport {
            addr: addr.clone(),
            port: addr.port_or(default_port),
            host: addr
                .host
                .ipv4()
                .map(|ip| ip.to_string())
                .unwrap_or_else(|| format!("{:?}", addr.host)),
            binding: bindings.get(i).cloned().unwrap_or(Binding::OtherDriver),
        })
        .collect()
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
            // A refusal explained device by device is shown there.
            let explained = d.devices.iter().any(|dev| {
                matches!(
                    dev.binding,
                    Binding::Problem { .. } | Binding::Unchecked { .. }
                )
            });
            match &d.refused {
                Some(why) if !explained => writeln!(f, " -> REFUSED: {why}")?,
                _ => writeln!(f)?,
            }
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
                    Binding::World(BoundWorld { path, models }) => {
                        writeln!(f, " -> world {path} ({models} models)")?
                    }
                    Binding::Model(BoundModel {
                        name, model_type, ..
                    }) => writeln!(f, " -> model \"{name}\" ({})", model_type.name())?,
                    Binding::Problem { reason } => writeln!(f, " -> PROBLEM: {reason}")?,
                    Binding::Unchecked { reason } => writeln!(f, " -> not checked: {reason}")?,
                }
            }
            for r in &d.requires {
                write!(f, "  requires \"{}\"", r.addr.text)?;
                match &r.target {
                    Target::Block { index, name } => {
                        writeln!(f, " -> driver {index} (\"{name}\")")?
                    }
                    Target::Remote => writeln!(f, " -> another server")?,
                    Target::Missing => writeln!(f, " -> nothing")?,
                }
            }
        }
        for r in &self.remote {
            writeln!(f, "remote device {} (required at {})", r.addr, r.origin)?;
        }
        let ports: Vec<String> = self.ports.iter().map(|p| p.to_string()).collect();
        writeln!(f, "listening ports: {}", ports.join(" "))?;
        if self.problems.is_empty() {
            write!(f, "ok: no problems found")
        } else {
            write!(f, "{} problem(s):", self.problems.len())?;
            for p in &self.problems {
                write!(f, "\n  {}", p.message)?;
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stage::{self, StageOptions};
    use crate::test_driver::{TEST_DRIVER_NAME, TestDriver};
    use std::path::PathBuf;
    use worldfile::LoadOptions;

    const WORLD: &str = "define bot position ( ranger ( sensor ( ) ) )\n\
                         bot ( name \"r0\" )\n";

    /// A folder with `w.world` and the cfg `text` as `t.cfg`; returns the cfg path.
    fn files(tag: &str, text: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("check-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("w.world"), WORLD).unwrap();
        std::fs::write(dir.join("t.cfg"), text).unwrap();
        dir.join("t.cfg")
    }

    fn run(tag: &str, text: &str) -> CheckReport {
        let path = files(tag, text);
        let cfg = CfgFile::load(&path, &LoadOptions::default()).unwrap();
        let mut registry = DriverRegistry::new();
        TestDriver::register(&mut registry, TEST_DRIVER_NAME);
        let stage = stage::register(&mut registry, StageOptions::default());
        let report = check(&cfg, 6665, &mut registry, &stage);
        let _ = std::fs::remove_dir_all(path.parent().unwrap());
        report
    }

    /// (line, kind) of every problem.
    fn problems(r: &CheckReport) -> Vec<(u32, &'static str)> {
        r.problems
            .iter()
            .map(|p| {
                let origin = p.origin.as_deref().unwrap_or_default();
                let line = origin.split(':').nth(1).map_or(0, |l| l.parse().unwrap());
                (line, p.kind.name())
            })
            .collect()
    }

    #[test]
    fn every_problem_is_reported_with_its_line_and_consequences_are_not() {
        let r = run(
            "all",
            "driver( name \"stage\" provides [\"simulation:0\"] worldfile \"w.world\" )\n\
             driver( name \"stage\" provides [\"position2d:0\" \"bumper:0\" \"ranger:0\" \"ranger:1\"] model \"r0\" )\n\
             driver( name \"vfh\" provides [\"position2d:1\"] requires [\"position2d:0\" \"laser:0\"] )\n\
             driver( name \"wavefront\" provides [\"planner:0\"] requires [\"position2d:1\" \"7000:map:0\"] )\n",
        );
        assert_eq!(
            problems(&r),
            [
                (2, "unsupported-interface"),
                (2, "no-unbound-model"),
                (3, "unknown-driver"),
                (4, "unknown-driver"),
                (3, "requires-missing"),
            ],
            "{r}"
        );
        // The stage block's devices, each with its binding or its reason.
        let bindings: Vec<String> = r.drivers[1]
            .devices
            .iter()
            .map(|d| match &d.binding {
                Binding::Model(model) => model.name.clone(),
                Binding::Problem { reason } => format!("problem: {reason}"),
                other => format!("{other:?}"),
            })
            .collect();
        assert_eq!(
            bindings,
            [
                "r0",
                "problem: the stage driver does not support interface `bumper` (14)",
                "r0.ranger:0",
                "problem: cannot bind `ranger:1`: no unbound `ranger` model in \"r0\" or its children",
            ]
        );
        assert!(matches!(
            r.drivers[0].devices[0].binding,
            Binding::World(BoundWorld { models: 2, .. })
        ));
        // Where requires lead: the refused vfh block still provides position2d:1.
        let targets: Vec<&Target> = r.drivers[2..]
            .iter()
            .flat_map(|d| d.requires.iter().map(|q| &q.target))
            .collect();
        assert_eq!(
            targets,
            [
                &Target::Block {
                    index: 1,
                    name: "stage".into()
                },
                &Target::Missing,
                &Target::Block {
                    index: 2,
                    name: "vfh".into()
                },
                &Target::Remote,
            ]
        );
        assert_eq!(r.ports, [6665]);
        assert_eq!(r.remote.len(), 1);
        assert_eq!(r.remote[0].addr, "127.0.0.1:7000:map:0");
        assert!(r.remote[0].origin.contains("t.cfg:4:"), "{:?}", r.remote);
        let text = r.to_string();
        assert!(
            text.contains("driver 2: \"vfh\" (")
                && text.contains("-> REFUSED: ")
                && text.contains("couldn't find driver \"vfh\""),
            "{text}"
        );
        assert!(
            text.contains("  requires \"position2d:1\" -> driver 2 (\"vfh\")"),
            "{text}"
        );
        assert!(
            text.contains("remote device 127.0.0.1:7000:map:0 (required at "),
            "{text}"
        );
        assert!(text.contains("5 problem(s):"), "{text}");
    }

    #[test]
    fn devices_after_a_world_that_does_not_load_are_not_checked() {
        let r = run(
            "noworld",
            "driver( name \"stage\" provides [\"simulation:0\"] worldfile \"missing.world\" )\n\
             driver( name \"stage\" provides [\"position2d:0\" \"wifi:0\"] model \"r0\" )\n",
        );
        // The world, and the interface the stage driver never serves; not the position device.
        assert_eq!(
            problems(&r),
            [(1, "world-does-not-load"), (2, "unsupported-interface")],
            "{r}"
        );
        assert!(
            r.problems[0]
                .message
                .contains("cannot read world file \"missing.world\" named at "),
            "{}",
            r.problems[0].message
        );
        assert!(matches!(
            r.drivers[1].devices[0].binding,
            Binding::Unchecked { .. }
        ));
        assert!(
            r.warnings
                .iter()
                .any(|w| w.message.starts_with("not checked: ")
                    && w.message.contains("position2d:0")),
            "{:?}",
            r.warnings
        );
    }

    #[test]
    fn cycles_duplicates_and_port_zero_without_binding_anything() {
        let r = run(
            "cycle",
            "driver( name \"testdriver\" provides [\"opaque:0\"] requires [\"opaque:1\"] )\n\
             driver( name \"testdriver\" provides [\"opaque:1\"] requires [\"opaque:0\"] )\n\
             driver( name \"testdriver\" provides [\"opaque:1\"] )\n\
             driver( name \"testdriver\" provides [\"0:opaque:2\"] )\n\
             driver( name \"testdriver\" provides [\"foo:0\"] )\n\
             driver( name \"nothing\" provides [\"bar:0\"] )\n",
        );
        assert_eq!(
            problems(&r),
            [
                (3, "duplicate-device"),
                (5, "bad-address"),
                (6, "bad-address"),
                (6, "unknown-driver"),
                (1, "requires-cycle"),
            ],
            "{r}"
        );
        // Port 0 stays 0: a check opens no listener to learn a port.
        assert_eq!(r.ports, [6665, 0]);
    }

    #[test]
    fn the_report_serialises() {
        let r = run(
            "json",
            "driver( name \"stage\" provides [\"simulation:0\"] worldfile \"missing.world\" )\n\
             driver( name \"stage\" provides [\"position2d:0\" \"wifi:0\"] model \"r0\" )\n\
             driver( name \"vfh\" provides [\"position2d:1\"] requires [\"7000:position2d:0\"] )\n",
        );
        let json = serde_json::to_value(&r).unwrap();
        assert_eq!(json["problems"][1]["kind"], "unsupported-interface");
        assert_eq!(
            json["drivers"][1]["devices"][0]["binding"]["kind"],
            "unchecked"
        );
        assert_eq!(
            json["drivers"][1]["devices"][1]["binding"]["kind"],
            "problem"
        );
        assert_eq!(
            json["drivers"][2]["requires"][0]["target"]["kind"],
            "remote"
        );
        assert_eq!(json["remote"][0]["addr"], "127.0.0.1:7000:position2d:0");
    }

    #[test]
    fn an_empty_configuration_has_no_devices() {
        let r = run("empty", "# nothing\n");
        assert_eq!(problems(&r), [(0, "no-devices")]);
        assert!(
            r.to_string()
                .ends_with("1 problem(s):\n  no devices read in the configuration")
        );
    }
}
