//! A hash grid over points for fixed-radius range queries (the photon lookup of merging).
//!
//! Cells are cubes of side 4r; a cell's integer coordinates hash (Teschner et al. 2003) into
//! one of `m` buckets. Every point is stored in the bucket of each cell its r-ball overlaps
//! (one to eight cells, once per distinct bucket), so a query reads a single bucket: the one
//! of the cell that holds the query point, which has every point within r of it, and reports
//! those at distance <= r. A counting sort lays the entries out bucket by bucket, in input
//! order within a bucket, so the grid, and the order in which a query visits points, depend on
//! the input only. The sort scatters each entry's point index (4 bytes), then copies the
//! points into place in entry order, asking for each a few entries ahead: scattering the
//! entries themselves (52 bytes for vcm's photons, 100 MB a pass on SmallVCM's box) wrote a
//! cache line or two at random per entry (72 -> 55 ms a pass). The build runs on rayon's
//! threads (keys by chunks of points, counts and scatter by ranges of buckets, the copy by
//! chunks of entries) and gives the same grid on any number of them: on SmallVCM's box 60 ms
//! on one thread, 31 ms on two, where it was a serial step of every vcm pass.
//!
//! Each point carries a payload `T` (an index, or what the query needs of the point), stored
//! with its position: a query touches one run of memory. (Cells of side 2r queried 2 x 2 x 2, with
//! the payload fetched from the caller's array, cost vcm a cache miss per bucket and per
//! point in range: most of its merging time.) A caller that knows a query point early can
//! hand its bucket to [`HashGrid::prefetch_range`] and later [`HashGrid::prefetch_entries`],
//! so that the two dependent cache misses of a query overlap other work. The second asks for
//! the whole bucket (up to `PREFETCH_LINES` cache lines; about 26 entries, 21 lines, on
//! SmallVCM's box), not only its first lines: the scan itself then no longer waits on memory.

use glam::{IVec3, Vec3};
use rayon::prelude::*;

/// Points with payloads `T`, bucketed by hashed cells for queries of all points within
/// the radius r of a point.
pub struct HashGrid<T = u32> {
    radius2: f32,
    inv_cell: f32,
    origin: Vec3,
    /// Number of points (each is stored in one to eight buckets).
    points: usize,
    /// `starts[b] .. starts[b + 1]` are bucket b's entries.
    starts: Vec<u32>,
    /// (position, payload), sorted by bucket.
    entries: Vec<(Vec3, T)>,
    /// Scratch of the counting sort, kept for the next [`HashGrid::rebuild`]: (bucket, point)
    /// pairs by chunk of points and part of the buckets, each bucket's next free slot, and
    /// the point of each entry.
    keys: Vec<[Vec<(u32, u32)>; PARTS]>,
    next: Vec<u32>,
    order: Vec<u32>,
}

impl<T> Default for HashGrid<T> {
    fn default() -> Self {
        HashGrid {
            radius2: 0.0,
            inv_cell: 0.0,
            origin: Vec3::ZERO,
            points: 0,
            starts: Vec::new(),
            entries: Vec::new(),
            keys: Vec::new(),
            next: Vec::new(),
            order: Vec::new(),
        }
    }
}

/// The most cache lines of a bucket [`HashGrid::prefetch_entries`] asks for: more than a
/// typical bucket has (on SmallVCM's box a query scans about 26 entries of 52 bytes, 21
/// lines; asking for 64 lines measured no faster).
const PREFETCH_LINES: usize = 32;

/// How many entries ahead [`HashGrid::rebuild`] asks for the point it will copy.
const GATHER_AHEAD: usize = 16;

/// A point within this fraction of a cell side from a cell face (a quarter: r of 4r, with a
/// margin for rounding) is also stored in the neighbour across that face.
const REACH: f32 = 0.25 + 1e-3;

impl<T: Copy + Default + Send + Sync> HashGrid<T> {
    /// A grid over `points` (position, payload) for queries of radius `radius` > 0.
    pub fn new(points: &[(Vec3, T)], radius: f32) -> HashGrid<T> {
        let mut grid = HashGrid::default();
        grid.rebuild(points, radius);
        grid
    }

