//! Bitmaps to rectangles (stage-models.md §2.4).
//!
//! A pixel is an obstacle when its first channel (grey, or red for colour images) is ≤ 127;
//! alpha is ignored. Occupied pixels are merged greedily into axis-aligned rectangles: along each
//! row, then downwards as far as every column of the run reaches. Rectangles are in pixel units
//! with y up (row 0 is the top of the image).
//!
//! Stage's scan has a last-row quirk: runs that reach the bottom row stop one pixel short, bottom
//! row pixels become zero-height rectangles, and the y flip is `H - 1 - (y + h)`. We reproduce it
//! by default ([`BitmapRows::StageCompatible`]) so maps match Stage's to the pixel (and recorded
//! sessions against real Stage); [`BitmapRows::Exact`] covers every occupied pixel fully.

use std::path::Path;

use serde::Serialize;

/// Which rectangle extraction to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum BitmapRows {
    /// Stage 4.1.1's scan, quirks included (the default).
    #[default]
    StageCompatible,
    /// Every occupied pixel covered, bottom row included, y flipped as `H - (y + h)`.
    Exact,
}

/// An axis-aligned rectangle in pixel units, y up.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct PixelRect {
    /// Left edge.
    pub x: u32,
    /// Bottom edge (y up).
    pub y: u32,
    /// Width.
    pub w: u32,
    /// Height (0 for Stage's bottom-row slivers).
    pub h: u32,
}

/// The occupancy grid of an image: `true` where the first channel is ≤ 127.
#[derive(Clone, Debug, PartialEq)]
pub struct Occupancy {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major, row 0 at the top.
    pub cells: Vec<bool>,
}

impl Occupancy {
    fn get(&self, x: u32, y: u32) -> bool {
        self.cells[(y as usize) * (self.width as usize) + x as usize]
    }

    fn clear(&mut self, x: u32, y: u32) {
        let w = self.width as usize;
        self.cells[(y as usize) * w + x as usize] = false;
    }
}

/// Decodes an image file (PNG, JPEG, GIF, BMP, PNM) into an occupancy grid.
pub fn load_occupancy(path: &Path, max_pixels: u64) -> Result<Occupancy, String> {
    let reader = image::ImageReader::open(path)
        .map_err(|e| e.to_string())?
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    let (w, h) = {
        let probe = image::ImageReader::open(path)
            .map_err(|e| e.to_string())?
            .with_guessed_format()
            .map_err(|e| e.to_string())?;
        probe.into_dimensions().map_err(|e| e.to_string())?
    };
    if (w as u64) * (h as u64) > max_pixels {
        return Err(format!(
            "image is {w}x{h} pixels, more than the limit of {max_pixels}"
        ));
    }
    let mut reader = reader;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(max_pixels.saturating_mul(16));
    reader.limits(limits);
    let img = reader.decode().map_err(|e| e.to_string())?;
    let (width, height) = (img.width(), img.height());
    // channel 0 is "grey or red"; 8-bit images are read in place (Stage's maps are mostly 8-bit
    // grey: hospital.png is 3117x1189, whose RGBA copy took a third of the world's loading)
    let first_channel = |raw: &[u8], channels: usize| -> Vec<bool> {
        raw.chunks_exact(channels).map(|p| p[0] <= 127).collect()
    };
    let cells = match &img {
        image::DynamicImage::ImageLuma8(b) => first_channel(b.as_raw(), 1),
        image::DynamicImage::ImageLumaA8(b) => first_channel(b.as_raw(), 2),
        image::DynamicImage::ImageRgb8(b) => first_channel(b.as_raw(), 3),
        image::DynamicImage::ImageRgba8(b) => first_channel(b.as_raw(), 4),
        // other depths and formats: grey becomes r = g = b = grey in the 8-bit RGBA conversion
        _ => first_channel(img.to_rgba8().as_raw(), 4),
    };
    Ok(Occupancy {
        width,
        height,
        cells,
    })
}

