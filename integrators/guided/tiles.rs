//! Guiding by image tile (`tiles = auto`, the default): the guided technique is switched off
//! in the tiles of the image where the learning passes measured that it does not pay for its
//! cost, so that a render spends nothing of the guider there.
//!
//! **The technique.** A [`TileMask`] splits the image into [`TILE`] x [`TILE`]-pixel tiles and
//! marks each on or off. The guided technique with a mask draws its path as before and fails
//! when x_1 projects into an off tile; its density is `p_g(X) · [tile of x_1 is on]`, one
//! function of x_1's position ([`TileMask::allows`]) for the sampler, p_g and the held-path
//! test alike, so the estimator stays exact. In an off tile U's paths are U's own (no p_g
//! evaluation, no claim: `HeldStructures::holds` declines them), and the guide paths whose g_1
//! lies there get selection weight 0 ([`GuideCache::restrict`]); the number of guided samples
//! shrinks by the weight they held, so every remaining guide path is followed as often as in
//! the learning passes that measured it.
//!
//! **The choice** ([`choose`]). From the later half of the measured learning passes (as the
//! global share, `share.rs`), per tile t: `V_t(0)`, the variance of U alone, and `V_t(r)`,
//! the variance with the chosen ratio r (U's paths under the mixture plus the guided samples
//! that landed in t); per tile the cost of guiding there, `c_t`: its share of U's p_g work
//! (spread evenly over the tiles) plus the guided samples of the guide paths whose g_1 lies in
//! t (by their selection weight). With `V = Σ_t V_t` and `C` U's cost plus the `c_t` of the
//! tiles on, a tile stays on where its variance gain pays for its cost at the image's
//! exchange rate, `(V_t(0) − V_t(r)) · C > c_t · V`, iterated to a fixed point. A tile whose
//! measured gain is noise turns off (guiding there buys nothing on average).
//!
//! `tiles = all` keeps every tile on (the technique of earlier versions); `tiles = checker`
//! switches every other tile off whatever was measured (a fixed mask for tests of the masked
//! estimator). The mask is saved with the cache, so a loaded cache repeats the render phase.

use crate::scene::Scene;
use glam::Vec3;

/// Tile side in pixels.
pub const TILE: u32 = 16;

/// Which tiles of the image the guided technique covers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TileMask {
    pub nx: u32,
    pub ny: u32,
    /// Row-major, `nx * ny` entries.
    pub on: Vec<bool>,
    width: u32,
}

/// How the mask is chosen (option `tiles`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TilePolicy {
    Auto,
    All,
    Checker,
}

impl TileMask {
    /// Every tile of a `width` x `height` image set to `on`.
    pub fn uniform(width: u32, height: u32, on: bool) -> TileMask {
        let (nx, ny) = (width.div_ceil(TILE), height.div_ceil(TILE));
        TileMask {
            nx,
            ny,
            on: vec![on; (nx * ny) as usize],
            width,
        }
    }

    /// Every other tile off (tile (0, 0) on).
    pub fn checker(width: u32, height: u32) -> TileMask {
        let mut m = TileMask::uniform(width, height, true);
        for ty in 0..m.ny {
            for tx in 0..m.nx {
                m.on[(ty * m.nx + tx) as usize] = (tx + ty) % 2 == 0;
            }
        }
        m
    }

    /// A mask read from a file: `on` must have `nx * ny` entries for the image's tiling.
    pub fn from_parts(width: u32, height: u32, on: Vec<bool>) -> Option<TileMask> {
        let m = TileMask::uniform(width, height, true);
        (on.len() == m.on.len()).then_some(TileMask { on, ..m })
    }

    pub fn tiles(&self) -> usize {
        self.on.len()
    }

    /// The tile of pixel index `pixel`.
    pub fn tile_of_pixel(&self, pixel: u32) -> usize {
        let (x, y) = (pixel % self.width, pixel / self.width);
        ((y / TILE) * self.nx + x / TILE) as usize
    }

    /// The tile x_1 at `p` projects into (None off the image).
    pub fn tile_of_point(&self, scene: &Scene, p: Vec3) -> Option<usize> {
        let raster = scene.camera.world_to_raster(p)?;
        Some(self.tile_of_pixel(scene.camera.pixel_index(raster) as u32))
    }

    /// Whether the guided technique covers a path whose x_1 is at `p` (a point off the image
    /// is allowed: no path of the image has it).
    #[inline]
    pub fn allows(&self, scene: &Scene, p: Vec3) -> bool {
        self.tile_of_point(scene, p).is_none_or(|t| self.on[t])
    }

