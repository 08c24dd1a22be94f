//! The per-vertex densities of the guided technique (a path's structure, `Node` and its hash,
//! is in `structure.rs` and re-exported here).
//!
//! A guide path `g_0 .. g_{L-1}` (camera to emitter) is followed vertex by vertex. Vertex 1 is
//! drawn from an isotropic kernel on the plane through `g_1` orthogonal to the camera ray (3D
//! in a medium). Each later vertex `x_v` is drawn from a mixture: with probability `p_b` (set
//! by the roughness at `x_{v-1}`) by the BSDF or phase function at `x_{v-1}` restricted to the
//! guide's mode there, otherwise from the segment's conditional Gaussian [`Kernel`] given
//! `x_{v-1}`: on the plane through `g_v` orthogonal to the guide segment for surface targets
//! (the ray towards the drawn point gives the vertex), a 3D point for medium targets, a point
//! on the unit-distance plane for lights at infinity. Delta lights end the path by a
//! deterministic connection. Densities are in the measure of DESIGN.md §3 (area, volume, or
//! solid angle at infinity; delta events carry discrete probabilities) and are computed from
//! vertex positions by the functions here, for sampling and evaluation alike.

use super::gaussian::{LogDensity, R, std_trunc_density, std_trunc_log_density};
use crate::bsdf::TransportMode;
pub use crate::integrators::paths::structure::{
    Node, Reach, hash_nodes, reach, signature, signature_of_split, structure,
};
use crate::integrators::paths::{Kind, Vertex, area_factor, vertex::to_measure};
use crate::math::Frame;
use crate::path::{Vertex as PathVertex, VertexKind};
use crate::scene::Scene;
use glam::{DVec3, Vec3};

/// The conditional Gaussian of one guide segment (g_{v-1} -> g_v), in the segment's frame
/// (`n` along the segment, or the direction for a light at infinity). Target coordinates `y`
/// (2D on the plane through g_v, 3D for a medium target, unit-plane coordinates at infinity)
/// are relative to g_v, conditioning coordinates `z` (2D, 3D in a medium) relative to g_{v-1}.
/// At sample time only the conditional mean `mu1 + K (z - mu2)` is computed; the conditional
/// covariance is stored as its eigenvectors `e` (columns) and standard deviations `s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kernel {
    /// Mean of the target coordinates `y` over the neighbours.
    pub mu1: [f32; 3],
    /// Mean of the conditioning coordinates `z` over the neighbours.
    pub mu2: [f32; 3],
    /// Regression matrix `K = Σ12 Σ22⁻¹`.
    pub k: [[f32; 3]; 3],
    /// Eigenvectors of the conditional covariance, as columns.
    pub e: [[f32; 3]; 3],
    /// Standard deviations along the eigenvectors `e`.
    pub s: [f32; 3],
    /// Medium targets: std of the distance along a phase-sampled direction.
    pub sigma_dist: f32,
}

impl Kernel {
    /// An isotropic kernel of std `sigma` centred on the guide vertex, without regression.
    pub fn isotropic(sigma: f32) -> Kernel {
        Kernel {
            mu1: [0.0; 3],
            mu2: [0.0; 3],
            k: [[0.0; 3]; 3],
            e: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            s: [sigma; 3],
            sigma_dist: sigma,
        }
    }

    /// Conditional mean of the target given conditioning coordinates `z` (dimension `dc`).
    pub fn mean(&self, z: [f64; 3], dc: usize) -> [f64; 3] {
        match dc {
            2 => self.mean_in::<2>(z),
            3 => self.mean_in::<3>(z),
            _ => panic!("kernels condition on 2 or 3 coordinates"),
        }
    }

