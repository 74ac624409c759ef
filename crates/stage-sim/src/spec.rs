//! Translation of the `worldfile` crate's resolved [`WorldSpec`] into a [`WorldDesc`]: types,
//! units and defaults are already resolved there, so this is a field-by-field mapping plus the
//! seeded choices Stage makes at random (`color "random"`, default odometry errors).

use std::path::Path;

use worldfile::LoadOptions;
use worldfile::color::ColorSpec;
use worldfile::models::{self as wm, TypeSpec};
use worldfile::world::{ModelSpec, WorldSettings, WorldSpec};

use crate::desc::*;
use crate::error::Result;
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::world::World;

fn pose(p: [f64; 4]) -> Pose {
    Pose::new(p[0], p[1], p[2], p[3])
}

fn color(c: &ColorSpec, rng: &mut SimRng) -> Color {
    match c {
        ColorSpec::Rgba(c) => *c,
        ColorSpec::Random => Color::rgb(rng.next_f64(), rng.next_f64(), rng.next_f64()),
    }
}

/// A ranger transducer from its worldfile properties (`random` colours drawn from `rng`).
pub(crate) fn sensor(s: &wm::SensorSpec, rng: &mut SimRng) -> SensorDesc {
    SensorDesc {
        pose: pose(s.pose),
        size: s.size,
        range: s.range,
        fov: s.fov,
        samples: s.samples.clamp(0, 1 << 20) as u32,
        noise: 0.0,
        noise_relative: 0.0,
        color: color(&s.color, rng),
    }
}

/// Position properties.
pub(crate) fn position(p: &wm::PositionSpec) -> PositionDesc {
    PositionDesc {
        drive: p.drive,
        localization: p.localization,
        localization_origin: Some(pose(p.localization_origin)),
        odom_error: p.odom_error,
        wheelbase: p.wheelbase,
        velocity_bounds: p.velocity_bounds,
        acceleration_bounds: p.acceleration_bounds,
        velocity: pose(p.velocity),
    }
}

/// Blobfinder properties.
pub(crate) fn blobfinder(b: &wm::BlobfinderSpec) -> BlobfinderDesc {
    BlobfinderDesc {
        image: [
            b.image[0].clamp(0, 1 << 16) as u32,
            b.image[1].clamp(0, 1 << 16) as u32,
        ],
        range: b.range,
        fov: b.fov,
        pan: b.pan,
        colors: b.colors.clone(),
    }
}

/// Fiducial-finder properties.
pub(crate) fn fiducial(f: &wm::FiducialSpec) -> FiducialDesc {
    FiducialDesc {
        range_min: f.range_min,
        range_max: f.range_max,
        range_max_id: f.range_max_id,
        fov: f.fov,
        ignore_zloc: f.ignore_zloc,
    }
}

/// Gripper properties.
pub(crate) fn gripper(g: &wm::GripperSpec) -> GripperDesc {
    GripperDesc {
        paddle_size: g.paddle_size,
        closed: g.paddle_state.paddles == wm::Paddles::Closed,
        up: g.paddle_state.lift == wm::Lift::Up,
        autosnatch: g.autosnatch,
    }
}

/// Camera properties (the worldfile keeps Stage's raw degrees for the camera).
pub(crate) fn camera(c: &wm::CameraSpec) -> CameraDesc {
    CameraDesc {
        resolution: [
            c.resolution[0].clamp(1, 4096) as u32,
            c.resolution[1].clamp(1, 4096) as u32,
        ],
        range: c.range,
        fov: [c.fov[0].to_radians(), c.fov[1].to_radians()],
        pantilt: [c.pantilt[0].to_radians(), c.pantilt[1].to_radians()],
    }
}

/// Actuator properties; a zero axis becomes (1, 0, 0) as in Stage.
pub(crate) fn actuator(a: &wm::ActuatorSpec) -> ActuatorDesc {
    let len = a.axis.iter().map(|v| v * v).sum::<f64>().sqrt();
    let axis = if len > 0.0 {
        [a.axis[0] / len, a.axis[1] / len, a.axis[2] / len]
    } else {
        [1.0, 0.0, 0.0]
    };
    ActuatorDesc {
        kind: match a.actuator_type {
            wm::ActuatorType::Linear => ActuatorKind::Linear,
            wm::ActuatorType::Rotational => ActuatorKind::Rotational,
        },
        axis,
        min_position: a.min_position,
        max_position: a.max_position,
        max_speed: a.max_speed,
        start_position: a.start_position.unwrap_or(0.0),
    }
}