    pub fn fraction_on(&self) -> f64 {
        self.on.iter().filter(|&&b| b).count() as f64 / self.on.len().max(1) as f64
    }
}

/// Per-tile evidence for [`choose`].
#[derive(Debug, Clone, Default)]
pub struct TileEvidence {
    /// Variance of U alone per tile, `V_t(0)`.
    pub v_off: Vec<f64>,
    /// Variance with the chosen ratio per tile, `V_t(r)`.
    pub v_on: Vec<f64>,
    /// U's cost without guiding (the whole image).
    pub cost_u: f64,
    /// U's p_g work with guiding (the whole image, spread evenly over the tiles).
    pub cost_pg_u: f64,
    /// The guided samples' cost at the chosen ratio (the whole image, attributed to tiles by
    /// the selection weight of the guide paths whose g_1 lies there).
    pub cost_guided: f64,
}

/// The tiles where guiding pays (module doc): `weight_by_tile[t]` is the selection weight of
/// the guide paths whose g_1 lies in tile t.
pub fn choose(e: &TileEvidence, weight_by_tile: &[f64]) -> Vec<bool> {
    let n = e.v_off.len();
    let cost = tile_costs(e, weight_by_tile);
    let mut on = vec![true; n];
    // The rule compares each tile with the image as the other tiles leave it; a few rounds
    // reach a fixed point (a cycle, which the bound cuts, would leave a valid mask as well).
    for _ in 0..16 {
        let v: f64 = (0..n)
            .map(|t| if on[t] { e.v_on[t] } else { e.v_off[t] })
            .sum();
        let c = e.cost_u + (0..n).filter(|&t| on[t]).map(|t| cost[t]).sum::<f64>();
        let next: Vec<bool> = (0..n)
            .map(|t| (e.v_off[t] - e.v_on[t]) * c > cost[t] * v)
            .collect();
        if next == on {
            break;
        }
        on = next;
    }
    on
}

/// Per tile the cost of guiding there: its share of U's p_g work and the guided samples of
/// the guide paths whose g_1 lies in it.
fn tile_costs(e: &TileEvidence, weight_by_tile: &[f64]) -> Vec<f64> {
    let n = e.v_off.len();
    (0..n)
        .map(|t| e.cost_pg_u / n as f64 + e.cost_guided * weight_by_tile.get(t).unwrap_or(&0.0))
        .collect()
}

/// Predicted `V · cost` of rendering with the tiles `on` relative to U alone.
pub fn relative_score(e: &TileEvidence, weight_by_tile: &[f64], on: &[bool]) -> f64 {
    let cost = tile_costs(e, weight_by_tile);
    let v: f64 = (0..on.len())
        .map(|t| if on[t] { e.v_on[t] } else { e.v_off[t] })
        .sum();
    let c = e.cost_u
        + (0..on.len())
            .filter(|&t| on[t])
            .map(|t| cost[t])
            .sum::<f64>();
    let base = e.v_off.iter().sum::<f64>() * e.cost_u;
    if base > 0.0 { v * c / base } else { 1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_the_image_and_checker_alternates() {
        let m = TileMask::checker(40, 20);
        assert_eq!((m.nx, m.ny), (3, 2));
        assert_eq!(m.tile_of_pixel(0), 0);
        assert_eq!(m.tile_of_pixel(39), 2);
        assert_eq!(m.tile_of_pixel(16 * 40 + 17), 4);
        assert_eq!(m.on, vec![true, false, true, false, true, false]);
        assert!(TileMask::from_parts(40, 20, vec![true; 5]).is_none());
    }

    /// A tile whose gain pays for its cost stays on; one whose gain is nothing or negative
    /// (noise) and one whose gain is too small for its guided samples turn off.
    #[test]
    fn a_tile_stays_on_only_where_its_gain_pays() {
        let e = TileEvidence {
            v_off: vec![10.0, 1.0, 1.0, 1.0],
            v_on: vec![2.0, 1.0, 1.1, 0.98],
            cost_u: 4.0,
            cost_pg_u: 0.4,
            cost_guided: 2.0,
        };
        // Tile 3 gains 2 % of its variance for a quarter of the guided samples.
        let on = choose(&e, &[0.5, 0.0, 0.0, 0.5]);
        assert_eq!(on, vec![true, false, false, false]);
        // The same evidence where tile 3's gain is large turns it on.
        let e2 = TileEvidence {
            v_on: vec![2.0, 1.0, 1.1, 0.2],
            ..e
        };
        assert_eq!(
            choose(&e2, &[0.5, 0.0, 0.0, 0.5]),
            vec![true, false, false, true]
        );
    }
}