    /// [`Self::mean`] with the dimension known at compile time (p_g evaluates it per
    /// candidate guide and vertex: the loops unroll).
    #[inline]
    fn mean_in<const DC: usize>(&self, z: [f64; 3]) -> [f64; 3] {
        let mut m = [0.0; 3];
        for (i, mi) in m.iter_mut().enumerate() {
            *mi = self.mu1[i] as f64;
            for j in 0..DC {
                *mi += self.k[i][j] as f64 * (z[j] - self.mu2[j] as f64);
            }
        }
        m
    }

    /// Truncated density of target coordinates `y` (dimension `dt`) around mean `m`.
    pub fn density(&self, y: [f64; 3], m: [f64; 3], dt: usize) -> f64 {
        self.log_density(y, m, dt).value()
    }

    /// [`Self::density`] as a [`LogDensity`].
    pub fn log_density(&self, y: [f64; 3], m: [f64; 3], dt: usize) -> LogDensity {
        match dt {
            1 => self.log_density_in::<1>(y, m),
            2 => self.log_density_in::<2>(y, m),
            3 => self.log_density_in::<3>(y, m),
            _ => panic!("truncated Gaussians are 1D to 3D"),
        }
    }

    #[inline]
    fn log_density_in<const DT: usize>(&self, y: [f64; 3], m: [f64; 3]) -> LogDensity {
        let mut z2 = 0.0;
        let mut norm = 1.0;
        for i in 0..DT {
            let mut c = 0.0;
            for j in 0..DT {
                c += self.e[j][i] as f64 * (y[j] - m[j]);
            }
            let s = self.s[i] as f64;
            z2 += (c / s) * (c / s);
            norm *= s;
        }
        if z2 > R * R {
            return LogDensity::ZERO;
        }
        std_trunc_log_density(DT, z2).scaled(1.0 / norm)
    }

    /// Map standard-normal coordinates `z` to target coordinates around mean `m`.
    pub fn warp(&self, z: [f64; 3], m: [f64; 3], dt: usize) -> [f64; 3] {
        let mut y = m;
        for (j, yj) in y.iter_mut().enumerate().take(dt) {
            for (i, zi) in z.iter().enumerate().take(dt) {
                *yj += self.e[j][i] as f64 * self.s[i] as f64 * zi;
            }
        }
        y
    }
}

