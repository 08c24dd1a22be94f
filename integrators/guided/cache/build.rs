//! Building the cache (spec §2.4, §3): the weight update of a rebuild, installing guide
//! paths, their first-vertex kernels and the pruning BVH over them, neighbours, and the
//! per-segment conditional Gaussians (regression kernels) from the neighbours. Deterministic,
//! so a saved cache loads to the same state. The widths and their deviations from the spec
//! are in the parent module's doc.

use super::{
    Guide, GuideCache, Install, NEIGHBOURS, RebuildParams, Record, SECOND_MOMENT_SHARE,
    SPACING_RANK, StructureIndex,
};
use crate::integrators::guided::gaussian::{Mat3, R, cholesky, cholesky_solve, symmetric_eigen};
use crate::integrators::guided::kernel;
use crate::integrators::guided::kernel::{
    FirstKernel, Kernel, Node, coords, direction_coords, dvec, is_infinite_vertex, segment_frame,
};
use crate::integrators::guided::plane::PlaneKernel;
use crate::math::AliasTable;
use crate::path::{Vertex as PathVertex, VertexKind};
use crate::scene::Scene;
use glam::{Vec3, Vec3A};
use obvhs::{BvhBuildParams, aabb::Aabb};
use rayon::prelude::*;
use std::collections::HashMap;
use std::time::Duration;

impl GuideCache {
    /// Rebuild the cache from its guide paths plus `records` (spec §2.4, §3; module doc).
    /// `second_moment`: empty, or per guide path of the current cache its share of the
    /// second moment of the iteration's samples (`Estimator::credit` summed); non-empty selects
    /// [`super::WeightRule::SecondMoment`].
    pub fn rebuild(
        &mut self,
        scene: &Scene,
        records: Vec<Record>,
        params: RebuildParams,
        second_moment: &[f64],
    ) {
        let max_len = crate::path::MAX_VERTICES;
        // ---- C of the old guide paths under the state that drew this iteration ----
        let old_c: Vec<f64> = (0..self.guides.len())
            .into_par_iter()
            .map(|l| {
                let g = &self.guides[l];
                let mut path = crate::path::Path::default();
                for v in self.path_vertices(scene, l) {
                    path.push(v);
                }
                let Some(y) = crate::integrators::paths::from_path(scene, &path) else {
                    return 0.0;
                };
                let mut scratch = Vec::new();
                let (p_g, _) = self.pdf(scene, &y, g.sig, self.nodes_of(l), &mut scratch);
                let mix = params.alpha * g.p_u + (1.0 - params.alpha) * p_g;
                if mix > 0.0 { g.f / mix } else { 0.0 }
            })
            .collect();
        struct Entry {
            vertices: Vec<PathVertex>,
            f: f64,
            p_u: f64,
            c: f64,
            w_old: Option<f64>,
            age: u16,
        }
        let mut entries: Vec<Entry> = Vec::with_capacity(self.guides.len() + records.len());
        for (l, &c) in old_c.iter().enumerate() {
            let g = self.guides[l];
            entries.push(Entry {
                vertices: self.path_vertices(scene, l),
                f: g.f,
                p_u: g.p_u,
                c,
                w_old: Some(g.weight),
                age: g.age.saturating_add(1),
            });
        }
        for r in records {
            let mut path = crate::path::Path::default();
            for v in &r.vertices {
                path.push(*v);
            }
            if kernel::structure(scene, &path, max_len).is_none() || !(r.c > 0.0 && r.c.is_finite())
            {
                continue;
            }
            entries.push(Entry {
                vertices: r.vertices,
                f: r.f,
                p_u: r.p_u,
                c: r.c,
                w_old: None,
                age: 0,
            });
        }
        // ---- Weights ----
        let sum_c: f64 = entries.iter().map(|e| e.c).sum();
        let sum_m2: f64 = second_moment.iter().sum();
        let by_m2 = if sum_m2 > 0.0 && second_moment.len() == old_c.len() {
            SECOND_MOMENT_SHARE
        } else {
            0.0
        };
        let mut weights: Vec<f64> = entries
            .iter()
            .enumerate()
            .map(|(i, e)| {
                let by_c = if sum_c > 0.0 { e.c / sum_c } else { 0.0 };
                let fresh = match second_moment.get(i) {
                    Some(m2) if by_m2 > 0.0 => by_m2 * m2 / sum_m2 + (1.0 - by_m2) * by_c,
                    _ => (1.0 - by_m2) * by_c,
                };
                match e.w_old {
                    Some(w) if !params.render_mode => {
                        params.damping * fresh + (1.0 - params.damping) * w
                    }
                    _ => fresh,
                }
            })
            .collect();
        // ---- Cap: keep the heaviest (ties by index, so the result is deterministic) ----
        let mut keep: Vec<usize> = (0..entries.len()).filter(|&i| weights[i] > 0.0).collect();
        if keep.len() > params.max_guides {
            keep.sort_by(|&a, &b| weights[b].total_cmp(&weights[a]).then(a.cmp(&b)));
            keep.truncate(params.max_guides);
            keep.sort_unstable();
        }
        let total: f64 = keep.iter().map(|&i| weights[i]).sum();
        for w in &mut weights {
            *w /= total.max(f64::MIN_POSITIVE);
        }
        let installs: Vec<Install> = keep
            .into_iter()
            .map(|i| {
                let e = std::mem::replace(
                    &mut entries[i],
                    Entry {
                        vertices: Vec::new(),
                        f: 0.0,
                        p_u: 0.0,
                        c: 0.0,
                        w_old: None,
                        age: 0,
                    },
                );
                (e.vertices, e.f, e.p_u, weights[i], e.age)
            })
            .collect();
        self.install(scene, installs, params.iteration);
    }

