//! Which pixels an emitter fills: the pixels whose every ray of a 3 x 3 grid over the closed
//! pixel square (its corners, its sides' midpoints and its centre) meets, first, an emitter
//! the camera can hit (an area light with radiance towards the pinhole). With the corners
//! tested, an emitter's straight edge (or an occluder's) can only cut a pixel it fills at a
//! corner region between two test rays, not along a side. BDPT-family
//! integrators leave a directly seen emitter to the camera ray in such pixels
//! (`integrators/paths/terms.rs`), where the camera's one sample per pixel is exact up to the
//! emitter's radiance varying across the pixel, and keep the light tracer's splats at the
//! emitter's edges, where a pixel's camera samples hit or miss and the splats' density is the
//! smoother estimate.
//!
//! A pure function of the scene, computed on first use (once, whichever thread asks), so the
//! images do not depend on the number of threads. Cost: one ray per pixel, nine for pixels
//! whose centre sees an emitter.

use super::Scene;
use glam::Vec2;
use rayon::prelude::*;

/// Rays per pixel side of the test grid.
const GRID: u32 = 3;

impl Scene {
    /// Whether an emitter fills pixel `pixel` (see the module doc).
    pub fn emitter_fills_pixel(&self, pixel: usize) -> bool {
        self.filled_pixels
            .get_or_init(|| self.find_filled_pixels())
            .get(pixel)
            .copied()
            .unwrap_or(false)
    }

    fn find_filled_pixels(&self) -> Vec<bool> {
        let res = self.camera.resolution;
        if !self.features.emissive_geometry {
            return vec![false; self.camera.pixel_count()];
        }
        let sees_emitter = |raster: Vec2| {
            let ray = self.camera.ray_through(raster);
            self.intersect(&ray).is_some_and(|sp| {
                !sp.is_null()
                    && sp.light().is_some_and(|l| {
                        matches!(self.lights[l], crate::light::Light::Area(_))
                            && self.lights[l].le(sp.hit.p, sp.hit.ng, -ray.d)
                                != crate::math::Spectrum::ZERO
                    })
            })
        };
        (0..self.camera.pixel_count())
            .into_par_iter()
            .map(|i| {
                let corner = Vec2::new((i as u32 % res.x) as f32, (i as u32 / res.x) as f32);
                let at =
                    |a: u32, b: u32| corner + Vec2::new(a as f32, b as f32) / (GRID - 1) as f32;
                let centre = GRID / 2;
                sees_emitter(at(centre, centre))
                    && (0..GRID * GRID).all(|j| {
                        let (a, b) = (j % GRID, j / GRID);
                        (a, b) == (centre, centre) || sees_emitter(at(a, b))
                    })
            })
            .collect()
    }
}
