//! `mapscale`: a map resampled to another resolution (Player 3.0.2's
//! server/drivers/map/mapscale.cc, on maptransform.cc).
//!
//! The driver `requires` a `map` device and `provides` one: it fetches the source map once
//! (GET_INFO, then 640 × 640 tiles, [`player_proto::MapInfo::tile_requests`]) when it is set
//! up, transforms it with [`scale`] and answers GET_INFO/GET_DATA from the result with
//! [`player_server::map::answer`] (other requests NACK). This module holds the algorithm and
//! the options ([`ScaleOptions::from_block`]); the driver that fetches the source map and serves
//! the result is [`super::transform::MapTransform`].
//!
//! cfg option: `resolution` (required): the new scale, metres per cell. Player prints an error
//! when it is missing and then computes a map of negative size; we refuse the block.
//!
//! The rule, as mapscale.cc has it: the map becomes an 8-bit RGB image whose red channel is 255
//! for free cells, 127 for unknown and 0 for the rest (green and blue stay 0), the map's top
//! row first; gdk-pixbuf's `gdk_pixbuf_scale_simple(GDK_INTERP_HYPER)` resizes it to
//! `rint(width × old/new)` × `rint(height × old/new)` pixels (`old` is the source map's float
//! scale, `new` the `resolution` stored as a float); each new pixel's red value above
//! `0.66 × 255` is free, below `0.33 × 255` occupied, unknown between. The origin is kept.
//!
//! [`scale_hyper`] is that resize, on one channel (the channels do not mix), computed as
//! current gdk-pixbuf computes it: the tent-convolved box filter in 16.16 fixed point with 16
//! sub-pixel phases, integer weights corrected to sum to 65536, source edges replicated, the
//! fast copy when the size does not change and the two-step reduction for very large
//! shrinks (both added to gdk-pixbuf after Player 3.0.2 was released).

use player_server::DriverBlock;
use player_server::map::OccupancyGrid;

use crate::error::Error;
use crate::options;

/// The name the driver has in cfg files.
pub const NAME: &str = "mapscale";

/// The options of a `mapscale` block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScaleOptions {
    /// The new scale (m/cell).
    pub resolution: f64,
}

impl ScaleOptions {
    /// Reads `resolution` from `block` (its `requires` is the server's).
    pub fn from_block(block: &DriverBlock) -> Result<ScaleOptions, Error> {
        let resolution = options::positive_length(
            block,
            "resolution",
            "the new map scale in metres per cell",
            "m/cell",
        )?;
        Ok(ScaleOptions { resolution })
    }

    /// The source map at this resolution.
    pub fn transform(&self, source: &OccupancyGrid) -> Result<OccupancyGrid, Error> {
        scale(source, self.resolution)
    }
}

/// Red value of a cell in mapscale's image.
fn pixel(cell: i8) -> u8 {
    match cell {
        OccupancyGrid::FREE => 255,
        OccupancyGrid::UNKNOWN => 127,
        _ => 0,
    }
}

/// Cell of a resampled red value.
fn cell(red: u8) -> i8 {
    let red = f64::from(red);
    if red > 0.66 * 255.0 {
        OccupancyGrid::FREE
    } else if red < 0.33 * 255.0 {
        OccupancyGrid::OCCUPIED
    } else {
        OccupancyGrid::UNKNOWN
    }
}

