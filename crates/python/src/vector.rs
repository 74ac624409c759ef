//! `VectorCore`: the whole per-step work of `VectorStageEnv` for the built-in tasks (`"goal"`,
//! `"explore"`, or none), in native code.
//!
//! A vector step used to be one native call for the simulation plus Python around it: the
//! actions clipped and turned into lists, dozens of arguments converted, readings split,
//! rewards and terminations computed in numpy, autoreset flags kept in arrays. With the
//! simulation on every core, that serial share capped the speed-up (Amdahl). Here the copies'
//! worlds, goals, distances, step counts and autoreset flags live natively; a step takes the
//! action array as one buffer and writes observations, rewards, flags and infos into one
//! block the Python side allocated, which it reads through numpy views. Only resets (once per
//! episode) stay in Python.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes};
use rayon::prelude::*;
use stage_sim::{ModelId, on_sim_threads};

use crate::explore::ExploreMap;
use crate::world::{World, explore_map, observe_one, sim_err, step_n};

/// The `"goal"` task's parameters (see `StageEnv`'s docstring for their meaning).
#[derive(Clone, Copy, Debug)]
pub struct GoalTask {
    /// Reached within this distance (m) of the goal.
    pub tolerance: f64,
    /// Added when the goal is reached.
    pub reward: f64,
    /// Taken off on a step that ends stalled.
    pub stall_penalty: f64,
    /// Whether a stall ends the episode.
    pub terminate_on_stall: bool,
}

/// What one step of the goal task gives: `(reward, reached, terminated)`.
///
/// The reward is the decrease of the distance to the goal (`before - distance`), minus
/// `stall_penalty` when the robot stalled, plus `reward` when it ends within `tolerance` of the
/// goal (`distance <= tolerance`), which terminates the episode; a stall terminates it too with
/// `terminate_on_stall`. The one definition of the formula: `StageEnv`, `parallel_env` (through
/// [`goal_reward`]) and `VectorStageEnv` (through [`VectorCore`]) all compute it here, in this
/// order of float operations, so their rewards agree to the bit.
pub fn goal_outcome(task: &GoalTask, before: f64, distance: f64, stall: bool) -> (f64, bool, bool) {
    let mut reward = before - distance;
    if stall {
        reward -= task.stall_penalty;
    }
    let reached = distance <= task.tolerance;
    if reached {
        reward += task.reward;
    }
    (
        reward,
        reached,
        reached || (stall && task.terminate_on_stall),
    )
}

/// The goal task's step as [`goal_outcome`] computes it: `(reward, reached, terminated)` from
/// the distance to the goal `before` and after (`distance`) the step and its stall flag.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn goal_reward(
    before: f64,
    distance: f64,
    stall: bool,
    goal_tolerance: f64,
    goal_reward: f64,
    stall_penalty: f64,
    terminate_on_stall: bool,
) -> (f64, bool, bool) {
    let task = GoalTask {
        tolerance: goal_tolerance,
        reward: goal_reward,
        stall_penalty,
        terminate_on_stall,
    };
    goal_outcome(&task, before, distance, stall)
}

/// `x` clipped to `[lo, hi]` by `StageEnv`'s rule (`_clip`): a NaN stays NaN, a value not
/// strictly inside a bound becomes the bound (so `-0.0` against a bound of `0.0` gives `0.0`).
fn clip(x: f64, lo: f64, hi: f64) -> f64 {
    let x = if x.is_nan() || x > lo { x } else { lo };
    if x.is_nan() || x < hi { x } else { hi }
}

/// One copy's episode as the core keeps it.
struct Episode {
    /// Its current world (None before its first reset), with the robot's and its rangers'
    /// ids in it, looked up once per episode.
    world: Option<(Py<World>, Ids)>,
    goal: [f64; 2],
    /// The distance to the goal after the last step (or the reset).
    distance: f64,
    /// Actions taken this episode.
    steps: u64,
    /// The episode ended at the last step: the next step resets the copy instead (Gymnasium's
    /// next-step autoreset), which the Python side does, then calls `begin`.
    pending: bool,
}

/// A robot's id and its rangers' ids, in the observation's order.
type Ids = (ModelId, Vec<ModelId>);