/// Merges occupied pixels into rectangles (consumes the grid).
pub fn rectangles(mut grid: Occupancy, rows: BitmapRows) -> Vec<PixelRect> {
    let (w, h) = (grid.width, grid.height);
    let mut out = Vec::new();
    for y in 0..h {
        let mut x = 0;
        while x < w {
            if !grid.get(x, y) {
                x += 1;
                continue;
            }
            let start = x;
            let mut height = h;
            while x < w && grid.get(x, y) {
                let mut yy = y;
                let run = match rows {
                    BitmapRows::StageCompatible => {
                        while grid.get(x, yy) && yy < h - 1 {
                            yy += 1;
                        }
                        yy - y
                    }
                    BitmapRows::Exact => {
                        while yy < h && grid.get(x, yy) {
                            yy += 1;
                        }
                        yy - y
                    }
                };
                height = height.min(run);
                x += 1;
            }
            for cy in y..y + height {
                for cx in start..x {
                    grid.clear(cx, cy);
                }
            }
            let bottom = match rows {
                BitmapRows::StageCompatible => h - 1 - (y + height),
                BitmapRows::Exact => h - (y + height),
            };
            out.push(PixelRect {
                x: start,
                y: bottom,
                w: x - start,
                h: height,
            });
            // Upstream's loop also steps over the free pixel that ended the run.
            x += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(rows: &[&str]) -> Occupancy {
        let height = rows.len() as u32;
        let width = rows[0].len() as u32;
        let cells = rows
            .iter()
            .flat_map(|r| r.bytes().map(|c| c == b'#'))
            .collect();
        Occupancy {
            width,
            height,
            cells,
        }
    }

    fn covered(rects: &[PixelRect], w: u32, h: u32, flip: u32) -> Vec<String> {
        // Render rectangles back to rows (row 0 at the top) to compare with the input.
        let mut cells = vec![vec!['.'; w as usize]; h as usize];
        for r in rects {
            for yy in r.y..r.y + r.h {
                for xx in r.x..r.x + r.w {
                    let row = (flip - yy) as usize;
                    cells[row][xx as usize] = '#';
                }
            }
        }
        cells.into_iter().map(|r| r.into_iter().collect()).collect()
    }

    /// Every pixel format gives what the 8-bit RGBA conversion's first channel gives (the
    /// 8-bit formats are read without that conversion).
    #[test]
    fn every_format_thresholds_its_first_channel() {
        let (w, h) = (7u32, 5u32);
        let value = |x: u32, y: u32, c: u32| ((x * 37 + y * 91 + c * 53) % 256) as u8;
        let dir = std::env::temp_dir().join(format!("worldfile-bitmap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let images: Vec<(&str, image::DynamicImage)> = vec![
            (
                "l8",
                image::GrayImage::from_fn(w, h, |x, y| image::Luma([value(x, y, 0)])).into(),
            ),
            (
                "la8",
                image::GrayAlphaImage::from_fn(w, h, |x, y| {
                    image::LumaA([value(x, y, 0), value(x, y, 1)])
                })
                .into(),
            ),
            (
                "rgb8",
                image::RgbImage::from_fn(w, h, |x, y| {
                    image::Rgb([value(x, y, 0), value(x, y, 1), value(x, y, 2)])
                })
                .into(),
            ),
            (
                "rgba8",
                image::RgbaImage::from_fn(w, h, |x, y| {
                    image::Rgba([value(x, y, 0), value(x, y, 1), value(x, y, 2), 9])
                })
                .into(),
            ),
            (
                "l16",
                image::ImageBuffer::<image::Luma<u16>, _>::from_fn(w, h, |x, y| {
                    image::Luma([value(x, y, 0) as u16 * 257 + (x % 2) as u16 * 128])
                })
                .into(),
            ),
        ];
        for (name, img) in images {
            let path = dir.join(format!("{name}.png"));
            img.save(&path).unwrap();
            let got = load_occupancy(&path, 1 << 20).unwrap();
            let reference: Vec<bool> = img.to_rgba8().pixels().map(|p| p.0[0] <= 127).collect();
            assert_eq!((got.width, got.height), (w, h), "{name}");
            assert_eq!(got.cells, reference, "{name}");
            assert!(got.cells.iter().any(|&c| c) && got.cells.iter().any(|&c| !c));
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn exact_mode_covers_every_occupied_pixel() {
        let rows = ["#..##", "#..##", "####.", "....#"];
        let rects = rectangles(grid(&rows), BitmapRows::Exact);
        assert_eq!(covered(&rects, 5, 4, 3), rows.to_vec());
        // Rectangles never overlap: their total area equals the occupied pixel count.
        let area: u32 = rects.iter().map(|r| r.w * r.h).sum();
        assert_eq!(area, 11);
    }

    #[test]
    fn stage_mode_all_black_3x3() {
        // Stage: one rectangle per column run, one pixel short, spanning 3x2 pixel units.
        let rects = rectangles(grid(&["###", "###", "###"]), BitmapRows::StageCompatible);
        assert_eq!(
            rects,
            vec![
                PixelRect {
                    x: 0,
                    y: 0,
                    w: 3,
                    h: 2
                },
                PixelRect {
                    x: 0,
                    y: 0,
                    w: 3,
                    h: 0
                },
            ]
        );
    }

    #[test]
    fn stage_mode_merges_rows_then_columns() {
        let rects = rectangles(
            grid(&["##.", "##.", "...", "..."]),
            BitmapRows::StageCompatible,
        );
        assert_eq!(
            rects,
            vec![PixelRect {
                x: 0,
                y: 1,
                w: 2,
                h: 2
            }]
        );
        let rects = rectangles(grid(&["##.", "##.", "...", "..."]), BitmapRows::Exact);
        assert_eq!(
            rects,
            vec![PixelRect {
                x: 0,
                y: 2,
                w: 2,
                h: 2
            }]
        );
    }

    #[test]
    fn shortest_column_sets_the_height() {
        let rects = rectangles(grid(&["##", "#.", "#.", ".."]), BitmapRows::Exact);
        assert_eq!(
            rects,
            vec![
                PixelRect {
                    x: 0,
                    y: 3,
                    w: 2,
                    h: 1
                },
                PixelRect {
                    x: 0,
                    y: 1,
                    w: 1,
                    h: 2
                },
            ]
        );
    }

    #[test]
    fn skips_the_pixel_after_a_run() {
        // The free pixel ending a run is stepped over; the next run still starts correctly.
        let rects = rectangles(grid(&["#.#"]), BitmapRows::Exact);
        assert_eq!(rects.len(), 2);
    }
}
