//! `mapcspace`: the configuration space of a round robot — a map whose obstacles are grown by
//! the robot's radius, so that a planner may treat the robot as a point (Player 3.0.2's
//! server/drivers/map/mapcspace.cc, on maptransform.cc).
//!
//! The driver `requires` a `map` device and `provides` one: it fetches the source map once
//! (GET_INFO, then 640 × 640 tiles, [`player_proto::MapInfo::tile_requests`]) when it is set
//! up, transforms it with [`cspace`] and answers GET_INFO/GET_DATA from the result with
//! [`player_server::map::answer`] (other requests NACK). This module holds the algorithm and
//! the options ([`CspaceOptions::from_block`]); the driver that fetches the source map and serves
//! the result is [`super::transform::MapTransform`].
//!
//! cfg options:
//! * `robot_radius` (required): the robot's radius (m).
//! * `robot_shape` (default `"circle"`, the only shape): Player 3.0.2 documents that default
//!   but prints an error when the option is absent (and then grows circles anyway); we take the
//!   documented default. Any other shape is refused.
//!
//! Player prints an error for a missing or negative radius and then serves the map unchanged;
//! we refuse the block.

use player_server::DriverBlock;
use player_server::map::OccupancyGrid;

use crate::error::Error;
use crate::options;

/// The name the driver has in cfg files.
pub const NAME: &str = "mapcspace";

/// The robot shapes `mapcspace` knows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RobotShape {
    /// A disc of `robot_radius`.
    Circle,
}

/// The options of a `mapcspace` block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CspaceOptions {
    /// Radius (m) obstacles are grown by.
    pub robot_radius: f64,
    /// The robot's shape.
    pub robot_shape: RobotShape,
}

impl CspaceOptions {
    /// Reads `robot_radius` and `robot_shape` from `block` (its `requires` is the server's).
    pub fn from_block(block: &DriverBlock) -> Result<CspaceOptions, Error> {
        let robot_radius = options::length(block, "robot_radius")?.ok_or(Error::MissingOption {
            option: "robot_radius",
            why: "the radius (m) to grow obstacles by",
        })?;
        if !(robot_radius >= 0.0 && robot_radius.is_finite()) {
            return Err(Error::BadOption {
                option: "robot_radius".into(),
                value: robot_radius.to_string(),
                why: "must be a length of 0 or more".into(),
            });
        }
        let robot_shape = match options::string(block, "robot_shape") {
            None | Some("circle") => RobotShape::Circle,
            Some(other) => {
                return Err(Error::BadOption {
                    option: "robot_shape".into(),
                    value: other.into(),
                    why: "unknown robot shape (the only one is \"circle\")".into(),
                });
            }
        };
        Ok(CspaceOptions {
            robot_radius,
            robot_shape,
        })
    }

    /// The C-space of `source` for this robot.
    pub fn transform(&self, source: &OccupancyGrid) -> OccupancyGrid {
        match self.robot_shape {
            RobotShape::Circle => cspace(source, self.robot_radius),
        }
    }
}

/// The radius in cells Player grows by: `rint(robot_radius / scale)`, the scale being the
/// source map's C float.
pub fn radius_cells(robot_radius: f64, scale: f32) -> i64 {
    (robot_radius / f64::from(scale)).round_ties_even() as i64
}

/// The offsets (di, dj) of the disc of `r` cells: those with `rint(√(di² + dj²)) ≤ r`.
pub fn disc(r: i64) -> Vec<(i64, i64)> {
    let mut out = Vec::new();
    for dj in -r..=r {
        for di in -r..=r {
            if ((di * di + dj * dj) as f64).sqrt().round_ties_even() as i64 <= r {
                out.push((di, dj));
            }
        }
    }
    out
}

