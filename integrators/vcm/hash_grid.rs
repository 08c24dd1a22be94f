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
//! cache line or two at random per entry (86 -> 55 ms a pass).
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
    /// pairs, each bucket's next free slot, and the point of each entry.
    keys: Vec<(u32, u32)>,
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
/// typical bucket has (README, "Throughput against the CPU peers", has the measurements).
const PREFETCH_LINES: usize = 32;

/// How many entries ahead [`HashGrid::rebuild`] asks for the point it will copy.
const GATHER_AHEAD: usize = 16;

/// A point within this fraction of a cell side from a cell face (a quarter: r of 4r, with a
/// margin for rounding) is also stored in the neighbour across that face.
const REACH: f32 = 0.25 + 1e-3;

impl<T: Copy + Default> HashGrid<T> {
    /// A grid over `points` (position, payload) for queries of radius `radius` > 0.
    pub fn new(points: &[(Vec3, T)], radius: f32) -> HashGrid<T> {
        let mut grid = HashGrid::default();
        grid.rebuild(points, radius);
        grid
    }

    /// [`HashGrid::new`] in this grid's memory (vcm rebuilds its grid every pass; fresh
    /// allocations of that size cost page faults every time).
    pub fn rebuild(&mut self, points: &[(Vec3, T)], radius: f32) {
        let origin = points
            .iter()
            .fold(Vec3::splat(f32::INFINITY), |m, (p, _)| m.min(*p));
        self.origin = if origin.is_finite() {
            origin
        } else {
            Vec3::ZERO
        };
        self.radius2 = radius * radius;
        self.inv_cell = 0.25 / radius;
        self.points = points.len();
        // Buckets: as many as points, at least one.
        let m = points.len().max(1);
        let mut keys = std::mem::take(&mut self.keys);
        keys.clear();
        for (i, (p, _)) in points.iter().enumerate() {
            let c = (*p - self.origin) * self.inv_cell;
            let base = c.floor();
            let frac = c - base;
            let base = base.as_ivec3();
            // The cells along each axis that the r-ball reaches: 1 or 2.
            let axis = |f: f32| -> (i32, i32) {
                if f < REACH {
                    (-1, 0)
                } else if f > 1.0 - REACH {
                    (0, 1)
                } else {
                    (0, 0)
                }
            };
            let (ax, ay, az) = (axis(frac.x), axis(frac.y), axis(frac.z));
            let mut buckets = [u32::MAX; 8];
            let mut count = 0;
            for dz in [az.0, az.1] {
                for dy in [ay.0, ay.1] {
                    for dx in [ax.0, ax.1] {
                        let b = bucket(base + IVec3::new(dx, dy, dz), m);
                        if !buckets[..count].contains(&b) {
                            buckets[count] = b;
                            count += 1;
                        }
                    }
                }
            }
            keys.extend(buckets[..count].iter().map(|&b| (b, i as u32)));
        }
        // Counting sort: counts, exclusive prefix sums, then scatter in input order.
        self.starts.clear();
        self.starts.resize(m + 1, 0);
        for &(b, _) in &keys {
            self.starts[b as usize + 1] += 1;
        }
        for i in 1..self.starts.len() {
            self.starts[i] += self.starts[i - 1];
        }
        let mut next = std::mem::take(&mut self.next);
        next.clear();
        next.extend_from_slice(&self.starts[..m]);
        // Each slot's point index first (4 bytes scattered per entry), then the entries
        // written in order from the points.
        let mut order = std::mem::take(&mut self.order);
        order.clear();
        order.resize(keys.len(), 0);
        for (j, &(b, i)) in keys.iter().enumerate() {
            if let Some(&(ahead, _)) = keys.get(j + GATHER_AHEAD) {
                crate::prefetch::line(&next[ahead as usize]);
            }
            let slot = &mut next[b as usize];
            order[*slot as usize] = i;
            *slot += 1;
        }
        self.entries.clear();
        // The points are read in bucket order, that is at random: each one is asked for
        // GATHER_AHEAD entries before it is copied.
        for (j, &i) in order.iter().enumerate() {
            if let Some(&ahead) = order.get(j + GATHER_AHEAD) {
                let p = &points[ahead as usize] as *const (Vec3, T) as *const u8;
                crate::prefetch::line(p);
                crate::prefetch::line(p.wrapping_add(std::mem::size_of::<(Vec3, T)>() - 1));
            }
            self.entries.push(points[i as usize]);
        }
        self.order = order;
        self.keys = keys;
        self.next = next;
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points
    }

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
        let empty = HashGrid::<u32>::new(&[], 0.1);
        empty.query(Vec3::ZERO, |_| panic!("no points"));
    }
}
