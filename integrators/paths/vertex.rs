//! Subpath vertices and the densities between them.
//!
//! Densities are in the area measure for surface and light vertices, the volume measure for
//! medium vertices and the solid-angle measure for lights at infinity (DESIGN.md §3). A delta
//! event (specular BSDF, point light position, pinhole) contributes its discrete probability
//! and the Dirac itself is left out: every technique that can produce a path contains the
//! same Diracs, so they cancel in every ratio. Roulette is not stored in the cached densities;
//! it is applied when path densities are assembled, because its probability depends on the
//! direction a vertex is reached from (`terms.rs`).

use crate::bsdf::{Bsdf, ShadingFrame, TransportMode};
use crate::math::Spectrum;
use crate::scene::{Scene, ShapeInfo};
use glam::Vec3;

/// What a vertex is.
#[derive(Clone, Copy)]
pub enum Kind<'a> {
    /// The pinhole.
    Camera,
    /// On a light. For lights at infinity `n` holds the direction from the scene towards the
    /// light and `p` is unused.
    Light {
        /// Index into `Scene::lights`.
        light: usize,
    },
    /// A scattering surface.
    Surface {
        /// The BSDF at the vertex (black on the back of a one-sided material).
        bsdf: &'a Bsdf,
        /// The shading frame and geometric normal.
        frame: ShadingFrame,
        /// The shape's light, media and flags.
        info: &'a ShapeInfo,
        /// The material at the vertex (differs from `info.material` on a checkerboard).
        material: u32,
    },
    /// A scattering point in a medium.
    Medium {
        /// Index into `Scene::media`.
        medium: u32,
    },
}

/// Free flight along the edge that reached a vertex, for the densities of both directions:
/// the product of pass probabilities of its medium segments, and the first and last segment.
#[derive(Clone, Copy, Default)]
pub struct Edge {
    /// Probability that free flight crosses every medium segment of the edge.
    pub pass: f32,
    /// (medium, length) of the segment next to the walk's previous vertex.
    pub first: Option<(u32, f32)>,
    /// (medium, length) of the segment next to this vertex.
    pub last: Option<(u32, f32)>,
}

impl Edge {
    /// An edge through no medium: free flight always passes.
    pub const VACUUM: Edge = Edge {
        pass: 1.0,
        first: None,
        last: None,
    };

    /// The free flight of a traced connection.
    pub fn along(tr: &crate::scene::Transmittance) -> Edge {
        Edge {
            pass: tr.pass,
            first: tr.first,
            last: tr.last,
        }
    }

    /// The same edge seen from its other end.
    pub fn reversed(self) -> Edge {
        Edge {
            first: self.last,
            last: self.first,
            ..self
        }
    }

    /// Add a segment of length `len` in `medium` (None: vacuum, which adds nothing).
    pub fn push(&mut self, scene: &Scene, medium: Option<u32>, len: f32) {
        if let Some(m) = medium {
            self.pass *= scene.media[m as usize].pass_probability(len);
            if self.first.is_none() {
                self.first = Some((m, len));
            }
            self.last = Some((m, len));
        }
    }

    /// Free-flight factor of generating the vertex at one end of the edge: the pass
    /// probabilities of all segments, except that a medium vertex is reached by scattering in
    /// its segment (`mean(sigma_t Tr)` instead of `mean(Tr)`).
    pub fn factor(&self, scene: &Scene, target_is_medium: bool, target_is_this: bool) -> f32 {
        if !target_is_medium {
            return self.pass;
        }
        let seg = if target_is_this {
            self.last
        } else {
            self.first
        };
        let Some((m, len)) = seg else {
            return self.pass;
        };
        let m = &scene.media[m as usize];
        let pass = m.pass_probability(len);
        if pass <= 0.0 {
            return 0.0;
        }
        let tr = m.tr(len);
        let scatter = (m.sigma_t * tr).dot(Spectrum::splat(1.0 / 3.0));
        self.pass / pass * scatter
    }
}

