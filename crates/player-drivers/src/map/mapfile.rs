//! `mapfile`: an occupancy grid read from an image file, served on a `map` device
//! (Player 3.0.2's server/drivers/map/mapfile.cc).
//!
//! cfg options, as Player reads them:
//! * `filename` (required): the image, relative to the cfg file's folder unless absolute. Any
//!   format the workspace's `image` crate decodes (PNG, PGM/PPM, BMP, GIF, JPEG; Player used
//!   gdk-pixbuf).
//! * `resolution` (required): metres per pixel.
//! * `negate` (default 0): non-zero reads dark pixels as free, for Stage 1.3 bitmaps.
//! * `origin` (default: the map's centre at (0, 0)): `[x y a]`, the real-world position of the
//!   lower-left pixel; the angle is ignored (the map's origin angle is always 0).
//!
//! Each pixel becomes one cell: the pixel's channel values are averaged (as gdk-pixbuf presents
//! them: 8-bit RGB, or RGBA when the image has alpha; 16-bit samples keep their high byte),
//! `occ = (255 - average) / 255` (or `average / 255` when negated), and the cell is occupied
//! (+1) when `occ > 0.95`, free (-1) when `occ < 0.1`, unknown (0) otherwise. The image's top
//! row is the map's highest row.
//!
//! Where we differ: Player loads the image when the first client subscribes and fails the
//! subscription if it cannot; we load it when the server starts, so a missing or unreadable
//! image (or a missing resolution) stops the server with an error naming the cfg block. An image
//! over [`MAX_PIXELS`] is refused from its header (Player reads any size). A
//! `resolution` of 0 is refused (Player accepts it and serves a map of scale 0). For images with
//! an alpha channel, Player 3.0.2 counted one channel too many and so read pixels at the wrong
//! stride, shearing the map and reading past the image's end (fixed upstream after 3.0.2, bug
//! 3006544); we average the four channels as the fixed driver does. Opaque black then reads as
//! unknown, as it does in both (use an image without alpha for walls).

use std::path::PathBuf;

use image::DynamicImage;
use player_proto::{DeviceAddr, InterfaceCode, Message, Pose2d};
use player_server::map::{self, OccupancyGrid};
use player_server::{Context, Driver, DriverBlock, DriverError, Reply};

use crate::error::Error;
use crate::options;

/// The name the driver is registered under.
pub const NAME: &str = "mapfile";

/// Above this `occ` a cell is occupied.
const OCCUPIED_ABOVE: f64 = 0.95;
/// Below this `occ` a cell is free.
const FREE_BELOW: f64 = 0.1;

/// Largest image read, in pixels: the worldfile loader's default bitmap bound. A map of this
/// size is 100 MB of cells; without a bound a 389 KB PNG of 20000 x 20000 pixels (highly
/// compressible) took `player --check` to 789 MB.
pub const MAX_PIXELS: u64 = 100_000_000;

/// The options of a `mapfile` block.
#[derive(Clone, Debug, PartialEq)]
pub struct MapFileOptions {
    /// The image, resolved against the cfg's folder.
    pub filename: PathBuf,
    /// Metres per pixel.
    pub resolution: f64,
    /// Dark pixels are free.
    pub negate: bool,
    /// Real-world position of the lower-left pixel; `None`: the map is centred on (0, 0).
    pub origin: Option<[f64; 2]>,
}

