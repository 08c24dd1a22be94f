//! Random walks: the camera subpath and the light subpath of one BDPT sample.
//!
//! A walk traces segments through index-matched boundaries, samples free flights in media,
//! records each vertex with its forward density (and, one step later, the reverse density of
//! its predecessor), scatters by BSDF or phase sampling, and plays Russian roulette with the
//! local continuation probability (`Bsdf::continuation`) once it has `rr_depth` segments.

use crate::bsdf::TransportMode;
use crate::geometry::{Ray, offset_origin};
use crate::integrators::paths::vertex::{Edge, Kind, Vertex, pdf_both};
pub use crate::integrators::paths::{continuation, local_continuation, roulette};
use crate::math::{Sampler, Spectrum};
use crate::scene::Scene;
use glam::{Vec2, Vec3};

/// The camera subpath through raster position `raster`, at most `max_vertices` vertices.
pub fn camera_subpath<'a>(
    scene: &'a Scene,
    raster: Vec2,
    max_vertices: usize,
    rr_depth: u32,
    sampler: &mut impl Sampler,
    path: &mut Vec<Vertex<'a>>,
) {
    camera_walk(scene, raster, max_vertices, rr_depth, false, sampler, path);
}

/// The camera subpath through `raster` up to and including the first vertex that is, like
/// the one before it, not on a delta surface (a diffuse or glossy surface, an emitter's
/// surface unless it is specular, a medium event, or the escape to a light at infinity; the
/// pinhole counts as one): the longest prefix in which a path to a light could still be
/// [`unconnectible`]. Its vertices and densities are those [`camera_subpath`] gives for the
/// same numbers, cut short.
pub fn camera_unconnectible_subpath<'a>(
    scene: &'a Scene,
    raster: Vec2,
    max_vertices: usize,
    rr_depth: u32,
    sampler: &mut impl Sampler,
    path: &mut Vec<Vertex<'a>>,
) {
    camera_walk(scene, raster, max_vertices, rr_depth, true, sampler, path);
}

fn camera_walk<'a>(
    scene: &'a Scene,
    raster: Vec2,
    max_vertices: usize,
    rr_depth: u32,
    stop_when_connectible: bool,
    sampler: &mut impl Sampler,
    path: &mut Vec<Vertex<'a>>,
) {
    path.clear();
    let cam = &scene.camera;
    path.push(Vertex {
        pdf_fwd: 1.0,
        medium: scene.camera_medium,
        ..Vertex::new(Kind::Camera, cam.position, Vec3::ZERO)
    });
    // We cos / pdf_We = 1 for the pinhole.
    walk(
        scene,
        cam.generate_ray(raster),
        Spectrum::ONE,
        TransportMode::Radiance,
        scene.camera_medium,
        max_vertices,
        rr_depth,
        stop_when_connectible,
        sampler,
        path,
    );
}

/// Whether the path of camera subpath `path`, whose last vertex is on a light, is one that
/// no connection makes: of the path E x_1 ... x_(k-1) L no two consecutive vertices are off
/// delta surfaces (the pinhole and the light counting as off), so every technique but s = 0
/// has density zero on it (paths E S* L, a light seen through mirrors and glass, and caustics
/// seen through them, E S+ D S+ L). The light seen directly (E L, k = 1) counts too,
/// although light tracing onto the pinhole also makes it.
pub fn unconnectible(path: &[Vertex]) -> bool {
    let n = path.len();
    let off = |i: usize| i == 0 || i + 1 == n || !is_specular_surface(&path[i]);
    n <= 2 || (1..n).all(|i| !(off(i - 1) && off(i)))
}

fn is_specular_surface(v: &Vertex) -> bool {
    v.is_specular_surface()
}

/// A light subpath: a light chosen by power, an emitted ray, then the walk.
pub fn light_subpath<'a>(
    scene: &'a Scene,
    max_vertices: usize,
    rr_depth: u32,
    sampler: &mut impl Sampler,
    path: &mut Vec<Vertex<'a>>,
) {
    path.clear();
    let Some((light, pmf, e)) = scene.sample_emission(sampler) else {
        return;
    };
    let l = &scene.lights[light];
    let infinite = l.is_infinite();
    let origin_pdf = pmf * if infinite { e.pdf_dir } else { e.pdf_pos };
    let n0 = if infinite { -e.dir } else { e.n };
    // The medium around the light (the side the ray leaves into when the light bounds media).
    let medium = scene.light_medium(light, n0, e.dir);
    path.push(Vertex {
        p_err: crate::geometry::gamma(8) * e.p.abs(), // The light vertex's throughput is 1 / its density; emission is applied when leaving.
        beta: Spectrum::splat(1.0 / origin_pdf),
        delta: l.is_delta(),
        pdf_fwd: origin_pdf,
        medium,
        ..Vertex::new(Kind::Light { light }, e.p, n0)
    });
    let cos = if e.n == Vec3::ZERO {
        1.0
    } else {
        e.n.dot(e.dir).abs()
    };
    let beta = e.le * cos / (pmf * e.pdf_pos * e.pdf_dir);
    let origin = if e.n == Vec3::ZERO || infinite {
        e.p
    } else {
        offset_origin(e.p, path[0].p_err, e.n, e.dir)
    };
    walk(
        scene,
        Ray::new(origin, e.dir),
        beta,
        TransportMode::Importance,
        medium,
        max_vertices,
        rr_depth,
        false,
        sampler,
        path,
    );
}

