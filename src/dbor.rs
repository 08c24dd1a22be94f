//! Firefly re-weighting by a framebuffer cascade (Zirr, Hanika, Dachsbacher 2018), the
//! `--dbor` image.
//!
//! Every sample value `v` (luminance of an RGB contribution to a pixel) is split between the
//! two adjacent layers of a cascade with scales `s_i = s_0 b^i` (b = 8, s_0 = 1, 6 layers):
//! `w_lo = (s_i / v − 1/b) / (1 − 1/b)` of it goes to layer i and the rest to layer i + 1, so
//! that the sample counts exactly once over the two layers (`w_lo v / s_i + w_hi v / s_{i+1}
//! = 1`); values below s_0 go to layer 0, values beyond the top scale to the top layer. The
//! plain sum of the layers is the unbiased image. The re-weighted image composes the layers
//! from the bottom up, `P_i = P_{i−1} + ρ_i L_i`, where the reliability ρ_i of a layer at a
//! pixel grows with the number of similar samples there (3 x 3 neighbourhood, κ = 32 samples
//! for full trust) and with the brightness already established by the lower layers. It is
//! biased (fireflies are damped) and converges to the unbiased image as samples accumulate.

use crate::film::Image;
use crate::math::{Spectrum, luminance};
use glam::{DVec3, Vec3};

/// Number of layers of the cascade.
pub const LAYERS: usize = 6;
/// Ratio b of the scales of adjacent layers.
pub const BASE: f64 = 8.0;
/// Similar samples κ in a pixel's 3 x 3 neighbourhood for a layer's full trust.
pub const KAPPA: f64 = 32.0;

/// Per-pixel sums of the sample shares of each layer.
#[derive(Debug, Clone)]
pub struct Cascade {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Per pixel (row-major), the RGB sums of each layer.
    pub layers: Vec<[DVec3; LAYERS]>,
}

/// The layers and value shares of a sample of luminance `v`: (layer, share) pairs, shares
/// adding to 1.
pub fn value_shares(v: f64) -> [(usize, f64); 2] {
    if v.is_nan() || v <= 1.0 {
        return [(0, 1.0), (0, 0.0)];
    }
    let i = (v.ln() / BASE.ln()).floor() as usize;
    if i >= LAYERS - 1 {
        return [(LAYERS - 1, 1.0), (LAYERS - 1, 0.0)];
    }
    let s = BASE.powi(i as i32);
    let w_lo = ((s / v - 1.0 / BASE) / (1.0 - 1.0 / BASE)).clamp(0.0, 1.0);
    [(i, w_lo), (i + 1, 1.0 - w_lo)]
}

impl Cascade {
    /// An empty cascade for an image of `width` x `height` pixels.
    pub fn new(width: u32, height: u32) -> Cascade {
        Cascade {
            width,
            height,
            layers: vec![[DVec3::ZERO; LAYERS]; (width * height) as usize],
        }
    }

    /// Add one sample's RGB value to a pixel's layers.
    pub fn splat_into(cell: &mut [DVec3; LAYERS], value: Spectrum) {
        let v = value.as_dvec3();
        for (layer, share) in value_shares(luminance(value) as f64) {
            if share > 0.0 {
                cell[layer] += v * share;
            }
        }
    }

    /// Add one sample's RGB value to pixel `pixel`'s layers.
    pub fn add(&mut self, pixel: u32, value: Spectrum) {
        Self::splat_into(&mut self.layers[pixel as usize], value);
    }

