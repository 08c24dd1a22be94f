//! Subpath vertices of `vcm`, the free flight along the edges between them, and the densities
//! of light vertices (origin, next-event estimation, emission towards a point).
//!
//! Measures as everywhere in lodestar (DESIGN.md §3): area for surfaces and finite lights,
//! volume in media, solid angle for lights at infinity. Cosines of measure conversions use
//! the geometric normal (1 at medium points); BSDF values use the shading normal. Every
//! direction density of a surface is `Bsdf::pdf` in radiance mode (delta surfaces: the lobe
//! probability), exactly as in `bdpt`, so that with merging off the MIS weights are BDPT's.

use crate::bsdf::{Bsdf, ShadingFrame, TransportMode};
use crate::light::Light;
use crate::math::Spectrum;
use crate::scene::{Endpoint, Scene, ShapeInfo};
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

/// What scatters at a vertex.
#[derive(Clone, Copy)]
pub enum Scatter<'a> {
    Surface {
        bsdf: &'a Bsdf,
        frame: ShadingFrame,
        info: &'a ShapeInfo,
        /// The material at the vertex (differs from `info.material` on a checkerboard).
        material: u32,
    },
    Medium {
        medium: u32,
    },
}

/// A scattering vertex of a camera or light subpath.
#[derive(Clone, Copy)]
pub struct Vertex<'a> {
    pub p: Vec3,
    /// Geometric normal (zero in media).
    pub n: Vec3,
    /// Position error bound (surfaces).
    pub p_err: Vec3,
    /// Unit direction towards the previous vertex of the walk.
    pub wo: Vec3,
    /// Throughput of the subpath up to here (no scattering at this vertex yet).
    pub beta: Spectrum,
    pub mis: Mis,
    pub scatter: Scatter<'a>,
    /// The medium the walk arrived through (the medium itself for medium vertices).
    pub medium: Option<u32>,
    /// Segments from the subpath's origin (the pinhole or the light).
    pub depth: u32,
    /// Cap on the continuation probability (the walk's `q_cap`).
    pub q_cap: f32,
}

impl<'a> Vertex<'a> {
    #[inline]
    pub fn is_medium(&self) -> bool {
        matches!(self.scatter, Scatter::Medium { .. })
    }

    #[inline]
    pub fn is_delta(&self) -> bool {
        matches!(self.scatter, Scatter::Surface { bsdf, .. } if bsdf.is_delta())
    }

    /// A connection can end here (medium points, non-delta non-black surfaces).
    #[inline]
    pub fn connectible(&self) -> bool {
        match self.scatter {
            Scatter::Surface { bsdf, .. } => !bsdf.is_delta() && !bsdf.is_black(),
            Scatter::Medium { .. } => true,
        }
    }

    /// Merging is done here: non-delta, non-black surfaces (not in media).
    #[inline]
    pub fn mergeable(&self) -> bool {
        match self.scatter {
            Scatter::Surface { bsdf, .. } => !bsdf.is_delta() && !bsdf.is_black(),
            Scatter::Medium { .. } => false,
        }
    }

    /// |cos| between the geometric normal and `d` (1 in media): the measure conversion.
    #[inline]
    pub fn cos(&self, d: Vec3) -> f32 {
        if self.is_medium() {
            1.0
        } else {
            self.n.dot(d).abs()
        }
    }

    /// Scattering value from `wo` into `wi`, times |cos(wi)| at the shading normal on surfaces;
    /// the phase function in media.
    #[inline]
    pub fn f(&self, scene: &Scene, wi: Vec3, mode: TransportMode) -> Spectrum {
        match self.scatter {
            Scatter::Surface { bsdf, frame, .. } => {
                bsdf.eval(&frame, self.wo, wi, mode) * wi.dot(frame.frame.n).abs()
            }
            Scatter::Medium { medium } => {
                Spectrum::splat(scene.media[medium as usize].phase.eval(self.wo, wi))
            }
        }
    }