impl MapFileOptions {
    /// Reads the options of `block`.
    pub fn from_block(block: &DriverBlock) -> Result<MapFileOptions, Error> {
        let Some(written) = options::string(block, "filename") else {
            return Err(Error::MissingOption {
                option: "filename",
                why: "the map image to read",
            });
        };
        let resolution = options::positive_length(
            block,
            "resolution",
            "the map's scale in metres per pixel",
            "m/pixel",
        )?;
        let negate = options::int(block, "negate")?.unwrap_or(0) != 0;
        let origin = match (
            options::tuple_length(block, "origin", 0)?,
            options::tuple_length(block, "origin", 1)?,
        ) {
            (None, _) => None,
            (Some(x), Some(y)) => Some([x, y]),
            (Some(_), None) => {
                return Err(Error::BadOption {
                    option: "origin".into(),
                    value: block.options["origin"].join(" "),
                    why: "needs [x y] (and an angle, which is ignored)".into(),
                });
            }
        };
        Ok(MapFileOptions {
            filename: block.resolve_path(written),
            resolution,
            negate,
            origin,
        })
    }

    /// Reads the image and makes the grid. An image over [`MAX_PIXELS`] is refused from its
    /// header, before anything is decoded.
    pub fn load(&self) -> Result<OccupancyGrid, Error> {
        let image_error = |source| Error::Image {
            path: self.filename.clone(),
            source,
        };
        let open = || {
            image::ImageReader::open(&self.filename)
                .map_err(|e| image_error(image::ImageError::IoError(e)))?
                .with_guessed_format()
                .map_err(|e| image_error(image::ImageError::IoError(e)))
        };
        let (width, height) = open()?.into_dimensions().map_err(image_error)?;
        if u64::from(width) * u64::from(height) > MAX_PIXELS {
            return Err(Error::Map(format!(
                "image file {} is {width} x {height} pixels, more than the limit of {MAX_PIXELS}",
                self.filename.display()
            )));
        }
        let image = open()?.decode().map_err(image_error)?;
        self.grid(&image)
    }

    /// The grid of `image` under these options.
    pub fn grid(&self, image: &DynamicImage) -> Result<OccupancyGrid, Error> {
        let (width, height) = (image.width(), image.height());
        let origin = match self.origin {
            Some([px, py]) => Pose2d { px, py, pa: 0.0 },
            None => Pose2d {
                px: -(f64::from(width) / 2.0) * self.resolution,
                py: -(f64::from(height) / 2.0) * self.resolution,
                pa: 0.0,
            },
        };
        let cells = occupancy(image, self.negate);
        OccupancyGrid::from_cells(width, height, self.resolution as f32, origin, cells)
            .ok_or_else(|| Error::Map(format!("a {width} x {height} map is too large")))
    }
}

/// The cells of `image`, row 0 being the image's bottom row (module docs for the rule).
pub fn occupancy(image: &DynamicImage, negate: bool) -> Vec<i8> {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let mut cells = vec![OccupancyGrid::UNKNOWN; w * h];
    let mut put = |x: u32, y: u32, channels: &[u8]| {
        let sum: u32 = channels.iter().map(|&c| u32::from(c)).sum();
        let row = h - 1 - y as usize;
        cells[row * w + x as usize] = classify(sum, channels.len(), negate);
    };
    match image {
        DynamicImage::ImageLuma8(img) => {
            for (x, y, p) in img.enumerate_pixels() {
                put(x, y, &[p[0]; 3]);
            }
        }
        DynamicImage::ImageLumaA8(img) => {
            for (x, y, p) in img.enumerate_pixels() {
                put(x, y, &[p[0], p[0], p[0], p[1]]);
            }
        }
        DynamicImage::ImageRgb8(img) => {
            for (x, y, p) in img.enumerate_pixels() {
                put(x, y, &p.0);
            }
        }
        DynamicImage::ImageRgba8(img) => {
            for (x, y, p) in img.enumerate_pixels() {
                put(x, y, &p.0);
            }
        }
        // gdk-pixbuf strips 16-bit samples to their high byte.
        DynamicImage::ImageLuma16(img) => {
            for (x, y, p) in img.enumerate_pixels() {
                put(x, y, &[high(p[0]); 3]);
            }
        }
        DynamicImage::ImageLumaA16(img) => {
            for (x, y, p) in img.enumerate_pixels() {
                let l = high(p[0]);
                put(x, y, &[l, l, l, high(p[1])]);
            }
        }
        DynamicImage::ImageRgb16(img) => {
            for (x, y, p) in img.enumerate_pixels() {
                put(x, y, &p.0.map(high));
            }
        }
        DynamicImage::ImageRgba16(img) => {
            for (x, y, p) in img.enumerate_pixels() {
                put(x, y, &p.0.map(high));
            }
        }
        other if other.color().has_alpha() => {
            for (x, y, p) in other.to_rgba8().enumerate_pixels() {
                put(x, y, &p.0);
            }
        }
        other => {
            for (x, y, p) in other.to_rgb8().enumerate_pixels() {
                put(x, y, &p.0);
            }
        }
    }
    cells
}

