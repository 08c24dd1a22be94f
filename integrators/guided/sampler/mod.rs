//! Drawing one guided path (spec §4.1): pick a guide path by weight, draw x_1 from its
//! first-vertex kernel (this decides the pixel), then each later vertex from the mixture of
//! the BSDF / phase branch (restricted to the guide's mode) and the segment's Gaussian, and end
//! on an emitter of the guide's kind. A step that fails (leaves the image, misses, hits the
//! wrong kind of vertex, crosses a surface the guide reflects at, ...) makes the sample a
//! failure: it still counts as a sample, of value zero.
//!
//! The density returned is the one the sample was drawn with along its guide path, `p(X | l)`,
//! assembled from sampling-time quantities for the branch taken (the other branch of each
//! mixture is evaluated); the tests compare it with the cache's evaluation of the finished path.

mod at;

use super::cache::GuideCache;
use super::gaussian::{sample_std_trunc, std_trunc_density};
use super::kernel::{
    MIN_PLANE_COS, Node, Reach, bsdf_branch_probability, coords, distance_density, dvec,
    is_infinite_vertex,
};
use super::manifold;
use crate::bsdf::TransportMode;
use crate::geometry::Ray;
use crate::integrators::paths::{Kind, Vertex, area_factor};
use crate::math::{Frame, Sampler};
use crate::path::{Path, Vertex as PathVertex, VertexKind};
use crate::scene::{Endpoint, Scene};
pub(super) use at::trace;
use at::{At, as_vertex, surface_vertex};
use glam::{Vec2, Vec3};

pub use super::stats::Failure;

/// A guided path drawn from a guide path, with what weighing it needs.
pub struct GuidedSample {
    /// The path, camera first; its pixel is where x_1 projects.
    pub path: Path,
    /// The raster position of x_1.
    pub raster: Vec2,
    /// Guide path followed.
    pub guide: usize,
    /// p(X | guide) as drawn.
    pub density: f64,
}

fn to_world(f: &Frame, origin: Vec3, c: [f64; 3]) -> Vec3 {
    (dvec(origin) + dvec(f.s) * c[0] + dvec(f.t) * c[1] + dvec(f.n) * c[2]).as_vec3()
}

/// Where a guided path was drawn from; its vertices are in the caller's buffer
/// ([`sample_path_into`]).
pub struct GuidedDraw {
    /// The raster position of x_1.
    pub raster: Vec2,
    /// Guide path followed.
    pub guide: usize,
    /// p(X | guide) as drawn, but for the vertices that start a specular chain the
    /// guide allows the chain step at (`deferred`).
    pub partial_density: f64,
    /// The chains of the guide that the step could solve, met on the way.
    pub deferred: manifold::DrawnChains,
}

impl GuidedDraw {
    /// Whether the specular-chain step drew some vertex of the path.
    pub fn used_chain_step(&self) -> bool {
        self.deferred.used_step()
    }

    /// [`manifold::DrawnChains::check`] of this draw's chains on the path's vertices `y`.
    pub fn check_chains(
        &self,
        scene: &Scene,
        cache: &GuideCache,
        y: &[Vertex],
        memo: &manifold::WalkMemo,
    ) -> Result<(), Failure> {
        self.deferred.check(scene, cache, self.guide, y, memo)
    }

    /// p(X | guide) of the path drawn (`path`): the partial density completed by
    /// [`manifold::DrawnChains::density`], as p_g evaluates it.
    pub fn density(&self, scene: &Scene, cache: &GuideCache, path: &Path) -> f64 {
        if self.deferred.is_empty() {
            return self.partial_density;
        }
        crate::integrators::paths::from_path(scene, path).map_or(0.0, |y| {
            self.partial_density * self.deferred.density(scene, cache, self.guide, &y)
        })
    }
}

/// Draw one guided path from `cache` (which must not be empty).
pub fn sample_path(
    scene: &Scene,
    cache: &GuideCache,
    sampler: &mut impl Sampler,
) -> Result<GuidedSample, Failure> {
    let mut path = Path::default();
    let d = sample_path_into(scene, cache, sampler, &mut path)?;
    if d.used_chain_step() {
        let y = crate::integrators::paths::from_path(scene, &path).ok_or(Failure::Structure)?;
        d.check_chains(scene, cache, &y, &manifold::WalkMemo::default())?;
    }
    let density = d.density(scene, cache, &path);
    Ok(GuidedSample {
        path,
        raster: d.raster,
        guide: d.guide,
        density,
    })
}