    /// Replace the cache by these guide paths (vertices camera first, f, p_u, weight, age;
    /// the weights must sum to 1):
    /// first-vertex kernels for learning iteration `iteration`, pruning BVH, neighbours,
    /// kernels and the alias table. Deterministic, so a saved cache loads to the same state.
    pub fn install(&mut self, scene: &Scene, paths: Vec<Install>, iteration: u32) {
        self.guides.clear();
        self.vertices.clear();
        self.nodes.clear();
        self.kernels.clear();
        self.frames.clear();
        self.planes.clear();
        self.ends.clear();
        self.iteration = iteration;
        let k = iteration.max(1) as f32;
        let pixel_angle = scene.camera.pixel_angle();
        let image_scale = kernel_pixel_scale(scene) as f32;
        for (vertices, f, p_u, weight, age) in paths {
            let mut path = crate::path::Path::default();
            for v in &vertices {
                path.push(*v);
            }
            let Some((sig, nodes)) = kernel::structure(scene, &path, crate::path::MAX_VERTICES)
            else {
                continue;
            };
            let g1 = vertices[1];
            let rho = match g1.kind {
                VertexKind::Surface { material, .. } => {
                    scene.materials[material as usize].bsdf.roughness()
                }
                _ => 1.0,
            };
            let s = (rho * (90.0 / k + 10.0).max(1.0) + (1.0 - rho) * (90.0 / k + 1.0).max(1.0))
                * image_scale;
            let w = self.widths;
            let factor = rho as f64 * w.first_vertex + (1.0 - rho as f64) * w.first_vertex_specular;
            let s = s.max(1.0) * factor as f32;
            let footprint = (g1.p - scene.camera.position).length() * pixel_angle;
            self.guides.push(Guide {
                start: self.vertices.len() as u32,
                kernels: 0,
                len: vertices.len() as u8,
                neighbours: 0,
                age,
                sig,
                sigma1: s * footprint,
                f,
                p_u,
                weight,
            });
            if let Some(&Node::Emitter { light, .. }) = nodes.last() {
                self.ends.push((vertices.len(), light));
            }
            self.vertices.extend_from_slice(&vertices[1..]);
            self.nodes.extend_from_slice(&nodes);
        }
        self.ends.sort_unstable();
        self.ends.dedup();
        self.build_bvh(scene);
        // ---- Neighbours and kernels (candidates under the spec's first-vertex widths) ----
        let per_guide: Vec<(u8, Vec<Kernel>, Option<f32>)> = (0..self.guides.len())
            .into_par_iter()
            .map(|l| {
                let mut cand = Vec::new();
                let sig = self.guides[l].sig;
                self.candidates(scene, sig, self.vertex(scene, l, 1).p, &mut cand);
                let nb = self.neighbours(scene, l, &cand);
                let kernels = (2..self.guides[l].len as usize)
                    .map(|v| self.build_kernel(scene, l, v, &nb))
                    .collect();
                (
                    nb.len() as u8,
                    kernels,
                    self.first_vertex_spacing(scene, l, &cand),
                )
            })
            .collect();
        let mut narrowed = false;
        for (l, (nb, kernels, spacing)) in per_guide.into_iter().enumerate() {
            self.guides[l].neighbours = nb;
            self.guides[l].kernels = self.kernels.len() as u32;
            self.kernels.extend(kernels);
            for v in 2..self.guides[l].len as usize {
                let (g_prev, g) = (self.vertex(scene, l, v - 1), self.vertex(scene, l, v));
                let frame = segment_frame(&g_prev, &g, is_infinite_vertex(scene, &g));
                let k = &self.kernels[self.guides[l].kernels as usize + v - 2];
                self.planes.push(PlaneKernel::new(&frame, g_prev.p, g.p, k));
                self.frames.push(frame);
            }
            // ---- Adaptive first-vertex width (module doc): at most the spacing of the
            // first vertices around g_1, never below one pixel footprint ----
            if let Some(d) = spacing {
                let g = &mut self.guides[l];
                let footprint = (self.vertices[g.start as usize].p - scene.camera.position)
                    .length()
                    * pixel_angle;
                let sigma1 = g.sigma1.min(d.max(footprint));
                narrowed |= sigma1 < g.sigma1;
                g.sigma1 = sigma1;
            }
        }
        if narrowed {
            self.build_bvh(scene);
        }
        // One source of truth for the selection pmf: the alias table normalises the weights
        // of the guide paths that were installed (a path without structure is dropped above,
        // so the given weights need not sum to 1 any more), and p_g weighs each guide by
        // exactly that pmf.
        let w: Vec<f64> = self.guides.iter().map(|g| g.weight).collect();
        self.alias = AliasTable::new(&w);
        for (l, g) in self.guides.iter_mut().enumerate() {
            g.weight = if self.alias.is_empty() {
                0.0
            } else {
                self.alias.pmf(l)
            };
        }
    }

