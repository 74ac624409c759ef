//! `fiducial` finder (spec §10).

use super::ModelKind;
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pose::{Pose, normalize};
use crate::rng::SimRng;
use crate::space::RayQuery;
use crate::view::View;
use worldfile::models as wm;

/// Fiducial-finder properties (spec §10.1): the worldfile crate's, already in metres and
/// radians, which the finder uses as they are (`range_min` is read but unused by Stage, kept for
/// the Player geometry).
pub type FiducialDesc = wm::FiducialSpec;

/// One detected fiducial.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fiducial {
    /// The target's `fiducial_return`, or 0 beyond `range_max_id`.
    pub id: i32,
    /// The target model.
    pub model: ModelId,
    /// Distance between the finder's and the target's pose points (m).
    pub range: f64,
    /// Bearing relative to the finder's heading (rad).
    pub bearing: f64,
    /// Target heading relative to the finder's heading (rad).
    pub heading: f64,
    /// Target size `[x y z]`.
    pub geom: [f64; 3],
    /// Target's absolute (global) pose.
    pub pose: Pose,
}

/// A fiducial finder's latest data.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FiducialData {
    /// Sim time of the update (µs).
    pub time_us: u64,
    /// Detections in model creation order.
    pub fiducials: Vec<Fiducial>,
}

/// A fiducial finder's configuration and latest data.
#[derive(Clone, Debug)]
pub struct FiducialModel {
    /// Configuration.
    pub cfg: FiducialDesc,
    /// Latest data.
    pub data: FiducialData,
}

pub(crate) fn desc_from_spec(f: &wm::FiducialSpec, _: &mut SimRng) -> FiducialDesc {
    f.clone()
}

pub(crate) fn start(desc: &FiducialDesc, _: &Pose, _: &mut SimRng) -> FiducialModel {
    FiducialModel {
        cfg: desc.clone(),
        data: FiducialData::default(),
    }
}

impl ModelKind for FiducialModel {
    fn ray_cost(&self) -> usize {
        8
    }

    /// One fiducial-finder update.
    fn update(&mut self, v: &View, m: ModelId, _: &Pose, fnode: &Node, _: &mut SimRng) {
        let (f, cfg, d) = (m, &self.cfg, &mut self.data);
        d.fiducials.clear();
        let fg = v.globals[f.index()];
        let key = v.returns[f.index()].fiducial_key;
        let root = v.root(f);
        let frame = v.body_frame(f);
        for &h in v.fiducial_targets {
            let hr = v.returns[h.index()];
            if hr.fiducial == 0 || hr.fiducial_key != key || v.root(h) == root {
                continue;
            }
            let hg = v.globals[h.index()];
            let dx = hg.x - fg.x;
            let dy = hg.y - fg.y;
            if dx.abs() > cfg.range_max || dy.abs() > cfg.range_max {
                continue;
            }
            let dist = dx.hypot(dy);
            if dist >= cfg.range_max {
                continue;
            }
            let dtheta = normalize(dy.atan2(dx) - fg.a);
            if dtheta.abs() > cfg.fov / 2.0 {
                continue;
            }
            let ray = frame.compose(&Pose {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                a: dtheta,
            });
            let q = RayQuery {
                x: ray.x,
                y: ray.y,
                a: ray.a,
                range: cfg.range_max,
                z: Some(fg.z + fnode.origin.z),
            };
            let hit = v.space.raycast(&q, |m| v.root(m) != root);
            let visible = match hit {
                Some(hh) => hh.model == h,
                None => cfg.ignore_zloc,
            };
            if !visible {
                continue;
            }
            d.fiducials.push(Fiducial {
                id: if dist < cfg.range_max_id {
                    hr.fiducial
                } else {
                    0
                },
                model: h,
                range: dist,
                bearing: dtheta,
                heading: normalize(hg.a - fg.a),
                geom: v.nodes[h.index()].size,
                pose: hg,
            });
        }
        d.time_us = v.sim_time;
    }

    fn shutdown(&mut self) {
        self.data.fiducials.clear();
    }

    /// Feeds every detection to the determinism digest.
    fn digest(&self, d: &mut Digest) {
        let data = &self.data;
        d.u64(data.time_us);
        d.u64(data.fiducials.len() as u64);
        for f in &data.fiducials {
            d.u64(f.id as u32 as u64);
            d.model(Some(f.model));
            for v in [f.range, f.bearing, f.heading] {
                d.f64(v);
            }
            f.geom.iter().for_each(|&v| d.f64(v));
            d.pose(&f.pose);
        }
    }
}