fn high(sample: u16) -> u8 {
    (sample >> 8) as u8
}

/// mapfile.cc's rule for one pixel whose `n` channel values add up to `sum`.
fn classify(sum: u32, n: usize, negate: bool) -> i8 {
    let average = f64::from(sum) / n as f64;
    let occ = if negate {
        average / 255.0
    } else {
        (255.0 - average) / 255.0
    };
    if occ > OCCUPIED_ABOVE {
        OccupancyGrid::OCCUPIED
    } else if occ < FREE_BELOW {
        OccupancyGrid::FREE
    } else {
        OccupancyGrid::UNKNOWN
    }
}

/// The `mapfile` driver: one `map` device serving the grid read at start-up.
#[derive(Debug)]
pub struct MapFile {
    addr: DeviceAddr,
    grid: OccupancyGrid,
}

impl MapFile {
    /// Builds the driver from its cfg block: checks it provides one `map` device, reads the
    /// options and the image.
    pub fn from_block(block: &DriverBlock) -> Result<MapFile, DriverError> {
        let addr = match block.provides.as_slice() {
            [p] if p.addr.interf == InterfaceCode::MAP => p.addr,
            _ => {
                return Err(DriverError::new(
                    "mapfile provides exactly one `map` device (e.g. provides [\"map:0\"])",
                ));
            }
        };
        let opts = MapFileOptions::from_block(block)?;
        let grid = opts.load()?;
        tracing::info!(
            "mapfile: read a {} x {} map from {} at {:.3} m/pix",
            grid.width(),
            grid.height(),
            opts.filename.display(),
            opts.resolution
        );
        Ok(MapFile { addr, grid })
    }

    /// The grid served.
    pub fn grid(&self) -> &OccupancyGrid {
        &self.grid
    }
}

impl Driver for MapFile {
    fn handle_request(&mut self, _ctx: &mut Context<'_>, request: &Message) -> Reply {
        if request.header.addr.interf != self.addr.interf
            || request.header.addr.index != self.addr.index
        {
            return Reply::NotHandled;
        }
        map::answer(&self.grid, &request.body)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::tests::block;
    use image::{GrayImage, Luma, Rgb, RgbImage, Rgba, RgbaImage};

    fn opts(resolution: f64, negate: bool, origin: Option<[f64; 2]>) -> MapFileOptions {
        MapFileOptions {
            filename: PathBuf::from("unused.png"),
            resolution,
            negate,
            origin,
        }
    }

    /// A PNG that announces `width` x `height` grey pixels and holds no image data (an empty
    /// IDAT chunk).
    fn png_header_only(width: u32, height: u32) -> Vec<u8> {
        fn chunk(png: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
            png.extend_from_slice(&(data.len() as u32).to_be_bytes());
            let mut crc = flate2::Crc::new();
            crc.update(kind);
            crc.update(data);
            png.extend_from_slice(kind);
            png.extend_from_slice(data);
            png.extend_from_slice(&crc.sum().to_be_bytes());
        }
        let mut ihdr = width.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&height.to_be_bytes());
        ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        chunk(&mut png, b"IHDR", &ihdr);
        chunk(&mut png, b"IDAT", &[]);
        chunk(&mut png, b"IEND", &[]);
        png
    }

