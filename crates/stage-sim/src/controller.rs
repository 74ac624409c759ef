//! Controllers: Stage's `ctrl` plugins, built in. A controller is attached to a model, runs
//! after each update of its *trigger* model (typically the sensor it reads) and acts through
//! [`Commands`], which the world applies after the step's moves, so the commands take effect
//! at the next step exactly as Stage's update callbacks do.
//!
//! Built in: `wander` (Stage's examples/ctrl/wander.cc behaviour), `expand_pioneer` and
//! `expand_swarm` (worlds/benchmark), `pioneer_flocking` and `lasernoise` (examples/ctrl).
//! Other names (`fasr`, `sink`, `source`, …) produce a warning naming the model.

use crate::desc::{Color, ModelType};
use crate::rng::SimRng;
use crate::world::{ModelId, Sensors, World};

/// A command a controller asks the world to apply.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Velocity goal for a position model: (model, vx m/s, vy m/s, va rad/s).
    Velocity(ModelId, f64, f64, f64),
    /// Subscribe a model.
    Subscribe(ModelId),
    /// Unsubscribe a model.
    Unsubscribe(ModelId),
    /// Recolour a model.
    SetColor(ModelId, Color),
    /// Set a model's speech text.
    Say(ModelId, String),
    /// Give every transducer of a ranger multiplicative range noise N(1, sd).
    RangerNoise(ModelId, f64),
}

/// The command sink handed to a controller.
#[derive(Debug, Default)]
pub struct Commands {
    model: Option<ModelId>,
    list: Vec<Command>,
}

impl Commands {
    /// A sink for the controller of `model`.
    pub fn new(model: ModelId) -> Commands {
        Commands {
            model: Some(model),
            list: Vec::new(),
        }
    }

    /// Velocity goal for the controller's own model.
    pub fn set_speed(&mut self, vx: f64, vy: f64, va: f64) {
        if let Some(m) = self.model {
            self.list.push(Command::Velocity(m, vx, vy, va));
        }
    }

    /// Any command.
    pub fn push(&mut self, c: Command) {
        self.list.push(c);
    }

    /// Takes the commands out in order.
    pub fn drain(&mut self) -> std::vec::Drain<'_, Command> {
        self.list.drain(..)
    }
}

