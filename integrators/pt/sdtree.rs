//! A spatio-directional tree of incident radiance (Müller, Gross and Novák 2017, "Practical
//! Path Guiding"): a binary tree over space (the scene's bounding cube, split in the middle
//! along x, y, z in turn) whose leaves each hold a quadtree over directions.
//!
//! Directions are mapped to the unit square by the cylindrical equal-area map
//! (`cos θ = 2x − 1`, `φ = 2π y`, world axes), so a density on the square is a density on the
//! sphere times 4π. A quadtree node keeps, per quadrant, the energy recorded in it; sampling
//! descends by energy (one uniform number per level) and ends uniformly inside a leaf
//! quadrant, and [`DTree::pdf`] is the product of the same choices, so the two agree exactly.
//!
//! Learning: during an iteration every path vertex records (position, direction, incident
//! radiance / density of the direction) into its leaf's *builder* quadtree. Energies are added
//! as fixed-point integers (`SCALE`), so the sums do not depend on the order in which threads
//! add them: a render is the same for any number of threads. After the iteration
//! ([`SdTree::refine`]) each leaf's builder becomes its sampling quadtree, a new builder is laid
//! out from it (a quadrant holding more than [`SUBDIVIDE`] of its tree's energy is split, to
//! depth [`MAX_DEPTH`]), and a leaf that recorded more than `SPLIT · sqrt(passes)` vertices is
//! split in space, both halves starting from its trees.

use glam::{Vec2, Vec3};
use std::sync::atomic::{AtomicU64, Ordering};

/// Fixed-point scale of recorded energies (2^20).
const SCALE: f64 = 1_048_576.0;
/// A single record's energy is capped here (training data only: the render's estimator never
/// sees the cap), so that 2^28 records cannot overflow a sum.
const CAP: f64 = 65_536.0;
/// Quadrants with more than this share of their tree's energy are split.
pub const SUBDIVIDE: f64 = 0.01;
/// Deepest quadtree level.
pub const MAX_DEPTH: u32 = 20;
/// A spatial leaf that recorded more than `SPLIT · sqrt(passes of the iteration)` vertices is
/// split (Müller et al.'s c = 12000).
pub const SPLIT: f64 = 12_000.0;
/// Deepest spatial level.
const MAX_SPATIAL_DEPTH: u32 = 30;

/// Direction (unit, world) to the unit square.
pub fn to_square(d: Vec3) -> Vec2 {
    let cos = d.z.clamp(-1.0, 1.0);
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += std::f32::consts::TAU;
    }
    Vec2::new(
        ((cos + 1.0) * 0.5).clamp(0.0, 1.0),
        (phi / std::f32::consts::TAU).clamp(0.0, 1.0),
    )
}

/// The unit square to a direction (inverse of [`to_square`]).
pub fn from_square(p: Vec2) -> Vec3 {
    let cos = 2.0 * p.x - 1.0;
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let (s, c) = (std::f32::consts::TAU * p.y).sin_cos();
    Vec3::new(sin * c, sin * s, cos)
}

/// Square density to solid-angle density.
pub const INV_FOUR_PI: f64 = 1.0 / (4.0 * std::f64::consts::PI);

/// A point of the unit square in 32-bit fixed point: the quadrant at each level of a
/// quadtree is the next bit of either coordinate (bit 0 of the quadrant: right half, bit 1:
/// upper half).
#[derive(Clone, Copy)]
struct Fixed(u32, u32);

impl Fixed {
    fn of(p: Vec2) -> Fixed {
        let f = |v: f32| (v as f64 * 4_294_967_296.0).clamp(0.0, 4_294_967_295.0) as u32;
        Fixed(f(p.x), f(p.y))
    }

    /// The quadrant at the current level, and the point one level down.
    #[inline]
    fn next(self) -> (usize, Fixed) {
        let q = (self.0 >> 31) | (self.1 >> 31) << 1;
        (q as usize, Fixed(self.0 << 1, self.1 << 1))
    }
}

/// Per node of a sampling quadtree: children (0: the quadrant is a leaf) and the density factor
/// of each quadrant.
#[derive(Debug, Clone, Copy)]
struct Node {
    child: [u32; 4],
    factor: [f32; 4],
}

