//! How candidate guide paths reach the cache.
//!
//! During a learning iteration every row of the image keeps its [`ROW_CANDIDATES`] brightest
//! paths (unguided and guided alike) and the luminance of every sample; at the end of the
//! iteration a [`Seeder`] turns these into the records the cache is rebuilt from. The guider
//! does not know which seeder it has.
//!
//! | seeder     | what becomes a guide path |
//! |------------|---------------------------|
//! | `outliers` | samples few others of similar brightness back up in their 4 x 4-pixel block (the cascade of `learn.rs`, spec §6.3a); per band of rows the `intake` largest `C` |
//! | `mcmc`     | the same test over the passes' candidates and the states of Markov chains started at earlier outliers (`chains.rs`) |

use super::cache::Record;
pub use super::candidates::{Candidate, LearnRow, ROW_CANDIDATES, Source};
use super::estimator::Estimator;
use super::learn::{OutlierCascade, TRUST_THRESHOLD};
use crate::integrators::unguided::Unguided;
use crate::scene::Scene;

/// Bands of rows that each contribute `intake` outliers per learning iteration.
pub const WORKERS: usize = 4;

/// The end of one learning iteration, as a seeder sees it.
pub struct LearnPass<'p> {
    /// The scene rendered.
    pub scene: &'p Scene,
    /// Learning iteration (0: the first, pure unguided).
    pub iteration: u32,
    /// Unguided share of the iteration (the C of a record was formed with it).
    pub alpha: f64,
    /// Rows in image order.
    pub rows: &'p mut [LearnRow],
}

/// What a seeder may use after a learning pass to make candidates of its own.
pub struct Explore<'e, 'a, U: Unguided> {
    /// The render's seed.
    pub seed: u64,
    /// Learning iteration (0: the first, pure unguided).
    pub iteration: u32,
    /// The estimator of the pass (its cache and share weigh the candidates' C).
    pub est: &'e Estimator<'a, U>,
}

/// A source of guide paths.
pub trait Seeder: Send + Sync {
    /// The seeder's name (`outliers`, `mcmc`), as option `seeder` takes it.
    fn name(&self) -> &'static str;
    /// After a learning pass, before `harvest`: add candidates of the seeder's own making to
    /// `rows` (default: none).
    fn explore<U: Unguided>(&mut self, _explore: Explore<'_, '_, U>, _rows: &mut [LearnRow]) {}
    /// The records to rebuild the cache with after a learning iteration.
    fn harvest(&mut self, pass: LearnPass) -> Vec<Record>;
    /// Counters for the render's statistics (default: none).
    fn stats(&self) -> Vec<(String, String)> {
        Vec::new()
    }
}

/// Outlier selection (spec §6.3a): a candidate whose brightness few samples of its block
/// share is recorded; per band of rows the `intake` largest C.
pub struct Outliers {
    /// Outliers kept per band of rows and learning iteration.
    pub intake: usize,
    /// Chain states kept per band lie at least this many pixels apart in x or y (0: any
    /// distance; see [`spread_out`]).
    pub chain_spread: u32,
    cascade: Option<OutlierCascade>,
}

impl Outliers {
    /// The outlier seeder keeping `intake` outliers per band and iteration.
    pub fn new(intake: usize) -> Outliers {
        Outliers {
            intake,
            chain_spread: 0,
            cascade: None,
        }
    }
}

impl Seeder for Outliers {
    fn name(&self) -> &'static str {
        "outliers"
    }

    fn harvest(&mut self, pass: LearnPass) -> Vec<Record> {
        self.select(pass).into_iter().map(|c| c.record).collect()
    }
}