    /// Box of guide `l`'s first-vertex kernel support (truncation radius R).
    fn first_kernel_box(&self, scene: &Scene, l: usize) -> Aabb {
        let g1 = self.vertex(scene, l, 1);
        let r = R as f32 * self.guides[l].sigma1;
        let half = if matches!(g1.kind, VertexKind::Medium { .. }) {
            Vec3::splat(r)
        } else {
            let n = (g1.p - scene.camera.position).normalize();
            (Vec3::ONE - n * n).max(Vec3::ZERO).sqrt() * r
        };
        // Padding for rounding, relative to the coordinates (the exact test is the truncation
        // in the density).
        let half = half * 1.001 + Vec3::splat(1e-6 * (r + g1.p.abs().max_element()));
        Aabb::new(Vec3A::from(g1.p - half), Vec3A::from(g1.p + half))
    }

    /// [`Self::first_kernel_box`] in the BVHs' coordinates.
    pub(super) fn scaled_kernel_box(&self, scene: &Scene, l: usize) -> Aabb {
        scale_box(&self.first_kernel_box(scene, l), self.bvh_scale)
    }

    /// One BVH per structure over its guides' first-vertex kernel boxes.
    fn build_bvh(&mut self, scene: &Scene) {
        self.index.clear();
        if self.guides.is_empty() {
            return;
        }
        let boxes: Vec<Aabb> = (0..self.guides.len())
            .map(|l| self.first_kernel_box(scene, l))
            .collect();
        // obvhs skips boxes within an absolute 1e-4 of a ray's origin: build and query in
        // coordinates scaled by a power of two (exact) so that the boxes and the camera span
        // about 2^20 (in a scene a millimetre across, every box was skipped and p_g was 0).
        let mut all = Aabb::from_point(Vec3A::from(scene.camera.position));
        for b in &boxes {
            all = all.union(b);
        }
        self.bvh_scale = crate::geometry::bvh::scale_for_obvhs(&all);
        let mut members: HashMap<u64, Vec<u32>> = HashMap::new();
        for (l, g) in self.guides.iter().enumerate() {
            members.entry(g.sig).or_default().push(l as u32);
        }
        for (sig, guides) in members {
            let scaled: Vec<Aabb> = guides
                .iter()
                .map(|&l| scale_box(&boxes[l as usize], self.bvh_scale))
                .collect();
            let mut t = Duration::ZERO;
            let bvh =
                obvhs::cwbvh::builder::build_cwbvh(&scaled, BvhBuildParams::fast_build(), &mut t);
            let kernels = bvh
                .primitive_indices
                .iter()
                .map(|&i| {
                    let l = guides[i as usize];
                    let g1 = self.vertex(scene, l as usize, 1);
                    FirstKernel::new(scene, &g1, self.guides[l as usize].sigma1, l)
                })
                .collect();
            let first = guides[0];
            let uniform = (guides.iter())
                .all(|&l| self.nodes_of(l as usize) == self.nodes_of(first as usize));
            let index = StructureIndex {
                bvh,
                kernels,
                first,
                uniform,
            };
            self.index.insert(sig, index);
        }
    }