/// `v` in f64, as the densities are computed.
pub fn dvec(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

/// Frame of guide segment (g_{v-1} -> g_v): z along the segment (the direction itself for a
/// light at infinity, stored in the vertex normal).
pub fn segment_frame(prev: &PathVertex, g: &PathVertex, g_infinite: bool) -> Frame {
    let n = if g_infinite {
        g.n
    } else {
        (g.p - prev.p).normalize()
    };
    Frame::from_z(n)
}

/// Coordinates of point `x` relative to `origin` in frame `f`, 2D or 3D.
pub fn coords(f: &Frame, x: Vec3, origin: Vec3, dims: usize) -> [f64; 3] {
    coords_of(f, dvec(x) - dvec(origin), dims)
}

/// [`coords`] of the offset `d` (a point minus the origin).
fn coords_of(f: &Frame, d: DVec3, dims: usize) -> [f64; 3] {
    [
        d.dot(dvec(f.s)),
        d.dot(dvec(f.t)),
        if dims == 3 { d.dot(dvec(f.n)) } else { 0.0 },
    ]
}

/// Unit-plane coordinates of direction `w` in frame `f` (None behind the plane).
pub fn direction_coords(f: &Frame, w: Vec3) -> Option<[f64; 3]> {
    let w = dvec(w);
    let c = w.dot(dvec(f.n));
    (c > 0.0).then(|| [w.dot(dvec(f.s)) / c, w.dot(dvec(f.t)) / c, 0.0])
}

/// Smallest |cos| between a direction drawn through a kernel plane and the plane's normal.
/// Below it the sampler fails (and the density is 0): there the point on the plane moves by
/// 1/|cos| per unit of direction, so the f32 hit point no longer determines it (a sample with
/// |cos| = 2e-4 was drawn with a density 8 % off its evaluation). Sampler and evaluation
/// apply the same cut, so p_g stays the exact density of what the sampler produces.
pub const MIN_PLANE_COS: f64 = 1e-2;

/// Solid-angle density of the direction from `o` towards `x` when a point is drawn on the
/// plane through `g` orthogonal to `f.n` with 2D density `q2` (target coordinates relative to
/// `g`) and the ray is shot through it: `q2(P) t_P² / |n·ω|`, 0 if the plane is behind or
/// `|n·ω| <` [`MIN_PLANE_COS`].
pub fn plane_direction_density(
    f: &Frame,
    g: Vec3,
    o: Vec3,
    w: Vec3,
    q2: impl Fn([f64; 3]) -> f64,
) -> f64 {
    plane_direction_density_unit(f, dvec(g), dvec(o), dvec(w).normalize(), |c| {
        LogDensity::plain(q2(c))
    })
    .value()
}

/// [`plane_direction_density`] with the points in f64, the direction `w` a unit vector and
/// the plane's density `q2` a [`LogDensity`].
fn plane_direction_density_unit(
    f: &Frame,
    g: DVec3,
    o: DVec3,
    w: DVec3,
    q2: impl Fn([f64; 3]) -> LogDensity,
) -> LogDensity {
    let n = dvec(f.n);
    let cos = n.dot(w);
    if cos.abs() < MIN_PLANE_COS {
        return LogDensity::ZERO;
    }
    let t_p = n.dot(g - o) / cos;
    if !(t_p > 0.0) {
        return LogDensity::ZERO;
    }
    let p = o + w * t_p - g;
    let y = [p.dot(dvec(f.s)), p.dot(dvec(f.t)), 0.0];
    q2(y).scaled(t_p * t_p / cos.abs())
}

/// Probability of the BSDF branch at vertex `x` (0 at the camera): `clamp(1 − 1.5 roughness)`
/// on surfaces (1 for specular ones), `clamp(1.5 |g| − 0.5)` in media (0 when isotropic).
pub fn bsdf_branch_probability(scene: &Scene, x: &Vertex) -> f64 {
    match x.kind {
        Kind::Surface { bsdf, .. } => (1.0 - 1.5 * bsdf.roughness() as f64).clamp(0.0, 1.0),
        Kind::Medium { medium } => {
            let g = scene.media[medium as usize].phase.g.abs() as f64;
            (1.5 * g - 0.5).clamp(0.0, 1.0)
        }
        Kind::Camera | Kind::Light { .. } => 0.0,
    }
}

/// Density of the 1D truncated Gaussian N(ell, sigma) at distance `t` (0 outside ±R sigma or
/// for t <= 0, which sampling counts as failures, not renormalised).
pub fn distance_density(t: f64, ell: f64, sigma: f64) -> f64 {
    if !(t > 0.0) {
        return 0.0;
    }
    let z = (t - ell) / sigma;
    std_trunc_density(1, z * z) / sigma
}

/// Density of the BSDF branch at `y[v-1]` producing `y[v]` (from `y[v-2]`), in `y[v]`'s
/// measure. Restricted to the guide's mode: a smooth dielectric picks the guide's lobe with
/// probability 1; other BSDFs sample freely and a sample in the wrong mode fails (so their
/// density is the BSDF's own). Medium targets add the distance density around `ell`.
pub fn bsdf_branch_density(
    scene: &Scene,
    y: &[Vertex],
    v: usize,
    medium_target: Option<(f64, f64)>,
) -> f64 {
    let (x, prev, next) = (&y[v - 1], &y[v - 2], &y[v]);
    let wo = (prev.p - x.p).normalize();
    let to_next = if next.is_infinite_light(scene) {
        next.n
    } else {
        (next.p - x.p).normalize()
    };
    let pdf_w = match x.kind {
        Kind::Surface { bsdf, frame, .. } => {
            if bsdf.is_delta() {
                // The restricted lobe is chosen with probability 1; the path is only valid if
                // its direction is that lobe's (the sampler never produces another one).
                if bsdf.delta_lobe_probability(&frame, wo, to_next) > 0.0 {
                    1.0
                } else {
                    0.0
                }
            } else {
                bsdf.pdf(&frame, wo, to_next, TransportMode::Radiance)
            }
        }
        Kind::Medium { medium } => scene.media[medium as usize].phase.eval(wo, to_next),
        Kind::Camera | Kind::Light { .. } => 0.0,
    };
    if pdf_w == 0.0 {
        return 0.0;
    }
    match medium_target {
        Some((ell, sigma)) => {
            let t = (dvec(next.p) - dvec(x.p)).length();
            pdf_w as f64 * distance_density(t, ell, sigma) / (t * t)
        }
        None => to_measure(scene, pdf_w, x.p, next) as f64,
    }
}

/// Density of the first vertex `y[1]` under the isotropic kernel of std `sigma1` around the
/// guide's first vertex `g1` (plane through g1 orthogonal to the camera ray; 3D in media).
pub fn first_vertex_density(scene: &Scene, y: &[Vertex], g1: &PathVertex, sigma1: f32) -> f64 {
    let kernel = FirstKernel::new(scene, g1, sigma1, 0);
    FirstVertexQuery::new(scene, &y[1]).density(&kernel)
}

/// A guide's first-vertex kernel as [`FirstVertexQuery::density`] reads it: its centre, its
/// distance from the camera and its variance, in f64, with the guide's index.
#[derive(Debug, Clone, Copy)]
pub struct FirstKernel {
    g: DVec3,
    dist: f64,
    s2: f64,
    /// Index of the guide path.
    pub guide: u32,
}

impl FirstKernel {
    /// The kernel of std `sigma1` around guide `guide`'s first vertex `g1`.
    pub fn new(scene: &Scene, g1: &PathVertex, sigma1: f32, guide: u32) -> FirstKernel {
        let g = dvec(g1.p);
        FirstKernel {
            g,
            dist: (g - dvec(scene.camera.position)).length(),
            s2: (sigma1 as f64) * (sigma1 as f64),
            guide,
        }
    }
}

/// What the first-vertex density needs of x_1 alone (its direction and distance from the
/// camera, the cosine at it), computed once and tested against every candidate guide.
#[derive(Debug, Clone, Copy)]
pub struct FirstVertexQuery {
    x0: DVec3,
    x1: DVec3,
    medium: bool,
    /// Unit direction from the camera to x_1, the distance, and |cos| at x_1 (1 in media).
    w: DVec3,
    d1: f64,
    cos1: f64,
}

impl FirstVertexQuery {
    /// The query of first path vertex `x1`.
    pub fn new(scene: &Scene, x1: &Vertex) -> FirstVertexQuery {
        FirstVertexQuery::at(scene, x1.p, x1.n, x1.is_medium())
    }

    /// [`Self::new`] for a first vertex at `p` with normal `n` (zero in a medium).
    pub fn at(scene: &Scene, p: Vec3, n: Vec3, medium: bool) -> FirstVertexQuery {
        let x0 = dvec(scene.camera.position);
        let to_x1 = dvec(p) - x0;
        let d1 = to_x1.length();
        let w = to_x1 / d1;
        let cos1 = if n == Vec3::ZERO {
            1.0
        } else {
            dvec(n).dot(w).abs()
        };
        FirstVertexQuery {
            x0,
            x1: dvec(p),
            medium,
            w,
            d1,
            cos1,
        }
    }

    /// Density of x_1 under `k`, in x_1's measure (area on surfaces, volume in media).
    #[inline]
    pub fn density(&self, k: &FirstKernel) -> f64 {
        self.inside(k).map_or(0.0, |t| self.density_of(&t))
    }

    /// Where x_1 falls in `k`'s support, or `None` outside it (density 0): the cheap half of
    /// [`Self::density`], which [`Self::density_of`] finishes.
    #[inline]
    pub fn inside(&self, k: &FirstKernel) -> Option<FirstTest> {
        // The kernel is isotropic, so only the distance to g1 matters (in the plane through
        // g1 orthogonal to the camera ray, or in 3D): no frame is needed.
        if self.medium {
            let r2 = (self.x1 - k.g).length_squared() / k.s2;
            return (r2 <= R * R).then_some(FirstTest {
                guide: k.guide,
                r2,
                s2: k.s2,
                t_p: 0.0,
                cos: 0.0,
            });
        }
        let d = k.g - self.x0;
        let cos = d.dot(self.w) / k.dist;
        if !(cos > 0.0) {
            return None;
        }
        let t_p = k.dist / cos;
        let r2 = (self.x0 + self.w * t_p - k.g).length_squared() / k.s2;
        (r2 <= R * R).then_some(FirstTest {
            guide: k.guide,
            r2,
            s2: k.s2,
            t_p,
            cos,
        })
    }

    /// The density of a kernel that [`Self::inside`] found x_1 in.
    #[inline]
    pub fn density_of(&self, t: &FirstTest) -> f64 {
        self.log_density_of(t).value()
    }

    /// [`Self::density_of`] as a [`LogDensity`].
    #[inline]
    pub fn log_density_of(&self, t: &FirstTest) -> LogDensity {
        if self.medium {
            return std_trunc_log_density(3, t.r2).scaled(1.0 / (t.s2 * t.s2.sqrt()));
        }
        // Solid angle (t_p² / cos on the kernel's plane), then area measure at x1 (|cos| / d²).
        std_trunc_log_density(2, t.r2)
            .scaled(t.t_p * t.t_p / (t.s2 * t.cos) * self.cos1 / (self.d1 * self.d1))
    }
}

/// A first-vertex kernel that holds x_1 ([`FirstVertexQuery::inside`]): the guide, x_1's
/// squared distance from the centre in standard deviations, and what the density needs
/// besides (the kernel's variance; on surfaces the distance to the kernel's plane along the
/// camera ray and the cosine there).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FirstTest {
    /// Index of the guide path.
    pub guide: u32,
    r2: f64,
    s2: f64,
    t_p: f64,
    cos: f64,
}

