//! Environment map: radiance at infinity from a latitude-longitude image (Mitsuba's `envmap`),
//! importance-sampled by a piecewise-constant 2D distribution over the image's cells.
//!
//! **Conventions (Mitsuba 3's).** A local direction `v` (the escaping ray's direction taken
//! into the map's frame, `to_world^-1 w`) has texture coordinates `u = atan2(v.x, -v.z) /
//! (2 pi)`, `v = acos(v.y) / pi`: `+y` is the zenith (the image's top row), the image's
//! centre column (`u = 1/2`) looks along `+z` and its left and right edges along `-z`.
//! The radiance is the bilinear interpolation of the pixels (times `scale`), with pixel
//! column `i` at `u = (i + 1/2) / W` (wrapping around) and pixel row `j` at `v = j / (H - 1)`
//! (the first row on the zenith, the last on the nadir), as Mitsuba 3 evaluates it.
//!
//! **Sampling.** The `W x (H - 1)` cells between those pixel centres get the weight of their
//! four corners' mean luminance times `sin(theta)` at the cell's centre: a cell whose corners
//! are all black has radiance 0 everywhere, every other cell a positive weight. A row is drawn
//! from the rows' marginal, a cell from the row's conditional, a point uniformly in the cell;
//! the solid-angle density is `p(cell) W (H - 1) / (2 pi^2 sin(theta))`.
//!
//! Emission sampling (light tracing) draws the direction the same way and the origin
//! uniformly on a disk of the scene's bounding-sphere radius facing it, like the constant
//! environment.

use super::cone::disk_origin;
use super::{EmissionSample, LightSample};
use crate::math::{Distribution1D, PI, Spectrum, luminance};
use glam::{Mat3, Vec2, Vec3};
use std::sync::Arc;

/// An environment map light.
#[derive(Debug, Clone)]
pub struct EnvMapLight {
    map: Arc<Map>,
    /// The map's frame: local directions to world directions (a rotation).
    to_world: Mat3,
    to_local: Mat3,
    /// Bounding sphere of the scene (set when the scene is built).
    pub center: Vec3,
    /// Radius of the scene's bounding sphere.
    pub radius: f32,
}

/// The pixels (with their scale) and the sampling distribution.
#[derive(Debug)]
struct Map {
    /// `W + 1` columns by `H` rows, row-major; column `W` repeats column 0 (the wrap).
    data: Vec<Spectrum>,
    width: usize,
    height: usize,
    /// Marginal over the `H - 1` rows of cells, and each row's conditional over its `W` cells.
    rows: Distribution1D,
    cells: Vec<Distribution1D>,
    /// `∫ luminance(L) dω` over the sphere.
    luminance_integral: f64,
}

impl EnvMapLight {
    /// A map of `width x height` linear RGB `pixels` (row-major, the top row first), scaled
    /// by `scale`, in the frame `to_world` (a rotation). At least 2 x 3 pixels, as Mitsuba
    /// requires; pixels must be finite and non-negative.
    pub fn new(
        pixels: &[Spectrum],
        width: usize,
        height: usize,
        scale: f32,
        to_world: Mat3,
    ) -> Result<EnvMapLight, String> {
        if width < 2 || height < 3 || pixels.len() != width * height {
            return Err(format!(
                "an environment map needs at least 2 x 3 pixels, got {width} x {height}"
            ));
        }
        if let Some(p) = pixels
            .iter()
            .find(|p| !(p.is_finite() && p.min_element() >= 0.0))
        {
            return Err(format!(
                "environment map pixels must be finite and >= 0, found {p}"
            ));
        }
        let (w, h) = (width, height);
        let mut data = Vec::with_capacity((w + 1) * h);
        for row in pixels.chunks(w) {
            data.extend(row.iter().map(|&p| p * scale));
            data.push(row[0] * scale);
        }
        let at = |x: usize, y: usize| luminance(data[y * (w + 1) + x]) as f64;
        let mut row_weights = Vec::with_capacity(h - 1);
        let mut cells = Vec::with_capacity(h - 1);
        let mut integral = 0.0f64;
        for y in 0..h - 1 {
            let sin_theta = (PI as f64 * (y as f64 + 0.5) / (h - 1) as f64).sin();
            let weights: Vec<f32> = (0..w)
                .map(|x| {
                    let mean = (at(x, y) + at(x + 1, y) + at(x, y + 1) + at(x + 1, y + 1)) / 4.0;
                    (mean * sin_theta) as f32
                })
                .collect();
            let sum: f64 = weights.iter().map(|&x| x as f64).sum();
            integral += sum;
            row_weights.push(sum as f32);
            cells.push(Distribution1D::new(&weights));
        }
        // Each cell spans 2 pi^2 / (W (H - 1)) of (phi, theta) area.
        let luminance_integral = integral * 2.0 * (PI as f64).powi(2) / (w * (h - 1)) as f64;
        let to_local = to_world.transpose();
        Ok(EnvMapLight {
            map: Arc::new(Map {
                data,
                width: w,
                height: h,
                rows: Distribution1D::new(&row_weights),
                cells,
                luminance_integral,
            }),
            to_world,
            to_local,
            center: Vec3::ZERO,
            radius: 1.0,
        })
    }

