//! The random walk of both subpaths, with the recursive MIS quantities carried along.
//!
//! A [`Walk`] traces one segment at a time (through index-matched boundaries, with free
//! flight in media) and returns the vertex it reaches with its [`Mis`] quantities complete;
//! [`Walk::scatter`] samples the BSDF or phase function, plays Russian roulette from the
//! first bounce with the local continuation probability (`Bsdf::continuation`), and folds
//! the vertex into the partial quantities of the next one (SmallVCM's update: the
//! direction densities and the cosine at the scattering vertex now, the distance, cosine and
//! free-flight factors of the next vertex once it is found).

use super::vertex::{Edge, Mis, MisVertex, nee_density};
use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset_origin};
use crate::integrators::paths::{self, Kind};
use crate::math::{Sampler, Spectrum};
use crate::scene::Scene;
use glam::Vec3;

/// How merging and connecting enter the MIS quantities (SmallVCM's weight factors).
#[derive(Debug, Clone, Copy)]
pub struct MisFactors {
    /// `eta = pi r^2 N` when merging is on (a merge at a vertex, relative to a connection),
    /// else 0.
    pub vm: f32,
    /// `1 / eta` when connecting is on (a connection, relative to a merge), else 0.
    pub vc: f32,
}

/// What tracing a segment found.
pub enum Step<'a> {
    /// A scattering vertex; `light` when it lies on an emitter.
    Vertex {
        v: MisVertex<'a>,
        light: Option<usize>,
    },
    /// The ray left the scene (with a non-zero chance of passing every medium): lights at
    /// infinity are seen along `dir`, with these quantities.
    Escaped { dir: Vec3, mis: Mis },
    /// Absorbed, or nothing to see.
    Dead,
}

/// A walk between vertices: ray, throughput, medium, and the partial MIS quantities that
/// wait for the next vertex's geometry.
pub struct Walk {
    pub ray: Ray,
    pub beta: Spectrum,
    pub medium: Option<u32>,
    pub mode: TransportMode,
    /// Segments traced so far.
    pub depth: u32,
    /// Position of the last vertex (pinhole, light point or scattering vertex).
    pub prev_p: Vec3,
    pending: Mis,
    /// The next `d_vcm` takes the squared distance (not on the first segment of a light at
    /// infinity, whose densities there are already per area).
    use_d2: bool,
    prev_is_medium: bool,
    /// The light point the walk started from, (light, point, normal): its next-event density
    /// from the first vertex multiplies that vertex's `d_vcm`.
    nee_origin: Option<(usize, Vec3, Vec3)>,
    /// Cap on every vertex's continuation probability (see [`deep_continuation`]).
    pub q_cap: f32,
    /// The last traced segment crossed no medium.
    pub vacuum: bool,
    /// The last [`Walk::scatter`] left its vertex through a delta lobe: the vertex is delta
    /// in the paths that go on through it (`paths::Vertex::delta`; a stored vertex stays
    /// as it arrived, as a connection's end).
    pub left_delta: bool,
}

/// vcm's cap on continuation probabilities for a depth limit of `max_depth`: 1 within the
/// stored-path limit, `paths::DEEP_CONTINUATION` beyond (an unlimited depth included), so
/// that paths end between perfect mirrors. vcm plays roulette from the first bounce with a
/// local probability (its MIS recursion needs densities that do not depend on which end a
/// vertex is counted from), so the cap is a property of the render, not of the vertex depth.
pub fn deep_continuation(max_depth: u32) -> f32 {
    if (max_depth as usize) < crate::path::MAX_VERTICES {
        1.0
    } else {
        crate::integrators::paths::DEEP_CONTINUATION
    }
}

impl Walk {
    /// A camera walk along `ray` (from the pinhole) with image-wide direction density `pdf_we`.
    pub fn camera(scene: &Scene, ray: Ray, pdf_we: f32) -> Walk {
        Walk {
            prev_p: ray.o,
            ray,
            beta: Spectrum::ONE,
            medium: scene.camera_medium,
            mode: TransportMode::Radiance,
            depth: 0,
            pending: Mis {
                d_vcm: 1.0 / pdf_we,
                d_vc: 0.0,
                d_vm: 0.0,
            },
            use_d2: true,
            prev_is_medium: false,
            nee_origin: None,
            q_cap: 1.0,
            vacuum: true,
            left_delta: false,
        }
    }

