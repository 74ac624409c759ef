//! `map`: a Stage model served as an occupancy grid (what Stage 2's `p_map.cc` did; Stage 4.1.1
//! ships that file but does not build it).
//!
//! The device binds to the model named in the block itself. Its map is the model's own blocks
//! (not its children's) rasterised at the world's `resolution` ([`stage_sim::World::rasterize`]):
//! cells a block covers are occupied, the others free, none unknown. The grid spans the
//! world-axis-aligned bounding box of the model's footprint at its current pose; its origin is
//! that box's lower-left corner with angle 0. The grid is made on the first request and again
//! whenever the model has moved since. Requests are answered as Player's grid map drivers do
//! ([`crate::map::answer`]); nothing is published.

use player_proto::{Body, Pose2d};
use stage_sim::{ModelId, Pose, World};

use super::{Interface, Writing, bound_answer};
use crate::driver::Reply;
use crate::map::{self, MAX_GRID_CELLS, OccupancyGrid};

/// A `map` device: the grid last made of its model, if any.
#[derive(Debug, Default)]
pub(super) struct Map {
    cache: Option<MapCache>,
}

impl Interface for Map {
    /// Answers a map request about the bound model, (re)making the cached grid first when needed.
    fn request(&mut self, b: &mut Writing<'_>, body: &Body) -> Reply {
        let (world, model, cache) = (&*b.world, b.model, &mut self.cache);
        let (Some(pose), Some(name)) = (
            bound_answer(model, world.global_pose(model)),
            bound_answer(model, world.name(model)),
        ) else {
            return Reply::Nack;
        };
        if cache.as_ref().is_none_or(|c| c.pose != pose) {
            *cache = grid_of(world, model, name).map(|grid| {
                tracing::debug!(
                    "stage: map of model \"{name}\": {} x {} cells at {} m",
                    grid.width(),
                    grid.height(),
                    grid.scale()
                );
                MapCache { pose, grid }
            });
        }
        match cache {
            Some(c) => map::answer(&c.grid, body),
            None => Reply::Nack,
        }
    }
}

/// A model's grid and the pose it was made at.
#[derive(Debug)]
struct MapCache {
    pose: Pose,
    grid: OccupancyGrid,
}

/// The model's grid as it stands now, or `None` (logged) when it cannot be made.
fn grid_of(world: &World, model: ModelId, name: &str) -> Option<OccupancyGrid> {
    let resolution = world.config().resolution;
    let Some(raster) = bound_answer(model, world.rasterize(model, resolution, MAX_GRID_CELLS))?
    else {
        tracing::warn!(
            "stage: cannot serve model \"{name}\" as a map at resolution {resolution} m: too \
             many cells"
        );
        return None;
    };
    let cells = raster
        .cells
        .iter()
        .map(|&hit| {
            if hit {
                OccupancyGrid::OCCUPIED
            } else {
                OccupancyGrid::FREE
            }
        })
        .collect();
    let origin = Pose2d {
        px: raster.origin[0],
        py: raster.origin[1],
        pa: 0.0,
    };
    let (w, h) = (
        u32::try_from(raster.width).ok()?,
        u32::try_from(raster.height).ok()?,
    );
    OccupancyGrid::from_cells(w, h, resolution as f32, origin, cells)
}