    /// [`HashGrid::new`] in this grid's memory (vcm rebuilds its grid every pass; fresh
    /// allocations of that size cost page faults every time), on rayon's threads: keys by
    /// chunks of points, counts and scatter by ranges of buckets, the copy by chunks of
    /// entries. The grid is the same whatever the number of threads.
    pub fn rebuild(&mut self, points: &[(Vec3, T)], radius: f32) {
        let inf = Vec3::splat(f32::INFINITY);
        let origin = points
            .par_chunks(CHUNK)
            .map(|c| c.iter().fold(inf, |m, (p, _)| m.min(*p)))
            .reduce(|| inf, Vec3::min);
        self.origin = if origin.is_finite() {
            origin
        } else {
            Vec3::ZERO
        };
        self.radius2 = radius * radius;
        self.inv_cell = 0.25 / radius;
        self.points = points.len();
        // Buckets: as many as points, at least one; PARTS ranges of them (about b PARTS / m,
        // by multiply-shift: no division per key), part p from bucket lo(p) on.
        let m = points.len().max(1);
        // (At least 1: with 2^28 points or more, every bucket falls in part 0.)
        let scale = (((PARTS as u64) << 32) / m as u64).max(1);
        let part_of = |b: u32| ((b as u64 * scale) >> 32) as usize;
        // lo(p): the least b with b scale >= p 2^32.
        let lo: Vec<usize> = (0..=PARTS)
            .map(|p| match p {
                PARTS => m,
                _ => (((p as u64) << 32).div_ceil(scale) as usize).min(m),
            })
            .collect();
        debug_assert!((0..PARTS).all(|p| lo[p] == lo[p + 1] || part_of(lo[p] as u32) == p));
        // 1. Each chunk's (bucket, point) keys, by part, in input order.
        let chunks = points.len().div_ceil(CHUNK);
        self.keys.resize_with(chunks, Default::default);
        let (origin, inv_cell) = (self.origin, self.inv_cell);
        self.keys[..chunks]
            .par_iter_mut()
            .enumerate()
            .for_each(|(c, parts)| {
                parts.iter_mut().for_each(Vec::clear);
                let first = c * CHUNK;
                let chunk = &points[first..(first + CHUNK).min(points.len())];
                for (k, (p, _)) in chunk.iter().enumerate() {
                    for &b in cell_buckets(*p, origin, inv_cell, m).as_slice() {
                        parts[part_of(b)].push((b, (first + k) as u32));
                    }
                }
            });
        let keys = &self.keys[..chunks];
        // Part p's keys: chunk after chunk, so in input order.
        let part = |p: usize| keys.iter().map(move |parts| &parts[p]);
        // 2. Counts, each part its own buckets; then exclusive prefix sums.
        self.starts.clear();
        self.starts.resize(m + 1, 0);
        split_at(&mut self.starts[1..], &lo)
            .into_par_iter()
            .enumerate()
            .for_each(|(p, counts)| {
                for &(b, _) in part(p).flatten() {
                    counts[b as usize - lo[p]] += 1;
                }
            });
        for i in 1..self.starts.len() {
            self.starts[i] += self.starts[i - 1];
        }
        // 3. Each entry's point index, each part in its own range of entries, in input order
        // within each bucket.
        let total = self.starts[m] as usize;
        self.next.clear();
        self.next.extend_from_slice(&self.starts[..m]);
        self.order.clear();
        self.order.resize(total, 0);
        let entry_lo: Vec<usize> = lo.iter().map(|&b| self.starts[b] as usize).collect();
        split_at(&mut self.next, &lo)
            .into_par_iter()
            .zip(split_at(&mut self.order, &entry_lo))
            .enumerate()
            .for_each(|(p, (next, order))| {
                let base = entry_lo[p];
                for keys in part(p) {
                    for (j, &(b, i)) in keys.iter().enumerate() {
                        if let Some(&(ahead, _)) = keys.get(j + GATHER_AHEAD) {
                            crate::prefetch::line(&next[ahead as usize - lo[p]]);
                        }
                        let slot = &mut next[b as usize - lo[p]];
                        order[*slot as usize - base] = i;
                        *slot += 1;
                    }
                }
            });
        // 4. The entries, copied from the points in entry order: the points are read at
        // random, so each one is asked for GATHER_AHEAD entries before it is copied.
        let order = &self.order;
        self.entries.clear();
        self.entries
            .par_extend(order.par_iter().enumerate().map(|(j, &i)| {
                if let Some(&ahead) = order.get(j + GATHER_AHEAD) {
                    let p = &points[ahead as usize] as *const (Vec3, T) as *const u8;
                    crate::prefetch::line(p);
                    crate::prefetch::line(p.wrapping_add(std::mem::size_of::<(Vec3, T)>() - 1));
                }
                points[i as usize]
            }));
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points
    }

