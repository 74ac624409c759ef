//! Building a world from its description.

use std::collections::HashMap;

use crate::controller::{self, Controller};
use crate::desc::{KindDesc, ModelDesc, WorldDesc};
use crate::error::{Error, Result};
use crate::models::KindState;
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::space::{Body, Space};

use super::tree::*;
use super::*;

/// The models' type-specific descriptions when the world takes them from its description
/// ([`World::from_owned_desc`]), in model order; each is released once its state is made.
type OwnedKinds = Vec<KindDesc>;

/// Model `i`'s type-specific description: from `kinds` when the world took them, else from
/// the description.
fn kind_of<'a>(desc: &'a WorldDesc, kinds: &'a Option<OwnedKinds>, i: usize) -> &'a KindDesc {
    match kinds {
        Some(kinds) => &kinds[i],
        None => &desc.models[i].kind,
    }
}

impl World {
    /// Builds a world from a description; `seed` drives every random choice.
    pub fn from_desc(desc: &WorldDesc, seed: u64) -> Result<World> {
        World::build(desc, None, seed)
    }

    /// [`World::from_desc`] on a description it owns: each model's type-specific description
    /// (a ranger's sensors: 16 MB in a 10,000-robot swarm) is released as soon as the model's
    /// state is made from it, so that the description and the world never both hold all of
    /// them (peak memory of a large load, issue 21). The same world as [`World::from_desc`].
    pub fn from_owned_desc(mut desc: WorldDesc, seed: u64) -> Result<World> {
        let kinds: OwnedKinds = desc
            .models
            .iter_mut()
            .map(|m| std::mem::replace(&mut m.kind, KindDesc::Model))
            .collect();
        World::build(&desc, Some(kinds), seed)
    }

