//! The densities with which every BDPT technique produces one complete path, and the MIS
//! weights built from them.
//!
//! A path y_0 (pinhole) .. y_k (emitter) has k segments. Technique s (s light vertices,
//! t = k + 1 - s camera vertices) samples y_1 .. y_{t-1} from the camera side and y_t .. y_k
//! from the light side, then connects y_{t-1} with y_t (s = 0: the camera walk hits the
//! emitter; s = 1 with t >= 2: next-event estimation chooses y_k). With
//!
//! * `pc[j]`: density of y_j when generated from y_{j-1} by the camera-side walk,
//! * `pl[j]`: density of y_j when generated from y_{j+1} by the light-side walk (`pl[k]` is
//!   the emission origin's density, light choice included),
//! * `nee_k`: density of y_k chosen by next-event estimation from y_{k-1},
//!
//! (all including Russian roulette and free flight), technique s has density
//! `p(s) = prod_{j<t} pc[j] * prod_{j>=t} pl[j]` (with `nee_k` in place of the light side for
//! s = 1, t >= 2), or zero when its connection would end at a delta vertex or it cannot hit
//! the emitter. The balance heuristic weight of s is `p(s) / sum p`, the power heuristic
//! `p(s)^2 / sum p^2`; `sum p` is also BDPT's `pdf_unguided` for the path (one sample of
//! each technique per pixel and pass).
//!
//! **Directly seen emitters** (k = 1: the pinhole sees y_1 on an emitter the camera walk can
//! hit, through no medium) are left to s = 0 alone where the emitter fills y_1's pixel
//! ([`super::direct_to_camera`], `Scene::emitter_fills_pixel`): technique (s, t) = (1, 1),
//! the emission origin connected to the pinhole, is not used for them (`p(1) = 0`). There the
//! camera's own sample, one per pixel, is the emitter's radiance whatever its position in the
//! pixel, while the light tracer's splats land on the pixel a Poisson number of times, so any
//! weight they take adds their count noise to the brightest pixels of the image (a bright
//! window seen directly: dining). At the emitter's edges (and its occluders') the camera's
//! samples hit or miss it, and the splats, many per pixel for a small emitter, are the
//! smoother estimate: there both techniques stay, weighed by the heuristic (leaving them to
//! s = 0 everywhere, as pbrt's BDPT does, made the Cornell box's MSE 2.3 times larger, its
//! light's edge pixels noisy). Through a medium both stay too (the camera's free flight passes
//! or not, while the connection's transmittance is exact).

/// MIS heuristic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Heuristic {
    /// Weight `p(s) / sum p`.
    Balance,
    /// Weight `p(s)^2 / sum p^2`.
    Power,
}

/// Per-vertex inputs of `technique_densities` for one path of `k` segments.
pub struct PathTerms {
    /// Number of segments of the path.
    pub k: usize,
    /// `pc[j]`: density of y_j generated from y_{j-1} by the camera-side walk (area measure,
    /// volume measure in media), Russian roulette and free flight included.
    pub pc: Vec<f64>,
    /// `pl[j]`: density of y_j generated from y_{j+1} by the light-side walk; `pl[k]` is the
    /// emission origin's, light choice included.
    pub pl: Vec<f64>,
    /// Density of next-event estimation choosing y_k from y_{k-1}, light choice included.
    pub nee_k: f64,
    /// A connection can end at y_j.
    pub connectible: Vec<bool>,
    /// The camera walk can hit y_k (an emitter that is not a delta).
    pub hittable: bool,
    /// k = 1, the segment y_0 y_1 crosses no medium and an emitter fills y_1's pixel: a
    /// directly seen emitter, left to s = 0 when `hittable` (see the module doc).
    pub direct_by_camera: bool,
    /// Vertex merging (`guided-vcm`'s estimator): eta = pi r^2 N, the number of light
    /// subpaths a merge draws from times the kernel's area; 0 without merging.
    pub eta: f64,
}

impl PathTerms {
    /// Terms of a path of `k` segments, every density zero and nothing connectible.
    pub fn new(k: usize) -> PathTerms {
        PathTerms {
            k,
            pc: vec![0.0; k + 1],
            pl: vec![0.0; k + 1],
            nee_k: 0.0,
            connectible: vec![false; k + 1],
            hittable: false,
            direct_by_camera: false,
            eta: 0.0,
        }
    }

