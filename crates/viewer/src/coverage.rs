//! Coverage counts of many translucent polygons, rasterised on the CPU: for each pixel, how
//! many of the polygons cover its centre.
//!
//! Why: 1,000 laser footprints of one colour, seen whole, cover a 1280x720 view some 30 times
//! over. Blended one by one, a software rasteriser (llvmpipe) fills 28 million pixels and pays
//! half a microsecond for each of their tens of thousands of triangles: 160 ms a frame. But
//! `n` layers of one colour `c` with alpha `a` blended over `d` give exactly
//! `c (1 - (1 - a)^n) + d (1 - a)^n`, so the picture needs only each pixel's count `n`. Counting
//! needs no per-triangle work at all: each polygon edge adds +1 or -1 where it crosses each
//! pixel row (a winding-number delta), interior edges of a fan never enter (the fan is one
//! polygon, its rim and two sides), and one running sum per row turns the deltas into counts.
//! The renderer composites the counts with one full-view pass ([`crate::render`]).
//!
//! The sampling rule is the GPU's: a pixel is covered when its centre is inside, with ties on
//! an edge going to the right and bottom neighbours (a centre exactly on a shared edge is
//! counted once).

/// Pixel transform: world metres to pixel coordinates (x right, y down), an affine map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelMap {
    /// Pixel column of world `(wx, wy)`: `x[0] * wx + x[1] * wy + x[2]`.
    pub x: [f64; 3],
    /// Pixel row: `y[0] * wx + y[1] * wy + y[2]`.
    pub y: [f64; 3],
}

impl PixelMap {
    /// The map of `view` (its `size` is the target's in pixels).
    pub fn of(view: &crate::view::View) -> PixelMap {
        let o = view.to_screen([0.0, 0.0]);
        let ex = view.to_screen([1.0, 0.0]);
        let ey = view.to_screen([0.0, 1.0]);
        PixelMap {
            x: [ex[0] - o[0], ey[0] - o[0], o[0]],
            y: [ex[1] - o[1], ey[1] - o[1], o[1]],
        }
    }

    /// Where the world point `p` lands, in pixels.
    pub fn apply(&self, p: [f32; 2]) -> [f64; 2] {
        let (x, y) = (f64::from(p[0]), f64::from(p[1]));
        [
            self.x[0] * x + self.x[1] * y + self.x[2],
            self.y[0] * x + self.y[1] * y + self.y[2],
        ]
    }
}

/// Most groups [`Coverage::count`] counts at once (one byte each of an RGBA pixel).
pub const MAX_GROUPS: usize = 4;

/// Rows counted together: a band's deltas (2 colours at 1280 pixels: 330 KB) stay in cache
/// while every edge crossing it is added, where adding edge by edge down the whole target
/// missed the cache on nearly every row.
const BAND_ROWS: usize = 32;

/// Reusable buffers of a coverage rasteriser.
#[derive(Debug, Default)]
pub struct Coverage {
    /// One part per thread: the edges of its share of the rings, listed by band.
    parts: Vec<Part>,
}

/// The edges of some of the rings, listed by band.
#[derive(Debug, Default)]
struct Part {
    /// Ring corners in pixels (one ring at a time).
    corners: Vec<[f64; 2]>,
    /// Every edge crossing a pixel row's centre.
    edges: Vec<Edge>,
    /// The edges crossing each band: band `b`'s are `by_band[band_start[b]..band_start[b + 1]]`.
    band_start: Vec<usize>,
    by_band: Vec<u32>,
}

/// A polygon edge as the rows see it.
#[derive(Clone, Copy, Debug)]
struct Edge {
    /// The first and one past the last row whose centre it crosses.
    rows: [u32; 2],
    /// The crossing's x less half a pixel at the first row's centre, and its change per row.
    x: f64,
    slope: f64,
    /// Winding change (+1 or -1) and the ring's group.
    dir: i32,
    group: u32,
}