    /// Whether the grid holds no point.
    pub fn is_empty(&self) -> bool {
        self.points == 0
    }

    /// The bucket a query at `p` reads (for [`HashGrid::prefetch_range`] and
    /// [`HashGrid::prefetch_entries`]).
    #[inline]
    pub fn bucket_of(&self, p: Vec3) -> usize {
        let c = ((p - self.origin) * self.inv_cell).floor().as_ivec3();
        bucket(c, self.starts.len().max(2) - 1) as usize
    }

    /// Ask the cache for bucket `b`'s range without waiting for it.
    #[inline]
    pub fn prefetch_range(&self, b: usize) {
        if let Some(s) = self.starts.get(b) {
            crate::prefetch::line(s);
        }
    }

    /// Ask the cache for bucket `b`'s entries without waiting for them (reads the
    /// range, which [`HashGrid::prefetch_range`] should have brought in).
    #[inline]
    pub fn prefetch_entries(&self, b: usize) {
        if b + 1 >= self.starts.len() {
            return;
        }
        let (s, e) = (self.starts[b] as usize, self.starts[b + 1] as usize);
        if s < e {
            crate::prefetch::slice(&self.entries[s..e], PREFETCH_LINES);
        }
    }

    /// Call `visit(payload)` for every point within the radius of `p`.
    #[inline]
    pub fn query(&self, p: Vec3, mut visit: impl FnMut(&T)) {
        if self.entries.is_empty() {
            return;
        }
        let b = self.bucket_of(p);
        let (s, e) = (self.starts[b] as usize, self.starts[b + 1] as usize);
        for (q, item) in &self.entries[s..e] {
            if (*q - p).length_squared() <= self.radius2 {
                visit(item);
            }
        }
    }
}

/// Points per task of [`HashGrid::rebuild`]'s first step.
const CHUNK: usize = 1 << 14;
/// Ranges of buckets [`HashGrid::rebuild`] counts and sorts as separate tasks.
const PARTS: usize = 16;

/// The distinct buckets (among `m`) of the cells that the r-ball around `p` reaches: one to
/// eight of them, in a fixed order.
#[inline(always)]
fn cell_buckets(p: Vec3, origin: Vec3, inv_cell: f32, m: usize) -> Buckets {
    let c = (p - origin) * inv_cell;
    let base = c.floor();
    let frac = c - base;
    let base = base.as_ivec3();
    // The cells along each axis that the r-ball reaches: 1 or 2.
    let axis = |f: f32| -> &'static [i32] {
        if f < REACH {
            &[-1, 0]
        } else if f > 1.0 - REACH {
            &[0, 1]
        } else {
            &[0]
        }
    };
    let (ax, ay, az) = (axis(frac.x), axis(frac.y), axis(frac.z));
    let mut out = Buckets {
        buckets: [u32::MAX; 8],
        count: 0,
    };
    // Distinct cells may still share a bucket: each bucket is kept once.
    for &dz in az {
        for &dy in ay {
            for &dx in ax {
                let b = bucket(base + IVec3::new(dx, dy, dz), m);
                if !out.as_slice().contains(&b) {
                    out.buckets[out.count] = b;
                    out.count += 1;
                }
            }
        }
    }
    out
}

