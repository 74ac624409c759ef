//! Translation of the `worldfile` crate's resolved [`WorldSpec`] into a [`WorldDesc`]: types,
//! units and defaults are already resolved there, so this is a field-by-field mapping plus the
//! seeded choices Stage makes at random (`color "random"`, default odometry errors).

use std::path::Path;

use worldfile::LoadOptions;
use worldfile::world::WorldSpec;

use crate::desc::*;
use crate::error::Result;
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::world::World;

/// Translates a resolved worldfile into a world description; `seed` draws random colours.
pub fn desc_from_spec(spec: &WorldSpec, seed: u64) -> (WorldDesc, Vec<String>) {
    let s = &spec.settings;
    let mut warnings = Vec::new();
    let mut models = Vec::with_capacity(spec.models.len());
    for m in &spec.models {
        let mut rng = SimRng::new(seed ^ 0xc010_5eed, m.id as u64);
        let kind = KindDesc::from_spec(m, &mut warnings, &mut rng);
        let c = &m.common;
        models.push(ModelDesc {
            name: m.name.clone(),
            aliases: vec![m.generated_name.clone()],
            parent: m.parent,
            pose: Pose::from_array(m.pose),
            size: m.size,
            origin: Pose::from_array(m.origin),
            color: crate::color::from_spec(&m.color, &mut rng),
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
            returns: Returns {
                obstacle: c.obstacle_return,
                ranger: c.ranger_return,
                fiducial: c.fiducial_return.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
                fiducial_key: c.fiducial_key.clamp(i32::MIN as i64, i32::MAX as i64) as i32,
                gripper: c.gripper_return,
            },
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
        ..WorldDesc::from_settings(s, name)
    };
    (desc, warnings)
}

impl World {
    /// Builds a world from the `worldfile` crate's resolved model tree.
    pub fn from_spec(spec: &WorldSpec, seed: u64) -> Result<World> {
        let (desc, warnings) = desc_from_spec(spec, seed);
        World::from_translated(desc, warnings, seed)
    }

    /// [`World::from_spec`], releasing the model tree once it is translated: a large world's
    /// resolved tree, its description and the world itself are each tens of megabytes, and
    /// the tree need not outlive the translation (peak memory of a 10,000-robot load, issue 21).
    pub fn from_owned_spec(spec: WorldSpec, seed: u64) -> Result<World> {
        let (desc, warnings) = desc_from_spec(&spec, seed);
        drop(spec);
        World::from_translated(desc, warnings, seed)
    }

    /// The world of a description translated from a spec, carrying the translation's
    /// warnings. The description is the caller's own temporary, so it is built from as owned
    /// ([`World::from_owned_desc`]: the same world, less memory at its peak).
    fn from_translated(desc: WorldDesc, warnings: Vec<String>, seed: u64) -> Result<World> {
        let mut w = World::from_owned_desc(desc, seed)?;
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
