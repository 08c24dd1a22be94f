//! The pinhole camera: ray generation, importance `We`, its densities and the world-to-raster
//! mapping.
//!
//! The image plane sits at distance 1 in front of the pinhole and has area `A_img`
//! (`2 tan(fov/2)` high). Raster coordinates run from (0, 0) at the top-left corner to
//! (width, height); pixel (x, y) covers [x, x+1) x [y, y+1).
//!
//! Densities are image-wide (DESIGN.md §3): a camera ray through a point chosen uniformly on the
//! whole image has solid-angle density `pdf_we = 1 / (A_img cos^3 theta)`, and the importance
//! is `We = 1 / (A_img cos^4 theta)`, so that `We cos / pdf_we = 1` for every camera ray and a
//! path traced from pixel j averages to pixel j's measurement when multiplied by `N_pix`.
//! The pinhole's position is a delta (its area density is a discrete 1).
//!
//! The pixel filter (`filter.rs`) decides where a pixel's samples look: [`Camera::generate_ray`]
//! moves a sample from its pixel to the filter's position, cut at the image's edges as
//! Mitsuba does; splats reach the pixels around them by the filter, renormalised the same way
//! ([`Camera::splat_pixel`]). The image-wide mapping and densities extend over a margin of
//! [`Filter::margin`] around the image (the same `We` and `pdf_we` formulas) that no sample
//! counts in. With [`Camera::splat_samples`] (`--film splatted`) camera rays go through their
//! raster position itself and the pass driver spreads each sample over the pixels its filter
//! covers instead (`render::render_rows`).

use crate::filter::Filter;
use crate::geometry::Ray;
use crate::math::Sampler;
use glam::{UVec2, Vec2, Vec3};

/// A pinhole camera: its frame in world space, resolution and field of view.
#[derive(Debug, Clone)]
pub struct Camera {
    /// The pinhole, in world space.
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit vectors spanning the image plane (right, and up in the image).
    pub right: Vec3,
    /// Unit up direction of the image, orthogonal to `forward` and `right`.
    pub up: Vec3,
    /// Image size in pixels (width, height).
    pub resolution: UVec2,
    /// Half the image plane's height and width at distance 1.
    half_h: f32,
    half_w: f32,
    /// Vertical field of view, in degrees.
    pub fov_y_degrees: f32,
    /// The pixel filter (box by default).
    pub filter: Filter,
    /// Whether camera samples are splatted into every pixel their filter covers, each pixel
    /// dividing by the sum of its weights (Mitsuba's film, `--film splatted`: consistent, less
    /// noise per sample), rather than each counting for the one pixel whose filter it was
    /// drawn from (the default: unbiased). Only integrators whose registry entry says so
    /// render with it (`integrators::Entry::splat_film`).
    pub splat_samples: bool,
}

/// A connection from a scene point to the camera (light tracing, BDPT t = 1).
#[derive(Debug, Clone, Copy)]
pub struct CameraSample {
    /// Unit direction from the scene point towards the pinhole.
    pub wi: Vec3,
    /// Distance from the scene point to the pinhole.
    pub dist: f32,
    /// Where the ray through the point crosses the image, in raster coordinates.
    pub raster: Vec2,
    /// `We` of the ray from the pinhole towards the point.
    pub we: f32,
    /// Solid-angle density (image-wide) of the camera generating that ray.
    pub pdf_we: f32,
}

impl Camera {
    /// `fov_y_degrees` in (0, 180); `up` must not be parallel to the viewing direction
    /// (the scene loader checks both).
    pub fn new(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        fov_y_degrees: f32,
        resolution: UVec2,
    ) -> Camera {
        let forward = (look_at - position).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let half_h = (0.5 * fov_y_degrees.to_radians()).tan();
        let half_w = half_h * resolution.x as f32 / resolution.y as f32;
        Camera {
            position,
            forward,
            right,
            up,
            resolution,
            half_h,
            half_w,
            fov_y_degrees,
            filter: Filter::default(),
            splat_samples: false,
        }
    }

    /// The same camera with pixel filter `filter`.
    pub fn with_filter(self, filter: Filter) -> Camera {
        Camera { filter, ..self }
    }

    /// Number of pixels, width times height.
    pub fn pixel_count(&self) -> usize {
        (self.resolution.x * self.resolution.y) as usize
    }

    /// Height of one pixel on the image plane at distance 1: a pixel's footprint at distance
    /// `d` along the view is about `d * pixel_angle()` (the guider sizes its kernels with it).
    pub fn pixel_angle(&self) -> f32 {
        2.0 * self.half_h / self.resolution.y as f32
    }

    /// Area of the image plane at distance 1.
    pub fn image_area(&self) -> f32 {
        4.0 * self.half_w * self.half_h
    }

