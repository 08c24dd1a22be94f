//! vcm's subpath vertices, the free flight along the edges between them, and the densities
//! of light vertices (origin, next-event estimation, emission towards a point).
//!
//! A vcm vertex is the vertex every estimator shares ([`paths::Vertex`]: a surface or medium
//! point with its scattering function, position, normals and throughput) together with what
//! vcm's recursion carries along a walk: the direction back along the walk and the recursive
//! MIS quantities ([`Mis`]). The explicit densities of `paths::Vertex` (`pdf_fwd`, `pdf_rev`)
//! are left 0: vcm weighs recursively, and where explicit densities are needed (guided-vcm)
//! they are computed from the whole path (`densities.rs`).
//!
//! Measures as everywhere in lodestar (DESIGN.md §3): area for surfaces and finite lights,
//! volume in media, solid angle for lights at infinity. Cosines of measure conversions use
//! the geometric normal (1 at medium points); BSDF values use the shading normal. Every
//! direction density of a surface is `Bsdf::pdf` in radiance mode (delta surfaces: the lobe
//! probability), exactly as in `bdpt`, so that with merging off the MIS weights are BDPT's.

use crate::bsdf::TransportMode;
use crate::integrators::paths::{self, Kind};
use crate::light::Light;
use crate::math::Spectrum;
use crate::scene::{Endpoint, Scene};
use glam::Vec3;

/// The recursive MIS quantities of a subpath vertex (Georgiev et al. 2012, tech. report
/// §4-5; SmallVCM's `dVCM`, `dVC`, `dVM`), for the walk that reached vertex x_i:
///
/// * `d_vcm = 1 / p_fwd(x_i)` (0 if x_{i-1} is a delta vertex; for the first light vertex
///   times `p_nee(x_0) / p_origin(x_0)`, the next-event density of the emitter point);
/// * `d_vc`, `d_vm`: the sums over the techniques that sample more of the path from the
///   other side (connections and merges at x_{i-1}, x_{i-2}, ...), relative to a connection
///   (`d_vc`) or a merge (`d_vm`) at x_i, still missing the reverse direction density at x_i.
///
/// All densities include Russian roulette (local continuation probabilities) and free flight.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Mis {
    pub d_vcm: f32,
    pub d_vc: f32,
    pub d_vm: f32,
}

/// Free flight along an edge: bdpt's, shared (pass probabilities, first and last medium
/// segment, and the free-flight factor of reaching either end).
pub use crate::integrators::paths::vertex::Edge;

/// A scattering vertex of a camera or light subpath: the shared vertex and vcm's recursion
/// state. Reads of the shared vertex's fields go through `Deref` (`v.p`, `v.beta`, `v.kind`).
#[derive(Clone, Copy)]
pub struct MisVertex<'a> {
    /// The vertex: a `Kind::Surface` or `Kind::Medium` point (normal zero in media), with the
    /// subpath's throughput up to it (no scattering at it yet), the medium the walk arrived
    /// through, `delta` and the free flight of the edge that reached it.
    pub v: paths::Vertex<'a>,
    /// Unit direction towards the previous vertex of the walk.
    pub wo: Vec3,
    pub mis: Mis,
    /// Segments from the subpath's origin (the pinhole or the light).
    pub depth: u32,
    /// Cap on the continuation probability (the walk's `q_cap`).
    pub q_cap: f32,
}

impl<'a> std::ops::Deref for MisVertex<'a> {
    type Target = paths::Vertex<'a>;
    #[inline]
    fn deref(&self) -> &paths::Vertex<'a> {
        &self.v
    }
}

impl<'a> MisVertex<'a> {
    #[inline]
    pub fn is_delta(&self) -> bool {
        self.v.delta
    }

    /// A connection can end here (medium points, non-delta non-black surfaces).
    #[inline]
    pub fn connectible(&self) -> bool {
        match self.v.kind {
            Kind::Surface { bsdf, .. } => !bsdf.is_delta() && !bsdf.is_black(),
            _ => true,
        }
    }

    /// Merging is done here: non-delta, non-black surfaces (not in media).
    #[inline]
    pub fn mergeable(&self) -> bool {
        matches!(self.v.kind, Kind::Surface { bsdf, .. } if !bsdf.is_delta() && !bsdf.is_black())
    }

    /// |cos| between the geometric normal and `d` (1 in media): the measure conversion.
    #[inline]
    pub fn cos(&self, d: Vec3) -> f32 {
        if self.is_medium() {
            1.0
        } else {
            self.v.n.dot(d).abs()
        }
    }