    /// Builds a world from a description, with the models' type-specific descriptions taken
    /// out of it (`kinds`) or left in it (`None`).
    fn build(desc: &WorldDesc, mut kinds: Option<OwnedKinds>, seed: u64) -> Result<World> {
        if desc.config.interval_sim_us == 0 {
            return Err(Error::InvalidWorld("interval_sim must be positive".into()));
        }
        let n = desc.models.len();
        if n >= u32::MAX as usize {
            return Err(Error::InvalidWorld("too many models".into()));
        }
        let mut nodes: Vec<Node> = Vec::with_capacity(n);
        for (i, m) in desc.models.iter().enumerate() {
            if let Some(p) = m.parent {
                if p >= i {
                    return Err(Error::InvalidModel {
                        model: m.name.clone(),
                        source_loc: m.source.clone(),
                        msg: format!("parent index {p} is not an earlier model"),
                    });
                }
            }
            for v in m
                .size
                .iter()
                .chain([m.pose.x, m.pose.y, m.pose.z, m.pose.a].iter())
            {
                if !v.is_finite() {
                    return Err(Error::InvalidModel {
                        model: m.name.clone(),
                        source_loc: m.source.clone(),
                        msg: "pose or size is not finite".into(),
                    });
                }
            }
            let root = match m.parent {
                Some(p) => nodes[p].root,
                None => ModelId(i as u32),
            };
            if let Some(p) = m.parent {
                nodes[p].children.push(ModelId(i as u32));
            }
            nodes.push(Node {
                name: m.name.clone(),
                model_type: kind_of(desc, &kinds, i).model_type(),
                parent: m.parent.map(|p| ModelId(p as u32)),
                children: Vec::new(),
                root,
                size: m.size,
                origin: m.origin,
                stack_children: m.stack_children,
                update_interval_us: m.update_interval_us.max(1),
                mass: m.mass,
                blocks: local_blocks(m)?,
                source: m.source.clone(),
            });
        }
        let poses: Vec<Pose> = desc.models.iter().map(|m| m.pose).collect();
        let mut globals = vec![Pose::ZERO; n];
        for i in 0..n {
            globals[i] = global_of(&nodes, &globals, i, &poses[i]);
        }
        // A tree that contains a position model can move: its bodies are dynamic.
        let mut moving_root = vec![false; n];
        for i in 0..n {
            if matches!(kind_of(desc, &kinds, i), KindDesc::Position(_)) {
                moving_root[nodes[i].root.index()] = true;
            }
        }
        let dynamic: Vec<bool> = (0..n).map(|i| moving_root[nodes[i].root.index()]).collect();
        let mut bodies = vec![Body::default(); n];
        for i in 0..n {
            body_of(&nodes[i], &globals[i], &mut bodies[i]);
        }
        let space = Space::new(bodies, &dynamic, nodes.iter().map(|n| n.root).collect());

        // sized once: growing it would hash every name again at each doubling
        let aliases: usize = desc.models.iter().map(|m| m.aliases.len()).sum();
        let mut names = HashMap::with_capacity(n + aliases);
        for (i, m) in desc.models.iter().enumerate() {
            for a in &m.aliases {
                names.insert(a.clone(), ModelId(i as u32));
            }
            names.insert(m.name.clone(), ModelId(i as u32));
        }

        let mut states = Vec::with_capacity(n);
        let mut positions = Vec::new();
        let mut grippers = Vec::new();
        // the position models' states first: each is one boxed allocation, and made one after
        // another they lie side by side, so that the passes of a step over every position
        // model (control update, move plan, move) read memory in order; made between the other
        // kinds' allocations, a 10,000-robot swarm's lay ~2 KiB apart, one cache miss each
        // (each model's random stream is its own, so the order they are made in changes nothing)
        let start = |kind: &KindDesc, i: usize| {
            let mut rng = SimRng::new(seed, i as u64);
            (KindState::new(kind, &globals[i], &mut rng), rng)
        };
        // collected: made now, before any other kind's state
        let made_early: Vec<_> = (0..n)
            .filter_map(|i| match kind_of(desc, &kinds, i) {
                kind @ KindDesc::Position(_) => Some((i, start(kind, i))),
                _ => None,
            })
            .collect();
        let mut made_early = made_early.into_iter().peekable();
        for (i, m) in desc.models.iter().enumerate() {
            let (kind, rng) = match made_early.next_if(|(j, _)| *j == i) {
                Some((_, made)) => made,
                None => start(kind_of(desc, &kinds, i), i),
            };
            if let Some(kinds) = &mut kinds {
                // the state holds what it needs: the description's part is released now
                kinds[i] = KindDesc::Model;
            }
            match kind {
                KindState::Position(_) => positions.push(ModelId(i as u32)),
                KindState::Gripper(_) => grippers.push(ModelId(i as u32)),
                _ => {}
            }
            // a kind that shapes its own body (the gripper's base and paddles, spec §11.2)
            if let Some(blocks) = kind.own_blocks(m.size) {
                let tmp = ModelDesc {
                    blocks,
                    default_body: false,
                    ..m.clone()
                };
                nodes[i].blocks = local_blocks(&tmp)?;
            }
            let self_start = kind.starts_itself();
            states.push(ModelState {
                subs: 0,
                next_update: nodes[i].update_interval_us.max(1),
                self_start,
                updated_at: None,
                rng,
                kind,
            });
        }
        let returns: Vec<Returns> = desc.models.iter().map(|m| m.returns).collect();
        let fiducial_targets = fiducial_targets(&returns);

        let mut world = World {
            cfg: WorldConfig {
                threads: desc.config.threads.max(1),
                show_clock_interval: desc.config.show_clock_interval.max(1),
                ..desc.config.clone()
            },
            seed,
            sim_time: 0,
            updates: 0,
            colors: desc.models.iter().map(|m| m.color).collect(),
            says: desc.models.iter().map(|m| m.say.clone()).collect(),
            nodes,
            returns,
            poses,
            globals,
            space,
            states,
            names,
            positions,
            grippers,
            fiducial_targets,
            controllers: Vec::new(),
            warnings: Vec::new(),
            rays_cast: 0,
            due: vec![false; n],
            updated: vec![false; n],
            subtree: Vec::new(),
            scratch: Vec::new(),
            move_plans: Vec::new(),
            #[cfg(test)]
            moves_one_by_one: false,
            #[cfg(test)]
            planned_moves: 0,
        };
        // gripper bodies were replaced above: refresh their world outlines
        for i in 0..n {
            if matches!(world.states[i].kind, KindState::Gripper(_)) {
                world.refresh_subtree(ModelId(i as u32));
            }
        }
        for (i, m) in desc.models.iter().enumerate() {
            if m.alwayson {
                world.subscribe(ModelId(i as u32))?;
            }
        }
        for (i, m) in desc.models.iter().enumerate() {
            for c in &m.ctrl {
                let name = c.split_whitespace().next().unwrap_or("");
                if name.is_empty() {
                    continue;
                }
                let rng = SimRng::new(seed ^ 0x5eed_c0de, i as u64);
                match controller::builtin(name, &world, ModelId(i as u32), c, rng) {
                    Ok(Some(inst)) => world.install_controller(inst),
                    Ok(None) => {
                        let msg = format!(
                            "controller {name} is not built in; model {} runs without it",
                            m.name
                        );
                        tracing::warn!("{msg}");
                        world.warnings.push(msg);
                    }
                    Err(e) => {
                        let msg = format!("controller {name} on model {}: {e}", m.name);
                        tracing::warn!("{msg}");
                        world.warnings.push(msg);
                    }
                }
            }
        }
        Ok(world)
    }