/// One section of the output block: `(key, dtype, shape, byte offset)`.
type Section = (String, &'static str, Vec<usize>, usize);

/// The native half of `VectorStageEnv` for the built-in tasks (or none) on `Dict`
/// observations: `VectorCore(num_envs, robot, rangers, omni, low, high, frame_skip,
/// max_episode_steps, goal=None, explore=None)`, `goal` being `(goal_tolerance, goal_reward,
/// stall_penalty, terminate_on_stall)` for the goal task, `explore` `(stall_penalty,
/// terminate_on_stall)` for the explore task (whose map of the robot each world holds, from
/// `World.explore_begin`). It holds every copy's world and episode state; `begin` starts a
/// copy's episode after the Python side reset it; `step` does the rest.
#[pyclass(module = "playerstage._native")]
pub struct VectorCore {
    robot: String,
    /// `(name, samples, range_max)` of each ranger in the observation, in its order.
    rangers: Vec<(String, usize, f64)>,
    omni: bool,
    low: Vec<f64>,
    high: Vec<f64>,
    frame_skip: u64,
    max_steps: Option<u64>,
    goal: Option<GoalTask>,
    /// The explore task's `(stall_penalty, terminate_on_stall)`.
    explore: Option<(f64, bool)>,
    copies: Vec<Episode>,
    sections: Vec<Section>,
    size: usize,
}

impl VectorCore {
    /// The action rows of `actions` (native float64 bytes), checked to be one per copy.
    fn actions(&self, actions: &Bound<'_, PyBytes>) -> PyResult<Vec<f64>> {
        let (n, dim) = (self.copies.len(), self.low.len());
        let raw = actions.as_bytes();
        if raw.len() != n * dim * 8 {
            return Err(PyValueError::new_err(format!(
                "VectorCore: {} bytes of actions for {n} envs of {dim} float64",
                raw.len()
            )));
        }
        Ok(raw
            .chunks_exact(8)
            .map(|b| f64::from_ne_bytes(b.try_into().expect("8 bytes")))
            .collect())
    }

    /// The speed command `[vx, vy, va]` of one action: clipped to the box by `StageEnv`'s
    /// rule, `(forward, turn)` of a diff or car drive as `[forward, 0, turn]`.
    fn command(&self, action: &[f64]) -> [f64; 3] {
        let c: Vec<f64> = action
            .iter()
            .zip(self.low.iter().zip(&self.high))
            .map(|(&x, (&lo, &hi))| clip(x, lo, hi))
            .collect();
        if self.omni {
            [c[0], c[1], c[2]]
        } else {
            [c[0], 0.0, c[1]]
        }
    }
}

/// Writes `values` as native-endian bytes into `dst` (exactly their size).
fn put<const N: usize, T: Copy>(dst: &mut [u8], values: &[T], bytes: fn(T) -> [u8; N]) {
    for (chunk, v) in dst.chunks_exact_mut(N).zip(values) {
        chunk.copy_from_slice(&bytes(*v));
    }
}

/// `buf` cut into each copy's rows: `rows[i][k]` is copy `i`'s part of section `k` (the
/// sections laid out by `VectorCore::new`, each `n` rows then padding).
fn row_slices<'b>(buf: &'b mut [u8], sections: &[Section], n: usize) -> Vec<Vec<&'b mut [u8]>> {
    let mut rows: Vec<Vec<&'b mut [u8]>> =
        (0..n).map(|_| Vec::with_capacity(sections.len())).collect();
    let mut rest = buf;
    let mut at = 0;
    for (_, dtype, shape, offset) in sections {
        let item = match *dtype {
            "float64" | "int64" => 8,
            "float32" => 4,
            _ => 1,
        };
        let row = shape[1..].iter().product::<usize>() * item;
        let (_, tail) = std::mem::take(&mut rest).split_at_mut(offset - at);
        let (part, tail) = tail.split_at_mut(row * n);
        rest = tail;
        at = offset + row * n;
        if row == 0 {
            // a ranger of no samples: an empty row each, so section indices stay put
            rows.iter_mut().for_each(|r| r.push(Default::default()));
        } else {
            for (r, chunk) in rows.iter_mut().zip(part.chunks_exact_mut(row)) {
                r.push(chunk);
            }
        }
    }
    rows
}

