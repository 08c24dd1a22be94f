//! A hash grid over points for fixed-radius range queries (the photon lookup of merging).
//!
//! Cells are cubes of side 2r; a cell's integer coordinates hash (Teschner et al. 2003) into
//! one of `n` buckets (n = number of points), and a counting sort lays the points out bucket
//! by bucket, in input order within a bucket, so the grid, and the order in which a query
//! visits points, depend on the input only. A query visits the 2 x 2 x 2 cells that can hold
//! points within r (each bucket once, even when two of those cells share it) and reports the
//! points at distance <= r.

use glam::{IVec3, Vec3};

#[derive(Default)]
pub struct HashGrid {
    radius2: f32,
    inv_cell: f32,
    origin: Vec3,
    /// `starts[b] .. starts[b + 1]` are bucket b's entries.
    starts: Vec<u32>,
    /// (position, caller's index), sorted by bucket.
    entries: Vec<(Vec3, u32)>,
    /// Scratch of the counting sort, kept for the next [`HashGrid::rebuild`].
    buckets: Vec<u32>,
    next: Vec<u32>,
}

impl HashGrid {
    /// A grid over `points` (position, caller's index) for queries of radius `radius` > 0.
    pub fn new(points: &[(Vec3, u32)], radius: f32) -> HashGrid {
        let mut grid = HashGrid::default();
        grid.rebuild(points, radius);
        grid
    }

    /// [`HashGrid::new`] in this grid's memory (vcm rebuilds its grid every pass; fresh
    /// allocations of that size cost page faults every time).
    pub fn rebuild(&mut self, points: &[(Vec3, u32)], radius: f32) {
        let origin = points
            .iter()
            .fold(Vec3::splat(f32::INFINITY), |m, (p, _)| m.min(*p));
        self.origin = if origin.is_finite() {
            origin
        } else {
            Vec3::ZERO
        };
        self.radius2 = radius * radius;
        self.inv_cell = 0.5 / radius;
        let n = points.len();
        self.starts.clear();
        self.starts.resize(n + 1, 0);
        let mut buckets = std::mem::take(&mut self.buckets);
        buckets.clear();
        buckets.extend(points.iter().map(|(p, _)| self.bucket(self.cell_of(*p))));
        // Counting sort: counts, exclusive prefix sums, then scatter in input order.
        for &b in &buckets {
            self.starts[b as usize + 1] += 1;
        }
        for i in 1..self.starts.len() {
            self.starts[i] += self.starts[i - 1];
        }
        self.next.clear();
        self.next.extend_from_slice(&self.starts[..n]);
        self.entries.clear();
        self.entries.resize(n, (Vec3::ZERO, 0));
        for (point, &b) in points.iter().zip(&buckets) {
            let slot = &mut self.next[b as usize];
            self.entries[*slot as usize] = *point;
            *slot += 1;
        }
        self.buckets = buckets;
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Call `visit(index)` for every point within the radius of `p`.
    #[inline]
    pub fn query(&self, p: Vec3, mut visit: impl FnMut(u32)) {
        if self.entries.is_empty() {
            return;
        }
        let c = (p - self.origin) * self.inv_cell;
        let base = c.floor();
        let frac = c - base;
        // The neighbour on the nearer side in each axis.
        let lo = base.as_ivec3()
            - IVec3::new(
                (frac.x < 0.5) as i32,
                (frac.y < 0.5) as i32,
                (frac.z < 0.5) as i32,
            );
        let mut buckets = [0u32; 8];
        for (i, b) in buckets.iter_mut().enumerate() {
            let d = IVec3::new((i & 1) as i32, ((i >> 1) & 1) as i32, ((i >> 2) & 1) as i32);
            *b = self.bucket(lo + d);
        }
        buckets.sort_unstable();
        for (i, &b) in buckets.iter().enumerate() {
            if i > 0 && buckets[i - 1] == b {
                continue;
            }
            let (s, e) = (self.starts[b as usize], self.starts[b as usize + 1]);
            for &(q, index) in &self.entries[s as usize..e as usize] {
                if (q - p).length_squared() <= self.radius2 {
                    visit(index);
                }
            }
        }
    }

    #[inline]
    fn cell_of(&self, p: Vec3) -> IVec3 {
        ((p - self.origin) * self.inv_cell).floor().as_ivec3()
    }

    #[inline]
    fn bucket(&self, c: IVec3) -> u32 {
        let h = (c.x as u32).wrapping_mul(73_856_093)
            ^ (c.y as u32).wrapping_mul(19_349_663)
            ^ (c.z as u32).wrapping_mul(83_492_791);
        h % (self.starts.len() as u32 - 1)
    }
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
                grid.query(q, |i| found.push(i));
                found.sort_unstable();
                let expect: Vec<u32> = points
                    .iter()
                    .filter(|(p, _)| (*p - q).length_squared() <= radius * radius)
                    .map(|(_, i)| *i)
                    .collect();
                assert_eq!(found, expect, "radius {radius}, query {q}");
            }
        }
        let empty = HashGrid::new(&[], 0.1);
        empty.query(Vec3::ZERO, |_| panic!("no points"));
    }
}