/// Density of the Gaussian branch of guide segment (g_prev -> g) with kernel `k` producing
/// `y[v]` from `y[v-1]`, in `y[v]`'s measure.
pub fn gaussian_branch_density(
    scene: &Scene,
    y: &[Vertex],
    v: usize,
    g_prev: &PathVertex,
    g: &PathVertex,
    g_infinite: bool,
    k: &Kernel,
) -> f64 {
    let f = segment_frame(g_prev, g, g_infinite);
    gaussian_branch_density_in(scene, y, v, &f, g_prev, g, k)
}

/// [`gaussian_branch_density`] with the segment's frame `f` ([`segment_frame`]) given (the
/// cache keeps each guide segment's frame).
pub fn gaussian_branch_density_in(
    scene: &Scene,
    y: &[Vertex],
    v: usize,
    f: &Frame,
    g_prev: &PathVertex,
    g: &PathVertex,
    k: &Kernel,
) -> f64 {
    SegmentTarget::new(scene, y, v).gaussian_density(f, g_prev, g, k)
}

/// What the Gaussian branch density of the path segment `y[v-1] -> y[v]` needs of the path
/// alone, not of the guide: computed once per path vertex and read by every candidate guide
/// of p_g's sum ([`GuideCache::terms`](super::cache::GuideCache::terms)).
#[derive(Debug, Clone, Copy)]
pub struct SegmentTarget {
    /// `y[v-1]` and whether it is a medium vertex (3D conditioning coordinates).
    x: DVec3,
    x_medium: bool,
    target: Target,
}