    /// Start over for a path of `k` segments: zero densities, nothing connectible (only the
    /// entries a path of `k` segments uses are touched, so reusing one `PathTerms` is cheap;
    /// the storage grows to the longest path seen).
    pub fn reset(&mut self, k: usize) {
        self.k = k;
        if self.pc.len() <= k {
            self.pc.resize(k + 1, 0.0);
            self.pl.resize(k + 1, 0.0);
            self.connectible.resize(k + 1, false);
        }
        self.pc[..=k].fill(0.0);
        self.pl[..=k].fill(0.0);
        self.connectible[..=k].fill(false);
        self.nee_k = 0.0;
        self.hittable = false;
        self.direct_by_camera = false;
    }

    /// `out[s]` = density of technique s, for s = 0..=k (other entries are left alone).
    /// `out` needs at least `k + 1` entries.
    pub fn technique_densities(&self, out: &mut [f64]) {
        let k = self.k;
        // First the light-side suffix: out[s] = prod_{j >= t} pl[j] with t = k + 1 - s.
        let mut suf = 1.0f64;
        for (o, pl) in out[1..=k].iter_mut().zip(self.pl[1..=k].iter().rev()) {
            suf *= pl;
            *o = suf;
        }
        // Then, with t growing, the camera-side prefix pre = prod_{j < t} pc[j].
        let mut pre = 1.0f64;
        for t in 1..=k + 1 {
            let s = k + 1 - t;
            out[s] = if s == 0 {
                if self.hittable { pre } else { 0.0 }
            } else if s == 1 && t >= 2 {
                if self.connectible[k - 1] {
                    pre * self.nee_k
                } else {
                    0.0
                }
            } else if k == 1 && self.hittable && self.direct_by_camera {
                // (1, 1) on a directly seen emitter: left to s = 0.
                0.0
            } else if self.connectible[t - 1] && self.connectible[t] {
                pre * out[s]
            } else {
                0.0
            };
            if t <= k {
                pre *= self.pc[t];
            }
        }
    }

    /// Vertex merging at y_j (1 <= j < k, `mergeable(j)`: a non-delta surface vertex): the
    /// camera walk and a light walk both generate y_j, and the kernel of radius r accepts
    /// the pair, with N light subpaths per pass:
    /// `p_vm(j) = eta prod_{l <= j} pc[l] prod_{l >= j} pl[l]` (pc\[0\], the pinhole, left
    /// out as in [`PathTerms::technique_densities`]). Writes `out[j]` for j = 0..=k (0 where
    /// nothing merges) and returns their sum; all 0 when `eta` is 0.
    pub fn merge_densities(&self, mergeable: impl Fn(usize) -> bool, out: &mut [f64]) -> f64 {
        let k = self.k;
        out[..=k].fill(0.0);
        if self.eta == 0.0 || k < 2 {
            return 0.0;
        }
        let mut pre = 1.0f64;
        for (j, o) in out.iter_mut().enumerate().take(k).skip(1) {
            pre *= self.pc[j];
            *o = pre;
        }
        let (mut suf, mut sum) = (self.pl[k], 0.0);
        for j in (1..k).rev() {
            suf *= self.pl[j];
            out[j] = if mergeable(j) {
                self.eta * out[j] * suf
            } else {
                0.0
            };
            sum += out[j];
        }
        sum
    }

    /// MIS weight of technique `s` for this path.
    pub fn weight(&self, s: usize, heuristic: Heuristic) -> f64 {
        let mut p = vec![0.0f64; self.k + 1];
        self.weight_with(s, heuristic, &mut p)
    }

    /// [`PathTerms::weight`], with `p` as scratch for the technique densities (so a caller
    /// that keeps one need not clear a fresh array per path).
    /// (`p` needs at least `k + 1` entries.)
    pub fn weight_with(&self, s: usize, heuristic: Heuristic, p: &mut [f64]) -> f64 {
        self.technique_densities(p);
        if crate::check::enabled() {
            for (s, &q) in p[..=self.k].iter().enumerate() {
                crate::check::density(crate::check::Technique::st("bdpt", s, self.k + 1 - s), q);
            }
        }
        let own = p[s];
        if own == 0.0 || !own.is_finite() {
            return 0.0;
        }
        // Ratios to the own density keep the sum in range whatever the densities' scale. The
        // own ratio is exactly 1 (not `own * (1 / own)`, which can round below 1 and give a
        // weight above 1), so the sum is at least 1 and the weight at most 1.
        let inv_own = 1.0 / own;
        let ratios = p[..=self.k]
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != s)
            .map(|(_, &q)| q * inv_own);
        let sum: f64 = 1.0
            + match heuristic {
                Heuristic::Balance => ratios.sum::<f64>(),
                Heuristic::Power => ratios.map(|r| r * r).sum::<f64>(),
            };
        let w = if sum.is_finite() && sum > 0.0 {
            1.0 / sum
        } else {
            0.0
        };
        crate::check::weight(crate::check::Technique::st("bdpt", s, self.k + 1 - s), w);
        w
    }
}