    /// The ray of a camera sample at raster position `raster`, which counts for the pixel
    /// holding it: through `raster` itself for the box filter (and with
    /// [`Camera::splat_samples`]), else through the pixel's centre moved by the filter sampled
    /// with `raster`'s place in the pixel.
    pub fn generate_ray(&self, raster: Vec2) -> Ray {
        if self.filter.is_box() || self.splat_samples {
            return self.ray_through(raster);
        }
        let pixel = raster.floor();
        let u = (raster - pixel).clamp(Vec2::ZERO, Vec2::splat(1.0 - f32::EPSILON));
        let c = pixel + 0.5;
        let res = self.resolution.as_vec2();
        // The filter cut at the image's edges (module doc of `filter.rs`).
        let d = Vec2::new(
            self.filter
                .sample_1d_within(u.x as f64, -c.x as f64, (res.x - c.x) as f64) as f32,
            self.filter
                .sample_1d_within(u.y as f64, -c.y as f64, (res.y - c.y) as f64) as f32,
        );
        self.ray_through(c + d)
    }

    /// Whether camera samples are spread over the pixels around them
    /// ([`Camera::splat_samples`] with a filter wider than the pixel).
    pub fn splats_samples(&self) -> bool {
        self.splat_samples && !self.filter.is_box()
    }

    /// The part of pixel (x, y)'s filter inside the image, `N_c` (`filter.rs`).
    fn filter_mass(&self, x: i64, y: i64) -> f64 {
        let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
        let (w, h) = (self.resolution.x as f64, self.resolution.y as f64);
        self.filter.mass_1d(-cx, w - cx) * self.filter.mass_1d(-cy, h - cy)
    }

    /// The ray through raster position `raster` (no filter).
    pub fn ray_through(&self, raster: Vec2) -> Ray {
        let ndc_x = 2.0 * raster.x / self.resolution.x as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * raster.y / self.resolution.y as f32;
        let d = self.forward + self.right * (ndc_x * self.half_w) + self.up * (ndc_y * self.half_h);
        Ray::new(self.position, d.normalize())
    }

    /// Raster position of the ray from the pinhole along unit `d`, if it is on the image or
    /// within the filter's margin around it.
    #[inline]
    pub fn raster_of_direction(&self, d: Vec3) -> Option<Vec2> {
        let cos = d.dot(self.forward);
        if cos <= 0.0 {
            return None;
        }
        let m = self.filter.margin();
        let (w, h) = (self.resolution.x as f32, self.resolution.y as f32);
        let (mx, my) = (1.0 + 2.0 * m / w, 1.0 + 2.0 * m / h);
        let x = d.dot(self.right) / (cos * self.half_w);
        let y = d.dot(self.up) / (cos * self.half_h);
        if !(-mx..mx).contains(&x) || !(-my..my).contains(&y) {
            return None;
        }
        let r = Vec2::new((x + 1.0) * 0.5 * w, (1.0 - y) * 0.5 * h);
        // Guard the upper edge against rounding.
        (r.x < w + m && r.y < h + m && r.x >= -m && r.y >= -m).then_some(r)
    }

    /// Raster position of world point `p`, if it projects onto the image.
    pub fn world_to_raster(&self, p: Vec3) -> Option<Vec2> {
        let d = p - self.position;
        let len = d.length();
        if len == 0.0 {
            return None;
        }
        self.raster_of_direction(d / len)
    }

    /// Raster position of pixel (x, y) jittered by `u` in [0, 1)²: always inside the pixel
    /// (`pixel_index` gives (x, y) back), also where the f32 sum x + u would round up to the
    /// next pixel's edge (from x = 4 on, u within half an ulp of 1).
    pub fn jittered(x: u32, y: u32, u: Vec2) -> Vec2 {
        let below = |i: u32| f32::from_bits((i as f32 + 1.0).to_bits() - 1);
        (Vec2::new(x as f32, y as f32) + u).min(Vec2::new(below(x), below(y)))
    }

    /// Row-major index of the pixel holding raster position `raster` (clamped to the image).
    pub fn pixel_index(&self, raster: Vec2) -> usize {
        let x = (raster.x as u32).min(self.resolution.x - 1);
        let y = (raster.y as u32).min(self.resolution.y - 1);
        (y * self.resolution.x + x) as usize
    }

    /// The pixel a splat at raster position `raster` goes to and its weight
    /// (`Filter::pick`, `u` in [0, 1), divided by the pixel's filter mass on the image), or
    /// `None` when `raster` or that pixel is off the image. For the box filter, the pixel
    /// holding `raster` with weight 1.
    pub fn splat_pixel(&self, raster: Vec2, u: f32) -> Option<(usize, f32)> {
        if self.filter.is_box() {
            return Some((self.pixel_index(raster), 1.0));
        }
        let res = self.resolution;
        if !(raster.x >= 0.0
            && raster.y >= 0.0
            && raster.x < res.x as f32
            && raster.y < res.y as f32)
        {
            return None;
        }
        let ((x, y), w) = self.filter.pick(raster, u)?;
        ((0..res.x as i64).contains(&x) && (0..res.y as i64).contains(&y)).then(|| {
            let n = self.filter_mass(x, y);
            ((y as u32 * res.x + x as u32) as usize, (w / n) as f32)
        })
    }