/// `source` resampled to `resolution` m/cell, as mapscale.cc does (module docs).
pub fn scale(source: &OccupancyGrid, resolution: f64) -> Result<OccupancyGrid, Error> {
    let new_scale = resolution as f32;
    let factor = f64::from(source.scale()) / f64::from(new_scale);
    let (sw, sh) = (source.width() as usize, source.height() as usize);
    let nw = (sw as f64 * factor).round_ties_even();
    let nh = (sh as f64 * factor).round_ties_even();
    let fits = |n: f64| n >= 1.0 && n <= f64::from(u32::MAX);
    if !(fits(nw) && fits(nh)) {
        return Err(Error::Map(format!(
            "scaling the {sw} x {sh} map from {} to {new_scale} m/cell gives a {nw} x {nh} map",
            source.scale()
        )));
    }
    let (nw, nh) = (nw as u32, nh as u32);
    let mut out = OccupancyGrid::new(nw, nh, new_scale, source.origin(), 0).ok_or_else(|| {
        Error::Map(format!(
            "scaling to {new_scale} m/cell gives a {nw} x {nh} map, too large to hold"
        ))
    })?;
    // The image has the map's top row first.
    let src = source.cells();
    let mut image = Vec::with_capacity(sw * sh);
    for row in src.chunks_exact(sw.max(1)).rev() {
        image.extend(row.iter().map(|&c| pixel(c)));
    }
    let scaled = scale_hyper(&image, sw, sh, nw as usize, nh as usize);
    let (nw, nh) = (nw as usize, nh as usize);
    for (j, row) in out.cells_mut().chunks_exact_mut(nw).enumerate() {
        let from = &scaled[(nh - 1 - j) * nw..(nh - j) * nw];
        for (c, &red) in row.iter_mut().zip(from) {
            *c = cell(red);
        }
    }
    Ok(out)
}

const SUBSAMPLE_BITS: u32 = 4;
const SUBSAMPLE: usize = 1 << SUBSAMPLE_BITS;
const SUBSAMPLE_MASK: i64 = (1 << SUBSAMPLE_BITS) - 1;
const SCALE_SHIFT: u32 = 16;
/// gdk-pixbuf reduces in two steps when a filter would need more than this many taps.
const MAX_FILTERS: i64 = 1000;

/// `gdk_pixbuf_scale_simple(src, dw, dh, GDK_INTERP_HYPER)` on one 8-bit channel: `src` is
/// `sw × sh` pixels, rows from the top; the result is `dw × dh`.
pub fn scale_hyper(src: &[u8], sw: usize, sh: usize, dw: usize, dh: usize) -> Vec<u8> {
    assert_eq!(src.len(), sw * sh, "source size");
    if dw == sw && dh == sh {
        return src.to_vec();
    }
    let mut dst = vec![0u8; dw * dh];
    if sw > 0 && sh > 0 {
        let src = Gray {
            pixels: src,
            width: sw,
            height: sh,
        };
        let scale = (dw as f64 / sw as f64, dh as f64 / sh as f64);
        scale_into(&mut dst, dw, dh, src, scale);
    }
    dst
}

/// One 8-bit channel of a source image, `width × height` pixels, rows from the top.
#[derive(Clone, Copy)]
struct Gray<'a> {
    pixels: &'a [u8],
    width: usize,
    height: usize,
}

/// `_pixops_scale_real` for a whole `dw × dh` destination, `src` scaled by `(x, y)`.
fn scale_into(dst: &mut [u8], dw: usize, dh: usize, src: Gray<'_>, scale: (f64, f64)) {
    let (mut scale_x, mut scale_y) = scale;
    if scale_x == 0.0 || scale_y == 0.0 {
        return;
    }
    let prescaled;
    let mut src = src;
    if need_to_prescale(scale_x, scale_y) {
        // Reduce by the square root of the factor first; gdk-pixbuf skips this when the
        // intermediate image would be empty (its allocation of 0 bytes "fails").
        let (px, py) = (scale_x.sqrt(), scale_y.sqrt());
        let tw = (src.width as f64 * px).round_ties_even() as usize;
        let th = (src.height as f64 * py).round_ties_even() as usize;
        if tw > 0 && th > 0 {
            let mut tmp = vec![0u8; tw * th];
            scale_into(&mut tmp, tw, th, src, (px, py));
            prescaled = tmp;
            src = Gray {
                pixels: &prescaled,
                width: tw,
                height: th,
            };
            scale_x /= px;
            scale_y /= py;
        }
    }
    let fx = Taps::bilinear_box(scale_x);
    let fy = Taps::bilinear_box(scale_y);
    process(dst, dw, dh, src, (scale_x, scale_y), (&fx, &fy));
}

fn need_to_prescale(scale_x: f64, scale_y: f64) -> bool {
    let n_x = (1.0 / scale_x + 3.0).ceil() as i64;
    let n_y = (1.0 / scale_y + 3.0).ceil() as i64;
    n_x * n_y > MAX_FILTERS
}