/// A model controller (Stage's `ctrl` plugin).
pub trait Controller: Send + Sync {
    /// Called after each update of the trigger model, with read access to the sensor data
    /// that update produced. Only that: a step runs its controllers while it installs the
    /// moves, which change everything else a controller might read.
    fn update(&mut self, sensors: &Sensors<'_>, cmds: &mut Commands);
}

/// A controller ready to be installed.
pub struct Installed {
    /// The model it controls.
    pub model: ModelId,
    /// The model whose updates call it.
    pub trigger: ModelId,
    /// Models to subscribe when installing.
    pub subscribe: Vec<ModelId>,
    /// Commands applied once when installing.
    pub init: Vec<Command>,
    /// The controller.
    pub ctrl: Box<dyn Controller>,
}

/// Why a built-in controller could not attach.
#[derive(Debug, thiserror::Error)]
pub enum CtrlError {
    /// The controlled model lacks a device the controller needs.
    #[error("needs {0}")]
    Missing(&'static str),
    /// The controlled model is not in the world.
    #[error(transparent)]
    Model(#[from] crate::error::Error),
}

/// Whether model `m`, taken from `world`'s own tree, has type `t`.
fn has_type(world: &World, m: ModelId, t: ModelType) -> bool {
    world
        .model_type(m)
        .expect("an id from the world's own tree belongs to it")
        == t
}

/// The rangers below `m` (checked) in pre-order.
fn rangers_in(world: &World, m: ModelId) -> Vec<ModelId> {
    world
        .subtree(m)
        .expect("the controlled model is checked first")
        .into_iter()
        .skip(1)
        .filter(|&c| has_type(world, c, ModelType::Ranger))
        .collect()
}

/// Builds the named built-in controller for `model`; `Ok(None)` if the name is unknown.
pub fn builtin(
    name: &str,
    world: &World,
    model: ModelId,
    args: &str,
    rng: SimRng,
) -> Result<Option<Installed>, CtrlError> {
    let _ = args;
    let model_type = world.model_type(model)?;
    match name {
        "wander" => {
            if model_type != ModelType::Position {
                return Err(CtrlError::Missing("a position model"));
            }
            // Stage's wander reads `ranger:1` (the laser after the sonar ring); fall back to the
            // only ranger when there is one.
            let direct: Vec<ModelId> = world
                .children(model)?
                .filter(|&c| has_type(world, c, ModelType::Ranger))
                .collect();
            let laser = direct
                .get(1)
                .or(direct.first())
                .copied()
                .or_else(|| rangers_in(world, model).first().copied())
                .ok_or(CtrlError::Missing("a ranger"))?;
            Ok(Some(Installed {
                model,
                trigger: laser,
                subscribe: vec![model, laser],
                init: Vec::new(),
                ctrl: Box::new(Wander {
                    laser,
                    rng,
                    avoidcount: 0,
                    speed: 0.0,
                    turn: 0.0,
                }),
            }))
        }
        "expand_pioneer" | "expand_swarm" => {
            if model_type != ModelType::Position {
                return Err(CtrlError::Missing("a position model"));
            }
            let ranger = *rangers_in(world, model)
                .first()
                .ok_or(CtrlError::Missing("a ranger"))?;
            let params = if name == "expand_pioneer" {
                Expand::pioneer(ranger)
            } else {
                Expand::swarm(ranger)
            };
            Ok(Some(Installed {
                model,
                trigger: ranger,
                subscribe: vec![ranger, model],
                init: Vec::new(),
                ctrl: Box::new(params),
            }))
        }
        "pioneer_flocking" => {
            if model_type != ModelType::Position {
                return Err(CtrlError::Missing("a position model"));
            }
            let ranger = *rangers_in(world, model)
                .first()
                .ok_or(CtrlError::Missing("a ranger"))?;
            let fiducial = world
                .subtree(model)?
                .into_iter()
                .skip(1)
                .find(|&c| has_type(world, c, ModelType::Fiducial))
                .ok_or(CtrlError::Missing("a fiducial finder"))?;
            Ok(Some(Installed {
                model,
                trigger: ranger,
                subscribe: vec![fiducial, ranger, model],
                init: Vec::new(),
                ctrl: Box::new(Flocking {
                    ranger,
                    fiducial,
                    rng,
                }),
            }))
        }
        "lasernoise" => {
            if model_type != ModelType::Ranger {
                return Err(CtrlError::Missing("to be attached to a ranger"));
            }
            Ok(Some(Installed {
                model,
                trigger: model,
                subscribe: vec![model],
                init: vec![Command::RangerNoise(model, 0.05)],
                ctrl: Box::new(Idle),
            }))
        }
        _ => Ok(None),
    }
}

/// A controller with nothing to do per update (its work was done at install time).
pub struct Idle;

impl Controller for Idle {
    fn update(&mut self, _sensors: &Sensors<'_>, _cmds: &mut Commands) {}
}

/// Stage's `pioneer_flocking` example: steer away from obstacles using the front eight sonars,
/// drive when the front is clear and then align with the nearest robot seen by the fiducial
/// finder; wiggle randomly when blocked.
pub struct Flocking {
    ranger: ModelId,
    fiducial: ModelId,
    rng: SimRng,
}

impl Controller for Flocking {
    fn update(&mut self, sensors: &Sensors<'_>, cmds: &mut Commands) {
        const VSPEED: f64 = 0.4;
        const EXPAND_WGAIN: f64 = 0.3;
        const FLOCK_WGAIN: f64 = 0.3;
        const SAFE_DIST: f64 = 1.0;
        const SAFE_ANGLE: f64 = 0.5;
        let Ok(data) = sensors.ranger_scans(self.ranger) else {
            return;
        };
        let r = |k: usize| data.first_range(k);
        if data.scans().len() < 8 {
            return;
        }
        let (mut dx, mut dy) = (0.0, 0.0);
        for k in 0..8 {
            let a = data.sensors[k].pose.a;
            dx += r(k).unwrap_or(0.0) * a.cos();
            dy += r(k).unwrap_or(0.0) * a.sin();
        }
        if dx == 0.0 || dy == 0.0 {
            return;
        }
        let resultant = dy.atan2(dx);
        let mut turn = EXPAND_WGAIN * resultant;
        let above = |k: usize, min: f64| r(k).is_some_and(|v| v > min);
        let clear = above(3, SAFE_DIST)
            && above(4, SAFE_DIST)
            && above(5, SAFE_DIST)
            && above(6, SAFE_DIST / 2.0)
            && above(2, SAFE_DIST)
            && above(1, SAFE_DIST / 2.0)
            && resultant.abs() < SAFE_ANGLE;
        let speed = if clear {
            let closest = match sensors.fiducials(self.fiducial) {
                Ok(f) => f
                    .fiducials
                    .iter()
                    .min_by(|a, b| a.range.total_cmp(&b.range))
                    .copied(),
                Err(_) => None,
            };
            if let Some(c) = closest {
                turn += FLOCK_WGAIN * c.heading;
            }
            VSPEED
        } else {
            if turn.abs() < 0.1 {
                turn = self.rng.next_f64();
            }
            0.0
        };
        cmds.set_speed(speed, 0.0, turn);
    }
}

/// Stage's `wander`: cruise at 0.4 m/s; when something is within 1 m ahead (middle third of the
/// scan) or within 0.3 m anywhere, creep (or stop) and turn away from the nearer side for a
/// random 10–19 updates.
pub struct Wander {
    laser: ModelId,
    rng: SimRng,
    avoidcount: i32,
    speed: f64,
    turn: f64,
}

impl Controller for Wander {
    fn update(&mut self, sensors: &Sensors<'_>, cmds: &mut Commands) {
        const CRUISE: f64 = 0.4;
        const AVOID_SPEED: f64 = 0.05;
        const AVOID_TURN: f64 = 0.5;
        const MIN_FRONT: f64 = 1.0;
        const STOP_DIST: f64 = 0.3;
        const AVOID_DURATION: u32 = 10;
        let Some(scan) = sensors.ranger_scans(self.laser).map_or(None, |r| r.scan(0)) else {
            return;
        };
        let r = scan.ranges;
        let n = r.len();
        if n < 1 {
            return;
        }
        // Stage's per-sample loop, as whole-slice passes (the front third, every sample, the
        // two halves): the same answers without a branch per sample
        let front = &r[(n / 3 + 1).min(n - n / 3)..n - n / 3];
        let obstruction = front.iter().any(|&v| v < MIN_FRONT);
        let stop = r.iter().any(|&v| v < STOP_DIST);
        let (right, left) = r.split_at((n / 2 + 1).min(n));
        let minleft = left.iter().fold(1e6f64, |m, &v| m.min(v));
        let minright = right.iter().fold(1e6f64, |m, &v| m.min(v));
        if obstruction || stop || self.avoidcount > 0 {
            self.speed = if stop { 0.0 } else { AVOID_SPEED };
            if self.avoidcount < 1 {
                self.avoidcount = (self.rng.below(AVOID_DURATION) + AVOID_DURATION) as i32;
                self.turn = if minleft < minright {
                    -AVOID_TURN
                } else {
                    AVOID_TURN
                };
            }
            self.avoidcount -= 1;
        } else {
            self.avoidcount = 0;
            self.speed = CRUISE;
            self.turn = 0.0;
        }
        cmds.set_speed(self.speed, 0.0, self.turn);
    }
}

/// The benchmark worlds' `expand_pioneer` / `expand_swarm`: turn towards the vector sum of the
/// ranger readings (each sensor's first sample along its heading) and drive forward only when
/// the sectors ahead are clear.
pub struct Expand {
    ranger: ModelId,
    speed: f64,
    safe_angle: f64,
    /// (sensor index, minimum range) that must all be exceeded to drive.
    clear: &'static [(usize, f64)],
    /// sin/cos of each sensor heading, worked out at the first update (made with room for a
    /// ring's worth at construction, so that in a large swarm it lies beside the controller
    /// rather than wherever a thread's first update put it).
    dirs: Vec<(f64, f64)>,
}

/// `expand_pioneer`'s safe distance (m) and the sonars that must see beyond its fractions.
const PIONEER_SAFE: f64 = 0.75;
const PIONEER_CLEAR: [(usize, f64); 6] = [
    (3, PIONEER_SAFE),
    (4, PIONEER_SAFE),
    (5, PIONEER_SAFE / 2.0),
    (6, PIONEER_SAFE / 4.0),
    (2, PIONEER_SAFE / 2.0),
    (1, PIONEER_SAFE / 4.0),
];
/// `expand_swarm`'s safe distance (m) and the IR sensors that must see beyond its fractions.
const SWARM_SAFE: f64 = 0.5;
const SWARM_CLEAR: [(usize, f64); 7] = [
    (0, SWARM_SAFE),
    (1, SWARM_SAFE / 1.5),
    (2, SWARM_SAFE / 3.0),
    (3, SWARM_SAFE / 5.0),
    (9, SWARM_SAFE / 5.0),
    (10, SWARM_SAFE / 3.0),
    (11, SWARM_SAFE / 1.5),
];

impl Expand {
    /// `expand_pioneer` (16-sonar pioneer ring): 0.2 m/s, safe distance 0.75 m.
    pub fn pioneer(ranger: ModelId) -> Expand {
        Expand {
            ranger,
            speed: 0.2,
            safe_angle: 0.5,
            clear: &PIONEER_CLEAR,
            dirs: Vec::with_capacity(16),
        }
    }

    /// `expand_swarm` (12 IR sensors): 0.3 m/s, safe distance 0.5 m.
    pub fn swarm(ranger: ModelId) -> Expand {
        Expand {
            ranger,
            speed: 0.3,
            safe_angle: 0.5,
            clear: &SWARM_CLEAR,
            dirs: Vec::with_capacity(12),
        }
    }
}

impl Controller for Expand {
    fn update(&mut self, sensors: &Sensors<'_>, cmds: &mut Commands) {
        let Ok(data) = sensors.ranger_scans(self.ranger) else {
            return;
        };
        let first = |k: usize| data.first_range(k);
        if self.dirs.len() != data.sensors.len() {
            self.dirs.clear();
            self.dirs
                .extend(data.sensors.iter().map(|s| s.pose.a.sin_cos()));
        }
        let (mut dx, mut dy) = (0.0, 0.0);
        for (&(s, c), r) in self.dirs.iter().zip(data.first_ranges()) {
            if let Some(r) = r {
                dx += r * c;
                dy += r * s;
            }
        }
        if dx == 0.0 || dy == 0.0 {
            return;
        }
        let resultant = dy.atan2(dx);
        let clear = resultant.abs() < self.safe_angle
            && self
                .clear
                .iter()
                .all(|&(k, min)| first(k).is_some_and(|r| r > min));
        cmds.set_speed(if clear { self.speed } else { 0.0 }, 0.0, resultant);
    }
}
