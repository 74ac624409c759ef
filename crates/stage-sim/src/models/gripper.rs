//! `gripper` (spec §11): paddles that open/close and lift, two break beams, two contact rays,
//! grasping and carrying `gripper_return` models.

use super::ModelKind;
use crate::block::BlockDesc;
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::space::RayQuery;
use crate::view::View;
use std::f64::consts::FRAC_PI_2;
use worldfile::models as wm;

/// Gripper properties (spec §11.1).
#[derive(Clone, Debug, PartialEq)]
pub struct GripperDesc {
    /// Paddle length, width, height as fractions of the gripper size.
    pub paddle_size: [f64; 3],
    /// Initially closed.
    pub closed: bool,
    /// Initially lifted.
    pub up: bool,
    /// Beams drive the paddles.
    pub autosnatch: bool,
}

default_from_spec!(GripperDesc);

/// Paddle (or lift) state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PaddleState {
    /// Fully open.
    Open,
    /// Fully closed (or closed on an object).
    Closed,
    /// Opening.
    Opening,
    /// Closing.
    Closing,
}

/// Lift state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LiftState {
    /// Up.
    Up,
    /// Down.
    Down,
    /// Going up.
    Upping,
    /// Going down.
    Downing,
}

/// A gripper command; it persists until replaced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GripperCmd {
    /// Open the paddles (drops a carried object).
    Open,
    /// Close the paddles (grasps a `gripper_return` model between them).
    Close,
    /// Lift.
    Up,
    /// Lower.
    Down,
}

/// What a server publishes for a gripper.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GripperData {
    /// Sim time of the update (µs).
    pub time_us: u64,
    /// Paddle state.
    pub paddles: PaddleState,
    /// Lift state.
    pub lift: LiftState,
    /// Paddle position, 0 open … 1 closed.
    pub paddle_pos: f64,
    /// Lift position, 0 down … 1 up.
    pub lift_pos: f64,
    /// Model breaking each beam (inner beam 0, outer beam 1).
    pub beams: [Option<ModelId>; 2],
    /// Model touching each paddle (left, right).
    pub contacts: [Option<ModelId>; 2],
    /// Paddles blocked by a contact.
    pub paddles_stalled: bool,
    /// The model being carried.
    pub carrying: Option<ModelId>,
}

/// A re-parenting decided during the update and applied after it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum GripAction {
    Grasp(ModelId),
    Release(ModelId),
}

/// Gripper state.
#[derive(Clone, Debug)]
pub struct GripperModel {
    /// Configuration.
    pub cfg: GripperDesc,
    /// Current command.
    pub cmd: GripperCmd,
    /// Latest data.
    pub data: GripperData,
    pub(crate) close_limit: f64,
    pub(crate) action: Option<GripAction>,
    pub(crate) body_changed: bool,
}

pub(crate) fn desc_from_spec(g: &wm::GripperSpec, _: &mut SimRng) -> GripperDesc {
    GripperDesc {
        paddle_size: g.paddle_size,
        closed: g.paddle_state.paddles == wm::Paddles::Closed,
        up: g.paddle_state.lift == wm::Lift::Up,
        autosnatch: g.autosnatch,
    }
}

pub(crate) fn start(desc: &GripperDesc, _: &Pose, _: &mut SimRng) -> GripperModel {
    GripperModel::new(desc.clone())
}

impl ModelKind for GripperModel {
    fn own_blocks(&self, size: [f64; 3]) -> Option<Vec<BlockDesc>> {
        Some(self.blocks(size))
    }

    fn ray_cost(&self) -> usize {
        4
    }

