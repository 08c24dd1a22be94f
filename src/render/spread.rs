//! Camera samples splatted into the pixels their filter covers (`--film splatted`,
//! `Camera::splat_samples`): Mitsuba's film. Each sample at raster position `r` adds
//! `f(r - c) L` to pixel c and `f(r - c)` to its weight sum for every pixel whose filter
//! reaches it; the image divides each pixel by its weight sum (`Film::new_weighted`), so
//! border pixels, which fewer samples reach, are normalised by what they got. Consistent
//! (the ratio's bias falls as 1 / spp); a pixel averages the samples of its neighbours too,
//! which makes it much less noisy per sample than filter importance sampling.

use crate::film::Film;
use crate::math::Spectrum;
use glam::Vec2;
use rayon::prelude::*;

/// The film of a `w` x `h` render: weighted when camera samples are spread.
pub(super) fn film(w: u32, h: u32, spread: bool) -> Film {
    if spread {
        Film::new_weighted(w, h)
    } else {
        Film::new(w, h)
    }
}

/// A camera sample to spread over the pixels its filter covers, with its filter weights: the
/// `nx` columns from `x0` and the `ny` rows from `y0` (`weights[off..]`: columns, then rows).
/// Kept small (32 bytes): every film row within the filter's reach reads it again.
struct Spread {
    l: Spectrum,
    x0: u32,
    y0: u32,
    nx: u32,
    ny: u32,
    off: u32,
}

/// One row's camera samples to spread ([`spread_samples`]): each sample and its weights.
#[derive(Default)]
pub(super) struct SpreadRow {
    samples: Vec<Spread>,
    weights: Vec<f64>,
}

impl SpreadRow {
    /// Empties the row, keeping its memory.
    fn clear(&mut self) {
        self.samples.clear();
        self.weights.clear();
    }

    /// The sample at raster `r` of value `l` on a `w` x `h` film: its per-axis filter weights
    /// at the pixels within the filter's radius.
    pub(super) fn push(
        &mut self,
        filter: &crate::filter::Filter,
        (w, h): (usize, usize),
        r: Vec2,
        l: Spectrum,
    ) {
        let radius = filter.radius() as f64;
        let off = self.weights.len();
        let mut axis = |x: f64, n: usize| {
            let first = ((x - 0.5 - radius).ceil().max(0.0)) as usize;
            let last = ((x - 0.5 + radius).floor() as i64).min(n as i64 - 1);
            let mut count = 0;
            for i in first as i64..=last {
                self.weights.push(filter.eval_1d(x - (i as f64 + 0.5)));
                count += 1;
            }
            (first, count)
        };
        let (x0, nx) = axis(r.x as f64, w);
        let (y0, ny) = axis(r.y as f64, h);
        self.samples.push(Spread {
            l,
            x0: x0 as u32,
            y0: y0 as u32,
            nx: nx as u32,
            ny: ny as u32,
            off: off as u32,
        });
    }
}

/// Film rows per accumulation task: each task reads the samples of the rows its filter
/// reaches once for all of its rows (a sample header and its weights are read once per
/// block rather than once per film row).
const BLOCK: usize = 8;