    #[test]
    fn an_image_over_the_pixel_bound_is_refused_from_its_header() {
        let path = std::env::temp_dir().join(format!("mapfile-huge-{}.png", std::process::id()));
        std::fs::write(&path, png_header_only(20_000, 20_000)).unwrap();
        let opts = MapFileOptions {
            filename: path.clone(),
            ..opts(0.05, false, None)
        };
        let err = opts.load().unwrap_err().to_string();
        std::fs::remove_file(&path).unwrap();
        assert!(
            err.contains("20000 x 20000 pixels, more than the limit of 100000000"),
            "{err}"
        );
    }

    #[test]
    fn grey_thresholds_follow_mapfile() {
        // occ = (255 - v) / 255: occupied above 0.95 (v < 12.75), free below 0.1
        // (v > 229.5), unknown between.
        let values = [0u8, 12, 13, 100, 229, 230, 255];
        let img = GrayImage::from_fn(values.len() as u32, 1, |x, _| Luma([values[x as usize]]));
        let cells = occupancy(&DynamicImage::ImageLuma8(img.clone()), false);
        assert_eq!(cells, [1, 1, 0, 0, 0, -1, -1]);
        // Negated: occ = v / 255.
        let cells = occupancy(&DynamicImage::ImageLuma8(img), true);
        assert_eq!(cells, [-1, -1, -1, 0, 0, 0, 1]);
    }

    #[test]
    fn colours_are_averaged() {
        // (255 + 0 + 0) / 3 = 85: unknown; (255, 255, 200) averages 236.7: free;
        // (10, 10, 15) averages 11.7: occupied.
        let px = [[255, 0, 0], [255, 255, 200], [10, 10, 15]];
        let img = RgbImage::from_fn(3, 1, |x, _| Rgb(px[x as usize]));
        assert_eq!(occupancy(&DynamicImage::ImageRgb8(img), false), [0, -1, 1]);
        // With alpha the four channels are averaged: opaque white is free, opaque black
        // (63.75) unknown, transparent black occupied.
        let px = [[255, 255, 255, 255], [0, 0, 0, 255], [0, 0, 0, 0]];
        let img = RgbaImage::from_fn(3, 1, |x, _| Rgba(px[x as usize]));
        assert_eq!(occupancy(&DynamicImage::ImageRgba8(img), false), [-1, 0, 1]);
        // 16-bit samples keep their high byte: 0x0CFF reads as 12 (occupied), 0xE6FF as
        // 230 (free).
        let img = image::ImageBuffer::<Luma<u16>, Vec<u16>>::from_fn(2, 1, |x, _| {
            Luma([[0x0CFF, 0xE6FF][x as usize]])
        });
        assert_eq!(occupancy(&DynamicImage::ImageLuma16(img), false), [1, -1]);
    }

    #[test]
    fn the_top_image_row_is_the_highest_map_row() {
        // 2 x 3 image: the top row black, the rest white.
        let img = GrayImage::from_fn(2, 3, |_, y| Luma([if y == 0 { 0 } else { 255 }]));
        let g = opts(0.5, false, None)
            .grid(&DynamicImage::ImageLuma8(img))
            .unwrap();
        assert_eq!((g.width(), g.height(), g.scale()), (2, 3, 0.5));
        assert_eq!(g.cells(), [-1, -1, -1, -1, 1, 1]);
        assert_eq!(g.get(0, 2), Some(1));
    }

    #[test]
    fn origin_defaults_to_the_centre_and_its_angle_is_ignored() {
        let img = DynamicImage::ImageLuma8(GrayImage::new(5, 4));
        let g = opts(0.1, false, None).grid(&img).unwrap();
        let o = g.origin();
        assert_eq!(
            (o.px, o.py, o.pa),
            (-(5.0 / 2.0) * 0.1, -(4.0 / 2.0) * 0.1, 0.0)
        );
        let g = opts(0.1, false, Some([3.0, -4.0])).grid(&img).unwrap();
        let o = g.origin();
        assert_eq!((o.px, o.py, o.pa), (3.0, -4.0, 0.0));
        // The scale is the C float the wire carries.
        assert_eq!(g.scale(), 0.1f32);
    }