    /// The (up to) `NEIGHBOURS` nearest guide paths of `l`'s structure, by summed squared
    /// vertex distance, among the candidates of `l`'s own first vertex; `l` itself first.
    fn neighbours(&self, scene: &Scene, l: usize, cand: &[u32]) -> Vec<u32> {
        let me = &self.guides[l];
        let len = me.len as usize;
        let mut scored: Vec<(f64, u32)> = cand
            .iter()
            .filter(|&&j| {
                let g = &self.guides[j as usize];
                g.sig == me.sig && g.f > 0.0 && self.nodes_of(j as usize) == self.nodes_of(l)
            })
            .map(|&j| {
                let d: f64 = (1..len)
                    .map(|v| {
                        let a = dvec(self.vertex(scene, l, v).p);
                        let b = dvec(self.vertex(scene, j as usize, v).p);
                        (a - b).length_squared()
                    })
                    .sum();
                (d, j)
            })
            .collect();
        scored.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        scored.dedup_by_key(|s| s.1);
        scored.truncate(NEIGHBOURS);
        scored.into_iter().map(|s| s.1).collect()
    }

    /// Distance from `g_1` of guide `l` to the [`SPACING_RANK`]-th nearest other first vertex
    /// of `l`'s structure among `cand` (guides whose first-vertex kernel covers `g_1`),
    /// measured as `l`'s own kernel measures it: across the plane through `g_1` orthogonal to
    /// the camera ray (in 3D for a medium vertex). `None` when fewer guides are at hand.
    fn first_vertex_spacing(&self, scene: &Scene, l: usize, cand: &[u32]) -> Option<f32> {
        let me = &self.guides[l];
        let o = dvec(scene.camera.position);
        let g1 = self.vertex(scene, l, 1);
        let d = dvec(g1.p) - o;
        let (dist, w) = (d.length(), d.normalize());
        let medium = matches!(g1.kind, VertexKind::Medium { .. });
        let mut gaps: Vec<f64> = cand
            .iter()
            .map(|&j| j as usize)
            .filter(|&j| {
                j != l && self.guides[j].sig == me.sig && self.nodes_of(j) == self.nodes_of(l)
            })
            .filter_map(|j| {
                let p = dvec(self.vertex(scene, j, 1).p);
                if medium {
                    return Some((p - dvec(g1.p)).length());
                }
                let wj = (p - o).normalize();
                let cos = wj.dot(w);
                // Where the camera ray through g_1 of j crosses l's kernel plane.
                (cos > 0.0).then(|| (o + wj * (dist / cos) - dvec(g1.p)).length())
            })
            .collect();
        if gaps.len() < SPACING_RANK {
            return None;
        }
        let (_, kth, _) = gaps.select_nth_unstable_by(SPACING_RANK - 1, f64::total_cmp);
        Some(*kth as f32)
    }