impl Coverage {
    /// Counts, for each pixel of a `width` x `height` target and each group of polygons, how
    /// many of the group's polygons cover the pixel's centre, and writes the count (saturated
    /// at 255) mapped through the group's table into `out` (resized): a byte per group and
    /// pixel, the groups rounded up to 1, 2 or 4 bytes (unused ones 0; the texel sizes of R8,
    /// RG8 and RGBA8), rows from the top.
    ///
    /// `rings` are (group, closed ring of world points mapped by `map`); groups are
    /// `0..tables.len()`, at most [`MAX_GROUPS`]. Rings of either orientation count +1 inside
    /// (one that winds around a pixel twice counts 2, as its triangle fan blended twice
    /// would); rings with non-finite points or an unknown group are left out. The work is
    /// shared among `threads` threads (1 or less: the caller's only): first the rings, then
    /// bands of rows.
    #[allow(clippy::too_many_arguments)]
    pub fn count<'a>(
        &mut self,
        width: usize,
        height: usize,
        map: &PixelMap,
        rings: impl IntoIterator<Item = (usize, &'a [[f32; 2]])>,
        tables: &[[u8; 256]],
        threads: usize,
        out: &mut Vec<u8>,
    ) {
        let groups = tables.len().min(MAX_GROUPS);
        let channels = groups.max(1).next_power_of_two();
        out.resize(width * height * channels, 0);
        if width == 0 || height == 0 || groups == 0 {
            out.fill(0);
            return;
        }
        let bands = height.div_ceil(BAND_ROWS);
        let threads = threads.clamp(1, bands);
        let shared: Vec<(usize, &[[f32; 2]])> =
            rings.into_iter().filter(|(g, _)| *g < groups).collect();
        self.parts.resize_with(threads, Part::default);
        let per = shared.len().div_ceil(threads).max(1);
        let jobs = self
            .parts
            .iter_mut()
            .zip(shared.chunks(per).chain(std::iter::repeat(&[][..])));
        share(jobs.collect(), threads, |_: &mut (), (part, rings)| {
            part.collect(rings, map, height)
        });
        let shape = Shape {
            width,
            groups,
            channels,
        };
        let parts = &self.parts;
        let bands = out.chunks_mut(width * channels * BAND_ROWS).enumerate();
        share(
            bands.collect(),
            threads,
            |deltas: &mut Vec<i32>, (b, out)| {
                let rows = out.len() / (width * channels);
                deltas.clear();
                deltas.resize((width + 1) * groups * rows, 0);
                for p in parts {
                    let edges = p.by_band[p.band_start[b]..p.band_start[b + 1]].iter();
                    band(
                        edges.map(|&e| &p.edges[e as usize]),
                        shape,
                        b * BAND_ROWS,
                        deltas,
                    );
                }
                resolve(deltas, shape, tables, out);
            },
        );
    }
}

/// Does every job, on the calling thread and up to `threads - 1` helpers, each taking the next
/// job as it comes free (bands differ in how many edges cross them) and keeping its own scratch
/// `S` from job to job. A helper that cannot be started leaves its share to the others: the work
/// gets done either way.
fn share<J: Send, S: Default>(jobs: Vec<J>, threads: usize, work: impl Fn(&mut S, J) + Sync) {
    let helpers = threads.min(jobs.len()).saturating_sub(1);
    let queue = std::sync::Mutex::new(jobs.into_iter());
    let next = || queue.lock().unwrap_or_else(|e| e.into_inner()).next();
    let drain = || {
        let mut scratch = S::default();
        while let Some(job) = next() {
            work(&mut scratch, job);
        }
    };
    std::thread::scope(|s| {
        for _ in 0..helpers {
            if std::thread::Builder::new().spawn_scoped(s, drain).is_err() {
                break;
            }
        }
        drain();
    });
}

impl Part {
    /// Makes the part the edges of `rings` on a target `height` rows tall, listed by band.
    fn collect(&mut self, rings: &[(usize, &[[f32; 2]])], map: &PixelMap, height: usize) {
        self.edges.clear();
        for &(group, ring) in rings {
            self.add_ring(ring, group, map, height);
        }
        self.bin(height);
    }

