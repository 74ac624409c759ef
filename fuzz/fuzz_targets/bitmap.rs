//! Image bytes from anyone, as a worldfile `bitmap` (worldfile's occupancy loader and its
//! rectangle merge, both row modes) and as the `mapfile` driver's map (decode, grid).
//!
//! Checks beyond "no panic": the loader keeps its pixel bound; the exact rectangles cover the
//! occupied pixels and nothing else, without overlap; a mapfile grid has one cell per pixel,
//! each occupied, free or unknown.

#![no_main]

use libfuzzer_sys::fuzz_target;
use player_drivers::map::mapfile::MapFileOptions;
use playerstage_fuzz::scratch;
use worldfile::BitmapRows;
use worldfile::bitmap::{load_occupancy, rectangles};

/// The pixel bound given to the worldfile loader (a world's `max_bitmap_pixels`).
const MAX_PIXELS: u64 = 1 << 20;

fuzz_target!(|data: &[u8]| {
    let path = scratch().join("input.img");
    std::fs::write(&path, data).expect("write the image");

    if let Ok(grid) = load_occupancy(&path, MAX_PIXELS) {
        let (w, h) = (grid.width as usize, grid.height as usize);
        assert!((w * h) as u64 <= MAX_PIXELS);
        assert_eq!(grid.cells.len(), w * h);
        let mut covered = vec![false; w * h];
        for r in rectangles(grid.clone(), BitmapRows::Exact) {
            // y is up: the rectangle's rows, top row first, are H - (y + h) .. H - y
            let top = h - (r.y + r.h) as usize;
            for row in top..top + r.h as usize {
                for col in r.x as usize..(r.x + r.w) as usize {
                    let i = row * w + col;
                    assert!(grid.cells[i], "rectangle covers a free pixel");
                    assert!(!covered[i], "rectangles overlap");
                    covered[i] = true;
                }
            }
        }
        assert_eq!(covered, grid.cells, "rectangles miss occupied pixels");
        let _ = rectangles(grid, BitmapRows::StageCompatible);
    }

    let opts = MapFileOptions {
        filename: path,
        resolution: 0.05,
        negate: data.first().is_some_and(|b| b & 1 == 1),
        origin: None,
    };
    if let Ok(grid) = opts.load() {
        let cells = grid.width() as usize * grid.height() as usize;
        assert_eq!(grid.cells().len(), cells);
        assert!(grid.cells().iter().all(|c| (-1..=1).contains(c)));
    }
});