/// A vertex of a camera or light subpath, with the throughput and densities that connections
/// and MIS weights need.
#[derive(Clone, Copy)]
pub struct Vertex<'a> {
    /// What the vertex is, with its scattering function.
    pub kind: Kind<'a>,
    /// Position (unused for lights at infinity).
    pub p: Vec3,
    /// Position error bound (surfaces), for spawning and visibility.
    pub p_err: Vec3,
    /// Geometric normal; zero in media, at the pinhole and on point lights.
    pub n: Vec3,
    /// Throughput of the subpath up to this vertex (for a light vertex: 1 / its density).
    pub beta: Spectrum,
    /// The path takes a delta lobe here (or the vertex is a delta light): the directions
    /// into and out of a surface vertex are related by a Dirac lobe, so its densities are
    /// lobe probabilities ([`pdf`]) and no connection joins the path at it. A walk's vertex is
    /// delta if its BSDF is ([`Bsdf::is_delta`]) and, on a BSDF that also has a non-delta
    /// lobe (smooth plastic), once the walk has left it through the delta lobe
    /// ([`BsdfSample::delta`]); the vertex that ends a connection is not (the connection leaves
    /// it in a direction no Dirac lobe picks), whatever its walk did next.
    ///
    /// [`Bsdf::is_delta`]: crate::bsdf::Bsdf::is_delta
    /// [`BsdfSample::delta`]: crate::bsdf::BsdfSample::delta
    pub delta: bool,
    /// Density of this vertex from its walk (no roulette), free flight included.
    pub pdf_fwd: f32,
    /// Density of the walk's previous vertex when generated from this one in the other
    /// direction (no roulette); set once the walk has sampled the next vertex.
    pub pdf_rev: f32,
    /// Free flight of the edge from the walk's previous vertex.
    pub edge: Edge,
    /// Medium of medium vertices; for others the medium the walk arrived through.
    pub medium: Option<u32>,
}