    /// Adds the edges of one ring that cross row centres of a target `height` rows tall.
    fn add_ring(&mut self, ring: &[[f32; 2]], group: usize, map: &PixelMap, height: usize) {
        self.corners.clear();
        self.corners.extend(ring.iter().map(|&p| map.apply(p)));
        let pts = &self.corners;
        if pts.len() < 3 || pts.iter().flatten().any(|v| !v.is_finite()) {
            return;
        }
        let mut twice_area = 0.0;
        let mut a = pts[pts.len() - 1];
        for &b in pts {
            twice_area += a[0] * b[1] - b[0] * a[1];
            a = b;
        }
        let sign = if twice_area >= 0.0 { 1 } else { -1 };
        let last_row = height as f64;
        let mut a = pts[pts.len() - 1];
        for &b in pts {
            let (top, bottom, dir) = if a[1] < b[1] {
                // downward edges (y growing) count against an anticlockwise-on-screen ring
                (a, b, -sign)
            } else {
                (b, a, sign)
            };
            a = b;
            // rows whose centre y + 0.5 lies in [top, bottom) (none for a level edge)
            let r0 = ceil_within(top[1] - 0.5, last_row);
            let r1 = ceil_within(bottom[1] - 0.5, last_row);
            if r0 >= r1 {
                continue;
            }
            let slope = (bottom[0] - top[0]) / (bottom[1] - top[1]);
            self.edges.push(Edge {
                rows: [r0 as u32, r1 as u32],
                x: top[0] + (r0 as f64 + 0.5 - top[1]) * slope - 0.5,
                slope,
                dir,
                group: group as u32,
            });
        }
    }

    /// Lists each band's edges (a counting sort: how many per band, then where each goes).
    fn bin(&mut self, height: usize) {
        let bands = height.div_ceil(BAND_ROWS);
        self.band_start.clear();
        self.band_start.resize(bands + 1, 0);
        let span = |e: &Edge| e.rows[0] as usize / BAND_ROWS..=(e.rows[1] as usize - 1) / BAND_ROWS;
        for e in &self.edges {
            for b in span(e) {
                self.band_start[b + 1] += 1;
            }
        }
        for b in 0..bands {
            self.band_start[b + 1] += self.band_start[b];
        }
        self.by_band.clear();
        self.by_band.resize(self.band_start[bands], 0);
        let mut next = self.band_start.clone();
        for (i, e) in self.edges.iter().enumerate() {
            for b in span(e) {
                self.by_band[next[b]] = i as u32;
                next[b] += 1;
            }
        }
    }
}

/// The layout of the delta and output rows.
#[derive(Clone, Copy, Debug)]
struct Shape {
    width: usize,
    groups: usize,
    channels: usize,
}

/// Adds the winding deltas of `edges` on the band's rows (from `first_row`, as many as
/// `deltas` holds) into `deltas`.
fn band<'a>(
    edges: impl Iterator<Item = &'a Edge>,
    shape: Shape,
    first_row: usize,
    deltas: &mut [i32],
) {
    let g = shape.groups;
    let stride = (shape.width + 1) * g;
    let end_row = first_row + deltas.len() / stride;
    let last = shape.width as f64;
    for e in edges {
        let r0 = (e.rows[0] as usize).max(first_row);
        let r1 = (e.rows[1] as usize).min(end_row);
        let mut x = e.x + (r0 - e.rows[0] as usize) as f64 * e.slope;
        let mut at = (r0 - first_row) * stride + e.group as usize;
        for _ in r0..r1 {
            // the first pixel whose centre is at or right of the crossing
            let c = ceil_within(x, last);
            deltas[at + c * g] += e.dir;
            x += e.slope;
            at += stride;
        }
    }
}

/// `ceil(x)` of `x` clamped to `[0, hi]` (`hi` a whole number below 2^32: a pixel count), by
/// truncation and without a libm call: the baseline x86-64 target has no rounding instruction,
/// and this runs per edge and row.
#[inline]
fn ceil_within(x: f64, hi: f64) -> usize {
    let t = x.clamp(0.0, hi);
    let i = t as u32;
    (i + u32::from(f64::from(i) < t)) as usize
}