#[derive(Debug, Clone, Copy)]
enum Target {
    /// A light at infinity: the unit direction and its cosine with the segment's axis are
    /// per guide; here the direction.
    Infinite { dir: DVec3 },
    /// A point in a medium.
    Medium { p: DVec3 },
    /// A surface point: the unit direction from `x` to it and the solid-angle-to-area factor.
    Surface { w: DVec3, area: f64 },
}

impl Target {
    /// The surface point `next` (normal `next_n`) as seen from `x`.
    fn surface(x: Vec3, next: Vec3, next_n: Vec3) -> Target {
        Target::Surface {
            w: dvec(next - x).normalize(),
            area: area_factor(x, next, next_n),
        }
    }
}

impl SegmentTarget {
    /// What the segment `y[v-1] -> y[v]` of path `y` gives every candidate guide.
    pub fn new(scene: &Scene, y: &[Vertex], v: usize) -> SegmentTarget {
        let (x, next) = (&y[v - 1], &y[v]);
        let target = if next.is_infinite_light(scene) {
            Target::Infinite { dir: dvec(next.n) }
        } else if next.is_medium() {
            Target::Medium { p: dvec(next.p) }
        } else {
            Target::surface(x.p, next.p, next.n)
        };
        SegmentTarget {
            x: dvec(x.p),
            x_medium: x.is_medium(),
            target,
        }
    }