/// What scoring a copy's step needs besides its world and episode.
struct Scoring<'a> {
    rangers: &'a [(String, usize, f64)],
    goal: Option<GoalTask>,
    explore: Option<(f64, bool)>,
    max_steps: Option<u64>,
}

impl Scoring<'_> {
    /// Reads `world` after a step (`running`: it has not reached `quit_time`), scores it for
    /// `copy` (reward, termination, truncation; the episode's distance, step count and
    /// autoreset flag updated) and writes the copy's rows `out` (one per section, in
    /// `VectorCore::new`'s order), as `StageEnv` computes them.
    fn score(
        &self,
        world: &stage_sim::World,
        map: Option<&mut ExploreMap>,
        copy: &mut Episode,
        running: bool,
        out: &mut [&mut [u8]],
    ) -> stage_sim::Result<()> {
        let Episode {
            world: held,
            goal: target,
            distance: before,
            steps,
            pending,
        } = copy;
        let (m, rs) = &held.as_ref().expect("a begun copy").1;
        let goal = self.goal.map(|_| *target);
        let obs = observe_one(world, *m, rs, self.rangers, goal)?;
        let nr = self.rangers.len();
        let mut from = 0;
        for ((_, samples, _), dst) in self.rangers.iter().zip(out.iter_mut()) {
            put(dst, &obs.scans[from..from + samples], f32::to_ne_bytes);
            from += samples;
        }
        let s = &obs.state;
        let odometry: [f32; 6] = std::array::from_fn(|k| s[k] as f32);
        put(out[nr], &odometry, f32::to_ne_bytes);
        let stall = s[6] != 0.0;
        put(out[nr + 1], &[i64::from(stall)], i64::to_ne_bytes);
        *steps += 1;
        let truncated = !running || self.max_steps.is_some_and(|limit| *steps >= limit);
        let (reward, terminated) = match (&self.goal, self.explore) {
            (_, Some((stall_penalty, terminate_on_stall))) => {
                // StageEnv's explore scoring: the new area, less the penalty on a stall
                let map = map.expect("checked by begin");
                let cells = map.see(world)?;
                let new = map.area(cells);
                put(out[nr + 6], &[new], f64::to_ne_bytes);
                put(out[nr + 7], &[map.explored()], f64::to_ne_bytes);
                let reward = new - if stall { stall_penalty } else { 0.0 };
                (reward, stall && terminate_on_stall)
            }
            (Some(task), None) => {
                let distance = s[10];
                let (reward, reached, terminated) = goal_outcome(task, *before, distance, stall);
                *before = distance;
                put(out[nr + 6], &[s[11] as f32, s[12] as f32], f32::to_ne_bytes);
                put(out[nr + 7], &[distance], f64::to_ne_bytes);
                out[nr + 8][0] = u8::from(reached);
                (reward, terminated)
            }
            (None, None) => (0.0, false),
        };
        put(out[nr + 2], &[reward], f64::to_ne_bytes);
        out[nr + 3][0] = u8::from(terminated);
        out[nr + 4][0] = u8::from(truncated);
        out[nr + 5][0] = u8::from(stall);
        *pending = terminated || truncated;
        Ok(())
    }
}

