//! One BDPT technique (s, t) on its own, for multiplexed Metropolis (`mmlt`): a camera
//! subpath of exactly t vertices and a light subpath of exactly s, joined by that technique
//! alone and weighted by its MIS weight among the techniques of its length.
//!
//! The numbers come from three sampler streams (`Sampler::start_stream`): 0 the camera walk
//! (continuing whatever the caller read from stream 0 before, e.g. the technique and the raster
//! position), 1 the light walk, 2 the connection (next-event estimation's light sample), so
//! that a primary-sample mutation that changes one walk's length does not shift the others'
//! numbers.
//!
//! [`Tracer::unconnectible_emission`] is the s = 0 technique on the paths no connection makes
//! (`walk::unconnectible`: a light seen through mirrors and glass, E S* L, and caustics seen
//! through them, E S+ D S+ L), all lengths at once from one camera walk, for `mmlt`'s
//! per-pixel estimate of the paths its chains leave out ([`Tracer::camera_unconnectible`]).

use super::cache::cache_subpath;
use super::{Tracer, light_nee, walk};
use crate::math::{Sampler, Spectrum};
use glam::Vec2;

/// Sampler streams of [`Tracer::sample_technique`].
pub const TECHNIQUE_STREAMS: u32 = 3;

impl<'a> Tracer<'a> {
    /// Technique (s, t) alone: its MIS-weighted estimate (the weight of technique s among
    /// all techniques of path length s + t − 1) and the raster position it lands at, which is
    /// `raster` unless t = 1 (the connection to the pinhole decides). `None` when a subpath
    /// ends early or the technique finds nothing. The camera walk reads stream 0 from where
    /// the caller left it.
    pub fn sample_technique(
        &mut self,
        raster: Vec2,
        s: usize,
        t: usize,
        sampler: &mut impl Sampler,
    ) -> Option<(Vec2, Spectrum)> {
        let (scene, st) = (self.scene, self.settings);
        let k = (s + t).checked_sub(1)?;
        if t == 0 || k == 0 || k > st.max_depth as usize {
            return None;
        }
        self.pixel = scene.camera.pixel_index(raster) as u32;
        let mut camera = std::mem::take(&mut self.camera);
        let mut light = std::mem::take(&mut self.light);
        let mut cc = std::mem::take(&mut self.camera_cache);
        let mut lc = std::mem::take(&mut self.light_cache);
        walk::camera_subpath(scene, raster, t, st.rr_depth, sampler, &mut camera);
        sampler.start_stream(1);
        light.clear();
        if s >= 2 || (s == 1 && t == 1) {
            walk::light_subpath(scene, s, st.rr_depth, sampler, &mut light);
        }
        sampler.start_stream(2);
        let out = if camera.len() != t || (s != 1 || t == 1) && light.len() != s {
            None
        } else {
            cache_subpath(scene, &camera, st.rr_depth, &mut cc);
            cache_subpath(scene, &light, st.rr_depth, &mut lc);
            self.light_nee = light_nee(scene, &light);
            if s == 0 {
                Some((raster, self.hit_emitter(&camera, &cc, None)))
            } else if t == 1 {
                self.connect_camera(&camera, &cc, &light, &lc)
            } else if s == 1 {
                Some((raster, self.next_event(&camera, &cc, sampler)))
            } else {
                Some((raster, self.connect(&camera, &cc, &light, &lc)))
            }
        };
        self.camera = camera;
        self.light = light;
        self.camera_cache = cc;
        self.light_cache = lc;
        out.filter(|(_, c)| *c != Spectrum::ZERO)
    }

    /// Whether the camera subpath of the last [`Tracer::sample_technique`], ending on a light
    /// (s = 0), makes a path that no connection makes (`walk::unconnectible`).
    pub fn camera_unconnectible(&self) -> bool {
        walk::unconnectible(&self.camera)
    }

    /// The s = 0 technique's MIS-weighted estimate, summed over every length up to
    /// `max_depth`, of the paths through `raster` that no connection makes
    /// (`walk::unconnectible`): one camera walk that stops where two consecutive vertices
    /// are off delta surfaces, with the emission found at each of its vertices that ends
    /// such a path weighed as [`Tracer::sample_technique`] weighs s = 0 (so this and the techniques
    /// `sample_technique` gives on all other paths add up to BDPT's estimate). Like
    /// `sample_technique`, it weighs with the explicit densities, so the settings must play
    /// no roulette along the subpath (`mmlt_bdpt_settings`: rr_depth = max_depth + 1).
    pub fn unconnectible_emission(&mut self, raster: Vec2, sampler: &mut impl Sampler) -> Spectrum {
        let (scene, st) = (self.scene, self.settings);
        let mut camera = std::mem::take(&mut self.camera);
        let mut cc = std::mem::take(&mut self.camera_cache);
        let max_vertices = st.max_depth as usize + 1;
        walk::camera_unconnectible_subpath(
            scene,
            raster,
            max_vertices,
            st.rr_depth,
            sampler,
            &mut camera,
        );
        self.light.clear();
        self.light_nee = light_nee(scene, &self.light);
        cache_subpath(scene, &camera, st.rr_depth, &mut cc);
        let mut sum = Spectrum::ZERO;
        for t in 2..=camera.len() {
            if walk::unconnectible(&camera[..t]) {
                sum += self.hit_emitter(&camera[..t], &cc[..t], None);
            }
        }
        self.camera = camera;
        self.camera_cache = cc;
        sum
    }
}