    /// Kernel of segment g_{v-1} -> g_v of guide `l` from its neighbours `nb`.
    fn build_kernel(&self, scene: &Scene, l: usize, v: usize, nb: &[u32]) -> Kernel {
        let g_prev = self.vertex(scene, l, v - 1);
        let g = self.vertex(scene, l, v);
        let infinite = is_infinite_vertex(scene, &g);
        let f = segment_frame(&g_prev, &g, infinite);
        let seg = (g.p - g_prev.p).length() as f64;
        let g1 = self.vertex(scene, l, 1);
        let pixel_angle = scene.camera.pixel_angle() as f64;
        let footprint = ((g1.p - scene.camera.position).length() as f64 * pixel_angle).max(1e-9);
        let (floor, ceil) = if infinite {
            (1e-5, 0.25)
        } else {
            (
                footprint * footprint,
                (0.5 * seg).powi(2).max(footprint * footprint),
            )
        };
        let age = self.guides[l].age as f64;
        let iso = ((90.0 / (age + 2.0)) * kernel_pixel_scale(scene)).max(1.0)
            * if infinite { pixel_angle } else { footprint };
        let isotropic = Kernel::isotropic(iso.min(ceil.sqrt()) as f32);
        if nb.len() < NEIGHBOURS {
            return isotropic;
        }
        let dt = if matches!(self.node(l, v), Node::Medium { .. }) {
            3
        } else {
            2
        };
        let dc = if matches!(self.node(l, v - 1), Node::Medium { .. }) {
            3
        } else {
            2
        };
        let mut samples: Vec<([f64; 3], [f64; 3])> = Vec::with_capacity(nb.len());
        for &j in nb {
            let xj = self.vertex(scene, j as usize, v);
            let pj = self.vertex(scene, j as usize, v - 1);
            let y = if infinite {
                match direction_coords(&f, xj.n) {
                    Some(c) => c,
                    None => return isotropic,
                }
            } else {
                coords(&f, xj.p, g.p, dt)
            };
            samples.push((y, coords(&f, pj.p, g_prev.p, dc)));
        }
        regression_kernel(
            &samples,
            dt,
            dc,
            floor,
            ceil,
            if infinite { 1e-3 } else { 1e-3 * seg },
            self.widths.regression,
        )
        .unwrap_or(isotropic)
    }
}

/// Largest ratio of a regression kernel's standard deviations. Kernels keep their
/// eigenvectors in f32, orthogonal to about 1e-7, so `warp` and `density` are inverse to each
/// other only to about 1e-7 times this ratio (in standard deviations): at 1e3 a drawn point's
/// density is evaluated within 1e-3 of the density it was drawn with. A neighbourhood more
/// anisotropic than that gets its small axes widened (tests/stress_gaussian.rs: condition
/// numbers of 1e9 put sampling and evaluation 2e-3 apart without the cap); the guided density
/// stays the density of what is sampled either way.
pub const MAX_ANISOTROPY: f64 = 1e3;

