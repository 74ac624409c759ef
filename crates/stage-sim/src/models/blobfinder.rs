//! `blobfinder` (spec §9): a fan of colour rays segmented into blobs.

use super::ModelKind;
use crate::color::{Color, same_rgb};
use crate::digest::Digest;
use crate::node::{ModelId, Node};
use crate::pose::Pose;
use crate::rng::SimRng;
use crate::space::RayQuery;
use crate::view::View;
use worldfile::models as wm;

/// Blobfinder properties (spec §9.1).
#[derive(Clone, Debug, PartialEq)]
pub struct BlobfinderDesc {
    /// Image width (rays) and height (pixels).
    pub image: [u32; 2],
    /// Ray length (m).
    pub range: f64,
    /// Horizontal field of view (rad).
    pub fov: f64,
    /// Centre direction relative to the body heading (rad).
    pub pan: f64,
    /// Colour channels; empty = report every colour.
    pub colors: Vec<Color>,
}

default_from_spec!(BlobfinderDesc);

/// One blob in image coordinates (x grows to the right of the image, y downwards).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blob {
    /// Colour of the blocks seen.
    pub color: Color,
    /// Leftmost image column.
    pub left: u32,
    /// Rightmost image column.
    pub right: u32,
    /// Top image row.
    pub top: u32,
    /// Bottom image row.
    pub bottom: u32,
    /// Mean range over the blob's columns (m).
    pub range: f64,
}

/// A blobfinder's latest data.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BlobfinderData {
    /// Sim time of the update (µs).
    pub time_us: u64,
    /// Image width (columns).
    pub width: u32,
    /// Image height (rows).
    pub height: u32,
    /// Blobs in scan order (right side of the image first).
    pub blobs: Vec<Blob>,
}

/// Per-model scratch plus configuration.
#[derive(Clone, Debug)]
pub struct BlobfinderModel {
    /// Configuration.
    pub cfg: BlobfinderDesc,
    /// Latest data.
    pub data: BlobfinderData,
    samples: Vec<Option<(Color, f64)>>,
}

pub(crate) fn desc_from_spec(b: &wm::BlobfinderSpec, _: &mut SimRng) -> BlobfinderDesc {
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

pub(crate) fn start(desc: &BlobfinderDesc, _: &Pose, _: &mut SimRng) -> BlobfinderModel {
    BlobfinderModel::new(desc.clone())
}

impl ModelKind for BlobfinderModel {
    fn ray_cost(&self) -> usize {
        self.cfg.image[0] as usize
    }

    /// One blobfinder update.
    fn update(&mut self, v: &View, m: ModelId, _: &Pose, _: &Node, _: &mut SimRng) {
        let b = self;
        let cfg = &b.cfg;
        let w = cfg.image[0] as usize;
        let h = cfg.image[1] as i64;
        let origin = v.body_frame(m).compose(&Pose {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            a: cfg.pan,
        });
        let root = v.root(m);
        b.samples.clear();
        for s in 0..w {
            let a = if w > 1 {
                origin.a - cfg.fov / 2.0 + s as f64 * cfg.fov / (w - 1) as f64
            } else {
                origin.a
            };
            let q = RayQuery {
                x: origin.x,
                y: origin.y,
                a,
                range: cfg.range,
                z: None,
            };
            let hit = v.space.raycast(&q, |hm| v.root(hm) != root);
            b.samples
                .push(hit.map(|hh| (v.block_color(hh.model, hh.block), hh.range)));
        }
        b.data.blobs.clear();
        let mut s = 0;
        while s < w {
            let Some((c, _)) = b.samples[s] else {
                s += 1;
                continue;
            };
            let right = s;
            let mut left = s;
            while left + 1 < w && b.samples[left + 1].is_some_and(|(cc, _)| same_rgb(&cc, &c)) {
                left += 1;
            }
            // the sample right after a blob is never the start of another (Stage quirk, §9.2)
            s = left + 2;
            if !cfg.colors.is_empty() && !cfg.colors.iter().any(|f| same_rgb(f, &c)) {
                continue;
            }
            let range = b.samples[right..=left]
                .iter()
                .map(|x| x.unwrap().1)
                .sum::<f64>()
                / (left - right + 1) as f64;
            let phi = 0.3f64.atan2(range);
            let rad_per_px = cfg.fov / h as f64;
            let half = (phi / rad_per_px) as i64;
            let top = (h / 2 - half).max(0);
            let bottom = (h / 2 + half).min(h);
            b.data.blobs.push(Blob {
                color: c,
                left: (w - 1 - left) as u32,
                right: (w - 1 - right) as u32,
                top: top as u32,
                bottom: bottom as u32,
                range,
            });
        }
        b.data.width = cfg.image[0];
        b.data.height = cfg.image[1];
        b.data.time_us = v.sim_time;
    }

    fn shutdown(&mut self) {
        self.data.blobs.clear();
    }

    /// Feeds the latest image size and blobs to the determinism digest.
    fn digest(&self, d: &mut Digest) {
        d.u64(self.data.time_us);
        d.u64(((self.data.width as u64) << 32) | self.data.height as u64);
        d.u64(self.data.blobs.len() as u64);
        for b in &self.data.blobs {
            d.color(&b.color);
            d.u64(((b.left as u64) << 32) | b.right as u64);
            d.u64(((b.top as u64) << 32) | b.bottom as u64);
            d.f64(b.range);
        }
    }
}

impl BlobfinderModel {
    /// A blobfinder with no data yet.
    pub fn new(cfg: BlobfinderDesc) -> Self {
        BlobfinderModel {
            data: BlobfinderData {
                width: cfg.image[0],
                height: cfg.image[1],
                ..Default::default()
            },
            cfg,
            samples: Vec::new(),
        }
    }
}