impl Outliers {
    /// The candidates that pass the outlier test, per band of rows the `intake` largest C
    /// (and, separately, the `intake` largest of the chain states among them).
    pub fn select(&mut self, pass: LearnPass) -> Vec<Candidate> {
        let scene = pass.scene;
        let res = scene.camera.resolution;
        if pass.iteration == 0 || self.cascade.is_none() {
            self.cascade = Some(OutlierCascade::new(res.x, res.y));
        }
        let cascade = self.cascade.as_mut().expect("made above");
        let rows = pass.rows;
        let n_pix = scene.camera.pixel_count() as f64;
        let total: f64 = rows
            .iter()
            .flat_map(|r| r.samples.iter())
            .map(|s| s.1 as f64)
            .sum();
        let mean = total / n_pix;
        if !(mean > 0.0) {
            return Vec::new();
        }
        let norm = |v: f64| v / (pass.alpha * mean);
        for r in rows.iter() {
            for &(pixel, lum) in &r.samples {
                cascade.add(pixel, norm(lum as f64));
            }
        }
        let h = rows.len();
        let mut records = Vec::new();
        for w in 0..WORKERS {
            let (a, b) = (w * h / WORKERS, (w + 1) * h / WORKERS);
            let mut pool: Vec<Candidate> = Vec::new();
            for r in &mut rows[a..b] {
                pool.extend(r.candidates.drain(..).filter(|c| {
                    c.densify
                        || cascade.trust(c.pixel, norm(c.value), pass.iteration + 1)
                            <= TRUST_THRESHOLD
                }));
            }
            // Chain states compete among themselves: they cluster around the outliers their
            // chains started at, and would otherwise crowd the passes' outliers out of the
            // intake (the cache's coverage of the image).
            let (mut chains, mut pool): (Vec<Candidate>, Vec<Candidate>) =
                pool.into_iter().partition(|c| c.source == Source::Chain);
            for list in [&mut pool, &mut chains] {
                list.sort_by(|x, y| y.record.c.total_cmp(&x.record.c));
            }
            pool.truncate(self.intake);
            let (intake, spread) = (self.intake, self.chain_spread);
            records.extend(pool);
            records.extend(spread_out(chains, intake, spread, res.x, |c| c.pixel));
        }
        records
    }
}

/// The first `intake` of `list` (sorted by decreasing C) whose pixels lie at least `spread`
/// pixels apart in x or y from every one kept before them (`spread` 0: the first `intake`).
///
/// A chain lingers where its target is large, so the states of one chain are near copies of
/// each other: kept side by side they add guide paths that cover no more of path space than
/// one does, while each costs a Gaussian to evaluate in every p_g near it. Kept apart, the
/// chain states spread over the caustic the chain explored.
pub fn spread_out<T>(
    list: Vec<T>,
    intake: usize,
    spread: u32,
    width: u32,
    pixel: impl Fn(&T) -> u32,
) -> Vec<T> {
    let at = |t: &T| {
        let p = pixel(t);
        ((p % width) as i64, (p / width) as i64)
    };
    let mut kept: Vec<T> = Vec::new();
    let mut places: Vec<(i64, i64)> = Vec::new();
    let spread = spread as i64;
    for t in list {
        if kept.len() == intake {
            break;
        }
        let (x, y) = at(&t);
        let near = |&(kx, ky): &(i64, i64)| (kx - x).abs() < spread && (ky - y).abs() < spread;
        if !places.iter().any(near) {
            places.push((x, y));
            kept.push(t);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::spread_out;

    /// Kept items come in the list's order, at most `intake` of them, each at least `spread`
    /// pixels (in x or y) from the ones kept before; spread 0 keeps the first `intake`.
    #[test]
    fn chain_states_are_kept_apart() {
        let width = 100;
        // (pixel, C) in decreasing C: a cluster around (10, 10), a state at (13, 10), one at
        // (10, 20), then a second cluster around (50, 50).
        let at = |x: u32, y: u32| y * width + x;
        let list = vec![
            (at(10, 10), 9.0),
            (at(11, 10), 8.0),
            (at(10, 12), 7.0),
            (at(13, 10), 6.0),
            (at(10, 20), 5.0),
            (at(50, 50), 4.0),
            (at(52, 48), 3.0),
            (at(56, 50), 2.0),
        ];
        let kept = |intake, spread| {
            spread_out(list.clone(), intake, spread, width, |t| t.0)
                .iter()
                .map(|t| t.1)
                .collect::<Vec<f64>>()
        };
        assert_eq!(kept(3, 0), vec![9.0, 8.0, 7.0]);
        assert_eq!(kept(100, 3), vec![9.0, 6.0, 5.0, 4.0, 2.0]);
        assert_eq!(kept(100, 4), vec![9.0, 5.0, 4.0, 2.0]);
        assert_eq!(kept(2, 3), vec![9.0, 6.0]);
        // Distinct pixels only.
        assert_eq!(kept(100, 1).len(), 8);
    }
}
