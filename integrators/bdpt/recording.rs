//! Recording mode of the BDPT tracer: instead of weighting, every complete path a technique
//! forms is handed to a [`PathSink`] with f(X) and the sum of all techniques' densities, so a
//! caller (the guider, `integrators::unguided`) can form its own weights.

use super::{Tracer, Vertex, to_path_into};
use crate::integrators::unguided::PathSink;
use crate::math::{Sampler, Spectrum};
use glam::Vec2;

/// Densities of the path a weight function saw in recording mode: its own technique's and
/// the sum over every technique (BDPT's `pdf_unguided` of the path).
#[derive(Clone, Copy)]
pub(super) struct Pending {
    p_s: f64,
    p_u: f64,
}

impl<'a> Tracer<'a> {
    /// One BDPT sample that weighs nothing itself: every complete path a technique forms goes
    /// to `sink` with f(X) (the technique's raw estimate times its density), the sum of every
    /// technique's density (`p_u`) and its pixel. The sink forms the weight, e.g. the balance
    /// heuristic over BDPT's techniques and a guided technique (`integrators::unguided`).
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

    /// Recording mode: keep the path `vertices` (camera first) weighed as technique `s`; the
    /// raw estimate is returned by the technique and handed on by `deliver`.
    pub(super) fn hold<'v>(
        &mut self,
        vertices: impl Iterator<Item = &'v Vertex<'a>>,
        s: usize,
    ) -> f64
    where
        'a: 'v,
    {
        let k = self.terms.k;
        self.densities.resize(self.densities.len().max(k + 1), 0.0);
        self.terms.technique_densities(&mut self.densities);
        let p_s = self.densities[s];
        let p_u: f64 = self.densities[..=k].iter().sum();
        self.pending = None;
        if !(p_s > 0.0 && p_s.is_finite() && p_u.is_finite()) {
            return 0.0;
        }
        self.joined.clear();
        self.joined.extend(vertices.copied());
        self.pending = Some(Pending { p_s, p_u });
        1.0
    }

    /// Hand the path held by the last weight function, whose raw estimate is `value`, to
    /// `sink` (recording mode); `pixel` is where it lands (`None`: the traced pixel).
    pub(super) fn deliver(
        &mut self,
        value: Spectrum,
        pixel: Option<u32>,
        sink: &mut (dyn PathSink + '_),
    ) {
        let Some(p) = self.pending.take() else {
            return;
        };
        if value == Spectrum::ZERO {
            return;
        }
        let f = value.as_dvec3() * p.p_s;
        let pixel_of_x1 = pixel.unwrap_or(self.pixel);
        to_path_into(&self.joined, f.as_vec3(), pixel_of_x1, &mut self.path_buf);
        sink.record(
            &self.path_buf,
            Some(&self.joined),
            f,
            p.p_u,
            pixel.is_some(),
        );
    }
}