/// The configuration space of `source` for a circular robot of `robot_radius` metres, as
/// mapcspace.cc computes it: every cell that is occupied or unknown (value ≥ 0) in the source
/// raises each cell of its disc ([`disc`] of [`radius_cells`]) to its own value, when that is
/// higher (so occupied beats unknown, and nothing is lowered). The size, scale and origin stay.
pub fn cspace(source: &OccupancyGrid, robot_radius: f64) -> OccupancyGrid {
    let r = radius_cells(robot_radius, source.scale());
    let mut out = source.clone();
    if r < 0 {
        return out; // an empty disc: Player's loops do nothing
    }
    let offsets = disc(r);
    let (w, h) = (i64::from(source.width()), i64::from(source.height()));
    let src = source.cells();
    let dst = out.cells_mut();
    for j in 0..h {
        for i in 0..w {
            let state = src[(j * w + i) as usize];
            if state < 0 {
                continue;
            }
            let inside = i >= r && j >= r && i + r < w && j + r < h;
            for &(di, dj) in &offsets {
                let (x, y) = (i + di, j + dj);
                if !inside && (!(0..w).contains(&x) || !(0..h).contains(&y)) {
                    continue;
                }
                let cell = &mut dst[(y * w + x) as usize];
                if *cell < state {
                    *cell = state;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::tests::block;
    use player_proto::Pose2d;

    fn grid(w: u32, h: u32, scale: f32, cells: Vec<i8>) -> OccupancyGrid {
        let origin = Pose2d {
            px: 1.0,
            py: 2.0,
            pa: 0.0,
        };
        OccupancyGrid::from_cells(w, h, scale, origin, cells).unwrap()
    }

    /// The map as rows from the top, for readable expectations.
    fn rows(g: &OccupancyGrid) -> Vec<String> {
        (0..g.height() as i64)
            .rev()
            .map(|j| {
                (0..g.width() as i64)
                    .map(|i| match g.get(i, j).unwrap() {
                        -1 => '.',
                        0 => '?',
                        _ => '#',
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn the_disc_rounds_distances_as_player() {
        assert_eq!(disc(0), [(0, 0)]);
        // r = 1: rint(√2) = 1, so the 3 × 3 square.
        assert_eq!(disc(1).len(), 9);
        // r = 2: rint(√5 = 2.24) = 2 in, rint(√8 = 2.83) = 3 out: 25 - 4 corners.
        assert_eq!(disc(2).len(), 21);
        assert!(!disc(2).contains(&(2, 2)));
        assert!(disc(2).contains(&(2, 1)));
        // Divided by the float scale 0.1f32 (0.10000000149): 0.25 → 2.49999996 → 2,
        // 0.35 → 3.49999995 → 3; and rint rounds halves to even: 0.5 → 0, 1.5 → 2.
        assert_eq!(radius_cells(0.25, 0.1), 2);
        assert_eq!(radius_cells(0.35, 0.1), 3);
        assert_eq!(radius_cells(0.5, 1.0), 0);
        assert_eq!(radius_cells(1.5, 1.0), 2);
    }

    #[test]
    fn obstacles_grow_by_the_disc_and_occupied_beats_unknown() {
        let mut cells = vec![-1i8; 7 * 5];
        cells[2 * 7 + 1] = 1; // (1, 2) occupied
        cells[2 * 7 + 5] = 0; // (5, 2) unknown
        let g = grid(7, 5, 0.5, cells);
        let c = cspace(&g, 0.5); // one cell
        assert_eq!(
            rows(&c),
            [".......", "###.???", "###.???", "###.???", "......."]
        );
        // Two cells: the discs meet; occupied wins where they overlap.
        let c = cspace(&g, 1.0);
        assert_eq!(
            rows(&c),
            ["###.???", "####???", "####???", "####???", "###.???"]
        );
        // Size, scale and origin are kept; the source is untouched.
        assert_eq!(c.info(), g.info());
        assert_eq!(g.cells().iter().filter(|&&v| v >= 0).count(), 2);
    }

    #[test]
    fn nothing_is_lowered_and_a_zero_radius_changes_nothing() {
        let g = grid(3, 1, 1.0, vec![1, 0, -1]);
        assert_eq!(cspace(&g, 0.0), g);
        assert_eq!(cspace(&g, 0.4), g);
        assert_eq!(cspace(&g, 1.0).cells(), [1, 1, 0]);
    }

    #[test]
    fn options_as_player_reads_them() {
        let o = CspaceOptions::from_block(&block(
            NAME,
            &[("robot_radius", "0.3"), ("robot_shape", "circle")],
        ))
        .unwrap();
        assert_eq!(o.robot_radius, 0.3);
        assert_eq!(o.robot_shape, RobotShape::Circle);
        let o = CspaceOptions::from_block(&block(NAME, &[("robot_radius", "0.3")])).unwrap();
        assert_eq!(o.robot_shape, RobotShape::Circle);
        let err = |opts: &[(&str, &str)]| {
            CspaceOptions::from_block(&block(NAME, opts))
                .unwrap_err()
                .to_string()
        };
        assert!(err(&[]).starts_with("option `robot_radius` is required"));
        assert!(err(&[("robot_radius", "-1")]).contains("`robot_radius`"));
        assert!(err(&[("robot_radius", "1"), ("robot_shape", "square")]).contains("`robot_shape`"));
        let g = grid(3, 1, 1.0, vec![1, -1, -1]);
        assert_eq!(o.transform(&g).cells(), [1, -1, -1]);
    }
}