/// The random walk from `ray`, pushing vertices up to `max_vertices`; with
/// `stop_when_connectible` it ends after the first vertex that is, like the one before it,
/// not on a delta surface.
#[allow(clippy::too_many_arguments)]
fn walk<'a>(
    scene: &'a Scene,
    mut ray: Ray,
    mut beta: Spectrum,
    mode: TransportMode,
    mut medium: Option<u32>,
    max_vertices: usize,
    rr_depth: u32,
    stop_when_connectible: bool,
    sampler: &mut impl Sampler,
    path: &mut Vec<Vertex<'a>>,
) {
    while path.len() < max_vertices {
        // ---- Trace one segment: through index-matched boundaries, with free flight ----
        let mut edge = Edge::VACUUM;
        let mut crossings = 0;
        let found = loop {
            let sp = scene.intersect(&ray);
            if let Some(m) = medium {
                let t_hit = sp.as_ref().map_or(f32::INFINITY, |sp| sp.hit.t);
                let flight = scene.media[m as usize].sample_distance(
                    t_hit,
                    sampler.next_1d(),
                    sampler.next_1d(),
                );
                beta *= flight.weight;
                edge.push(scene, medium, flight.t);
                if flight.scattered {
                    let p = ray.at(flight.t);
                    break Some(Vertex {
                        beta,
                        edge,
                        medium,
                        ..Vertex::new(Kind::Medium { medium: m }, p, Vec3::ZERO)
                    });
                }
            }
            let Some(sp) = sp else { break None };
            if sp.is_null() {
                crossings += 1;
                if crossings > 256 {
                    break None;
                }
                medium = scene.medium_after(&sp, ray.d, medium);
                ray = sp.hit.spawn(ray.d);
                continue;
            }
            let kind = Kind::Surface {
                bsdf: sp.bsdf,
                frame: sp.frame,
                info: sp.info,
                material: sp.material,
            };
            break Some(Vertex {
                p_err: sp.hit.p_err,
                beta,
                delta: sp.bsdf.is_delta(),
                edge,
                medium,
                ..Vertex::new(kind, sp.hit.p, sp.hit.ng)
            });
        };
        if beta == Spectrum::ZERO {
            return;
        }
        let n = path.len();
        let prev_p = path[n - 1].p;
        let mut v = match found {
            Some(v) => v,
            // Escaped: a camera path may end on a light at infinity (the s = 0 technique);
            // its position is one unit along the escape direction from the last vertex.
            None if mode == TransportMode::Radiance
                && !scene.infinite_lights.is_empty()
                && edge.pass > 0.0 =>
            {
                let light = scene.infinite_lights[0];
                Vertex {
                    beta,
                    edge,
                    medium,
                    ..Vertex::new(Kind::Light { light }, prev_p + ray.d, ray.d)
                }
            }
            None => return,
        };
        // A vertex that f32 cannot tell apart from the one before it (a free flight of a few
        // ulps from a surface) leaves the edge between them without a direction or 1 / d²:
        // the walk ends before it (probability about sigma_t times an ulp per segment).
        let d2 = (v.p - prev_p).length_squared();
        if d2.is_nan() || d2 < f32::MIN_POSITIVE {
            return;
        }
        // Densities from positions (the same function every technique uses): of v from the
        // last vertex, and of the vertex before that from the last vertex given v.
        let (fwd, rev) = pdf_both(scene, &path[n - 1], (n >= 2).then(|| &path[n - 2]), &v);
        v.pdf_fwd = fwd * edge.factor(scene, v.is_medium(), true);
        if n >= 2 {
            let factor = path[n - 1]
                .edge
                .factor(scene, path[n - 2].is_medium(), false);
            path[n - 2].pdf_rev = rev * factor;
        }
        let escaped = found.is_none();
        path.push(v);
        let connectible = || !is_specular_surface(&v) && !is_specular_surface(&path[n - 1]);
        if escaped || path.len() == max_vertices || stop_when_connectible && connectible() {
            return;
        }

        // ---- Scatter ----
        let cur = path[path.len() - 1];
        let wo = -ray.d;
        let wi = match cur.kind {
            Kind::Surface { bsdf, frame, .. } => {
                let (u_lobe, u) = (sampler.next_1d(), sampler.next_2d());
                let Some(bs) = bsdf.sample(&frame, wo, u_lobe, u, mode) else {
                    return;
                };
                beta *= bs.weight;
                // The lobe taken (smooth plastic's may be either): the vertex's densities
                // from here on are that lobe's.
                let last = path.len() - 1;
                path[last].delta = bs.delta;
                bs.wi
            }
            Kind::Medium { medium: m } => {
                scene.media[m as usize]
                    .phase
                    .sample(wo, sampler.next_2d())
                    .0
            }
            Kind::Camera | Kind::Light { .. } => return,
        };
        let n = path.len();

        // ---- Russian roulette ----
        let q = continuation(scene, &cur, n - 1, rr_depth);
        if q < 1.0 {
            if sampler.next_1d() >= q {
                return;
            }
            beta /= q;
        }
        ray = match cur.kind {
            Kind::Surface { info, .. } => {
                if let Some(mi) = &info.interface {
                    medium = mi.crossing(wi, cur.n);
                }
                Ray::new(offset_origin(cur.p, cur.p_err, cur.n, wi), wi)
            }
            _ => Ray::new(cur.p, wi),
        };
    }
}