#[pymethods]
impl VectorCore {
    #[new]
    #[pyo3(signature = (num_envs, robot, rangers, omni, low, high, frame_skip, max_episode_steps, goal=None, explore=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        num_envs: usize,
        robot: String,
        rangers: Vec<(String, usize, f64)>,
        omni: bool,
        low: Vec<f64>,
        high: Vec<f64>,
        frame_skip: u64,
        max_episode_steps: Option<u64>,
        goal: Option<(f64, f64, f64, bool)>,
        explore: Option<(f64, bool)>,
    ) -> PyResult<Self> {
        if goal.is_some() && explore.is_some() {
            return Err(PyValueError::new_err(
                "VectorCore: one task, goal or explore",
            ));
        }
        let dim = if omni { 3 } else { 2 };
        if num_envs == 0 || low.len() != dim || high.len() != dim {
            return Err(PyValueError::new_err(format!(
                "VectorCore: {num_envs} envs, bounds {low:?} {high:?}: expected at least one \
                 env and {dim} bounds each"
            )));
        }
        let n = num_envs;
        // every section 8-byte aligned, so each numpy view over the block is aligned; the
        // order is the one `Scoring::score` writes a copy's rows in (by index)
        let mut sections: Vec<Section> = Vec::new();
        let mut size = 0;
        let mut add = |key: String, dtype: &'static str, shape: Vec<usize>, item: usize| {
            let bytes = shape.iter().product::<usize>() * item;
            sections.push((key, dtype, shape, size));
            size += bytes.div_ceil(8) * 8;
        };
        for (name, samples, _) in &rangers {
            add(format!("rangers/{name}"), "float32", vec![n, *samples], 4);
        }
        add("odometry".into(), "float32", vec![n, 6], 4);
        add("stall".into(), "int64", vec![n], 8);
        add("reward".into(), "float64", vec![n], 8);
        add("terminated".into(), "bool", vec![n], 1);
        add("truncated".into(), "bool", vec![n], 1);
        add("stall_flag".into(), "bool", vec![n], 1);
        if goal.is_some() {
            add("goal".into(), "float32", vec![n, 2], 4);
            add("distance".into(), "float64", vec![n], 8);
            add("reached".into(), "bool", vec![n], 1);
        }
        if explore.is_some() {
            add("new_area".into(), "float64", vec![n], 8);
            add("explored".into(), "float64", vec![n], 8);
        }
        let goal = goal.map(
            |(tolerance, reward, stall_penalty, terminate_on_stall)| GoalTask {
                tolerance,
                reward,
                stall_penalty,
                terminate_on_stall,
            },
        );
        let copies = (0..n)
            .map(|_| Episode {
                world: None,
                goal: [0.0; 2],
                distance: 0.0,
                steps: 0,
                pending: false,
            })
            .collect();
        Ok(VectorCore {
            robot,
            rangers,
            omni,
            low,
            high,
            frame_skip,
            max_steps: max_episode_steps,
            goal,
            explore,
            copies,
            sections,
            size,
        })
    }

    /// The output block's layout: its size in bytes and its sections `(key, dtype, shape,
    /// byte offset)`; `rangers/NAME` are the ranger observations, `stall_flag` the infos'
    /// bool stall, the rest what their names say.
    fn layout(&self) -> (usize, Vec<Section>) {
        (self.size, self.sections.clone())
    }

    /// Starts copy `i`'s episode on `world` once the Python side reset it: its goal (the goal
    /// task), the distance to it after the reset's first step, and the actions taken so far
    /// (0). The robot and rangers are looked up here, once per episode: a world without them
    /// raises `WorldError` naming the model.
    #[pyo3(signature = (i, world, goal, distance, steps))]
    fn begin(
        &mut self,
        i: usize,
        world: Bound<'_, World>,
        goal: Option<[f64; 2]>,
        distance: f64,
        steps: u64,
    ) -> PyResult<()> {
        if i >= self.copies.len() {
            return Err(PyValueError::new_err(format!(
                "VectorCore.begin: copy {i} of {}",
                self.copies.len()
            )));
        }
        if self.goal.is_some() && goal.is_none() {
            return Err(PyValueError::new_err(
                "VectorCore.begin: the goal task needs a goal",
            ));
        }
        let ids = {
            let mut w = world.borrow_mut();
            if self.explore.is_some() && explore_map(&mut w.explore, &self.robot).is_none() {
                return Err(PyValueError::new_err(
                    "VectorCore.begin: the explore task needs the world's map (explore_begin)",
                ));
            }
            let m = w.sensor(&self.robot, "position model", |sim, m| {
                sim.position_state(m).map(|_| m)
            })?;
            let mut rs = Vec::with_capacity(self.rangers.len());
            for (name, _, _) in &self.rangers {
                rs.push(w.sensor(name, "ranger", |sim, r| sim.ranger_scans(r).map(|_| r))?);
            }
            (m, rs)
        };
        self.copies[i] = Episode {
            world: Some((world.unbind(), ids)),
            goal: goal.unwrap_or_default(),
            distance,
            steps,
            pending: false,
        };
        Ok(())
    }

    /// The copies whose episode ended at the last step (the next step resets them).
    fn pending(&self) -> Vec<usize> {
        (0..self.copies.len())
            .filter(|&i| self.copies[i].pending)
            .collect()
    }

    /// The speed commands `[vx, vy, va]` that `step` would send each copy for `actions` (as
    /// `step` takes them): each action clipped to the box by `StageEnv`'s rule, `(forward,
    /// turn)` of a diff or car drive as `[forward, 0, turn]`.
    fn commands(&self, actions: &Bound<'_, PyBytes>) -> PyResult<Vec<[f64; 3]>> {
        let acts = self.actions(actions)?;
        Ok(acts
            .chunks_exact(self.low.len())
            .map(|a| self.command(a))
            .collect())
    }

    /// One vector step: `actions` (the `num_envs` rows of actions as one buffer of native
    /// float64, e.g. a C-ordered array's `tobytes()`) clipped to the action box by
    /// `StageEnv`'s rule and commanded to every copy not pending an autoreset; then, on the
    /// simulation's pool with the GIL released, each such copy's world stepped `frame_skip`
    /// times, read, scored and written into its rows of the block. Returns the block (a
    /// bytearray laid out as `layout` says, so numpy views over it are writable) and the
    /// copies pending an autoreset, whose rows are left zero for the Python side to fill with
    /// their new episodes' first observations.
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: &Bound<'py, PyBytes>,
    ) -> PyResult<(Bound<'py, PyByteArray>, Vec<usize>)> {
        let n = self.copies.len();
        let dim = self.low.len();
        let acts = self.actions(actions)?;
        if let Some(i) = (0..n).find(|&i| self.copies[i].world.is_none()) {
            return Err(PyRuntimeError::new_err(format!(
                "VectorStageEnv: copy {i} was never reset; call reset() before step()"
            )));
        }
        let skipped: Vec<usize> = (0..n).filter(|&i| self.copies[i].pending).collect();

        // every stepped copy's world borrowed and commanded (serial: a few microseconds)
        let mut held = Vec::with_capacity(n - skipped.len());
        for (i, c) in self.copies.iter().enumerate().filter(|(_, c)| !c.pending) {
            let (w, ids) = c.world.as_ref().expect("checked above");
            let mut w = w.bind(py).try_borrow_mut().map_err(|_| {
                PyRuntimeError::new_err("VectorStageEnv.step: a copy's world is in use elsewhere")
            })?;
            let v = self.command(&acts[i * dim..(i + 1) * dim]);
            w.world
                .position_cmd_vel(ids.0, v[0], v[1], v[2])
                .map_err(sim_err)?;
            held.push(w);
        }

        let VectorCore {
            robot,
            rangers,
            frame_skip,
            max_steps,
            goal,
            explore,
            copies,
            sections,
            size,
            ..
        } = self;
        let (frame_skip, max_steps, goal, explore) = (*frame_skip, *max_steps, *goal, *explore);
        let rangers = &*rangers;
        let block = PyByteArray::new_with(py, *size, |buf| {
            // each copy's rows of every section: disjoint slices, so each copy is scored and
            // written on its own thread and nothing is left serial but handing out the block
            let mut rows = row_slices(buf, sections, n);
            let jobs: Vec<_> = held
                .iter_mut()
                .zip(
                    copies
                        .iter_mut()
                        .zip(rows.iter_mut())
                        .filter(|(c, _)| !c.pending),
                )
                .map(|(w, (c, out))| {
                    let w = &mut **w;
                    let map = explore_map(&mut w.explore, robot);
                    ((&mut w.world, &mut w.tracks, map), (c, out))
                })
                .collect();
            let done: Vec<stage_sim::Result<()>> = py.allow_threads(|| {
                on_sim_threads(|| {
                    jobs.into_par_iter()
                        .map(|((world, tracks, map), (copy, out))| {
                            let running = step_n(world, tracks, frame_skip);
                            let task = Scoring {
                                rangers,
                                goal,
                                explore,
                                max_steps,
                            };
                            task.score(world, map, copy, running, out)
                        })
                        .collect()
                })
            });
            done.into_iter().try_for_each(|r| r.map_err(sim_err))
        })?;
        Ok((block, skipped))
    }

    /// Copy `i`'s current world (None before its first reset).
    fn world(&self, py: Python<'_>, i: usize) -> Option<Py<World>> {
        self.copies
            .get(i)
            .and_then(|c| c.world.as_ref().map(|w| w.0.clone_ref(py)))
    }
}