    /// A light walk leaving light `li` from `p` (normal `n`; for lights at infinity the
    /// direction towards the light) along `ray`, with throughput `beta` and the emission
    /// densities of [`super::vertex::emission_densities`].
    #[allow(clippy::too_many_arguments)]
    pub fn light(
        ray: Ray,
        beta: Spectrum,
        li: usize,
        p: Vec3,
        n: Vec3,
        (p_origin, p_emit): (f32, f32),
        cos_origin: f32,
        infinite: bool,
        hittable: bool,
        factors: MisFactors,
    ) -> Walk {
        // VCM tech. report (31)-(32): the next-event density joins at the first vertex.
        let d_vcm = 1.0 / (p_origin * p_emit);
        let d_vc = if hittable {
            cos_origin / (p_origin * p_emit)
        } else {
            0.0
        };
        Walk {
            prev_p: p,
            ray,
            beta,
            medium: None,
            mode: TransportMode::Importance,
            depth: 0,
            pending: Mis {
                d_vcm,
                d_vc,
                d_vm: d_vc * factors.vc,
            },
            use_d2: !infinite,
            prev_is_medium: false,
            nee_origin: Some((li, p, n)),
            q_cap: 1.0,
            vacuum: true,
            left_delta: false,
        }
    }

    /// Trace the next segment.
    pub fn trace<'a>(&mut self, scene: &'a Scene, sampler: &mut impl Sampler) -> Step<'a> {
        let mut edge = Edge::VACUUM;
        let mut crossings = 0;
        let found = loop {
            let sp = scene.intersect(&self.ray);
            if let Some(m) = self.medium {
                let t_hit = sp.as_ref().map_or(f32::INFINITY, |sp| sp.hit.t);
                let flight = scene.media[m as usize].sample_distance(
                    t_hit,
                    sampler.next_1d(),
                    sampler.next_1d(),
                );
                self.beta *= flight.weight;
                edge.push(scene, self.medium, flight.t);
                if flight.scattered {
                    break Some((
                        self.ray.at(flight.t),
                        Vec3::ZERO,
                        Vec3::ZERO,
                        Kind::Medium { medium: m },
                        None,
                    ));
                }
            }
            let Some(sp) = sp else { break None };
            if sp.is_null() {
                crossings += 1;
                if crossings > 256 {
                    return Step::Dead;
                }
                self.medium = scene.medium_after(&sp, self.ray.d, self.medium);
                self.ray = sp.hit.spawn(self.ray.d);
                continue;
            }
            let light = sp.light();
            break Some((
                sp.hit.p,
                sp.hit.ng,
                sp.hit.p_err,
                Kind::Surface {
                    bsdf: sp.bsdf,
                    frame: sp.frame,
                    info: sp.info,
                    material: sp.material,
                },
                light,
            ));
        };
        if self.beta == Spectrum::ZERO {
            return Step::Dead;
        }
        self.depth += 1;
        self.vacuum = edge.first.is_none();
        let ff_rev = edge.factor(scene, self.prev_is_medium, false);
        let Some((p, n, p_err, kind, light)) = found else {
            let ff = edge.pass;
            if ff <= 0.0 || self.mode == TransportMode::Importance {
                return Step::Dead;
            }
            let mis = Mis {
                d_vcm: self.pending.d_vcm / ff,
                d_vc: self.pending.d_vc * ff_rev / ff,
                d_vm: self.pending.d_vm * ff_rev / ff,
            };
            return Step::Escaped {
                dir: self.ray.d,
                mis,
            };
        };
        let delta = matches!(kind, Kind::Surface { bsdf, .. } if bsdf.is_delta());
        let mut v = MisVertex {
            v: paths::Vertex {
                p_err,
                beta: self.beta,
                delta,
                edge,
                medium: self.medium,
                ..paths::Vertex::new(kind, p, n)
            },
            wo: -self.ray.d,
            mis: Mis::default(),
            depth: self.depth,
            q_cap: self.q_cap,
        };
        let ff_fwd = edge.factor(scene, v.is_medium(), true);
        let cos = v.cos(self.ray.d);
        let d2 = (p - self.prev_p).length_squared();
        let g = cos * ff_fwd;
        if g <= 0.0 || d2 <= 0.0 {
            return Step::Dead;
        }
        let mut d_vcm = self.pending.d_vcm / g;
        if self.use_d2 {
            d_vcm *= d2;
        }
        if let Some((li, lp, ln)) = self.nee_origin {
            let wi = if scene.lights[li].is_infinite() {
                ln
            } else {
                (lp - p).normalize()
            };
            d_vcm *= nee_density(scene, li, p, lp, ln, wi);
        }
        v.mis = Mis {
            d_vcm,
            d_vc: self.pending.d_vc * ff_rev / g,
            d_vm: self.pending.d_vm * ff_rev / g,
        };
        Step::Vertex { v, light }
    }

    /// Scatter at `v` (the vertex the last [`Walk::trace`] returned): sample a direction, play
    /// Russian roulette and prepare the next vertex's quantities. False when the walk ends.
    pub fn scatter(
        &mut self,
        scene: &Scene,
        v: &MisVertex,
        factors: MisFactors,
        sampler: &mut impl Sampler,
    ) -> bool {
        let wo = v.wo;
        let (wi, delta) = match v.kind {
            Kind::Surface { bsdf, frame, .. } => {
                let (u_lobe, u) = (sampler.next_1d(), sampler.next_2d());
                let Some(bs) = bsdf.sample(&frame, wo, u_lobe, u, self.mode) else {
                    return false;
                };
                self.beta *= bs.weight;
                (bs.wi, bs.delta)
            }
            Kind::Medium { medium } => {
                let wi = scene.media[medium as usize]
                    .phase
                    .sample(wo, sampler.next_2d())
                    .0;
                (wi, false)
            }
            // Walks reach surfaces and medium points only.
            Kind::Camera | Kind::Light { .. } => return false,
        };
        self.left_delta = delta;
        let q = v.continuation(scene);
        if q < 1.0 {
            if sampler.next_1d() >= q {
                return false;
            }
            self.beta /= q;
        }
        let (pdf_fwd, pdf_rev) = if delta {
            v.delta_pdfs(scene, wi)
        } else {
            let (_, fwd, rev) = v.f_pdfs(scene, wi, TransportMode::Radiance);
            (fwd, rev)
        };
        if pdf_fwd <= 0.0 {
            return false;
        }
        // VCM tech. report (34)-(38); SmallVCM's update after sampling a direction.
        let m = &v.mis;
        let c = v.cos(wi) / pdf_fwd;
        self.pending = if delta {
            Mis {
                d_vcm: 0.0,
                d_vc: c * m.d_vc * pdf_rev,
                d_vm: c * m.d_vm * pdf_rev,
            }
        } else {
            let merge = if v.mergeable() { 1.0 } else { 0.0 };
            Mis {
                d_vcm: 1.0 / pdf_fwd,
                d_vc: c * (m.d_vc * pdf_rev + m.d_vcm + factors.vm * merge),
                d_vm: c * (m.d_vm * pdf_rev + m.d_vcm * factors.vc + merge),
            }
        };
        self.ray = match v.kind {
            Kind::Surface { info, .. } => {
                if let Some(mi) = &info.interface {
                    self.medium = mi.crossing(wi, v.n);
                }
                Ray::new(offset_origin(v.p, v.p_err, v.n, wi), wi)
            }
            _ => Ray::new(v.p, wi),
        };
        self.prev_p = v.p;
        self.prev_is_medium = v.is_medium();
        self.use_d2 = true;
        self.nee_origin = None;
        true
    }
}
