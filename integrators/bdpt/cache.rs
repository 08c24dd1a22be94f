//! Per-vertex quantities of one subpath that every connection through the vertex reuses,
//! computed once after the walk: the direction and measure conversion towards the walk's
//! previous vertex, the local roulette probability, whether a connection can end there, and
//! the forward density with roulette applied; and, for the recursive MIS weights
//! (`weights.rs`), each vertex's share of the techniques that sample more of a path from the
//! other side.

use super::walk::{local_continuation, roulette};
use crate::integrators::paths::vertex::{Kind, Vertex, to_measure};
use crate::integrators::paths::{Heuristic, hittable, origin_density};
use crate::scene::Scene;
use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Cached {
    /// Unit direction towards the walk's previous vertex (zero for the first vertex).
    pub wo: Vec3,
    /// Turns a solid-angle density at this vertex towards the previous vertex into that
    /// vertex's measure (0 for the first vertex).
    pub to_prev: f32,
    /// Local continuation probability (roulette once past `rr_depth`).
    pub q: f32,
    /// A connection can end here ([`Vertex::connectible_end`]); whether one can join a
    /// longer path here also asks whether the walk left the vertex through a delta lobe
    /// (`Vertex::delta`).
    pub connectible: bool,
    /// The walk's density of this vertex with the roulette of the vertex it left from: the
    /// camera-side `pc[j]` (or light-side `pl[k - j]`) of every path that contains the
    /// subpath up to here. For the first vertex of a light subpath: its origin density `pl[k]`.
    pub fwd: f64,
    /// Recursive MIS ([`mis_sums`]): the heuristic's measure of technique "connect x_{i-1}
    /// with x_i" relative to the generic form of its density: 0 or 1 (can both ends
    /// connect?), except at the ends of a light subpath: x_0 is hit by the camera walk
    /// (`hittable`, 0 or 1), x_1 connects to a light point chosen by next-event estimation
    /// (`h(p_nee / p_origin)` when x_1 is connectible). For paths that end the subpath at
    /// x_i (the connection leaves x_i).
    pub mis_valid: f64,
    /// `mis_valid` for paths that go on through x_i as the walk did: 0 where the walk left
    /// x_i through a delta lobe (smooth plastic's coating), else `mis_valid`.
    pub mis_valid_inside: f64,
    /// Recursive MIS: the sum, over the techniques that connect at or before this vertex
    /// (counted from the subpath's origin), of their densities relative to one whose
    /// connection leaves this vertex for the next vertex of the subpath, each through the
    /// heuristic (`S_i = r_i (mis_valid_inside_i + S_{i-1})`, `r_i = h(p_rev(x_i) /
    /// p_fwd(x_i))`).
    /// Set for every vertex but the last (p_rev(x_i) needs x_{i+1}).
    pub mis_sum: f64,
}

impl Cached {
    /// A subpath's first vertex: the pinhole, or a light vertex with its origin density.
    pub fn first(scene: &Scene, v: &Vertex) -> Cached {
        let (fwd, mis_valid) = match v.kind {
            Kind::Light { light } => (
                origin_density(scene, v, light) as f64,
                hittable(scene, light) as u8 as f64,
            ),
            _ => (1.0, 0.0),
        };
        Cached {
            wo: Vec3::ZERO,
            to_prev: 0.0,
            q: local_continuation(scene, v),
            connectible: v.connectible_end(scene),
            fwd,
            mis_valid,
            mis_valid_inside: mis_valid,
            mis_sum: 0.0,
        }
    }
}

/// Fill `out` with the cached quantities of every vertex of `path`.
pub fn cache_subpath(scene: &Scene, path: &[Vertex], rr_depth: u32, out: &mut Vec<Cached>) {
    out.clear();
    let Some(first) = path.first() else { return };
    out.push(Cached::first(scene, first));
    for j in 1..path.len() {
        let (v, prev) = (&path[j], &path[j - 1]);
        let rr = if j >= 2 {
            roulette(out[j - 1].q, j - 1, rr_depth) as f64
        } else {
            1.0
        };
        out.push(Cached {
            wo: (prev.p - v.p).normalize(),
            to_prev: to_measure(scene, 1.0, v.p, prev),
            q: local_continuation(scene, v),
            connectible: v.connectible_end(scene),
            fwd: rr * v.pdf_fwd as f64,
            mis_valid: 0.0,
            mis_valid_inside: 0.0,
            mis_sum: 0.0,
        });
    }
}

/// The heuristic applied to a ratio of densities: itself (balance) or its square (power).
#[inline]
pub fn heuristic(h: Heuristic, ratio: f64) -> f64 {
    match h {
        Heuristic::Balance => ratio,
        Heuristic::Power => ratio * ratio,
    }
}

/// Fill in `mis_valid` and `mis_sum` of a cached subpath (after [`cache_subpath`]), for
/// roulette from the first bounce (every roulette factor is then the vertex's local `q`,
/// whichever end its segments are counted from). `light_nee`: for a light subpath, the
/// next-event density of its first vertex from its second; `None` for a camera subpath.
/// (SmallVCM's recursive weights in bdpt's notation, without merging: `integrators/vcm`
/// holds those with it.)
pub fn mis_sums(path: &[Vertex], out: &mut [Cached], light_nee: Option<f64>, h: Heuristic) {
    let n = path.len();
    // x_{i-1} lies inside every path that reaches x_i: no connection joins it where the walk
    // left it through a delta lobe (of a surface that also has another: smooth plastic).
    let walked_delta = |i: usize| path[i].is_specular_surface();
    for i in 1..n {
        let valid = out[i - 1].connectible && !walked_delta(i - 1) && out[i].connectible;
        out[i].mis_valid = valid as u8 as f64;
    }
    if let (Some(nee), true) = (light_nee, n >= 2) {
        out[1].mis_valid = if out[1].connectible {
            heuristic(h, nee / out[0].fwd)
        } else {
            0.0
        };
    }
    for (i, c) in out.iter_mut().enumerate().take(n) {
        c.mis_valid_inside = if walked_delta(i) { 0.0 } else { c.mis_valid };
    }
    // The pinhole is never hit: no technique connects "before" it.
    let mut sum = 0.0;
    for i in 0..n.saturating_sub(1) {
        if i > 0 || light_nee.is_some() {
            let rev = out[i + 1].q as f64 * path[i].pdf_rev as f64;
            sum = heuristic(h, rev / out[i].fwd) * (out[i].mis_valid_inside + sum);
        }
        out[i].mis_sum = sum;
    }
}