/// A sampling quadtree over the unit square.
#[derive(Debug, Clone)]
pub struct DTree {
    /// Per node, children (0: the quadrant is a leaf) and energy per quadrant.
    child: Vec<[u32; 4]>,
    energy: Vec<[f64; 4]>,
    /// The children and, per quadrant, `4 e_q / Σ e` (1 for a node without energy): the
    /// density factor of choosing the quadrant, one multiplication per level in `sample` and
    /// `pdf` (f32, so a node is half a cache line).
    nodes: Vec<Node>,
}

impl DTree {
    fn new(child: Vec<[u32; 4]>, energy: Vec<[f64; 4]>) -> DTree {
        let nodes = energy
            .iter()
            .zip(&child)
            .map(|(e, &child)| {
                let sum: f64 = e.iter().sum();
                let factor = if sum > 0.0 {
                    e.map(|x| (4.0 * x / sum) as f32)
                } else {
                    [1.0; 4]
                };
                Node { child, factor }
            })
            .collect();
        DTree {
            child,
            energy,
            nodes,
        }
    }

    /// Total energy recorded.
    pub fn total(&self) -> f64 {
        self.energy[0].iter().sum()
    }

    /// Nodes of the tree.
    pub fn nodes(&self) -> usize {
        self.child.len()
    }

    /// A point of the unit square and its density there. `u` gives one number per level and
    /// two for the point in the leaf quadrant.
    pub fn sample(&self, mut u: impl FnMut() -> f32) -> (Vec2, f64) {
        // The chosen quadrants' bits, high first, and how many levels.
        let (mut x, mut y, mut depth) = (0u32, 0u32, 0u32);
        let mut pdf = 1.0f64;
        let mut node = 0usize;
        loop {
            // The factors are the quadrants' probabilities times 4 (a node without energy and
            // all below it: 1, uniform).
            let n = &self.nodes[node];
            let target = u() * 4.0;
            let mut q = 3;
            let mut acc = 0.0f32;
            for (i, &fi) in n.factor.iter().enumerate() {
                acc += fi;
                if target < acc && fi > 0.0 {
                    q = i;
                    break;
                }
            }
            while n.factor[q] <= 0.0 {
                q -= 1; // rounding at the top end: the last quadrant with energy
            }
            pdf *= n.factor[q] as f64;
            x |= ((q & 1) as u32) << (31 - depth);
            y |= ((q >> 1) as u32) << (31 - depth);
            depth += 1;
            match n.child[q] {
                0 => break,
                c => node = c as usize,
            }
        }
        // Uniform in the cell: the bits below its level, the lowest 8 clear so that the point
        // is exact in f32 (and so stays in its cell).
        let rest = |u: f32| {
            let bits = ((u as f64 * 4_294_967_296.0) as u64).min(u32::MAX as u64) as u32;
            bits.checked_shr(depth).unwrap_or(0) & !0xff
        };
        let (x, y) = (x | rest(u()), y | rest(u()));
        let p = Vec2::new(
            (x as f64 / 4_294_967_296.0) as f32,
            (y as f64 / 4_294_967_296.0) as f32,
        );
        (p, pdf)
    }

    /// Density of [`Self::sample`] at `p` (per unit square area).
    pub fn pdf(&self, p: Vec2) -> f64 {
        let mut at = Fixed::of(p);
        let mut pdf = 1.0f64;
        let mut node = 0usize;
        loop {
            let (q, inner) = at.next();
            let n = &self.nodes[node];
            let factor = n.factor[q];
            if factor == 0.0 {
                return 0.0;
            }
            pdf *= factor as f64;
            match n.child[q] {
                0 => return pdf,
                c => {
                    node = c as usize;
                    at = inner;
                }
            }
        }
    }