/// World-level settings with an empty model list.
pub(crate) fn settings(s: &WorldSettings, name: String) -> WorldDesc {
    WorldDesc {
        name,
        interval_sim_us: s.interval_sim_usec().max(1),
        quit_time_us: s.quit_time_usec(),
        resolution: s.resolution,
        speedup: s.speedup,
        paused: s.paused,
        threads: s.threads.max(1) as usize,
        show_clock: s.show_clock,
        show_clock_interval: s.show_clock_interval.max(1) as u64,
        models: Vec::new(),
    }
}

fn kind(m: &ModelSpec, warnings: &mut Vec<String>, rng: &mut SimRng) -> KindDesc {
    match &m.spec {
        TypeSpec::Model => KindDesc::Model,
        TypeSpec::Position(p) => KindDesc::Position(position(p)),
        TypeSpec::Ranger(r) => KindDesc::Ranger(r.sensors.iter().map(|s| sensor(s, rng)).collect()),
        TypeSpec::Laser(l) => {
            warnings.push(format!(
                "model {}: Stage 3 `laser` simulated as a ranger with one {}-sample sensor",
                m.name, l.samples
            ));
            KindDesc::Ranger(vec![sensor(&l.as_sensor(), rng)])
        }
        TypeSpec::Blobfinder(b) => KindDesc::Blobfinder(blobfinder(b)),
        TypeSpec::Fiducial(f) => KindDesc::Fiducial(fiducial(f)),
        TypeSpec::Gripper(g) => KindDesc::Gripper(gripper(g)),
        TypeSpec::Camera(c) => KindDesc::Camera(camera(c)),
        TypeSpec::Actuator(a) => KindDesc::Actuator(actuator(a)),
        TypeSpec::Blinkenlight(b) => KindDesc::Blinkenlight {
            period_ms: b.period.clamp(0, u32::MAX as i64) as u32,
            dutycycle: b.dutycycle,
        },
        TypeSpec::Lightindicator => KindDesc::LightIndicator,
        TypeSpec::Wifi(_) => {
            warnings.push(format!(
                "model {}: Stage 3 `wifi` is not simulated (no radio model); it is a plain model",
                m.name
            ));
            KindDesc::Model
        }
    }
}

/// Translates a resolved worldfile into a world description; `seed` draws random colours.
pub fn desc_from_spec(spec: &WorldSpec, seed: u64) -> (WorldDesc, Vec<String>) {
    let s = &spec.settings;
    let mut warnings = Vec::new();
    let mut models = Vec::with_capacity(spec.models.len());
    for m in &spec.models {
        let mut rng = SimRng::new(seed ^ 0xc010_5eed, m.id as u64);
        let kind = kind(m, &mut warnings, &mut rng);
        let c = &m.common;
        models.push(ModelDesc {
            name: m.name.clone(),
            aliases: vec![m.generated_name.clone()],
            parent: m.parent,
            pose: pose(m.pose),
            size: m.size,
            origin: pose(m.origin),
            color: color(&m.color, &mut rng),
            blocks: m
                .blocks
                .iter()
                .map(|b| BlockDesc {
                    points: b.points.clone(),
                    zmin: b.z[0],
                    zmax: b.z[1],
                    color: b.color,
                })
                .collect(),
            default_body: false,
            stack_children: c.stack_children,
            obstacle_return: c.obstacle_return,
            ranger_return: c.ranger_return,
            fiducial_return: c.fiducial_return.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
            fiducial_key: c.fiducial_key.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
            gripper_return: c.gripper_return,
            update_interval_us: (c.update_interval.max(1) as u64).saturating_mul(1000),
            alwayson: c.alwayson,
            ctrl: c.ctrl.clone(),
            say: c.say.clone(),
            mass: c.mass,
            source: m
                .location
                .as_ref()
                .map(|l| l.to_string())
                .unwrap_or_default(),
            kind,
        });
    }
    let name = if s.name.is_empty() {
        spec.path.clone()
    } else {
        s.name.clone()
    };
    let desc = WorldDesc {
        models,
        ..settings(s, name)
    };
    (desc, warnings)
}

impl World {
    /// Builds a world from the `worldfile` crate's resolved model tree.
    pub fn from_spec(spec: &WorldSpec, seed: u64) -> Result<World> {
        let (desc, warnings) = desc_from_spec(spec, seed);
        let mut w = World::from_desc(&desc, seed)?;
        w.add_warnings(warnings);
        Ok(w)
    }

    /// Loads a worldfile (Stage's `STAGEPATH` honoured) and builds its world.
    pub fn load(path: &Path, seed: u64) -> Result<(World, WorldSpec)> {
        World::load_with(path, &LoadOptions::from_env(), seed)
    }

    /// [`World::load`] with explicit loader options (search path, limits).
    pub fn load_with(path: &Path, opts: &LoadOptions, seed: u64) -> Result<(World, WorldSpec)> {
        let spec = WorldSpec::load(path, opts)?;
        let w = World::from_spec(&spec, seed)?;
        Ok((w, spec))
    }
}
