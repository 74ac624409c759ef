//! `camera` (spec §12). Stage renders it with OpenGL in the GUI only (and crashes headless); we
//! ray-cast it instead, headless too: per column one planar ray collects every edge crossing,
//! per row the elevation decides which crossing's block spans the ray's height there.

use super::ModelKind;
use crate::color::Color;
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::space::{RayHit, RayQuery};
use crate::view::View;
use worldfile::models as wm;

/// Camera properties (spec §12).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    /// Image width and height (pixels).
    pub resolution: [u32; 2],
    /// Near and far clipping distances (m).
    pub range: [f64; 2],
    /// Horizontal and vertical field of view (rad).
    pub fov: [f64; 2],
    /// Pan and tilt (rad).
    pub pantilt: [f64; 2],
}

default_from_spec!(CameraDesc);

/// Colour of the ground plane in camera images.
pub const FLOOR: Color = Color::rgb(0.7, 0.7, 0.7);

/// A colour + depth image.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraImage {
    /// Sim time of the update (µs).
    pub time_us: u64,
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// RGBA8, row-major from the top-left; the sky is transparent black.
    pub rgba: Vec<u8>,
    /// Distance along each pixel's ray (m); `range.far` where nothing is seen.
    pub depth: Vec<f32>,
}

/// Camera state.
#[derive(Clone, Debug)]
pub struct CameraModel {
    /// Configuration.
    pub cfg: CameraDesc,
    /// Latest image.
    pub image: CameraImage,
    hits: Vec<RayHit>,
}

/// Camera properties (the worldfile keeps Stage's raw degrees for the camera).
pub(crate) fn desc_from_spec(c: &wm::CameraSpec, _: &mut SimRng) -> CameraDesc {
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

pub(crate) fn start(desc: &CameraDesc, _: &Pose, _: &mut SimRng) -> CameraModel {
    CameraModel::new(desc.clone())
}

impl ModelKind for CameraModel {
    fn starts_itself(&self) -> bool {
        true
    }

    fn ray_cost(&self) -> usize {
        (self.cfg.resolution[0] * 4) as usize
    }

    /// One camera update: viewpoint at the parent's x, y and heading (own pose without a parent),
    /// at the camera's global height, offset by pan/tilt.
    fn update(&mut self, v: &View, m: ModelId, _: &Pose, node: &Node, _: &mut SimRng) {
        let c = self;
        let g = v.globals[m.index()];
        let base = match node.parent {
            Some(p) => {
                let pg = v.globals[p.index()];
                Pose { z: g.z, ..pg }
            }
            None => g,
        };
        let [w, h] = c.cfg.resolution;
        let (w, h) = (w as usize, h as usize);
        let [near, far] = c.cfg.range;
        let [fov_h, fov_v] = c.cfg.fov;
        let [pan, tilt] = c.cfg.pantilt;
        let z0 = base.z + node.size[2] / 2.0;
        let root = v.root(m);
        c.image.width = w as u32;
        c.image.height = h as u32;
        c.image.rgba.resize(w * h * 4, 0);
        c.image.depth.resize(w * h, far as f32);
        for col in 0..w {
            let a = base.a + pan + fov_h / 2.0 - (col as f64 + 0.5) * fov_h / w as f64;
            let q = RayQuery {
                x: base.x,
                y: base.y,
                a,
                range: far,
                z: None,
            };
            v.space
                .raycast_all(&q, |hm| v.root(hm) != root, &mut c.hits);
            for row in 0..h {
                let el = tilt + fov_v / 2.0 - (row as f64 + 0.5) * fov_v / h as f64;
                let (tan, cos) = (el.tan(), el.cos());
                let t_ground = if tan < 0.0 { z0 / -tan } else { f64::INFINITY };
                let mut px: Option<(Color, f64)> = None;
                for hit in &c.hits {
                    if hit.range > t_ground {
                        break;
                    }
                    let zr = z0 + hit.range * tan;
                    let blk = v.space.body(hit.model).blocks[hit.block as usize];
                    let dist = hit.range / cos;
                    if zr >= blk.zmin && zr <= blk.zmax && dist >= near {
                        px = Some((v.block_color(hit.model, hit.block), dist));
                        break;
                    }
                }
                if px.is_none() && t_ground / cos <= far && t_ground / cos >= near {
                    px = Some((FLOOR, t_ground / cos));
                }
                let i = row * w + col;
                match px {
                    Some((color, dist)) => {
                        let to8 = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
                        c.image.rgba[i * 4..i * 4 + 4].copy_from_slice(&[
                            to8(color.r),
                            to8(color.g),
                            to8(color.b),
                            255,
                        ]);
                        c.image.depth[i] = dist.min(far) as f32;
                    }
                    None => {
                        c.image.rgba[i * 4..i * 4 + 4].copy_from_slice(&[0, 0, 0, 0]);
                        c.image.depth[i] = far as f32;
                    }
                }
            }
        }
        c.image.time_us = v.sim_time;
    }

    /// Feeds the latest image (colour and depth) to the determinism digest.
    fn digest(&self, d: &mut Digest) {
        let im = &self.image;
        d.u64(im.time_us);
        d.u64(((im.width as u64) << 32) | im.height as u64);
        d.bytes(&im.rgba);
        d.u64(im.depth.len() as u64);
        im.depth.iter().for_each(|&z| d.u64(z.to_bits() as u64));
    }
}

impl CameraModel {
    /// A camera with no image yet.
    pub fn new(cfg: CameraDesc) -> Self {
        CameraModel {
            cfg,
            image: CameraImage::default(),
            hits: Vec::new(),
        }
    }
}