    #[test]
    fn options_as_player_reads_them() {
        let mut b = block(
            NAME,
            &[
                ("filename", "maps/cave.png"),
                ("resolution", "0.05"),
                ("negate", "1"),
                ("origin", "-8 -8 45"),
            ],
        );
        b.cfg_path = Some(PathBuf::from("/cfgs/x.cfg"));
        let o = MapFileOptions::from_block(&b).unwrap();
        assert_eq!(o.filename, PathBuf::from("/cfgs/maps/cave.png"));
        assert_eq!(o.resolution, 0.05);
        assert!(o.negate);
        assert_eq!(o.origin, Some([-8.0, -8.0]));
        let o = MapFileOptions::from_block(&block(
            NAME,
            &[("filename", "/abs/m.pgm"), ("resolution", "1")],
        ))
        .unwrap();
        assert_eq!(o.filename, PathBuf::from("/abs/m.pgm"));
        assert!(!o.negate);
        assert_eq!(o.origin, None);
    }

    #[test]
    fn bad_options_are_named() {
        let err = |opts: &[(&str, &str)]| {
            MapFileOptions::from_block(&block(NAME, opts))
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            err(&[("resolution", "0.1")]),
            "option `filename` is required: the map image to read"
        );
        assert_eq!(
            err(&[("filename", "m.png")]),
            "option `resolution` is required: the map's scale in metres per pixel"
        );
        assert!(err(&[("filename", "m.png"), ("resolution", "-1")]).contains("positive"));
        assert!(err(&[("filename", "m.png"), ("resolution", "0")]).contains("positive"));
        assert!(err(&[("filename", "m.png"), ("resolution", "fine")]).contains("`resolution`"));
        assert!(
            err(&[("filename", "m.png"), ("resolution", "1"), ("origin", "3")])
                .contains("`origin`")
        );
        assert!(
            err(&[
                ("filename", "m.png"),
                ("resolution", "1"),
                ("negate", "yes")
            ])
            .contains("`negate`")
        );
    }

    #[test]
    fn one_bit_images_read_as_black_and_white() {
        // Stage's ghost.png is a 1-bit greyscale PNG: its samples expand to 0 and 255.
        let Some(path) = test_support::shared("stage-worlds/bitmaps/ghost.png") else {
            return;
        };
        let o = MapFileOptions {
            filename: path,
            ..opts(1.0, false, None)
        };
        let g = o.load().unwrap();
        assert_eq!((g.width(), g.height()), (23, 20));
        let occupied = g.cells().iter().filter(|&&c| c == 1).count();
        let free = g.cells().iter().filter(|&&c| c == -1).count();
        assert!(occupied > 0 && free > 0, "{occupied} occupied, {free} free");
        assert_eq!(occupied + free, 23 * 20, "no unknown cells");
    }

    #[test]
    fn a_missing_image_is_an_error_naming_the_file() {
        let o = opts(0.1, false, None);
        let e = o.load().unwrap_err().to_string();
        assert!(e.starts_with("cannot read image file unused.png: "), "{e}");
    }

    #[test]
    fn the_driver_wants_one_map_device() {
        use player_proto::constants::LOCALHOST_ADDR;
        let laser = DeviceAddr::new(LOCALHOST_ADDR, 6665, InterfaceCode::LASER, 0);
        let b = block(NAME, &[("filename", "m.png"), ("resolution", "1")])
            .providing([laser], "test.cfg:1");
        let e = MapFile::from_block(&b).unwrap_err().to_string();
        assert!(e.contains("exactly one `map` device"), "{e}");
    }
}