    /// `(f(wi), p(wo -> wi), p(wi -> wo))` with `wo` this vertex's own: the scattering
    /// value (|cos(wi)| at the shading normal on surfaces, the phase function in media) and
    /// both direction densities times the continuation probability, in one BSDF (or phase)
    /// evaluation except on delta surfaces (there the lobe probabilities): what a connection
    /// or next-event estimation needs at each end, and a walk's MIS update.
    #[inline]
    pub fn f_pdfs(&self, scene: &Scene, wi: Vec3, mode: TransportMode) -> (Spectrum, f32, f32) {
        let q = self.continuation(scene);
        match self.v.kind {
            Kind::Surface { bsdf, frame, .. } if bsdf.is_delta() => (
                bsdf.eval(&frame, self.wo, wi, mode) * wi.dot(frame.frame.n).abs(),
                bsdf.delta_lobe_probability(&frame, self.wo, wi) * q,
                bsdf.delta_lobe_probability(&frame, wi, self.wo) * q,
            ),
            _ => {
                let e = paths::vertex::connection_end(scene, &self.v, self.wo, wi, mode);
                (e.f, e.pdf_other * q, e.pdf_prev * q)
            }
        }
    }

    /// `(p(wo -> wi), p(wi -> wo))` of the delta lobe taking this vertex's `wo` to `wi` (its
    /// lobe probabilities) times the continuation probability: the densities of a walk that
    /// left the vertex through that lobe.
    #[inline]
    pub fn delta_pdfs(&self, scene: &Scene, wi: Vec3) -> (f32, f32) {
        let Kind::Surface { bsdf, frame, .. } = self.v.kind else {
            return (0.0, 0.0);
        };
        let q = self.continuation(scene);
        (
            bsdf.delta_lobe_probability(&frame, self.wo, wi) * q,
            bsdf.delta_lobe_probability(&frame, wi, self.wo) * q,
        )
    }

    /// Russian-roulette continuation probability of leaving this vertex (from the first
    /// bounce on, a property of the surface or medium alone).
    #[inline]
    pub fn continuation(&self, scene: &Scene) -> f32 {
        paths::local_continuation(scene, &self.v).min(self.q_cap)
    }

    /// The vertex as one end of a visibility test.
    #[inline]
    pub fn endpoint(&self) -> Endpoint {
        paths::endpoint(&self.v)
    }

    /// Medium a ray leaving along `d` starts in.
    #[inline]
    pub fn medium_towards(&self, scene: &Scene, d: Vec3) -> Option<u32> {
        paths::medium_towards(scene, &self.v, d)
    }

    /// The vertex as a `Path` vertex (for inspection).
    pub fn path_vertex(&self) -> crate::path::Vertex {
        paths::path_vertex(&self.v)
    }
}

pub use crate::integrators::paths::{emission, hittable};

/// Whether a light's origin can be connected to the camera (not at infinity).
pub fn connectible_light(light: &Light) -> bool {
    !light.is_infinite()
}

/// Density of next-event estimation from `from` choosing the point `p_l` (normal `n_l`) on
/// light `li`, seen along unit `wi`, in the light vertex's measure, light choice included
/// (delta lights: the choice probability alone).
pub fn nee_density(scene: &Scene, li: usize, from: Vec3, p_l: Vec3, n_l: Vec3, wi: Vec3) -> f32 {
    let l = &scene.lights[li];
    let pick = scene.light_sampler.pmf(li);
    if l.is_delta() {
        return pick;
    }
    let pdf_w = l.pdf_li(from, p_l, n_l, wi);
    if l.is_infinite() {
        return pick * pdf_w;
    }
    let d2 = (p_l - from).length_squared();
    if d2 == 0.0 {
        return 0.0;
    }
    pick * pdf_w * n_l.dot(wi).abs() / d2
}

/// (origin density, "emission direction density") of light `li` emitting from the point
/// with normal `n` along unit `dir` (for lights at infinity `n` is the direction towards the
/// light): finite lights give (choice x area density, solid-angle density of `dir`); lights at
/// infinity (choice x solid-angle density of the direction, area density on their disk).
/// The density of the next vertex is the second factor times |cos| there (and 1 / d^2 for
/// finite lights).
pub fn emission_densities(scene: &Scene, li: usize, n: Vec3, dir: Vec3) -> (f32, f32) {
    let l = &scene.lights[li];
    let pick = scene.light_sampler.pmf(li);
    if l.is_infinite() {
        let (pos, d) = l.pdf_le(n, -n);
        (pick * d, pos)
    } else {
        let (pos, d) = l.pdf_le(n, dir);
        (pick * pos, d)
    }
}