    /// The segment from surface point `x` to surface point `next` with normal `next_n`.
    pub fn surface_pair(x: Vec3, next: Vec3, next_n: Vec3) -> SegmentTarget {
        SegmentTarget {
            x: dvec(x),
            x_medium: false,
            target: Target::surface(x, next, next_n),
        }
    }

    /// For a segment from a surface vertex to a surface target: the vertex, the unit
    /// direction to the target and the solid-angle-to-area factor, what a
    /// [`PlaneKernel`](super::plane::PlaneKernel) evaluates the density from.
    #[inline]
    pub fn surface_to_surface(&self) -> Option<(DVec3, DVec3, f64)> {
        match self.target {
            Target::Surface { w, area } if !self.x_medium => Some((self.x, w, area)),
            _ => None,
        }
    }

    /// The Gaussian branch density of guide segment (g_prev -> g) in frame `f` with kernel
    /// `k`, in the target's measure (area, volume, or solid angle at infinity).
    pub fn gaussian_density(
        &self,
        f: &Frame,
        g_prev: &PathVertex,
        g: &PathVertex,
        k: &Kernel,
    ) -> f64 {
        self.log_gaussian_density(f, g_prev, g, k).value()
    }

    /// [`Self::gaussian_density`] as a [`LogDensity`].
    pub fn log_gaussian_density(
        &self,
        f: &Frame,
        g_prev: &PathVertex,
        g: &PathVertex,
        k: &Kernel,
    ) -> LogDensity {
        let dc = if self.x_medium { 3 } else { 2 };
        let m = k.mean(coords_of(f, self.x - dvec(g_prev.p), dc), dc);
        match self.target {
            Target::Infinite { dir } => {
                let Some(c) = direction_coords(f, dir.as_vec3()) else {
                    return LogDensity::ZERO;
                };
                let cos = dir.normalize().dot(dvec(f.n));
                k.log_density(c, m, 2).scaled(1.0 / (cos * cos * cos))
            }
            Target::Medium { p } => k.log_density(coords_of(f, p - dvec(g.p), 3), m, 3),
            Target::Surface { w, area } => {
                plane_direction_density_unit(f, dvec(g.p), self.x, w, |c| k.log_density(c, m, 2))
                    .scaled(area)
            }
        }
    }
}

/// Whether `v` of a path is a light at infinity.
pub fn is_infinite_vertex(scene: &Scene, v: &PathVertex) -> bool {
    matches!(v.kind, VertexKind::Emitter { light, .. } if scene.lights[light as usize].is_infinite())
}