/// One dimension of a filter: `n` taps for each of the [`SUBSAMPLE`] phases, starting
/// `offset` pixels from the sample position.
struct Taps {
    n: usize,
    offset: f64,
    weights: Vec<f64>,
}

impl Taps {
    /// `bilinear_box_make_weights`: bilinear reconstruction sampled by a box of `1/scale`.
    fn bilinear_box(scale: f64) -> Taps {
        let n = (1.0 / scale + 3.0).ceil() as usize;
        let mut weights = Vec::with_capacity(SUBSAMPLE * n);
        for phase in 0..SUBSAMPLE {
            let x = phase as f64 / SUBSAMPLE as f64;
            let a = x + 1.0 / scale;
            for i in 0..n {
                let i = i as f64;
                let w = linear_box_half(0.5 + i - a, 0.5 + i - x)
                    + linear_box_half(1.5 + x - i, 1.5 + a - i);
                weights.push(w * scale);
            }
        }
        Taps {
            n,
            offset: -1.0,
            weights,
        }
    }
}

/// ∫ from `b0` to `b1` of f(x) = x on [0, 1), 0 elsewhere.
fn linear_box_half(b0: f64, b1: f64) -> f64 {
    let (x0, x1) = if 0.0 < b0 {
        if 1.0 > b0 {
            (b0, b1.min(1.0))
        } else {
            return 0.0;
        }
    } else if b1 > 0.0 {
        (0.0, b1.min(1.0))
    } else {
        return 0.0;
    };
    0.5 * (x1 * x1 - x0 * x0)
}

/// `make_filter_table`: integer weights for every (y phase, x phase), `n_y` rows of `n_x`
/// each, corrected to sum to 65536.
fn filter_table(fx: &Taps, fy: &Taps) -> Vec<i32> {
    let n = fx.n * fy.n;
    let mut table = vec![0i32; SUBSAMPLE * SUBSAMPLE * n];
    for i_off in 0..SUBSAMPLE {
        for j_off in 0..SUBSAMPLE {
            let block = &mut table[(i_off * SUBSAMPLE + j_off) * n..][..n];
            let mut total = 0i32;
            for i in 0..fy.n {
                for j in 0..fx.n {
                    let weight =
                        fx.weights[j_off * fx.n + j] * fy.weights[i_off * fy.n + i] * 1.0 * 65536.0
                            + 0.5;
                    total += weight as i32;
                    block[fx.n * i + j] = weight as i32;
                }
            }
            correct_total(block, total);
        }
    }
    table
}

/// `correct_total`: spreads the rounding error over the weights, last first, so they add up
/// to 65536.
fn correct_total(weights: &mut [i32], total: i32) {
    let correction = 65536 - total;
    if correction == 0 {
        return;
    }
    let mut remaining = correction;
    let mut d = 1;
    let mut c = correction;
    while c != 0 && remaining != 0 {
        for w in weights.iter_mut().rev() {
            if c == 0 || remaining == 0 {
                break;
            }
            if *w + c >= 0 {
                *w += c;
                remaining -= c;
                if (0 < remaining && remaining < c) || (0 > remaining && remaining > c) {
                    c = remaining;
                }
            }
        }
        d += 1;
        c = correction / d;
    }
}

/// Division rounding towards minus infinity for negative numerators (pixops' `MYDIV`).
fn floor_div(a: i64, b: i64) -> i64 {
    if a > 0 { a / b } else { (a - b + 1) / b }
}