/// [`sample_path`] into `path` (cleared first), a buffer the caller keeps across samples
/// (a `Path` stores its vertices inline: building and moving one per sample costs more than
/// a failed sample's rays).
pub fn sample_path_into(
    scene: &Scene,
    cache: &GuideCache,
    sampler: &mut impl Sampler,
    path: &mut Path,
) -> Result<GuidedDraw, Failure> {
    let (l, _) = cache.select(sampler.next_f64(), sampler.next_f64());
    let guide = cache.guides[l];
    let len = guide.len as usize;
    let x0 = scene.camera.position;
    path.clear();
    path.pixel = 0;
    path.push(cache.vertex(scene, l, 0));

    // ---- Vertex 1: the isotropic first-vertex kernel ----
    let g1 = cache.vertex(scene, l, 1);
    let f0 = Frame::from_z((g1.p - x0).normalize());
    let s = guide.sigma1 as f64;
    let mut density;
    let (mut prev, mut at);
    let raster = match cache.node(l, 1) {
        Node::Medium { medium } => {
            let z = sample_std_trunc(3, sampler);
            let p = to_world(&f0, g1.p, [z[0] * s, z[1] * s, z[2] * s]);
            let w0 = (p - x0).normalize();
            let raster = scene
                .camera
                .raster_of_direction(w0)
                .ok_or(Failure::OffImage)?;
            let tr = scene
                .transmittance(
                    &Endpoint::point(x0),
                    Some(&Endpoint::point(p)),
                    w0,
                    scene.camera_medium,
                )
                .ok_or(Failure::Occluded)?;
            if tr.end_medium != Some(medium) {
                return Err(Failure::Occluded);
            }
            density = std_trunc_density(3, z[0] * z[0] + z[1] * z[1] + z[2] * z[2]) / (s * s * s);
            at = At::medium(p, medium);
            path.push(at.pv);
            path.pixel = scene.camera.pixel_index(raster) as u32;
            raster
        }
        Node::Surface { delta, .. } => {
            let z = sample_std_trunc(2, sampler);
            let p = to_world(&f0, g1.p, [z[0] * s, z[1] * s, 0.0]);
            let w0 = (p - x0).normalize();
            let raster = scene
                .camera
                .raster_of_direction(w0)
                .ok_or(Failure::OffImage)?;
            let (sp, medium) = trace(scene, Ray::new(x0, w0), scene.camera_medium);
            let sp = sp.ok_or(Failure::Miss)?;
            if sp.bsdf.is_black() || sp.bsdf.is_delta() != delta {
                return Err(Failure::Miss);
            }
            let t_p = dvec(f0.n).dot(dvec(g1.p) - dvec(x0)) / dvec(f0.n).dot(dvec(w0));
            density = std_trunc_density(2, z[0] * z[0] + z[1] * z[1]) / (s * s) * t_p * t_p
                / dvec(f0.n).dot(dvec(w0)).abs()
                * area_factor(x0, sp.hit.p, sp.hit.ng);
            let pv = surface_vertex(&sp);
            path.push(pv);
            path.pixel = scene.camera.pixel_index(raster) as u32;
            at = At {
                pv,
                sp: Some(sp),
                medium,
            };
            raster
        }
        Node::Emitter { .. } => return Err(Failure::Structure),
    };
    prev = path.vertices()[0];
    let mut deferred = manifold::DrawnChains::default();

    // ---- Vertices 2 .. L-1 ----
    for v in 2..len {
        let node = cache.node(l, v);
        let (g_prev, g) = (cache.vertex(scene, l, v - 1), cache.vertex(scene, l, v));
        let last = v + 1 == len;
        // Delta lights: a deterministic connection.
        if let Node::Emitter {
            light,
            reach: Reach::Delta,
        } = node
        {
            let lt = &scene.lights[light as usize];
            let ls = lt
                .sample_li(at.pv.p, Vec2::splat(0.5))
                .ok_or(Failure::Light)?;
            let (p, n) = if lt.is_infinite() {
                (at.pv.p + ls.wi, ls.wi)
            } else {
                (ls.p, Vec3::ZERO)
            };
            check_mode(cache, l, v - 1, &prev, &at.pv, p)?;
            path.push(PathVertex {
                p,
                n,
                ns: Vec3::ZERO,
                uv: glam::Vec2::ZERO,
                tangent: Vec3::ZERO,
                kind: VertexKind::Emitter { light, delta: true },
            });
            break;
        }
        let x = at.vertex();
        let p_b = bsdf_branch_probability(scene, &x);
        let kernel = cache.kernel(l, v);
        let g_inf = is_infinite_vertex(scene, &g);
        let seg_frame = *cache.frame(l, v);
        let ell = (dvec(g.p) - dvec(g_prev.p)).length();
        let medium_target = matches!(node, Node::Medium { .. });
        // Where the guide has a specular chain after x_{v-1}, the chain step draws x_v with
        // probability `share` (`manifold/`); no number is drawn elsewhere.
        let share = cache.manifold.share;
        let chain = (share > 0.0)
            .then(|| manifold::chain_at(scene, cache, l, v - 1))
            .flatten();
        let use_chain = chain.is_some() && (share >= 1.0 || (sampler.next_1d() as f64) < share);
        let use_bsdf = !use_chain && p_b > 0.0 && (p_b >= 1.0 || (sampler.next_1d() as f64) < p_b);

        // Choose the direction (and for medium targets the point).
        let mut point: Option<Vec3> = None;
        let dir: Vec3;
        let branch_density_w: f64; // solid-angle density (BSDF) or point density (Gaussian)
        if let Some(chain) = chain.filter(|_| use_chain) {
            let goal = manifold::draw_goal(scene, cache, l, &chain, at.pv.p, sampler)
                .ok_or(Failure::Light)?;
            let from = manifold::From {
                p: at.pv.p,
                n: at.pv.n,
                medium: None,
            };
            let seed = manifold::seed(scene, cache, l, v - 1, at.pv.p);
            dir = manifold::solve(scene, &from, seed, &chain, &goal)?.dir;
            // The vertex's density is the mixture's, completed from the finished path.
            branch_density_w = 0.0;
        } else if use_bsdf {
            let wo = (prev.p - at.pv.p).normalize();
            let (wi, pdf) = match &at.sp {
                Some(sp) => {
                    let u_lobe = if sp.bsdf.is_delta() {
                        // Restrict a smooth dielectric to the guide's lobe.
                        match cache.node(l, v - 1) {
                            Node::Surface { transmit: true, .. } => 1.0,
                            _ => 0.0,
                        }
                    } else {
                        sampler.next_1d()
                    };
                    let bs = sp
                        .bsdf
                        .sample(
                            &sp.frame,
                            wo,
                            u_lobe,
                            sampler.next_2d(),
                            TransportMode::Radiance,
                        )
                        .ok_or(Failure::Scatter)?;
                    // Smooth plastic's coating: a delta lobe on a surface the guide's structure
                    // treats as non-delta, which guided samples never take.
                    if bs.delta && !sp.bsdf.is_delta() {
                        return Err(Failure::Scatter);
                    }
                    (bs.wi, if bs.delta { 1.0 } else { bs.pdf as f64 })
                }
                None => {
                    let VertexKind::Medium { medium } = at.pv.kind else {
                        return Err(Failure::Structure);
                    };
                    let (wi, pdf) = scene.media[medium as usize]
                        .phase
                        .sample(wo, sampler.next_2d());
                    (wi, pdf as f64)
                }
            };
            dir = wi;
            if medium_target {
                let z = sample_std_trunc(1, sampler)[0];
                let sd = kernel.sigma_dist as f64;
                let t = ell + sd * z;
                if !(t > 0.0) {
                    return Err(Failure::Scatter);
                }
                point = Some((dvec(at.pv.p) + dvec(wi) * t).as_vec3());
                branch_density_w = pdf * distance_density(t, ell, sd) / (t * t);
            } else {
                branch_density_w = pdf;
            }
        } else {
            let dc = if matches!(at.pv.kind, VertexKind::Medium { .. }) {
                3
            } else {
                2
            };
            let m = kernel.mean(coords(&seg_frame, at.pv.p, g_prev.p, dc), dc);
            let dt = if medium_target { 3 } else { 2 };
            let z = sample_std_trunc(dt, sampler);
            let y = kernel.warp(z, m, dt);
            let q = kernel.density(y, m, dt);
            if medium_target {
                let p = to_world(&seg_frame, g.p, y);
                point = Some(p);
                dir = (p - at.pv.p).normalize();
                branch_density_w = q;
            } else if g_inf {
                let w = (dvec(seg_frame.s) * y[0] + dvec(seg_frame.t) * y[1] + dvec(seg_frame.n))
                    .normalize();
                let cos = w.dot(dvec(seg_frame.n));
                dir = w.as_vec3();
                branch_density_w = q / (cos * cos * cos);
            } else {
                let p = to_world(&seg_frame, g.p, [y[0], y[1], 0.0]);
                let w = (dvec(p) - dvec(at.pv.p)).normalize();
                let cos = dvec(seg_frame.n).dot(w);
                let t_p = dvec(seg_frame.n).dot(dvec(g.p) - dvec(at.pv.p)) / cos;
                if !(t_p > 0.0) || cos.abs() < MIN_PLANE_COS {
                    return Err(Failure::Miss);
                }
                dir = w.as_vec3();
                branch_density_w = q * t_p * t_p / cos.abs();
            }
        }
        if dir == Vec3::ZERO || !dir.is_finite() {
            return Err(Failure::Scatter);
        }

        // Find the vertex.
        let next: At;
        let taken: f64;
        let start_medium = at.medium_towards(scene, dir);
        if let Some(p) = point {
            let Node::Medium { medium } = node else {
                return Err(Failure::Structure);
            };
            let tr = scene
                .transmittance(&at.endpoint(), Some(&Endpoint::point(p)), dir, start_medium)
                .ok_or(Failure::Occluded)?;
            if tr.end_medium != Some(medium) {
                return Err(Failure::Occluded);
            }
            taken = branch_density_w;
            next = At::medium(p, medium);
        } else {
            // A direction a light at infinity does not emit along (outside the sun's cone) is
            // a miss whatever the ray would hit: decided before tracing it.
            if let Node::Emitter {
                light,
                reach: Reach::Infinite,
            } = node
                && scene.lights[light as usize].le(Vec3::ZERO, Vec3::ZERO, dir) == Vec3::ZERO
            {
                return Err(Failure::Light);
            }
            let (sp, medium) = trace(scene, at.ray(dir), start_medium);
            match (node, sp) {
                (
                    Node::Emitter {
                        light,
                        reach: Reach::Infinite,
                    },
                    None,
                ) => {
                    taken = branch_density_w;
                    next = At::emitter(at.pv.p + dir, dir, light, medium);
                }
                (
                    Node::Emitter {
                        light,
                        reach: Reach::Area,
                    },
                    Some(sp),
                ) => {
                    if sp.light() != Some(light as usize)
                        || scene.lights[light as usize].le(sp.hit.p, sp.hit.ng, -dir) == Vec3::ZERO
                    {
                        return Err(Failure::Light);
                    }
                    taken = branch_density_w * area_factor(at.pv.p, sp.hit.p, sp.hit.ng);
                    next = At::emitter(sp.hit.p, sp.hit.ng, light, medium);
                }
                (Node::Surface { delta, .. }, Some(sp)) if !last => {
                    if sp.bsdf.is_black() || sp.bsdf.is_delta() != delta {
                        return Err(Failure::Miss);
                    }
                    taken = branch_density_w * area_factor(at.pv.p, sp.hit.p, sp.hit.ng);
                    next = At {
                        pv: surface_vertex(&sp),
                        sp: Some(sp),
                        medium,
                    };
                }
                (Node::Emitter { .. }, _) => return Err(Failure::Light),
                _ => return Err(Failure::Miss),
            }
        }
        check_mode(cache, l, v - 1, &prev, &at.pv, next.pv.p)?;
        path.push(next.pv);

        // Mixture density at this vertex: the branch taken from sampling-time quantities, the
        // other branch evaluated.
        let other = if use_chain {
            0.0 // both branches are evaluated below
        } else {
            // Only y[v-2..=v] matter to the branch densities (index 2 of this window).
            let y_now = [
                Vertex::new(Kind::Camera, prev.p, prev.n),
                x,
                as_vertex(scene, &next),
            ];
            if use_bsdf {
                if p_b < 1.0 {
                    super::kernel::gaussian_branch_density_in(
                        scene, &y_now, 2, &seg_frame, &g_prev, &g, kernel,
                    )
                } else {
                    0.0
                }
            } else if p_b > 0.0 {
                let mt = medium_target.then_some((ell, kernel.sigma_dist as f64));
                super::kernel::bsdf_branch_density(scene, &y_now, 2, mt)
            } else {
                0.0
            }
        };
        let usual = if use_chain {
            // Both branches of the usual mixture evaluated.
            let y_now = [
                Vertex::new(Kind::Camera, prev.p, prev.n),
                x,
                as_vertex(scene, &next),
            ];
            let gaussian = if p_b < 1.0 {
                super::kernel::gaussian_branch_density_in(
                    scene, &y_now, 2, &seg_frame, &g_prev, &g, kernel,
                )
            } else {
                0.0
            };
            let bsdf = if p_b > 0.0 {
                super::kernel::bsdf_branch_density(scene, &y_now, 2, None)
            } else {
                0.0
            };
            p_b * bsdf + (1.0 - p_b) * gaussian
        } else if use_bsdf {
            p_b * taken + (1.0 - p_b) * other
        } else {
            (1.0 - p_b) * taken + p_b * other
        };
        match chain {
            Some(chain) => deferred.push(chain, usual, use_chain),
            None => density *= usual,
        }
        prev = at.pv;
        at = next;
    }
    Ok(GuidedDraw {
        raster,
        guide: l,
        partial_density: density,
        deferred,
    })
}

/// The path must reflect or transmit at surface vertex `v` as the guide does.
fn check_mode(
    cache: &GuideCache,
    l: usize,
    v: usize,
    prev: &PathVertex,
    x: &PathVertex,
    next: Vec3,
) -> Result<(), Failure> {
    if let Node::Surface { transmit, .. } = cache.node(l, v) {
        let t = ((prev.p - x.p).dot(x.n) > 0.0) != ((next - x.p).dot(x.n) > 0.0);
        if t != transmit {
            return Err(Failure::Structure);
        }
    }
    Ok(())
}
