//! Recording mode of the BDPT tracer: instead of weighting, every complete path a technique
//! forms is handed to a [`PathSink`] with f(X) and the sum of all techniques' densities, so a
//! caller (the guider, `integrators::unguided`) can form its own weights.

use super::Tracer;
use crate::integrators::paths::{Vertex, to_path_into};
use crate::integrators::unguided::PathSink;
use crate::math::{Sampler, Spectrum};
use crate::path::MAX_VERTICES;
use glam::Vec2;

/// What the last weight function left for [`Tracer::deliver`] in recording mode.
#[derive(Clone, Copy)]
pub(super) enum Pending {
    /// The path's densities, assembled: its own technique's (`own`) and the sum over every
    /// technique (`pdf_unguided` of the path).
    Explicit { p_s: f64, p_u: f64, own: usize },
    /// The recursive weight `w` of technique `own`; `Tracer::terms` holds the path's inputs
    /// should the sink ask for its densities.
    Recursive { w: f64, own: usize },
}

impl<'a> Tracer<'a> {
    /// One BDPT sample that weighs nothing itself: every complete path a technique forms goes
    /// to `sink` with f(X) (the technique's raw estimate times its density), the sum of every
    /// technique's density (`p_u`) and its pixel. The sink forms the weight, e.g. the balance
    /// heuristic over BDPT's techniques and a guided technique (`integrators::unguided`).
    /// Where the recursive weights apply, the sink is asked first whether it needs a path's
    /// densities ([`PathSink::needs_densities`]); if not, the path goes to it weighted by the
    /// recursive weight, and its densities are never assembled.
    pub fn sample_recorded(
        &mut self,
        raster: Vec2,
        sampler: &mut impl Sampler,
        sink: &mut dyn PathSink,
    ) {
        self.recording = true;
        self.run(raster, sampler, Some(sink));
        self.recording = false;
        self.splats.clear();
    }

    /// Technique `own`'s density and the sum of every technique's (s = 0..=k for BDPT's
    /// techniques, k + 1 + j for merging at y_j) for the path `c` followed by `lp` reversed,
    /// whose inputs are in `self.terms`; `None` if the own density is 0 or either is not
    /// finite.
    fn densities_of(
        &mut self,
        c: &[Vertex<'a>],
        lp: &[Vertex<'a>],
        own: usize,
    ) -> Option<(f64, f64)> {
        let k = self.terms.k;
        self.densities
            .resize(self.densities.len().max(2 * (k + 1)), 0.0);
        let (vc, vm) = self.densities.split_at_mut(k + 1);
        self.terms.technique_densities(vc);
        let scene = self.scene;
        let t = c.len();
        let vm_sum = self.terms.merge_densities(
            |j| super::mergeable(scene, if j < t { &c[j] } else { &lp[k - j] }),
            vm,
        );
        let p_s = if own <= k { vc[own] } else { vm[own - k - 1] };
        let p_u: f64 = vc.iter().sum::<f64>() + vm_sum;
        (p_s > 0.0 && p_s.is_finite() && p_u.is_finite()).then_some((p_s, p_u))
    }

    /// Explicit balance weights: the path `c` followed by `lp` reversed (camera first)
    /// weighed as technique `own` among all of BDPT's techniques and, with merging
    /// (`Tracer::shared`), merging at every mergeable vertex. In recording mode the densities
    /// are kept for `deliver` and the return is 1 (the raw estimate is delivered); otherwise
    /// it is the weight.
    pub(super) fn hold(&mut self, c: &[Vertex<'a>], lp: &[Vertex<'a>], own: usize) -> f64 {
        self.pending = None;
        let Some((p_s, p_u)) = self.densities_of(c, lp, own) else {
            return 0.0;
        };
        if !self.recording {
            return (p_s / p_u).min(1.0);
        }
        self.pending = Some(Pending::Explicit { p_s, p_u, own });
        1.0
    }

    /// The recursive weight `w` of technique `own`: returned as it is, or in recording mode
    /// kept for `deliver` (with `self.terms` filled) and 1 returned.
    pub(super) fn hold_recursive(&mut self, w: f64, own: usize) -> f64 {
        if !self.recording {
            self.pending = None;
            return w;
        }
        self.pending = (w > 0.0).then_some(Pending::Recursive { w, own });
        if w > 0.0 { 1.0 } else { 0.0 }
    }

    /// Hand the path held by the last weight function, `c` followed by `lp` reversed, whose
    /// raw estimate is `value`, to `sink` (recording mode); `pixel` is where it lands
    /// (`None`: the traced pixel).
    pub(super) fn deliver(
        &mut self,
        value: Spectrum,
        pixel: Option<u32>,
        sink: &mut (dyn PathSink + '_),
        c: &[Vertex<'a>],
        lp: &[Vertex<'a>],
    ) {
        let Some(pending) = self.pending.take() else {
            return;
        };
        if value == Spectrum::ZERO {
            return;
        }
        let pixel_of_x1 = pixel.unwrap_or(self.pixel);
        let own = match pending {
            Pending::Explicit { own, .. } => own,
            Pending::Recursive { w, own } => {
                if !sink.needs_densities(c, lp) {
                    sink.record_weighted(pixel_of_x1, value.as_dvec3() * w, pixel.is_some());
                    return;
                }
                own
            }
        };
        self.joined.clear();
        self.joined.extend(c.iter().chain(lp.iter().rev()));
        let k = self.joined.len() - 1;
        // A merge: the camera vertex y_m stands in for the photon, so the merged path's
        // densities as the merge weighed it (across y_m, the photon's own) are not those of
        // its vertices, by orders of magnitude where the photon's neighbour is about as near
        // as the radius. The sink gets the densities of the vertices instead, as `pdf_unguided`
        // evaluates them for every other path (and as vcm's tracer delivers merges in render
        // passes), so that every technique that can form this vertex path weighs it with the
        // same numbers: f = (the merge's raw estimate) x (merging's density at y_m).
        if own > k && !self.merges_as_weighed {
            let eta = self.shared.map_or(0.0, |s| s.eta);
            let (mut vc, mut vm) = ([0.0f64; MAX_VERTICES], [0.0f64; MAX_VERTICES]);
            let from_vertices = super::densities_from_vertices(
                self.scene,
                &self.joined,
                self.settings,
                eta,
                &mut self.vertex_terms,
                &mut vc,
                &mut vm,
            )
            .map(|sum| (vm[own - k - 1], sum))
            .filter(|&(p_s, p_u)| p_s > 0.0 && p_s.is_finite() && p_u.is_finite());
            if let Some((p_s, p_u)) = from_vertices {
                let f = value.as_dvec3() * p_s;
                to_path_into(&self.joined, f.as_vec3(), pixel_of_x1, &mut self.path_buf);
                sink.record_from_vertices(&self.path_buf, &self.joined, f, p_u, pixel.is_some());
                return;
            }
            // The vertices give the merge no density (a segment the merge never traced is
            // blocked for them): its own densities go to the sink as a connection's do.
        }
        // A connection joins two traced subpaths: its densities are the path's own.
        let (p_s, p_u) = match pending {
            Pending::Explicit { p_s, p_u, .. } => (p_s, p_u),
            Pending::Recursive { .. } => match self.densities_of(c, lp, own) {
                Some(d) => d,
                None => return,
            },
        };
        let f = value.as_dvec3() * p_s;
        to_path_into(&self.joined, f.as_vec3(), pixel_of_x1, &mut self.path_buf);
        sink.record(&self.path_buf, Some(&self.joined), f, p_u, pixel.is_some());
    }
}