impl<'a> Vertex<'a> {
    /// A vertex with neutral bookkeeping (throughput 1, no densities yet, no position error,
    /// a vacuum edge, not delta); walks set what they know with struct-update syntax.
    pub fn new(kind: Kind<'a>, p: Vec3, n: Vec3) -> Vertex<'a> {
        Vertex {
            kind,
            p,
            p_err: Vec3::ZERO,
            n,
            beta: Spectrum::ONE,
            delta: false,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            edge: Edge::VACUUM,
            medium: None,
        }
    }

    /// Whether the vertex is a scattering point in a medium.
    pub fn is_medium(&self) -> bool {
        matches!(self.kind, Kind::Medium { .. })
    }

    /// Whether the vertex is on a light at infinity (environment, directional, sun).
    pub fn is_infinite_light(&self, scene: &Scene) -> bool {
        matches!(self.kind, Kind::Light { light } if scene.lights[light].is_infinite())
    }

    /// Whether a technique could join this path with a connection (a deterministic edge)
    /// at this vertex: [`Self::connectible_end`], and on a surface the path not taking a delta
    /// lobe here (`delta`). For the vertices of a complete path.
    pub fn connectible(&self, scene: &Scene) -> bool {
        self.connectible_end(scene) && !self.is_specular_surface()
    }

    /// Whether the path takes a delta lobe of a surface here (`delta` on a surface).
    #[inline]
    pub fn is_specular_surface(&self) -> bool {
        self.delta && matches!(self.kind, Kind::Surface { .. })
    }

    /// Whether a connection can end here, leaving the vertex along the connection: the
    /// pinhole, medium points, non-delta non-black surfaces (smooth plastic too, by its base),
    /// lights but directional ones and those at infinity. For the last vertex of a subpath
    /// being connected, whatever lobe its walk took afterwards.
    pub fn connectible_end(&self, scene: &Scene) -> bool {
        match self.kind {
            Kind::Camera | Kind::Medium { .. } => true,
            Kind::Surface { bsdf, .. } => !bsdf.is_delta() && !bsdf.is_black(),
            // A light whose emission is a delta in direction cannot be connected to.
            Kind::Light { light } => {
                !matches!(scene.lights[light], crate::light::Light::Directional(_))
                    && !scene.lights[light].is_infinite()
            }
        }
    }

    /// Scattering value towards `next`, having come from `prev`: BSDF times |cos| at the
    /// shading normal on surfaces (mode as for the walk), the phase function in media.
    pub fn f(&self, scene: &Scene, prev: Vec3, next: Vec3, mode: TransportMode) -> Spectrum {
        let (wo, wi) = ((prev - self.p).normalize(), (next - self.p).normalize());
        match self.kind {
            Kind::Surface { bsdf, frame, .. } => {
                bsdf.eval(&frame, wo, wi, mode) * wi.dot(frame.frame.n).abs()
            }
            Kind::Medium { medium } => {
                Spectrum::splat(scene.media[medium as usize].phase.eval(wo, wi))
            }
            Kind::Camera | Kind::Light { .. } => Spectrum::ZERO,
        }
    }

    /// |cos| between the normal at this vertex and the direction to `other` (1 in media).
    pub fn abs_cos_to(&self, other: Vec3) -> f32 {
        if self.n == Vec3::ZERO || self.is_medium() {
            1.0
        } else {
            self.n.dot((other - self.p).normalize()).abs()
        }
    }
}

/// What a connection needs from one of its ends `v`: the scattering value towards the other
/// end (as [`Vertex::f`]) and two solid-angle densities at `v` (as [`pdf`] before the measure
/// conversion): of the other end, having come from the walk's previous vertex, and of that
/// previous vertex, having come from the other end.
#[derive(Clone, Copy)]
pub struct ConnectionEnd {
    /// Scattering value towards the other end, |cos| included on surfaces.
    pub f: Spectrum,
    /// Solid-angle density at `v` of the other end, coming from the previous vertex.
    pub pdf_other: f32,
    /// Solid-angle density at `v` of the previous vertex, coming from the other end.
    pub pdf_prev: f32,
}

/// [`ConnectionEnd`] of a surface or medium vertex `v`, with unit directions `wo` towards the
/// walk's previous vertex and `wi` towards the other end; one BSDF (or phase) evaluation
/// gives all three. Zero at the pinhole and on lights, which connections treat themselves.
/// Inlined into every connection: the three values then stay in registers.
#[inline(always)]
pub fn connection_end(
    scene: &Scene,
    v: &Vertex,
    wo: Vec3,
    wi: Vec3,
    mode: TransportMode,
) -> ConnectionEnd {
    match &v.kind {
        Kind::Surface { bsdf, frame, .. } => {
            let e = bsdf.eval_pdfs(frame, wo, wi, mode);
            ConnectionEnd {
                f: e.f * wi.dot(frame.frame.n).abs(),
                pdf_other: e.pdf_fwd,
                pdf_prev: e.pdf_rev,
            }
        }
        Kind::Medium { medium } => {
            // Henyey-Greenstein depends on wo . wi only: one value for both directions.
            let p = scene.media[*medium as usize].phase.eval(wo, wi);
            ConnectionEnd {
                f: Spectrum::splat(p),
                pdf_other: p,
                pdf_prev: p,
            }
        }
        Kind::Camera | Kind::Light { .. } => ConnectionEnd {
            f: Spectrum::ZERO,
            pdf_other: 0.0,
            pdf_prev: 0.0,
        },
    }
}

/// The factor turning a solid-angle density towards the finite vertex `to`, at distance^2
/// `d2` along unit `w`, into `to`'s measure: `|cos| / d^2` on surfaces, `1 / d^2` in media and
/// at points without a normal (as [`to_measure`]).
#[inline]
pub fn measure_factor(to: &Vertex, w: Vec3, d2: f32) -> f32 {
    if to.n != Vec3::ZERO && !to.is_medium() {
        to.n.dot(w).abs() / d2
    } else {
        1.0 / d2
    }
}

/// Convert a solid-angle density at `from` towards `to` into `to`'s measure: area (|cos| / d^2)
/// for surfaces and finite lights, volume (1 / d^2) in media; lights at infinity keep solid angle.
#[inline]
pub fn to_measure(scene: &Scene, pdf_w: f32, from: Vec3, to: &Vertex) -> f32 {
    scaled(pdf_w, to_measure_factor(scene, from, to))
}

/// `pdf_w` times a measure factor `g` in f64, rounded once (0 when `g` is 0, whatever `pdf_w`).
#[inline]
pub fn scaled(pdf_w: f32, g: f64) -> f32 {
    if g == 0.0 {
        0.0
    } else {
        (pdf_w as f64 * g) as f32
    }
}

/// The factor [`to_measure`] multiplies by: 1 towards a light at infinity, 0 when `to` sits
/// at `from`, else [`area_factor`](super::area_factor) (`1 / d^2` in media). For callers that
/// convert several densities towards the same vertex.
#[inline]
pub fn to_measure_factor(scene: &Scene, from: Vec3, to: &Vertex) -> f64 {
    if to.is_infinite_light(scene) {
        return 1.0;
    }
    if to.p == from {
        return 0.0;
    }
    let n = if to.is_medium() { Vec3::ZERO } else { to.n };
    super::area_factor(from, to.p, n)
}

/// Density (in `next`'s measure; no roulette, no free flight) with which vertex `v`, reached
/// from `prev`, generates `next`: by the camera's ray sampling, by a light's emission
/// sampling, by BSDF or phase sampling (a delta vertex: its lobe probability, the Dirac left
/// out). This is the from-scratch definition (`path_terms`); the walks ([`pdf_both`]) and
/// connections ([`connection_end`] with [`measure_factor`]) evaluate the same BSDF and phase
/// densities from vertex positions, two directions per call, so all techniques agree to
/// rounding.
pub fn pdf(scene: &Scene, v: &Vertex, prev: Option<Vec3>, next: &Vertex) -> f32 {
    let towards = |q: Vec3| (q - v.p).normalize();
    // A vertex at infinity is a direction.
    let to_next = if next.is_infinite_light(scene) {
        next.n
    } else {
        towards(next.p)
    };
    match v.kind {
        Kind::Camera => to_measure(scene, scene.camera.pdf_we(to_next), v.p, next),
        Kind::Light { light } => {
            let l = &scene.lights[light];
            if l.is_infinite() {
                // Origins on a disk facing the light: an area density projected onto `next`.
                let (pdf_pos, _) = l.pdf_le(v.n, -v.n);
                let cos = if next.n == Vec3::ZERO || next.is_medium() {
                    1.0
                } else {
                    next.n.dot(v.n).abs()
                };
                pdf_pos * cos
            } else {
                let (_, pdf_dir) = l.pdf_le(v.n, to_next);
                to_measure(scene, pdf_dir, v.p, next)
            }
        }
        Kind::Surface { bsdf, frame, .. } => {
            let Some(prev) = prev else { return 0.0 };
            let pdf_w = if v.delta {
                bsdf.delta_lobe_probability(&frame, towards(prev), to_next)
            } else {
                bsdf.pdf(&frame, towards(prev), to_next, TransportMode::Radiance)
            };
            to_measure(scene, pdf_w, v.p, next)
        }
        Kind::Medium { medium } => {
            let Some(prev) = prev else { return 0.0 };
            to_measure(
                scene,
                scene.media[medium as usize]
                    .phase
                    .eval(towards(prev), to_next),
                v.p,
                next,
            )
        }
    }
}

/// Both densities at `v` between its neighbours `prev` and `next` in one evaluation: of `next`
/// having come from `prev` ([`pdf`]`(v, prev, next)`) and of `prev` having come from `next`
/// ([`pdf`]`(v, next, prev)`; 0 without `prev`), each in the measure of the vertex it
/// generates. The walks use it once per vertex; the direction to `prev` is taken from its
/// position, also when it is a light at infinity (equal to its direction up to rounding).
pub fn pdf_both(scene: &Scene, v: &Vertex, prev: Option<&Vertex>, next: &Vertex) -> (f32, f32) {
    let Some(prev) = prev else {
        return (pdf(scene, v, None, next), 0.0);
    };
    let wo = (prev.p - v.p).normalize();
    let wi = if next.is_infinite_light(scene) {
        next.n
    } else {
        (next.p - v.p).normalize()
    };
    let (fwd, rev) = match &v.kind {
        Kind::Surface { bsdf, frame, .. } => {
            if v.delta {
                (
                    bsdf.delta_lobe_probability(frame, wo, wi),
                    bsdf.delta_lobe_probability(frame, wi, wo),
                )
            } else {
                let e = bsdf.eval_pdfs(frame, wo, wi, TransportMode::Radiance);
                (e.pdf_fwd, e.pdf_rev)
            }
        }
        Kind::Medium { medium } => {
            // Henyey-Greenstein depends on wo . wi only: one value for both directions.
            let p = scene.media[*medium as usize].phase.eval(wo, wi);
            (p, p)
        }
        // The pinhole and lights start walks: they have no previous vertex.
        Kind::Camera | Kind::Light { .. } => return (pdf(scene, v, Some(prev.p), next), 0.0),
    };
    (
        to_measure(scene, fwd, v.p, next),
        to_measure(scene, rev, v.p, prev),
    )
}