    /// `pi R^2 ∫ luminance(L) dω`: the flux through the scene's bounding disk.
    pub fn power(&self) -> f32 {
        (PI as f64 * (self.radius as f64).powi(2) * self.map.luminance_integral) as f32
    }

    /// Half a pixel's width in `u`: where column 0's centre is.
    fn half_texel(&self) -> f32 {
        0.5 / self.map.width as f32
    }

    /// Radiance arriving from world direction `w` (towards the sky).
    pub fn le(&self, w: Vec3) -> Spectrum {
        let uv = direction_to_uv(self.to_local * w);
        self.radiance(uv)
    }

    /// The bilinear interpolation at texture coordinates `uv`.
    fn radiance(&self, uv: Vec2) -> Spectrum {
        let m = &*self.map;
        let (w, h) = (m.width, m.height);
        let mut u = uv.x - self.half_texel();
        u -= u.floor();
        let x = u * w as f32;
        let y = uv.y.clamp(0.0, 1.0) * (h - 1) as f32;
        let (ix, iy) = ((x as usize).min(w - 1), (y as usize).min(h - 2));
        let (fx, fy) = (x - ix as f32, y - iy as f32);
        let at = |x: usize, y: usize| m.data[y * (w + 1) + x];
        let top = at(ix, iy) * (1.0 - fx) + at(ix + 1, iy) * fx;
        let bottom = at(ix, iy + 1) * (1.0 - fx) + at(ix + 1, iy + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// A direction towards the sky drawn by the map's distribution.
    pub fn sample_li(&self, u: Vec2) -> Option<LightSample> {
        let m = &*self.map;
        let (row, p_row, v_in) = m.rows.sample(u.y);
        let (col, p_col, u_in) = m.cells[row].sample(u.x);
        if p_row * p_col <= 0.0 {
            return None;
        }
        let uv = Vec2::new(
            (col as f32 + u_in) / m.width as f32 + self.half_texel(),
            (row as f32 + v_in) / (m.height - 1) as f32,
        );
        let (local, sin_theta) = uv_to_direction(uv);
        if sin_theta <= 0.0 {
            return None;
        }
        let wi = (self.to_world * local).normalize();
        // The density `pdf_li` gives the direction (the cell's `p` unless rounding moved it
        // across a cell boundary, a set of measure zero), so that both always agree.
        let pdf = self.pdf_li(wi);
        let li = self.le(wi);
        if !(pdf.is_finite() && pdf > 0.0) || li == Spectrum::ZERO {
            return None;
        }
        Some(LightSample {
            wi,
            dist: f32::INFINITY,
            p: Vec3::ZERO,
            n: Vec3::ZERO,
            li,
            pdf,
            delta: false,
        })
    }

    /// Solid-angle density of [`Self::sample_li`] choosing world direction `wi`.
    pub fn pdf_li(&self, wi: Vec3) -> f32 {
        let m = &*self.map;
        let v = self.to_local * wi;
        let sin_theta = (v.x * v.x + v.z * v.z).sqrt();
        if sin_theta <= 0.0 {
            return 0.0;
        }
        let uv = direction_to_uv(v);
        let mut u = uv.x - self.half_texel();
        u -= u.floor();
        let col = ((u * m.width as f32) as usize).min(m.width - 1);
        let row = ((uv.y * (m.height - 1) as f32) as usize).min(m.height - 2);
        let p = m.rows.pmf(row) * m.cells[row].pmf(col);
        p * (m.width * (m.height - 1)) as f32 / (2.0 * PI * PI * sin_theta)
    }

    /// An emitted ray: a direction by the map's distribution (by `u_dir`), its origin uniform
    /// on the bounding disk facing it (by `u_pos`).
    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2) -> Option<EmissionSample> {
        let s = self.sample_li(u_dir)?;
        let w = s.wi;
        Some(EmissionSample {
            p: disk_origin(self.center, self.radius, w, u_pos),
            n: -w,
            dir: -w,
            le: s.li,
            pdf_pos: 1.0 / (PI * self.radius * self.radius),
            pdf_dir: s.pdf,
        })
    }

    /// (area density of the origin, solid-angle density of the direction of travel `dir`)
    /// of [`Self::sample_le`].
    pub fn pdf_le(&self, dir: Vec3) -> (f32, f32) {
        (1.0 / (PI * self.radius * self.radius), self.pdf_li(-dir))
    }
}

/// Texture coordinates of a local direction (Mitsuba's latitude-longitude mapping).
fn direction_to_uv(v: Vec3) -> Vec2 {
    let u = v.x.atan2(-v.z) / (2.0 * PI);
    Vec2::new(u - u.floor(), v.y.clamp(-1.0, 1.0).acos() / PI)
}

/// The local direction of texture coordinates `uv`, and its `sin(theta)`.
fn uv_to_direction(uv: Vec2) -> (Vec3, f32) {
    let (theta, phi) = (uv.y * PI, uv.x * 2.0 * PI);
    let (sin_t, cos_t) = theta.sin_cos();
    let (sin_p, cos_p) = phi.sin_cos();
    (Vec3::new(sin_p * sin_t, cos_t, -cos_p * sin_t), sin_t)
}