/// Splat one pass's camera samples (`rows[y]`: row y's samples) into a weighted film: pixel c
/// gains `f(r - c) L` and weight `f(r - c)` from the sample at `r` for every pixel whose
/// filter reaches it (Mitsuba's film; `Camera::splat_samples`). One task per block of
/// [`BLOCK`] film rows, which takes the sample rows its filter reaches in order, so every
/// pixel adds its samples in the same order (sample row, then sample) whatever the number of
/// threads. The rows are emptied (their memory kept for the next pass): each sample counts
/// once.
pub(super) fn spread_samples(film: &mut Film, radius: f32, rows: &mut [SpreadRow]) {
    let (w, h) = (film.width as usize, film.height as usize);
    // A sample in row `yi` lies in [yi, yi + 1): it reaches pixel row y when
    // y - 1/2 - radius < yi < y + 1/2 + radius.
    let radius = radius as f64;
    let first_reaching = |y: usize| ((y as f64 - 0.5 - radius).floor() as i64 + 1).max(0) as usize;
    let last_reaching =
        |y: usize| (((y as f64 + 0.5 + radius).ceil() as i64) - 1).min(h as i64 - 1) as usize;
    film.par_weighted_blocks_mut(BLOCK)
        .enumerate()
        .for_each(|(b, (sums, weights))| {
            let (top, n) = (b * BLOCK, sums.len() / w);
            for row in &rows[first_reaching(top)..=last_reaching(top + n - 1)] {
                for s in &row.samples {
                    let (y0, ny) = (s.y0 as usize, s.ny as usize);
                    let (off, x0, nx) = (s.off as usize, s.x0 as usize, s.nx as usize);
                    let l = s.l.as_dvec3();
                    let wx = &row.weights[off..off + nx];
                    for y in y0.max(top)..(y0 + ny).min(top + n) {
                        let wy = row.weights[off + nx + (y - y0)];
                        let columns = (y - top) * w + x0..(y - top) * w + x0 + nx;
                        let pixels = sums[columns.clone()].iter_mut().zip(&mut weights[columns]);
                        for ((sum, weight), &wx_i) in pixels.zip(wx) {
                            let wt = wy * wx_i;
                            if wt > 0.0 {
                                *sum += l * wt;
                                *weight += wt;
                            }
                        }
                    }
                }
            }
        });
    rows.iter_mut().for_each(SpreadRow::clear);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Splatted camera samples of one value give every pixel exactly that value, the border
    /// pixels (fewer samples reach them) included: each pixel divides by its own weight sum.
    /// Samples on one half of the image only do not reach pixels beyond the filter's radius.
    #[test]
    fn splatted_samples_are_normalised_per_pixel() {
        use crate::filter::{Filter, FilterKind};
        let (w, h) = (7usize, 5usize);
        for filter in [
            Filter::new(FilterKind::Tent { radius: 1.5 }),
            Filter::new(FilterKind::Gaussian { stddev: 0.5 }),
        ] {
            let c = Spectrum::new(0.25, 0.5, 2.0);
            let mut film = Film::new_weighted(w as u32, h as u32);
            let mut rows: Vec<SpreadRow> = (0..h).map(|_| SpreadRow::default()).collect();
            for (y, row) in rows.iter_mut().enumerate() {
                for x in 0..w {
                    for (jx, jy) in [(0.13, 0.71), (0.62, 0.28), (0.91, 0.95)] {
                        let r = Vec2::new(x as f32 + jx, y as f32 + jy);
                        row.push(&filter, (w, h), r, c);
                    }
                }
            }
            spread_samples(&mut film, filter.radius(), &mut rows);
            for p in &film.to_image(1.0, 0.0).pixels {
                assert!((*p - c).abs().max_element() < 1e-6, "{p} != {c}");
            }
            // Each sample counts once: the rows are empty for the next pass.
            assert!(
                rows.iter()
                    .all(|r| r.samples.is_empty() && r.weights.is_empty())
            );
            // Only the left two columns lit: pixels beyond the radius get no weight (0).
            let mut film = Film::new_weighted(w as u32, h as u32);
            let mut rows: Vec<SpreadRow> = (0..h).map(|_| SpreadRow::default()).collect();
            for (y, row) in rows.iter_mut().enumerate() {
                for x in 0..2 {
                    row.push(
                        &filter,
                        (w, h),
                        Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
                        c,
                    );
                }
            }
            spread_samples(&mut film, filter.radius(), &mut rows);
            let img = film.to_image(1.0, 0.0);
            let reach = (1.5 + filter.radius()).ceil() as usize;
            for y in 0..h {
                assert!((img.pixels[y * w] - c).abs().max_element() < 1e-6);
                assert_eq!(img.pixels[y * w + reach], Spectrum::ZERO);
            }
        }
    }
}