    /// A builder laid out from this tree's energies: quadrants above [`SUBDIVIDE`] of the
    /// total are split (new quadrants assumed to share their energy evenly), the rest merged.
    fn refined(&self) -> DTreeBuilder {
        let total = self.total();
        let mut child = vec![[0u32; 4]];
        // (source node or None for a node new in this layout, its energy per quadrant,
        // the layout node, depth)
        let mut stack = vec![(Some(0usize), self.energy[0], 0usize, 1u32)];
        while let Some((src, e, at, depth)) = stack.pop() {
            for q in 0..4 {
                if depth >= MAX_DEPTH || e[q] <= SUBDIVIDE * total {
                    continue;
                }
                let c = child.len();
                child.push([0; 4]);
                child[at][q] = c as u32;
                let (src_child, ce) = match src.map(|s| self.child[s][q]) {
                    Some(sc) if sc != 0 => (Some(sc as usize), self.energy[sc as usize]),
                    _ => (None, [e[q] / 4.0; 4]),
                };
                stack.push((src_child, ce, c, depth + 1));
            }
        }
        DTreeBuilder::with_layout(child)
    }
}

/// A quadtree being recorded into (fixed layout, atomic energies).
#[derive(Debug)]
pub struct DTreeBuilder {
    child: Vec<[u32; 4]>,
    energy: Vec<[AtomicU64; 4]>,
}

impl DTreeBuilder {
    fn with_layout(child: Vec<[u32; 4]>) -> DTreeBuilder {
        let energy = child.iter().map(|_| Default::default()).collect();
        DTreeBuilder { child, energy }
    }

    /// One node, four leaf quadrants.
    fn root() -> DTreeBuilder {
        DTreeBuilder::with_layout(vec![[0; 4]])
    }

    fn record(&self, p: Vec2, value: f64) {
        let e = (value.min(CAP) * SCALE) as u64;
        if e == 0 {
            return;
        }
        let mut at = Fixed::of(p);
        let mut node = 0usize;
        loop {
            let (q, inner) = at.next();
            self.energy[node][q].fetch_add(e, Ordering::Relaxed);
            match self.child[node][q] {
                0 => return,
                c => {
                    node = c as usize;
                    at = inner;
                }
            }
        }
    }

    /// The recorded energies as a sampling tree; `None` when nothing was recorded.
    fn to_sampling(&self) -> Option<DTree> {
        let energy: Vec<[f64; 4]> = self
            .energy
            .iter()
            .map(|e| {
                e.each_ref()
                    .map(|a| a.load(Ordering::Relaxed) as f64 / SCALE)
            })
            .collect();
        let tree = DTree::new(self.child.clone(), energy);
        (tree.total() > 0.0).then_some(tree)
    }
}

impl Clone for DTreeBuilder {
    /// The same layout, energies zero.
    fn clone(&self) -> Self {
        DTreeBuilder::with_layout(self.child.clone())
    }
}

/// One spatial leaf.
#[derive(Debug)]
struct Leaf {
    sampling: Option<DTree>,
    builder: DTreeBuilder,
    count: AtomicU64,
}

impl Clone for Leaf {
    fn clone(&self) -> Self {
        Leaf {
            sampling: self.sampling.clone(),
            builder: self.builder.clone(),
            count: AtomicU64::new(0),
        }
    }
}

/// Spatial node: a leaf index, or two children split in the middle along `depth % 3`.
#[derive(Debug, Clone, Copy)]
enum SNode {
    Leaf(u32),
    Split(u32, u32),
}

/// The spatio-directional tree.
#[derive(Debug)]
pub struct SdTree {
    lo: Vec3,
    inv_size: f32,
    nodes: Vec<SNode>,
    leaves: Vec<Leaf>,
}

impl SdTree {
    /// One spatial leaf over the cube of side `2 radius` around `center`, nothing learned.
    pub fn new(center: Vec3, radius: f32) -> SdTree {
        let r = radius.max(1e-6) * 1.001;
        SdTree {
            lo: center - Vec3::splat(r),
            inv_size: 1.0 / (2.0 * r),
            nodes: vec![SNode::Leaf(0)],
            leaves: vec![Leaf {
                sampling: None,
                builder: DTreeBuilder::root(),
                count: AtomicU64::new(0),
            }],
        }
    }