    /// Installs a controller whose models were checked (built-in ones pick them from this
    /// world; [`World::add_controller`] checks them).
    pub(super) fn install_controller(&mut self, inst: controller::Installed) {
        for &s in &inst.subscribe {
            self.subscribe(s)
                .expect("a controller's models are checked before it is installed");
        }
        for c in inst.init {
            self.apply_logged(c);
        }
        self.controllers.push(ControllerSlot {
            trigger: inst.trigger,
            ctrl: inst.ctrl,
            cmds: controller::Commands::new(inst.model),
        });
    }

    /// Attaches a controller to `model`, called after each update of `trigger` (which is
    /// subscribed, as is `model`). Commands it emits are applied after the step's moves.
    pub fn add_controller(
        &mut self,
        model: ModelId,
        trigger: ModelId,
        ctrl: Box<dyn Controller>,
    ) -> Result<()> {
        self.check(model)?;
        self.check(trigger)?;
        self.install_controller(controller::Installed {
            model,
            trigger,
            subscribe: vec![model, trigger],
            init: Vec::new(),
            ctrl,
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A world built from a description it owns (each model's type-specific part released as
    /// its state is made) is the world built from a borrowed one, step after step.
    #[test]
    fn an_owned_description_builds_the_same_world() {
        let text = r#"
define ir sensor ( range [0 2] fov 30 samples 3 )
define bot position ( size [0.3 0.3 0.2] ranger ( ir ( pose [0 0 0 0] ) ir ( pose [0 0 0 90] ) ) ctrl "wander" )
model ( name "wall" pose [2 0 0 0] size [0.2 4 0.5] )
bot ( name "a" pose [0 0 0 0] )
bot ( name "b" pose [0 1 0 45] )
gripper ( name "g" pose [-1 0 0 0] )
"#;
        let opts = worldfile::LoadOptions::default();
        let spec = worldfile::WorldSpec::parse(std::path::Path::new("t.world"), text, &opts)
            .expect("the world parses");
        let (desc, _) = crate::spec::desc_from_spec(&spec, 7);
        let mut borrowed = World::from_desc(&desc, 7).unwrap();
        let mut owned = World::from_owned_desc(desc, 7).unwrap();
        assert_eq!(owned.model_count(), borrowed.model_count());
        let mut owned_spec = World::from_owned_spec(spec.clone(), 7).unwrap();
        let mut from_spec = World::from_spec(&spec, 7).unwrap();
        for _ in 0..20 {
            assert_eq!(owned.state_digest(), borrowed.state_digest());
            assert_eq!(owned_spec.state_digest(), from_spec.state_digest());
            for w in [&mut borrowed, &mut owned, &mut owned_spec, &mut from_spec] {
                w.step();
            }
        }
        assert_eq!(owned.state_digest(), borrowed.state_digest());
        assert_eq!(owned_spec.state_digest(), from_spec.state_digest());
    }
}