    /// One gripper update (spec §11.3).
    fn update(&mut self, v: &View, m: ModelId, _: &Pose, node: &Node, _: &mut SimRng) {
        let g = self;
        let d = &mut g.data;
        g.action = None;
        match g.cmd {
            GripperCmd::Close if d.paddles != PaddleState::Closed => {
                d.paddles = PaddleState::Closing
            }
            GripperCmd::Open if d.paddles != PaddleState::Open => d.paddles = PaddleState::Opening,
            GripperCmd::Up if d.lift != LiftState::Up => d.lift = LiftState::Upping,
            GripperCmd::Down if d.lift != LiftState::Down => d.lift = LiftState::Downing,
            _ => {}
        }
        let mut changed = false;
        match d.paddles {
            PaddleState::Opening => {
                if travel(&mut d.paddle_pos, -TRAVEL, 0.0) {
                    d.paddles = PaddleState::Open;
                }
                if let Some(obj) = d.carrying {
                    if d.paddle_pos == 0.0 || d.paddle_pos < g.close_limit {
                        g.action = Some(GripAction::Release(obj));
                        d.carrying = None;
                        g.close_limit = 1.0;
                    }
                }
                changed = true;
            }
            PaddleState::Closing => {
                if travel(&mut d.paddle_pos, TRAVEL, g.close_limit) {
                    d.paddles = PaddleState::Closed;
                }
                changed = true;
            }
            _ => {}
        }
        match d.lift {
            LiftState::Downing => {
                if travel(&mut d.lift_pos, -TRAVEL, 0.0) {
                    d.lift = LiftState::Down;
                }
                changed = true;
            }
            LiftState::Upping => {
                if travel(&mut d.lift_pos, TRAVEL, 1.0) {
                    d.lift = LiftState::Up;
                }
                changed = true;
            }
            _ => {}
        }
        g.body_changed |= changed;

        let [sx, sy, _] = node.size;
        let [px, py, _] = g.cfg.paddle_size;
        let pos = d.paddle_pos;
        let frame = v.body_frame(m);
        let pred = |h: ModelId| h != m && v.returns[h.index()].gripper;
        let cast = |x: f64, y: f64, a: f64, len: f64| -> Option<ModelId> {
            if len <= 0.0 {
                return None;
            }
            let o = frame.compose(&Pose { x, y, z: 0.0, a });
            v.space
                .raycast(
                    &RayQuery {
                        x: o.x,
                        y: o.y,
                        a: o.a,
                        range: len,
                        z: None,
                    },
                    pred,
                )
                .map(|h| h.model)
        };
        let gap_y = (1.0 - pos) * (sy / 2.0 - sy * py);
        let beam_len = (1.0 - pos) * (sy - 2.0 * sy * py);
        for (i, inset) in [0.75 * px, 0.25 * px].into_iter().enumerate() {
            let x = sx * (1.0 - inset) - sx / 2.0;
            d.beams[i] = cast(x, gap_y, -FRAC_PI_2, beam_len);
        }
        if g.cfg.autosnatch {
            g.cmd = if d.beams.iter().any(Option::is_some) {
                GripperCmd::Close
            } else {
                GripperCmd::Open
            };
        }
        let cx = (1.0 - px) * sx - sx / 2.0;
        d.contacts[0] = cast(cx, gap_y, 0.0, px * sx);
        d.contacts[1] = cast(cx, -gap_y, 0.0, px * sx);
        d.paddles_stalled = false;
        if let Some(hit) = d.contacts[0].or(d.contacts[1]) {
            d.paddles_stalled = true;
            if d.paddles == PaddleState::Closing && d.carrying.is_none() && g.action.is_none() {
                let osy = v.nodes[hit.index()].size[1];
                g.close_limit = (1.0 - osy / (sy - py / 2.0)).max(0.0);
                d.carrying = Some(hit);
                g.action = Some(GripAction::Grasp(hit));
            }
        }
        d.time_us = v.sim_time;
    }

    /// Feeds the last command and the paddle, lift, beam and carrying state to the
    /// determinism digest.
    fn digest(&self, d: &mut Digest) {
        d.u64(self.cmd as u64);
        let s = &self.data;
        d.u64(s.time_us);
        d.u64(((s.paddles as u64) << 8) | s.lift as u64);
        d.f64(s.paddle_pos);
        d.f64(s.lift_pos);
        s.beams.iter().chain(&s.contacts).for_each(|&m| d.model(m));
        d.u64(s.paddles_stalled as u64);
        d.model(s.carrying);
    }
}

impl GripperModel {
    /// A gripper in its initial state.
    pub fn new(cfg: GripperDesc) -> Self {
        let pos = if cfg.closed { 1.0 } else { 0.0 };
        let lift = if cfg.up { 1.0 } else { 0.0 };
        GripperModel {
            cmd: if cfg.closed {
                GripperCmd::Close
            } else {
                GripperCmd::Open
            },
            data: GripperData {
                time_us: 0,
                paddles: if cfg.closed {
                    PaddleState::Closed
                } else {
                    PaddleState::Open
                },
                lift: if cfg.up {
                    LiftState::Up
                } else {
                    LiftState::Down
                },
                paddle_pos: pos,
                lift_pos: lift,
                beams: [None; 2],
                contacts: [None; 2],
                paddles_stalled: false,
                carrying: None,
            },
            cfg,
            close_limit: 1.0,
            action: None,
            body_changed: false,
        }
    }

    /// The three blocks (base + two paddles) for the current state, in the body frame of a
    /// gripper of `size`: the worldfile crate's layout and size scaling (spec §11.2, §2.3).
    pub fn blocks(&self, size: [f64; 3]) -> Vec<BlockDesc> {
        let raw = worldfile::body::gripper_blocks(
            self.cfg.paddle_size,
            self.data.paddle_pos,
            self.data.lift_pos,
        );
        let (scaled, _) = worldfile::body::scale(&raw, size);
        scaled
            .into_iter()
            .map(|b| BlockDesc {
                points: b.points,
                zmin: b.z[0],
                zmax: b.z[1],
                color: b.color,
            })
            .collect()
    }
}

/// How far paddles and lift move in one update (of their 0 … 1 travel).
const TRAVEL: f64 = 0.05;

/// Moves `pos` by `delta` (one update's travel, negative to lower), stopping at `limit`;
/// whether it got there.
fn travel(pos: &mut f64, delta: f64, limit: f64) -> bool {
    *pos += delta;
    let arrived = if delta < 0.0 {
        *pos < limit
    } else {
        *pos > limit
    };
    if arrived {
        *pos = limit;
    }
    arrived
}