/// `pixops_process` with `scale_line` and `process_pixel`/`scale_pixel` for an opaque image:
/// `src` scaled by `(x, y)` through the taps `(x, y)` into a `dw × dh` destination.
fn process(
    dst: &mut [u8],
    dw: usize,
    dh: usize,
    src: Gray<'_>,
    (scale_x, scale_y): (f64, f64),
    (fx, fy): (&Taps, &Taps),
) {
    let Gray {
        pixels: src,
        width: sw,
        height: sh,
    } = src;
    let x_step = (f64::from(1u32 << SCALE_SHIFT) / scale_x) as i64;
    let y_step = (f64::from(1u32 << SCALE_SHIFT) / scale_y) as i64;
    if x_step == 0 || y_step == 0 {
        return;
    }
    let table = filter_table(fx, fy);
    let (n_x, n_y) = (fx.n, fy.n);
    let n_xy = n_x * n_y;
    let scaled_x_offset = (fx.offset * f64::from(1u32 << SCALE_SHIFT)).floor() as i64;
    // From this destination pixel on, the taps would run off the source's right edge.
    let run_end_x = ((sw as i64 - n_x as i64 + 1) << SCALE_SHIFT) - scaled_x_offset;
    let run_end = floor_div(run_end_x + x_step - 1, x_step).min(dw as i64);
    let phase = |v: i64| ((v >> (SCALE_SHIFT - SUBSAMPLE_BITS)) & SUBSAMPLE_MASK) as usize;
    let mut lines = vec![0usize; n_y];
    let mut y = (fy.offset * f64::from(1u32 << SCALE_SHIFT)).floor() as i64;
    for out in dst.chunks_exact_mut(dw.max(1)).take(dh) {
        let y_start = y >> SCALE_SHIFT;
        let run_weights = &table[phase(y) * n_xy * SUBSAMPLE..];
        for (j, line) in lines.iter_mut().enumerate() {
            let row = (y_start + j as i64).clamp(0, sh as i64 - 1) as usize;
            *line = row * sw;
        }
        // Near the edges every tap is clamped to the image (process_pixel).
        let edge_pixel = |x: i64| -> u8 {
            let w = &run_weights[phase(x) * n_xy..][..n_xy];
            let x_start = x >> SCALE_SHIFT;
            let mut r: u32 = 0;
            for (i, &line) in lines.iter().enumerate() {
                for j in 0..n_x {
                    let col = (x_start + j as i64).clamp(0, sw as i64 - 1) as usize;
                    let ta = (0xff * w[n_x * i + j]) as u32;
                    r = r.wrapping_add(ta.wrapping_mul(u32::from(src[line + col])));
                }
            }
            (r.wrapping_add(0xff_ffff) >> 24) as u8
        };
        let mut k = 0usize;
        let mut x = scaled_x_offset;
        while x >> SCALE_SHIFT < 0 && k < dw {
            out[k] = edge_pixel(x);
            x += x_step;
            k += 1;
        }
        // Inside, every tap is on the image (scale_line).
        while (k as i64) < run_end {
            let w = &run_weights[phase(x) * n_xy..][..n_xy];
            let x_scaled = (x >> SCALE_SHIFT) as usize;
            let mut r: u32 = 0;
            for (i, &line) in lines.iter().enumerate() {
                let taps = &src[line + x_scaled..][..n_x];
                for (&wt, &q) in w[n_x * i..][..n_x].iter().zip(taps) {
                    r = r.wrapping_add((wt as u32).wrapping_mul(u32::from(q)));
                }
            }
            out[k] = (r.wrapping_add(0xffff) >> 16) as u8;
            x += x_step;
            k += 1;
        }
        x = k as i64 * x_step + scaled_x_offset;
        while k < dw {
            out[k] = edge_pixel(x);
            x += x_step;
            k += 1;
        }
        y += y_step;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::options::tests::block;
    use player_proto::Pose2d;

    fn grid(w: u32, h: u32, scale: f32, cells: Vec<i8>) -> OccupancyGrid {
        let origin = Pose2d {
            px: -3.0,
            py: 4.0,
            pa: 0.0,
        };
        OccupancyGrid::from_cells(w, h, scale, origin, cells).unwrap()
    }

    #[test]
    fn filter_weights_sum_to_one_in_fixed_point() {
        for scale in [0.1, 0.3, 0.5, 0.77, 1.0, 1.6, 2.0, 3.3] {
            let t = Taps::bilinear_box(scale);
            assert_eq!(t.n, (1.0f64 / scale + 3.0).ceil() as usize);
            // Each phase's taps integrate the unit-area tent over the box: they add up to 1.
            for phase in t.weights.chunks_exact(t.n) {
                let sum: f64 = phase.iter().sum();
                assert!((sum - 1.0).abs() < 1e-9, "scale {scale}: {sum}");
            }
            let table = filter_table(&t, &Taps::bilinear_box(0.5));
            let n = t.n * Taps::bilinear_box(0.5).n;
            for block in table.chunks_exact(n) {
                assert_eq!(block.iter().sum::<i32>(), 65536);
                assert!(block.iter().all(|&w| w >= 0));
            }
        }
    }

    #[test]
    fn correct_total_spreads_the_error_from_the_last_weight() {
        let mut w = [10, 20, 65500];
        correct_total(&mut w, 65530);
        assert_eq!(w, [10, 20, 65506]);
        let mut w = [10, 3, 65530];
        correct_total(&mut w, 65543);
        assert_eq!(w, [10, 3, 65523]);
        // A weight that would go negative is skipped.
        let mut w = [40000, 25540, 2];
        correct_total(&mut w, 65542);
        assert_eq!(w, [40000, 25534, 2]);
    }

    #[test]
    fn uniform_images_stay_uniform_at_any_size() {
        for (sw, sh, dw, dh) in [(7, 5, 3, 2), (4, 4, 9, 13), (50, 3, 1, 1), (3, 3, 3, 7)] {
            for v in [0u8, 127, 255] {
                let out = scale_hyper(&vec![v; sw * sh], sw, sh, dw, dh);
                assert_eq!(out, vec![v; dw * dh], "{sw}x{sh} -> {dw}x{dh} of {v}");
            }
        }
        // The same size is a copy.
        let src: Vec<u8> = (0..12).map(|v| v * 20).collect();
        assert_eq!(scale_hyper(&src, 4, 3, 4, 3), src);
    }

    #[test]
    fn halving_averages_with_the_tent_filter() {
        // 4 x 1, halved: scale 0.5, 5 taps from one pixel left of each 2-pixel box. Computed
        // by hand from the weights gdk-pixbuf uses (tent ⊛ box: 1/16, 7/16, 7/16, 1/16 over
        // the pixels -1..2 of the box at 0), edges replicated.
        let out = scale_hyper(&[0, 0, 255, 255], 4, 1, 2, 1);
        // Left: 0·(1+7+7)/16 + 255·1/16 = 15.94 → 16 (rounded up); right: 255 − 16 = 239.
        assert_eq!(out, [16, 239]);
        // A step scaled up 2x: the tent spreads it over the middle.
        let out = scale_hyper(&[0, 255], 2, 1, 4, 1);
        assert_eq!(out[0], 0);
        assert_eq!(out[3], 255);
        assert!(out[1] < out[2], "{out:?}");
    }

    #[test]
    fn matches_gdk_pixbuf_byte_for_byte() {
        // Outputs of gdk_pixbuf_scale_simple(GDK_INTERP_HYPER) 2.42.10 on the red channel:
        // (source size, destination size, source, destination).
        type Case<'a> = (usize, usize, usize, usize, &'a [u8], &'a [u8]);
        let cases: [Case; 3] = [
            (
                5,
                3,
                3,
                2,
                &[
                    255, 255, 127, 0, 0, 255, 127, 127, 0, 0, 255, 255, 255, 255, 0,
                ],
                &[237, 123, 2, 238, 205, 71],
            ),
            (
                3,
                2,
                7,
                5,
                &[0, 127, 255, 255, 127, 0],
                &[
                    0, 14, 67, 123, 178, 234, 255, 25, 36, 79, 123, 169, 214, 230, 115, 116, 121,
                    127, 132, 138, 140, 223, 213, 173, 130, 89, 47, 32, 255, 241, 187, 132, 76, 21,
                    0,
                ],
            ),
            (
                9,
                4,
                4,
                2,
                &[
                    255, 255, 255, 0, 0, 255, 255, 255, 255, 255, 255, 127, 0, 0, 255, 255, 255,
                    255, 127, 127, 127, 0, 0, 127, 127, 255, 255, 255, 255, 255, 0, 0, 255, 255,
                    255, 255,
                ],
                &[240, 65, 193, 254, 198, 64, 156, 248],
            ),
        ];
        for (sw, sh, dw, dh, src, want) in cases {
            assert_eq!(
                scale_hyper(src, sw, sh, dw, dh),
                want,
                "{sw}x{sh} -> {dw}x{dh}"
            );
        }
    }

    #[test]
    fn big_reductions_go_in_two_steps_and_stay_in_bounds() {
        assert!(!need_to_prescale(0.05, 0.05));
        assert!(need_to_prescale(0.03, 0.03));
        // 200 x 150 to 4 x 3 (a 50x shrink) of a half-black image.
        let (sw, sh) = (200, 150);
        let src: Vec<u8> = (0..sw * sh)
            .map(|k| if k % sw < sw / 2 { 0 } else { 255 })
            .collect();
        let out = scale_hyper(&src, sw, sh, 4, 3);
        for row in out.chunks(4) {
            assert_eq!(row[0], 0, "{out:?}");
            assert_eq!(row[3], 255, "{out:?}");
        }
    }

    #[test]
    fn odd_sizes_never_read_outside_the_image() {
        for sw in 1..9 {
            for dw in 1..13 {
                let src: Vec<u8> = (0..sw * 3).map(|k| (k * 37 % 256) as u8).collect();
                let out = scale_hyper(&src, sw, 3, dw, 2);
                assert_eq!(out.len(), dw * 2);
            }
        }
    }

    #[test]
    fn maps_are_resampled_as_mapscale_does() {
        // A 6 x 4 map at 0.1 m: a wall along the left two columns, unknown along the top
        // row, the rest free; at 0.2 m it is 3 x 2.
        let mut cells = vec![-1i8; 24];
        for j in 0..4 {
            cells[j * 6] = 1;
            cells[j * 6 + 1] = 1;
        }
        for c in &mut cells[18..24] {
            *c = if *c == 1 { 1 } else { 0 };
        }
        let g = grid(6, 4, 0.1, cells);
        let s = scale(&g, 0.2).unwrap();
        assert_eq!((s.width(), s.height(), s.scale()), (3, 2, 0.2f32));
        assert_eq!(s.origin(), g.origin());
        // Left column occupied; right of the bottom row free; the top row mixes free and
        // unknown (0.5 x 255 + 0.5 x 127 = 191 → still free beside the wall, see below).
        assert_eq!(s.get(0, 0), Some(1));
        assert_eq!(s.get(0, 1), Some(1));
        assert_eq!(s.get(2, 0), Some(-1));
        // Doubling the resolution keeps every cell's state away from the borders.
        let d = scale(&g, 0.05).unwrap();
        assert_eq!((d.width(), d.height()), (12, 8));
        assert_eq!(d.get(0, 0), Some(1));
        assert_eq!(d.get(11, 0), Some(-1));
        assert_eq!(d.get(11, 7), Some(0));
        // The same resolution is the same map.
        assert_eq!(scale(&g, 0.1).unwrap(), g);
    }

    #[test]
    fn sizes_round_half_to_even_from_the_float_scales() {
        // 5 cells at 1 m to 2 m: rint(2.5) = 2.
        let g = grid(5, 3, 1.0, vec![-1; 15]);
        let s = scale(&g, 2.0).unwrap();
        assert_eq!((s.width(), s.height()), (2, 2));
        // 0.1f32 / 0.3f32 = 0.33333334: 30 cells become rint(10.0000002) = 10, 3 become 1.
        let g = grid(30, 3, 0.1, vec![-1; 90]);
        let s = scale(&g, 0.3).unwrap();
        assert_eq!((s.width(), s.height()), (10, 1));
        // Shrinking to nothing is an error.
        let e = scale(&g, 100.0).unwrap_err().to_string();
        assert!(e.contains("gives a 0 x 0 map"), "{e}");
    }

    #[test]
    fn options_as_player_reads_them() {
        let o = ScaleOptions::from_block(&block(NAME, &[("resolution", "0.5")])).unwrap();
        assert_eq!(o.resolution, 0.5);
        let err = |opts: &[(&str, &str)]| {
            ScaleOptions::from_block(&block(NAME, opts))
                .unwrap_err()
                .to_string()
        };
        assert!(err(&[]).starts_with("option `resolution` is required"));
        assert!(err(&[("resolution", "0")]).contains("positive"));
        assert!(err(&[("resolution", "x")]).contains("`resolution`"));
        let g = grid(2, 2, 0.25, vec![-1; 4]);
        assert_eq!(o.transform(&g).unwrap().width(), 1);
    }
}