/// Turns a band's deltas into table-mapped counts, row by row (a malformed ring's negative
/// winding counts as 0).
fn resolve(deltas: &[i32], shape: Shape, tables: &[[u8; 256]], out: &mut [u8]) {
    let (w, g, ch) = (shape.width, shape.groups, shape.channels);
    let rows = deltas
        .chunks(((w + 1) * g).max(1))
        .zip(out.chunks_mut((w * ch).max(1)));
    for (row, px) in rows {
        let mut acc = [0i32; MAX_GROUPS];
        for (d, p) in row.chunks_exact(g).zip(px.chunks_exact_mut(ch)) {
            for k in 0..g {
                acc[k] += d[k];
                p[k] = tables[k][acc[k].clamp(0, 255) as usize];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use stage_sim::SimRng;

    /// The identity map: world metres are pixels, y down.
    fn pixels() -> PixelMap {
        PixelMap {
            x: [1.0, 0.0, 0.0],
            y: [0.0, 1.0, 0.0],
        }
    }

    /// The table that writes counts as they are.
    const COUNTS: [u8; 256] = {
        let mut t = [0u8; 256];
        let mut i = 0;
        while i < 256 {
            t[i] = i as u8;
            i += 1;
        }
        t
    };

    /// Whether `p` is inside the ring by crossing parity (brute force).
    fn inside(ring: &[[f32; 2]], p: [f64; 2]) -> bool {
        let mut c = false;
        for i in 0..ring.len() {
            let a = [ring[i][0] as f64, ring[i][1] as f64];
            let j = (i + 1) % ring.len();
            let b = [ring[j][0] as f64, ring[j][1] as f64];
            if (a[1] > p[1]) != (b[1] > p[1]) {
                let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
                if p[0] < x {
                    c = !c;
                }
            }
        }
        c
    }

    /// A random star-shaped ring around `c` (a laser footprint: centre, then rim points at
    /// increasing angles), turning anticlockwise or clockwise.
    fn star(rng: &mut SimRng, c: [f64; 2], reach: f64, clockwise: bool) -> Vec<[f32; 2]> {
        let n = 3 + (rng.next_f64() * 40.0) as usize;
        let span = 0.5 + rng.next_f64() * 5.5;
        let mut ring = vec![[c[0] as f32, c[1] as f32]];
        for i in 0..n {
            let a = span * i as f64 / (n - 1) as f64 * if clockwise { -1.0 } else { 1.0 };
            let r = reach * (0.1 + 0.9 * rng.next_f64());
            ring.push([(c[0] + r * a.cos()) as f32, (c[1] + r * a.sin()) as f32]);
        }
        ring
    }

    #[test]
    fn counts_match_a_per_pixel_point_in_polygon_test() {
        let mut rng = SimRng::new(7, 0);
        let (w, h) = (97, 61);
        let rings: Vec<Vec<[f32; 2]>> = (0..60)
            .map(|k| {
                let c = [rng.next_f64() * 110.0 - 6.0, rng.next_f64() * 75.0 - 7.0];
                let reach = 5.0 + rng.next_f64() * 30.0;
                star(&mut rng, c, reach, k % 3 == 0)
            })
            .collect();
        let mut cov = Coverage::default();
        for threads in [1, 2, 5] {
            let mut counts = Vec::new();
            let it = rings.iter().map(|r| (0, r.as_slice()));
            cov.count(w, h, &pixels(), it, &[COUNTS], threads, &mut counts);
            assert_eq!(counts.len(), w * h);
            let (mut covered, mut most) = (0, 0);
            for y in 0..h {
                for x in 0..w {
                    let p = [x as f64 + 0.5, y as f64 + 0.5];
                    let want = rings.iter().filter(|r| inside(r, p)).count();
                    assert_eq!(
                        counts[y * w + x] as usize,
                        want,
                        "pixel {x},{y}, {threads} threads"
                    );
                    covered += want;
                    most = most.max(want);
                }
            }
            assert!(
                covered > w * h && most >= 4,
                "{covered} coverings, at most {most}"
            );
        }
    }

    #[test]
    fn shared_edges_and_centres_on_edges_are_counted_once() {
        // two squares sharing the edge x = 5 through pixel centres' column boundary, and a
        // square whose left edge runs exactly through centres (x = 2.5)
        let left = [[0.0, 0.0], [5.0, 0.0], [5.0, 4.0], [0.0, 4.0]];
        let right = [[5.0, 0.0], [10.0, 0.0], [10.0, 4.0], [5.0, 4.0]];
        let on = [[2.5, 5.0], [7.5, 5.0], [7.5, 8.0], [2.5, 8.0]];
        let mut counts = Vec::new();
        let rings = [(0, &left[..]), (0, &right[..]), (0, &on[..])];
        Coverage::default().count(10, 8, &pixels(), rings, &[COUNTS], 1, &mut counts);
        // the two squares tile rows 0..4 exactly
        assert!(counts[..40].iter().all(|&c| c == 1), "{:?}", &counts[..40]);
        // a centre on the left edge is in (columns 2..7), one on the right edge out
        for y in 5..8 {
            let row = &counts[y * 10..y * 10 + 10];
            assert_eq!(row, &[0, 0, 1, 1, 1, 1, 1, 0, 0, 0], "row {y}");
        }
    }

    #[test]
    fn rings_off_target_or_malformed_change_nothing_and_counts_saturate() {
        let far = [[-50.0, -50.0], [-40.0, -50.0], [-40.0, -40.0]];
        let nan = [[0.0, 0.0], [f32::NAN, 1.0], [3.0, 3.0]];
        let line = [[0.0, 0.0], [4.0, 4.0]];
        let square = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]];
        let mut rings: Vec<(usize, &[[f32; 2]])> =
            vec![(0, &far), (0, &nan), (0, &line), (1, &far)];
        rings.extend(std::iter::repeat_n((0, &square[..]), 300));
        let mut counts = Vec::new();
        Coverage::default().count(6, 6, &pixels(), rings, &[COUNTS], 2, &mut counts);
        for y in 0..6 {
            for x in 0..6 {
                let want = if x < 4 && y < 4 { 255 } else { 0 };
                assert_eq!(counts[y * 6 + x], want, "pixel {x},{y}");
            }
        }
        // an empty target is no work and no panic
        let rings = [(0, &square[..])];
        Coverage::default().count(0, 0, &pixels(), rings, &[COUNTS], 2, &mut counts);
        assert!(counts.is_empty());
    }

    #[test]
    fn groups_are_counted_apart_and_mapped_through_their_tables() {
        let mut rng = SimRng::new(11, 0);
        let (w, h) = (40, 30);
        let rings: Vec<(usize, Vec<[f32; 2]>)> = (0..30)
            .map(|k| {
                let c = [rng.next_f64() * 40.0, rng.next_f64() * 30.0];
                (k % 3, {
                    let reach = 4.0 + rng.next_f64() * 15.0;
                    star(&mut rng, c, reach, k % 2 == 0)
                })
            })
            .collect();
        let mut doubled = COUNTS;
        for (i, v) in doubled.iter_mut().enumerate() {
            *v = (2 * i).min(255) as u8;
        }
        let tables = [COUNTS, doubled, COUNTS];
        let mut out = Vec::new();
        let it = rings.iter().map(|(g, r)| (*g, r.as_slice()));
        Coverage::default().count(w, h, &pixels(), it, &tables, 2, &mut out);
        assert_eq!(out.len(), w * h * 4);
        for y in 0..h {
            for x in 0..w {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                let n = |g: usize| {
                    rings
                        .iter()
                        .filter(|(k, r)| *k == g && inside(r, p))
                        .count()
                };
                let want = [n(0) as u8, 2 * n(1) as u8, n(2) as u8, 0];
                assert_eq!(out[(y * w + x) * 4..][..4], want, "pixel {x},{y}");
            }
        }
    }

    #[test]
    fn shared_jobs_are_each_done_once_whatever_the_thread_count() {
        for (jobs, threads) in [(0, 2), (1, 4), (7, 1), (50, 3), (5, 16)] {
            let done = std::sync::Mutex::new(Vec::new());
            share(
                (0..jobs).collect(),
                threads,
                |count: &mut usize, j: usize| {
                    *count += 1;
                    done.lock().unwrap().push(j);
                },
            );
            let mut done = done.into_inner().unwrap();
            done.sort();
            assert_eq!(
                done,
                (0..jobs).collect::<Vec<_>>(),
                "{jobs} jobs, {threads} threads"
            );
        }
    }

    #[test]
    fn the_pixel_map_follows_the_view() {
        let view = crate::view::View {
            center: [1.0, 2.0],
            scale: 40.0,
            yaw: 0.7,
            size: [320.0, 200.0],
        };
        let map = PixelMap::of(&view);
        for p in [[0.0f32, 0.0], [3.5, -1.25], [1.0, 2.0]] {
            let want = view.to_screen([p[0] as f64, p[1] as f64]);
            let got = map.apply(p);
            assert!((want[0] - got[0]).abs() < 1e-9 && (want[1] - got[1]).abs() < 1e-9);
        }
    }
}