    /// `(self.f(wi), self.pdf_w(wo, wi), self.pdf_w(wi, wo))` with `wo` this vertex's own,
    /// bit for bit, in one BSDF (or phase) evaluation except on delta surfaces: what a
    /// connection or next-event estimation needs at each end, and a walk's MIS update.
    #[inline]
    pub fn f_pdfs(&self, scene: &Scene, wi: Vec3, mode: TransportMode) -> (Spectrum, f32, f32) {
        match self.scatter {
            Scatter::Surface { bsdf, frame, .. } if !bsdf.is_delta() => {
                let e = bsdf.eval_pdfs(&frame, self.wo, wi, mode);
                let q = bsdf.continuation().min(self.q_cap);
                (
                    e.f * wi.dot(frame.frame.n).abs(),
                    e.pdf_fwd * q,
                    e.pdf_rev * q,
                )
            }
            Scatter::Medium { medium } => {
                // Henyey-Greenstein depends on wo . wi only: one value for both directions.
                let m = &scene.media[medium as usize];
                let p = m.phase.eval(self.wo, wi);
                let q = m.continuation().min(self.q_cap);
                (Spectrum::splat(p), p * q, p * q)
            }
            Scatter::Surface { .. } => (
                self.f(scene, wi, mode),
                self.pdf_w(scene, self.wo, wi),
                self.pdf_w(scene, wi, self.wo),
            ),
        }
    }

    /// Solid-angle density of scattering from `wo` into `wi` (radiance-mode BSDF density, or
    /// the delta lobe's probability), times the continuation probability: the direction
    /// density every technique uses for this vertex.
    #[inline]
    pub fn pdf_w(&self, scene: &Scene, wo: Vec3, wi: Vec3) -> f32 {
        match self.scatter {
            Scatter::Surface { bsdf, frame, .. } => {
                let p = if bsdf.is_delta() {
                    bsdf.delta_lobe_probability(&frame, wo, wi)
                } else {
                    bsdf.pdf(&frame, wo, wi, TransportMode::Radiance)
                };
                p * bsdf.continuation().min(self.q_cap)
            }
            Scatter::Medium { medium } => {
                let m = &scene.media[medium as usize];
                m.phase.eval(wo, wi) * m.continuation().min(self.q_cap)
            }
        }
    }

    /// Russian-roulette continuation probability of leaving this vertex (from the first
    /// bounce on, a property of the surface or medium alone).
    #[inline]
    pub fn continuation(&self, scene: &Scene) -> f32 {
        match self.scatter {
            Scatter::Surface { bsdf, .. } => bsdf.continuation(),
            Scatter::Medium { medium } => scene.media[medium as usize].continuation(),
        }
        .min(self.q_cap)
    }

    /// The vertex as one end of a visibility test.
    #[inline]
    pub fn endpoint(&self) -> Endpoint {
        match self.scatter {
            Scatter::Surface { .. } => Endpoint {
                p: self.p,
                n: self.n,
                err: self.p_err,
            },
            Scatter::Medium { .. } => Endpoint::point(self.p),
        }
    }

    /// Medium a ray leaving along `d` starts in.
    #[inline]
    pub fn medium_towards(&self, d: Vec3) -> Option<u32> {
        match self.scatter {
            Scatter::Medium { medium } => Some(medium),
            Scatter::Surface { info, .. } => info
                .interface
                .map_or(self.medium, |mi| mi.crossing(d, self.n)),
        }
    }

    /// The vertex as a `Path` vertex (for inspection).
    pub fn path_vertex(&self) -> crate::path::Vertex {
        use crate::path::VertexKind;
        match self.scatter {
            Scatter::Surface {
                bsdf,
                frame,
                info,
                material,
            } => crate::path::Vertex {
                p: self.p,
                n: self.n,
                ns: frame.frame.n,
                kind: VertexKind::Surface {
                    material,
                    shape: info.index,
                    delta: bsdf.is_delta(),
                },
            },
            Scatter::Medium { medium } => crate::path::Vertex {
                p: self.p,
                n: Vec3::ZERO,
                ns: Vec3::ZERO,
                kind: VertexKind::Medium { medium },
            },
        }
    }
}

/// Emitted radiance (area lights; intensity for point and spot lights) towards `w`.
pub fn emission(light: &Light, n: Vec3, w: Vec3) -> Spectrum {
    match light {
        Light::Point(p) => p.intensity,
        Light::Spot(s) => s.intensity_towards(w),
        other => other.le(n, w),
    }
}

/// Whether a camera walk can hit the light (it has area, or extent at infinity).
pub fn hittable(light: &Light) -> bool {
    matches!(
        light,
        Light::Area(_) | Light::Environment(_) | Light::EnvMap(_) | Light::Sun(_)
    )
}

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