/// Conditional Gaussian of target coordinates given conditioning coordinates from joint
/// samples (y, z): mean, unbiased covariance, ridge `eps² I` on Σ22, `K = Σ12 Σ22⁻¹`,
/// `Σc = Σ11 − K Σ21` with eigenvalues multiplied by `width²` and clamped to [floor, ceil].
pub fn regression_kernel(
    samples: &[([f64; 3], [f64; 3])],
    dt: usize,
    dc: usize,
    floor: f64,
    ceil: f64,
    eps: f64,
    width: f64,
) -> Option<Kernel> {
    let n = samples.len() as f64;
    let mut my = [0.0; 3];
    let mut mz = [0.0; 3];
    for (y, z) in samples {
        for i in 0..3 {
            my[i] += y[i] / n;
            mz[i] += z[i] / n;
        }
    }
    let (mut s11, mut s12, mut s22): (Mat3, Mat3, Mat3) = Default::default();
    for (y, z) in samples {
        for a in 0..3 {
            for b in 0..3 {
                s11[a][b] += (y[a] - my[a]) * (y[b] - my[b]) / (n - 1.0);
                s12[a][b] += (y[a] - my[a]) * (z[b] - mz[b]) / (n - 1.0);
                s22[a][b] += (z[a] - mz[a]) * (z[b] - mz[b]) / (n - 1.0);
            }
        }
    }
    for (i, row) in s22.iter_mut().enumerate().take(dc) {
        row[i] += eps * eps;
    }
    let l22 = cholesky(&s22, dc)?;
    let mut k = [[0.0f64; 3]; 3];
    for a in 0..dt {
        k[a] = cholesky_solve(&l22, dc, s12[a]);
    }
    let mut sc = [[0.0f64; 3]; 3];
    for a in 0..dt {
        for b in 0..dt {
            let kz: f64 = (0..dc).map(|j| k[a][j] * s12[b][j]).sum();
            sc[a][b] = s11[a][b] - kz;
        }
    }
    for a in 0..dt {
        for b in 0..a {
            let m = 0.5 * (sc[a][b] + sc[b][a]);
            sc[a][b] = m;
            sc[b][a] = m;
        }
    }
    let (lambda, e) = symmetric_eigen(&sc, dt);
    if lambda.iter().take(dt).any(|l| !l.is_finite()) {
        return None;
    }
    let lam: Vec<f64> = (0..dt)
        .map(|i| (lambda[i] * width * width).clamp(floor, ceil))
        .collect();
    // Cap the anisotropy (see MAX_ANISOTROPY): raise the small variances.
    let lam_max = lam.iter().copied().fold(0.0f64, f64::max);
    let lam: Vec<f64> = lam
        .iter()
        .map(|&l| l.max(lam_max / (MAX_ANISOTROPY * MAX_ANISOTROPY)))
        .collect();
    if !lam.iter().all(|l| l.is_finite() && *l > 0.0)
        || !mz.iter().chain(&my).all(|v| v.is_finite())
    {
        return None;
    }
    let mut out = Kernel::isotropic(1.0);
    for i in 0..3 {
        out.mu1[i] = my[i] as f32;
        out.mu2[i] = mz[i] as f32;
        for j in 0..3 {
            out.k[i][j] = if i < dt && j < dc {
                k[i][j] as f32
            } else {
                0.0
            };
            out.e[i][j] = if i < dt && j < dt {
                e[i][j] as f32
            } else if i == j {
                1.0
            } else {
                0.0
            };
        }
        out.s[i] = if i < dt { lam[i].sqrt() as f32 } else { 1.0 };
    }
    if dt == 3 {
        // Std of the distance coordinate (n) given the lateral ones (u, w), for the phase
        // branch in media: Σ_nn − Σ_n,uw Σ_uw⁻¹ Σ_uw,n of the clamped covariance.
        let mut c = [[0.0f64; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                c[a][b] = (0..3).map(|i| e[a][i] * lam[i] * e[b][i]).sum();
            }
        }
        let var = cholesky(&c, 2).map_or(c[2][2], |l| {
            let x = cholesky_solve(&l, 2, [c[0][2], c[1][2], 0.0]);
            c[2][2] - x[0] * c[0][2] - x[1] * c[1][2]
        });
        out.sigma_dist = var.max(floor).sqrt() as f32;
    } else {
        out.sigma_dist = floor.sqrt() as f32;
    }
    Some(out)
}

/// Image height the spec's kernel widths in pixels refer to (the paper's images are about a
/// megapixel). Widths are scaled by `height / KERNEL_REFERENCE_HEIGHT` (at most 1) and floored
/// at one pixel, so a kernel covers the same share of a smaller image instead of most of it.
pub const KERNEL_REFERENCE_HEIGHT: f64 = 1000.0;

fn kernel_pixel_scale(scene: &Scene) -> f64 {
    (scene.camera.resolution.y as f64 / KERNEL_REFERENCE_HEIGHT).min(1.0)
}

/// A box in the pruning BVHs' coordinates (scaled by a power of two, so exactly).
fn scale_box(b: &Aabb, k: f32) -> Aabb {
    Aabb::new(b.min * k, b.max * k)
}
