//! Per-vertex quantities of one subpath that every connection through the vertex reuses,
//! computed once after the walk: the direction and measure conversion towards the walk's
//! previous vertex, the local roulette probability, whether a connection can end there, and
//! the forward density with roulette applied.

use super::origin_density;
use super::vertex::{Kind, Vertex, to_measure};
use super::walk::{local_continuation, roulette};
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
    /// A connection can end here ([`Vertex::connectible`]).
    pub connectible: bool,
    /// The walk's density of this vertex with the roulette of the vertex it left from: the
    /// camera-side `pc[j]` (or light-side `pl[k - j]`) of every path that contains the
    /// subpath up to here. For the first vertex of a light subpath: its origin density `pl[k]`.
    pub fwd: f64,
}

impl Cached {
    /// A subpath's first vertex: the pinhole, or a light vertex with its origin density.
    pub fn first(scene: &Scene, v: &Vertex) -> Cached {
        let fwd = match v.kind {
            Kind::Light { light } => origin_density(scene, v, light) as f64,
            _ => 1.0,
        };
        Cached {
            wo: Vec3::ZERO,
            to_prev: 0.0,
            q: local_continuation(scene, v),
            connectible: v.connectible(scene),
            fwd,
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
            connectible: v.connectible(scene),
            fwd: rr * v.pdf_fwd as f64,
        });
    }
}