    /// Rows of cells, for accumulation in parallel with the film's rows.
    pub fn rows_mut(&mut self) -> std::slice::ChunksMut<'_, [DVec3; LAYERS]> {
        self.layers.chunks_mut(self.width as usize)
    }

    /// The unbiased image: the plain sum of the layers over `samples` samples per pixel.
    pub fn sum_image(&self, samples: f64) -> Image {
        let mut img = Image::new(self.width, self.height);
        for (p, cell) in img.pixels.iter_mut().zip(&self.layers) {
            *p = (cell.iter().sum::<DVec3>() / samples).as_vec3();
        }
        img
    }

    /// Zirr et al.'s re-weighted image after `samples` samples per pixel.
    pub fn reweighted(&self, samples: f64) -> Image {
        let (w, h) = (self.width as i64, self.height as i64);
        let mean =
            |x: i64, y: i64, l: usize| -> DVec3 { self.layers[(y * w + x) as usize][l] / samples };
        // Mean of layer l over the (2r + 1)^2 neighbourhood (clamped at the border).
        let avg = |x: i64, y: i64, l: usize, r: i64| -> DVec3 {
            let mut s = DVec3::ZERO;
            let mut n = 0.0;
            for dy in -r..=r {
                for dx in -r..=r {
                    let (xx, yy) = (x + dx, y + dy);
                    if (0..w).contains(&xx) && (0..h).contains(&yy) {
                        s += mean(xx, yy, l);
                        n += 1.0;
                    }
                }
            }
            s / n
        };
        let lum = |c: DVec3| luminance(Vec3::new(c.x as f32, c.y as f32, c.z as f32)) as f64;
        let scale = |l: usize| BASE.powi(l as i32);
        let m = 1.0 + 0.6 * (BASE - 1.0) + (1.0 - (1.0 + 0.6 * (BASE - 1.0))) * (1.0 / KAPPA);
        let mut img = Image::new(self.width, self.height);
        for y in 0..h {
            for x in 0..w {
                let mut p = mean(x, y, 0);
                for i in 1..LAYERS {
                    let count = |r: i64| -> f64 {
                        let mut c = DVec3::ZERO;
                        for j in i - 1..=(i + 1).min(LAYERS - 1) {
                            c += avg(x, y, j, r) * (samples / (KAPPA * scale(j)));
                        }
                        lum(c)
                    };
                    let mut rel = count(1) - 1.0 / KAPPA;
                    if rel >= 0.0 {
                        rel = count(0) - 1.0 / KAPPA;
                    }
                    let col = lum(p).max(0.05) * samples / (KAPPA * scale(i)) * m;
                    let rho = ((rel + col) / 2.0).clamp(0.0, 1.0);
                    p += mean(x, y, i) * rho;
                }
                img.pixels[(y * w + x) as usize] = p.as_vec3();
            }
        }
        img
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_sample_counts_once_and_the_layers_sum_to_the_value() {
        for v in [0.0, 0.5, 1.0, 1.5, 7.9, 8.0, 60.0, 4095.0, 1e9] {
            let s = value_shares(v);
            assert!((s[0].1 + s[1].1 - 1.0).abs() < 1e-12);
            if v > 1.0 && v < BASE.powi(LAYERS as i32 - 1) {
                let count =
                    s[0].1 * v / BASE.powi(s[0].0 as i32) + s[1].1 * v / BASE.powi(s[1].0 as i32);
                assert!((count - 1.0).abs() < 1e-12, "{v}: {count}");
            }
        }
        let mut c = Cascade::new(2, 1);
        c.add(0, Vec3::splat(0.3));
        c.add(0, Vec3::splat(100.0));
        c.add(1, Vec3::new(3.0, 1.0, 0.5));
        let img = c.sum_image(1.0);
        assert!((img.pixels[0] - Vec3::splat(100.3)).abs().max_element() < 1e-4);
        assert!(
            (img.pixels[1] - Vec3::new(3.0, 1.0, 0.5))
                .abs()
                .max_element()
                < 1e-6
        );
    }

    /// A lone firefly among dim samples is damped; a well-sampled bright pixel is kept.
    #[test]
    fn reweighting_damps_a_lone_firefly_only() {
        let mut c = Cascade::new(5, 5);
        let spp = 64;
        for p in 0..25u32 {
            for _ in 0..spp {
                c.add(p, Vec3::splat(0.5));
            }
        }
        c.add(12, Vec3::splat(5000.0));
        let img = c.reweighted(spp as f64);
        let sum = c.sum_image(spp as f64);
        assert!(sum.pixels[12].x > 70.0);
        assert!(img.pixels[12].x < 5.0, "{}", img.pixels[12].x);
        assert!((img.pixels[0].x - 0.5).abs() < 1e-6);
    }
}