struct Buckets {
    buckets: [u32; 8],
    count: usize,
}

impl Buckets {
    fn as_slice(&self) -> &[u32] {
        &self.buckets[..self.count]
    }
}

/// `items` cut at the ascending offsets `cuts` (first 0, last `items.len()`) into
/// `cuts.len() - 1` disjoint slices.
fn split_at<'s, U>(mut items: &'s mut [U], cuts: &[usize]) -> Vec<&'s mut [U]> {
    let mut parts = Vec::with_capacity(cuts.len() - 1);
    for w in cuts.windows(2) {
        let (head, tail) = items.split_at_mut(w[1] - w[0]);
        parts.push(head);
        items = tail;
    }
    parts
}

/// The bucket of cell `c` among `m`.
#[inline]
fn bucket(c: IVec3, m: usize) -> u32 {
    let h = (c.x as u32).wrapping_mul(73_856_093)
        ^ (c.y as u32).wrapping_mul(19_349_663)
        ^ (c.z as u32).wrapping_mul(83_492_791);
    // h scaled to [0, m) by its high bits (Lemire's multiply-shift: no division; the
    // products above carry every coordinate bit into the high bits).
    ((h as u64 * m as u64) >> 32) as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{IndependentSampler, Sampler};

    /// Every query returns exactly the points a brute-force search finds, each once.
    #[test]
    fn queries_match_brute_force() {
        let mut s = IndependentSampler::new(1, 0, 0);
        let mut pt = || Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 2.0 - 1.0;
        let points: Vec<(Vec3, u32)> = (0..3000).map(|i| (pt(), i)).collect();
        for radius in [0.01, 0.07, 0.3] {
            let grid = HashGrid::new(&points, radius);
            assert_eq!(grid.len(), points.len());
            for _ in 0..300 {
                // Also outside the points' bounding box.
                let q = pt() * 1.1;
                let mut found = Vec::new();
                grid.query(q, |&i| found.push(i));
                found.sort_unstable();
                let expect: Vec<u32> = points
                    .iter()
                    .filter(|(p, _)| (*p - q).length_squared() <= radius * radius)
                    .map(|(_, i)| *i)
                    .collect();
                assert_eq!(found, expect, "radius {radius}, query {q}");
            }
        }
    }

    /// The rebuild runs on rayon's threads (several chunks of points here): the grid is the
    /// same on one thread and on three, and its queries still find exactly the points in range.
    #[test]
    fn rebuild_is_the_same_on_any_number_of_threads() {
        let mut s = IndependentSampler::new(2, 0, 0);
        // Points on two planes, as vcm's photons lie on surfaces, and in a volume.
        let points: Vec<(Vec3, u32)> = (0..3 * CHUNK as u32 + 123)
            .map(|i| {
                let (x, y) = (s.next_1d(), s.next_1d());
                let p = match i % 3 {
                    0 => Vec3::new(x, y, 0.25),
                    1 => Vec3::new(x, 0.5, y),
                    _ => Vec3::new(x, y, s.next_1d()),
                };
                (p, i)
            })
            .collect();
        let build = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| HashGrid::new(&points, 0.01))
        };
        let (one, three) = (build(1), build(3));
        assert_eq!(one.starts, three.starts);
        assert_eq!(one.entries, three.entries);
        assert!(
            one.entries.len() > points.len(),
            "points stored in several cells"
        );
        for q in points.iter().step_by(97).map(|(p, _)| *p + 0.004) {
            let mut found = Vec::new();
            three.query(q, |&i| found.push(i));
            let expect: Vec<u32> = points
                .iter()
                .filter(|(p, _)| (*p - q).length_squared() <= 1e-4)
                .map(|(_, i)| *i)
                .collect();
            assert_eq!(found, expect, "query {q}");
        }
    }

    #[test]
    fn an_empty_grid_finds_nothing() {
        let empty = HashGrid::<u32>::new(&[], 0.1);
        empty.query(Vec3::ZERO, |_| panic!("no points"));
    }
}