    fn leaf_of(&self, p: Vec3) -> &Leaf {
        let mut x = ((p - self.lo) * self.inv_size).clamp(Vec3::ZERO, Vec3::splat(1.0));
        let mut node = 0usize;
        let mut depth = 0usize;
        loop {
            match self.nodes[node] {
                SNode::Leaf(l) => return &self.leaves[l as usize],
                SNode::Split(a, b) => {
                    let axis = depth % 3;
                    if x[axis] < 0.5 {
                        x[axis] *= 2.0;
                        node = a as usize;
                    } else {
                        x[axis] = x[axis] * 2.0 - 1.0;
                        node = b as usize;
                    }
                    depth += 1;
                }
            }
        }
    }

    /// The sampling quadtree of the region around `p`, if it learned anything.
    pub fn directions_at(&self, p: Vec3) -> Option<&DTree> {
        self.leaf_of(p).sampling.as_ref()
    }

    /// Record incident radiance (luminance) `l_over_pdf` = L / p(ω) arriving at `p` from
    /// direction `w` (unit, pointing away from `p`).
    pub fn record(&self, p: Vec3, w: Vec3, l_over_pdf: f64) {
        let leaf = self.leaf_of(p);
        leaf.count.fetch_add(1, Ordering::Relaxed);
        if l_over_pdf > 0.0 && l_over_pdf.is_finite() {
            leaf.builder.record(to_square(w), l_over_pdf);
        }
    }

    /// End of a learning iteration of `passes` passes (module doc).
    pub fn refine(&mut self, passes: u64) {
        let threshold = SPLIT * (passes.max(1) as f64).sqrt();
        // Space first: leaves that recorded many vertices split (their trees copied).
        let mut stack: Vec<(usize, u32, f64)> = Vec::new();
        let mut depth_of = vec![0u32; self.nodes.len()];
        for n in 0..self.nodes.len() {
            if let SNode::Split(a, b) = self.nodes[n] {
                depth_of[a as usize] = depth_of[n] + 1;
                depth_of[b as usize] = depth_of[n] + 1;
            }
        }
        for (n, node) in self.nodes.iter().enumerate() {
            if let SNode::Leaf(l) = *node {
                let c = self.leaves[l as usize].count.load(Ordering::Relaxed) as f64;
                stack.push((n, depth_of[n], c));
            }
        }
        // Each leaf's trees are finished before copying, so both halves start from them.
        for leaf in &mut self.leaves {
            leaf.sampling = leaf.builder.to_sampling();
            leaf.builder = match &leaf.sampling {
                Some(t) => t.refined(),
                None => DTreeBuilder::root(),
            };
            leaf.count = AtomicU64::new(0);
        }
        while let Some((n, depth, count)) = stack.pop() {
            if count <= threshold || depth >= MAX_SPATIAL_DEPTH {
                continue;
            }
            let SNode::Leaf(l) = self.nodes[n] else {
                continue;
            };
            let copy = self.leaves[l as usize].clone();
            let l2 = self.leaves.len() as u32;
            self.leaves.push(copy);
            let (a, b) = (self.nodes.len() as u32, self.nodes.len() as u32 + 1);
            self.nodes.push(SNode::Leaf(l));
            self.nodes.push(SNode::Leaf(l2));
            self.nodes[n] = SNode::Split(a, b);
            stack.push((a as usize, depth + 1, count / 2.0));
            stack.push((b as usize, depth + 1, count / 2.0));
        }
    }

    /// (spatial leaves, mean quadtree nodes of the leaves that learned something).
    pub fn size(&self) -> (usize, f64) {
        let learned: Vec<usize> = self
            .leaves
            .iter()
            .filter_map(|l| l.sampling.as_ref().map(DTree::nodes))
            .collect();
        let mean = if learned.is_empty() {
            0.0
        } else {
            learned.iter().sum::<usize>() as f64 / learned.len() as f64
        };
        (self.leaves.len(), mean)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_map_round_trips() {
        for i in 0..100 {
            let p = Vec2::new((i as f32 * 0.37).fract(), (i as f32 * 0.61).fract());
            let q = to_square(from_square(p));
            assert!((p - q).abs().max_element() < 1e-4, "{p} {q}");
        }
    }
}
