//! Recording mode of the BDPT tracer: instead of weighting, every complete path a technique
//! forms is handed to a [`PathSink`] with f(X) and the sum of all techniques' densities, so a
//! caller (the guider, `integrators::unguided`) can form its own weights.

use super::Tracer;
use crate::integrators::paths::{Vertex, join_subpaths, to_path_into};
use crate::integrators::unguided::PathSink;
use crate::math::{Sampler, Spectrum};
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

    /// Technique `own`'s density (s) and the sum of every technique's for the path whose
    /// inputs are in `self.terms`; `None` if the own density is 0 or either is not finite.
    fn densities_of(&mut self, own: usize) -> Option<(f64, f64)> {
        let k = self.terms.k;
        self.densities.resize(self.densities.len().max(k + 1), 0.0);
        let vc = &mut self.densities[..=k];
        self.terms.technique_densities(vc);
        let p_s = vc[own];
        let p_u: f64 = vc.iter().sum::<f64>();
        (p_s > 0.0 && p_s.is_finite() && p_u.is_finite()).then_some((p_s, p_u))
    }

    /// Explicit balance weights: the path whose inputs are in `self.terms` weighed as
    /// technique `own` among all of BDPT's techniques. In recording mode the densities are
    /// kept for `deliver` and the return is 1 (the raw estimate is delivered); otherwise it
    /// is the weight.
    pub(super) fn hold(&mut self, own: usize) -> f64 {
        self.pending = None;
        let Some((p_s, p_u)) = self.densities_of(own) else {
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
    /// (`None`: the traced pixel); `connected`: a connection joins `c` and `lp` (else `lp` is
    /// the emitter the camera walk hit).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn deliver(
        &mut self,
        value: Spectrum,
        pixel: Option<u32>,
        sink: &mut (dyn PathSink + '_),
        c: &[Vertex<'a>],
        lp: &[Vertex<'a>],
        connected: bool,
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
        join_subpaths(c, lp, connected, &mut self.joined);
        let (p_s, p_u) = match pending {
            Pending::Explicit { p_s, p_u, .. } => (p_s, p_u),
            Pending::Recursive { .. } => match self.densities_of(own) {
                Some(d) => d,
                None => return,
            },
        };
        let f = value.as_dvec3() * p_s;
        to_path_into(&self.joined, f.as_vec3(), pixel_of_x1, &mut self.path_buf);
        sink.record(&self.path_buf, Some(&self.joined), f, p_u, pixel.is_some());
    }
}