    /// The number [`Camera::splat_pixel`] needs: none for the box filter (0 without reading
    /// the sampler, so box renders keep their random streams), else the sampler's next.
    pub fn splat_number(&self, sampler: &mut impl Sampler) -> f32 {
        if self.filter.is_box() {
            0.0
        } else {
            sampler.next_1d()
        }
    }

    /// Importance `We` of the ray leaving the pinhole along unit `d` (0 off the image).
    pub fn we(&self, d: Vec3) -> f32 {
        if self.raster_of_direction(d).is_none() {
            return 0.0;
        }
        let cos = d.dot(self.forward);
        1.0 / (self.image_area() * cos * cos * cos * cos)
    }

    /// Image-wide solid-angle density of generating the ray along unit `d` (0 off the image).
    pub fn pdf_we(&self, d: Vec3) -> f32 {
        if self.raster_of_direction(d).is_none() {
            return 0.0;
        }
        let cos = d.dot(self.forward);
        1.0 / (self.image_area() * cos * cos * cos)
    }

    /// Connect scene point `p` to the pinhole.
    pub fn sample_wi(&self, p: Vec3) -> Option<CameraSample> {
        let v = self.position - p;
        let dist = v.length();
        if dist == 0.0 {
            return None;
        }
        let wi = v / dist;
        let raster = self.raster_of_direction(-wi)?;
        Some(CameraSample {
            wi,
            dist,
            raster,
            we: self.we(-wi),
            pdf_we: self.pdf_we(-wi),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera::new(
            Vec3::new(0.0, 0.0, 3.9),
            Vec3::ZERO,
            Vec3::Y,
            39.3077,
            UVec2::new(320, 240),
        )
    }

    #[test]
    fn raster_round_trip() {
        let c = cam();
        for raster in [
            Vec2::new(0.5, 0.5),
            Vec2::new(160.0, 120.0),
            Vec2::new(319.5, 10.25),
        ] {
            let r = c.generate_ray(raster);
            let back = c.raster_of_direction(r.d).unwrap();
            assert!((back - raster).length() < 1e-3, "{raster} -> {back}");
            let p = r.at(2.5);
            assert!((c.world_to_raster(p).unwrap() - raster).length() < 1e-3);
        }
        assert!(c.world_to_raster(Vec3::new(0.0, 0.0, 10.0)).is_none());
    }

    /// A jittered raster position stays in its pixel where the plain f32 sum x + u rounds to
    /// the next pixel's edge (u = 1 - 2^-24 from x = 4 on), and moves nothing elsewhere.
    #[test]
    fn jittered_positions_stay_in_their_pixel() {
        let c = cam();
        let u = Vec2::splat(1.0 - f32::EPSILON / 2.0);
        assert_eq!(
            (239.0f32 + u.y) as u32,
            240,
            "the case the jitter guards against"
        );
        for (x, y) in [(0, 0), (5, 7), (200, 100), (319, 239)] {
            let r = Camera::jittered(x, y, u);
            assert_eq!(
                c.pixel_index(r),
                (y * 320 + x) as usize,
                "({x}, {y}) -> {r}"
            );
            let v = Vec2::new(0.25, 0.75);
            assert_eq!(Camera::jittered(x, y, v), Vec2::new(x as f32, y as f32) + v);
        }
    }

    /// The image-wide pdf integrates to one over the directions through the image.
    #[test]
    fn pdf_we_integrates_to_one() {
        let c = cam();
        let n = 400;
        let mut sum = 0.0f64;
        // Integrate over the image plane: dw = cos^3 dA.
        let (w, h) = (2.0 * c.half_w, 2.0 * c.half_h);
        for i in 0..n {
            for j in 0..n {
                let x = -c.half_w + (i as f32 + 0.5) / n as f32 * w;
                let y = -c.half_h + (j as f32 + 0.5) / n as f32 * h;
                let d = (c.forward + c.right * x + c.up * y).normalize();
                let cos = d.dot(c.forward);
                sum += (c.pdf_we(d) * cos * cos * cos) as f64 * (w * h) as f64 / (n * n) as f64;
            }
        }
        assert!((sum - 1.0).abs() < 1e-3, "{sum}");
        let d = c.generate_ray(Vec2::new(12.0, 200.0)).d;
        assert!((c.we(d) * d.dot(c.forward) / c.pdf_we(d) - 1.0).abs() < 1e-5);
    }
}
