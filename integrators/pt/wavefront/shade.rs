//! One vertex of up to sixteen paths at once: what [`PathTracer::advance`] does at a surface,
//! in three steps.
//!
//! 1. **Gather** (scalar, per path): emission (a hit emitter's, or the lights at infinity
//!    for a ray that escaped: few paths, so pt's own code adds it), the hit's point and
//!    normals, its material (checkerboard and one-sided backs resolved as
//!    `Scene::surface_point` does), and the path's random numbers, drawn in `advance`'s order
//!    from the path's own sampler: for a diffuse vertex the light's index and point (table
//!    look-ups: a point on a mesh light here; a spherical light's centre, radius and numbers,
//!    seen from outside it, are handed to the lanes; whole `Light::sample_li` for other
//!    lights), then the BSDF's three numbers.
//! 2. **Shade** (sixteen lanes): next-event estimation (a mesh light's density and
//!    direction, a spherical light's whole cone sample, the BSDF's value and density, the
//!    power heuristic, the shadow segment) and
//!    the continuation (cosine-weighted, mirror or Fresnel-weighted specular sampling, its
//!    weight, the spawned ray), as lane operations (`lanes.rs`) that repeat the scalar code's
//!    arithmetic (`math.rs`).
//! 3. **Scatter** (scalar, per path): the roulette number where a path needs one, the path's
//!    new state, and its next-event sample queued for the shadow batch.

use super::lanes::{F, M, Soa3, V3, W};
use super::math::{
    Frame, cosine_hemisphere, fresnel_dielectric, geometry_agrees, offset_origin, power_heuristic,
    shadow_segment, sphere_sample_li,
};
use crate::bsdf::Bsdf;
use crate::geometry::{Hit, Ray, gamma};
use crate::integrators::pt::round::Round;
use crate::integrators::pt::{Deferred, Extras, PathState, PathTracer, Scattered};
use crate::light::Light;
use crate::light::{AreaLight, AreaShape};
use crate::math::{INV_PI, Sampler, Spectrum};
use crate::scene::{Material, Scene, ShapeInfo};

/// The lanes of one call, filled by the gather step (lanes past the chunk's length stay at
/// their defaults: no hit, so they do nothing).
#[derive(Default)]
struct Gathered {
    d: Soa3,
    beta: Soa3,
    l: Soa3,
    p: Soa3,
    p_err: Soa3,
    ng: Soa3,
    ns: Soa3,
    /// Scatters (not black, not at the maximum depth).
    scatter: [bool; W],
    diffuse: [bool; W],
    albedo: Soa3,
    eta: [f32; W],
    /// Roulette continuation of the vertex (`roulette_probability`).
    q: [f32; W],
    /// A smooth conductor (a mirror) and its reflectance.
    conductor: [bool; W],
    reflectance: Soa3,
    /// Next-event estimation ran (a diffuse vertex), and found a point on a light.
    nee: [bool; W],
    nee_found: [bool; W],
    /// The light point was drawn on a mesh light without spot profile (its density and
    /// direction are left to the lanes); otherwise `Light::sample_li` gave `wi`, `pdf_l`,
    /// `delta` and `finite` below.
    on_mesh: [bool; W],
    /// The light is a sphere without spot profile or texture and the vertex lies outside it:
    /// the lanes sample it (`math::sphere_sample_li`) from its centre, radius and numbers.
    on_sphere: [bool; W],
    sphere_c: Soa3,
    sphere_r: [f32; W],
    ul_x: [f32; W],
    ul_y: [f32; W],
    p_l: Soa3,
    n_l: Soa3,
    li: Soa3,
    pmf_l: [f32; W],
    area_l: [f32; W],
    wi_l: Soa3,
    pdf_l: [f32; W],
    delta_l: [bool; W],
    finite_l: [bool; W],
    u_lobe: [f32; W],
    u_x: [f32; W],
    u_y: [f32; W],
    /// The vertex was shaded by pt's scalar code in the gather step (a material the lanes
    /// do not know, [`in_lanes`]), and whether its path goes on.
    scalar: [Option<bool>; W],
}

/// What the lanes computed, for the scatter step.
struct Shaded {
    l: V3,
    /// Next-event value (before visibility) and shadow segment.
    nee_value: V3,
    nee_query: M,
    query_o: V3,
    query_d: V3,
    query_len: F,
    /// The continuation was sampled: new throughput (before roulette), density, delta.
    cont: M,
    beta: V3,
    pdf: F,
    delta: M,
    wi: V3,
    origin: V3,
}

#[inline(always)]
fn v3(a: &Soa3) -> V3 {
    V3::load(a)
}

#[inline(always)]
fn f(a: &[f32; W]) -> F {
    F::from_array(a)
}

#[inline(always)]
fn m(a: &[bool; W]) -> M {
    M::from_bools(a)
}

/// The rounds of `PathTracer::li_row_wavefront` until every path of `paths` has ended:
/// each round traces the paths' rays together, shades them sixteen at a time
/// ([`shade_lanes`]), then settles the round (shadow rays, ended paths).
#[inline(always)]
pub(super) fn rounds<S: Sampler>(
    pt: &PathTracer,
    scene: &Scene,
    mut paths: Vec<(usize, PathState)>,
    samplers: &mut [S],
    out: &mut [Spectrum],
    b: &mut Round,
) {
    while !paths.is_empty() {
        b.trace(scene, &paths);
        for (c, (group, hits)) in paths.chunks_mut(W).zip(b.hits.chunks_mut(W)).enumerate() {
            shade_lanes(
                pt,
                scene,
                group,
                hits,
                samplers,
                c * W,
                &mut b.alive,
                &mut b.deferred,
                &mut b.owner,
            );
        }
        b.settle(scene, &mut paths, out);
    }
}

/// One vertex of each path of `paths` (at most [`W`]) whose ray found `hits[k]`: the
/// paths' radiance, throughput and next ray updated as `advance` would, `alive` pushed
/// for each, and each next-event sample pushed to `deferred` with its path's index in
/// the round (`base + k`) in `owner`. Scenes that `super::supports` accepts only.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn shade_lanes<S: Sampler>(
    pt: &PathTracer,
    scene: &Scene,
    paths: &mut [(usize, PathState)],
    hits: &mut [Option<Hit>],
    samplers: &mut [S],
    base: usize,
    alive: &mut Vec<bool>,
    deferred: &mut Vec<Deferred>,
    owner: &mut Vec<usize>,
) {
    debug_assert!(paths.len() <= W && hits.len() == paths.len());
    let g = gather(pt, scene, paths, hits, samplers, base, deferred, owner);
    let s = shade(&g);
    let (l, nee_value, query_o, query_d, query_len) = (
        s.l.store(),
        s.nee_value.store(),
        s.query_o.store(),
        s.query_d.store(),
        s.query_len.to_array(),
    );
    let (beta, pdf, wi, origin) = (
        s.beta.store(),
        s.pdf.to_array(),
        s.wi.store(),
        s.origin.store(),
    );
    // The masks as bits, read once (lane `k` is bit `k`).
    let (nee_query, cont, delta) = (s.nee_query.bits(), s.cont.bits(), s.delta.bits());
    let on = |bits: u16, k: usize| bits >> k & 1 != 0;
    for (k, (i, path)) in paths.iter_mut().enumerate() {
        if let Some(goes_on) = g.scalar[k] {
            alive.push(goes_on);
            continue;
        }
        if g.nee[k] {
            deferred.push(Deferred {
                beta: path.beta,
                value: nee_value.get(k),
                query: on(nee_query, k).then_some((query_o.get(k), query_d.get(k), query_len[k])),
            });
            owner.push(base + k);
        }
        path.l = l.get(k);
        if !on(cont, k) {
            alive.push(false);
            continue;
        }
        path.beta = beta.get(k);
        path.prev = Scattered {
            delta: on(delta, k),
            pdf: pdf[k],
            p: g.p.get(k),
        };
        path.pass = 1.0;
        // Roulette (`PathTracer::roulette`), with the path's own next number.
        let q = g.q[k];
        if q < 1.0 {
            if samplers[*i].next_1d() >= q {
                alive.push(false);
                continue;
            }
            path.beta /= q;
        }
        path.ray = Ray::new(origin.get(k), wi.get(k));
        path.depth += 1;
        alive.push(true);
    }
}

/// Step 1 (module doc): the lanes' inputs, and the paths' random numbers up to the
/// roulette. Emission (of a hit emitter, or of the lights at infinity for a ray that
/// escaped) is added to the path here, by pt's own code: few lanes need it. A vertex
/// the lanes do not shade ([`in_lanes`]) is advanced here by pt's own code, its
/// next-event sample pushed to `deferred` (owned by `base + k`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn gather<S: Sampler>(
    pt: &PathTracer,
    scene: &Scene,
    paths: &mut [(usize, PathState)],
    hits: &mut [Option<Hit>],
    samplers: &mut [S],
    base: usize,
    deferred: &mut Vec<Deferred>,
    owner: &mut Vec<usize>,
) -> Gathered {
    let mut g = Gathered::default();
    let mut no_extras = Extras {
        rec: None,
        guide: None,
        trail: None,
        deferred: None,
        direct: None,
    };
    for (k, ((i, path), hit)) in paths.iter_mut().zip(hits.iter_mut()).enumerate() {
        let Some(h) = hit.take() else {
            pt.escape(scene, path, &mut no_extras);
            g.l.set(k, path.l);
            continue;
        };
        let info = &scene.shape_info[h.shape as usize];
        let material = &scene.materials[info.material_at(h.p) as usize];
        if !in_lanes(material, info) {
            let sampler = &mut samplers[*i];
            let goes_on =
                pt.advance_in_round(scene, path, Some(h), sampler, deferred, owner, base + k);
            g.scalar[k] = Some(goes_on);
            continue;
        }
        if let Some(li) = info.light {
            pt.hit_emitter(scene, path, &mut no_extras, li as usize, &h);
        }
        g.d.set(k, path.ray.d);
        g.beta.set(k, path.beta);
        g.l.set(k, path.l);
        g.p.set(k, h.p);
        g.p_err.set(k, h.p_err);
        g.ng.set(k, h.ng);
        g.ns.set(k, h.ns);
        let back = material.one_sided && path.ray.d.dot(h.ng) > 0.0;
        let bsdf = if back { &Bsdf::Black } else { &material.bsdf };
        match *bsdf {
            Bsdf::Diffuse { albedo } => {
                g.diffuse[k] = true;
                g.albedo.set(k, albedo);
            }
            // The albedo at the hit's texture coordinates, as `Scene::surface_point`.
            Bsdf::TexturedDiffuse { ref albedo } => {
                g.diffuse[k] = true;
                let uv = scene.shapes[h.shape as usize].tex_coords(&h);
                g.albedo.set(k, albedo.eval(uv));
            }
            Bsdf::Conductor { reflectance } => {
                g.conductor[k] = true;
                g.reflectance.set(k, reflectance);
            }
            Bsdf::Dielectric { eta } => g.eta[k] = eta,
            _ => {}
        }
        g.scatter[k] = !bsdf.is_black() && path.depth != pt.settings.max_depth;
        if !g.scatter[k] {
            continue;
        }
        g.q[k] = pt.roulette_probability(path.depth, bsdf.continuation());
        let sampler = &mut samplers[*i];
        if g.diffuse[k] {
            g.nee[k] = true;
            let u_light = sampler.next_1d();
            let u = sampler.next_2d();
            if let Some((light, pmf)) = scene.light_sampler.sample(u_light) {
                g.pmf_l[k] = pmf;
                // An area light without spot profile or texture: the lanes take a mesh's
                // point, and a sphere's whole sample when the vertex lies outside it.
                let plain = match &scene.lights[light] {
                    Light::Area(
                        a @ AreaLight {
                            spot: None,
                            texture: None,
                            ..
                        },
                    ) => Some((a, &a.geometry)),
                    _ => None,
                };
                match plain {
                    Some((a, AreaShape::Mesh { mesh, sampler })) => {
                        let (p_l, n_l) = sampler.sample(mesh, u);
                        g.p_l.set(k, p_l);
                        g.n_l.set(k, n_l);
                        g.li.set(k, a.radiance);
                        g.area_l[k] = sampler.area;
                        (g.on_mesh[k], g.nee_found[k]) = (true, true);
                    }
                    Some((a, AreaShape::Sphere(sphere)))
                        if (sphere.center - h.p).length_squared()
                            > sphere.radius * sphere.radius =>
                    {
                        g.sphere_c.set(k, sphere.center);
                        g.sphere_r[k] = sphere.radius;
                        (g.ul_x[k], g.ul_y[k]) = (u.x, u.y);
                        g.li.set(k, a.radiance);
                        (g.on_sphere[k], g.nee_found[k]) = (true, true);
                    }
                    _ => {
                        if let Some(ls) = scene.lights[light].sample_li(h.p, u) {
                            g.p_l.set(k, ls.p);
                            g.n_l.set(k, ls.n);
                            g.li.set(k, ls.li);
                            g.wi_l.set(k, ls.wi);
                            (g.pdf_l[k], g.delta_l[k]) = (ls.pdf, ls.delta);
                            g.finite_l[k] = ls.dist.is_finite();
                            g.nee_found[k] = true;
                        }
                    }
                }
            }
        }
        g.u_lobe[k] = sampler.next_1d();
        let u = sampler.next_2d();
        (g.u_x[k], g.u_y[k]) = (u.x, u.y);
    }
    g
}

/// Whether the lanes shade a vertex on a surface of `material` (and `info`): a diffuse
/// (plain or textured), mirror, smooth dielectric or black BSDF without a normal map, on a
/// surface that is not null. Other vertices are advanced by pt's scalar code.
pub(super) fn in_lanes(material: &Material, info: &ShapeInfo) -> bool {
    matches!(
        material.bsdf,
        Bsdf::Black
            | Bsdf::Diffuse { .. }
            | Bsdf::TexturedDiffuse { .. }
            | Bsdf::Conductor { .. }
            | Bsdf::Dielectric { .. }
    ) && material.normal_map.is_none()
        && !info.null
}

/// Step 2 (module doc): next-event estimation and the continuation of sixteen paths, each
/// lane as `PathTracer::advance`, `direct` and `Bsdf::sample` compute it for a diffuse,
/// mirror or smooth dielectric vertex.
#[inline(always)]
fn shade(g: &Gathered) -> Shaded {
    let (d, beta) = (v3(&g.d), v3(&g.beta));
    let (p, p_err, ng, ns) = (v3(&g.p), v3(&g.p_err), v3(&g.ng), v3(&g.ns));
    let wo = -d;

    let l = v3(&g.l);

    let frame = Frame::from_z(ns);
    let wo_l = frame.to_local(wo);
    let albedo = v3(&g.albedo);
    let diffuse = m(&g.diffuse);

    // ---- Next-event estimation (`direct`; `AreaLight::sample_li` on a mesh or a sphere in
    // lanes) ----
    let (on_mesh, on_sphere) = (m(&g.on_mesh), m(&g.on_sphere));
    // (Skipped where no lane has a spherical light: most scenes have none.)
    let (p_s, n_s, pdf_sphere) = if on_sphere.bits() != 0 {
        sphere_sample_li(v3(&g.sphere_c), f(&g.sphere_r), p, f(&g.ul_x), f(&g.ul_y))
    } else {
        (V3::zero(), V3::zero(), F::zero())
    };
    let p_l = V3::select(on_sphere, p_s, v3(&g.p_l));
    let n_l = V3::select(on_sphere, n_s, v3(&g.n_l));
    let v = p_l - p;
    let d2 = v.length_squared();
    let dist = d2.sqrt();
    let cos_l = n_l.dot(-v) / dist;
    let pdf_mesh = d2 / (cos_l * f(&g.area_l));
    let in_lanes = on_mesh | on_sphere;
    let wi = V3::select(in_lanes, v / dist, v3(&g.wi_l));
    // A sphere's radiance leaves its front side only (`AreaLight::le`).
    let li = V3::select(
        on_sphere & !n_l.dot(-wi).gt(F::zero()),
        V3::zero(),
        v3(&g.li),
    );
    let pdf_l = F::select(
        on_mesh,
        pdf_mesh,
        F::select(on_sphere, pdf_sphere, f(&g.pdf_l)),
    );
    let density_ok = !dist.eq(F::zero()) & pdf_l.is_finite() & pdf_l.gt(F::zero()) & !li.is_zero();
    let lanes_ok = density_ok & (cos_l.gt(F::zero()) | !on_mesh);
    let found = m(&g.nee_found) & (lanes_ok | !in_lanes);
    let delta_l = m(&g.delta_l) & !in_lanes;
    let finite_l = m(&g.finite_l) | on_mesh | (on_sphere & dist.is_finite());
    // `Bsdf::eval_pdf` of the diffuse BSDF, times |cos| at the shading normal.
    let wi_l = frame.to_local(wi);
    let transmission = (wo_l.z * wi_l.z).lt(F::zero());
    let same_side = (wo_l.z * wi_l.z).gt(F::zero());
    let agrees = geometry_agrees(ng, wo, wi, transmission);
    let lit = agrees & same_side;
    let cos_i = wi_l.z.abs();
    let pdf_scatter = F::select(lit & cos_i.gt(F::zero()), cos_i * INV_PI, F::zero());
    let f_nee = V3::select(lit, albedo * F::splat(INV_PI), V3::zero()) * wi.dot(ns).abs();
    let nee_query = found & !f_nee.is_zero();
    let err_l = V3::splat(F::splat(gamma(8))) * p_l.abs();
    let (to_o, to_d, to_len) = shadow_segment(p, p_err, ng, p_l, err_l, n_l);
    let query_o = V3::select(finite_l, to_o, offset_origin(p, p_err, ng, wi));
    let query_d = V3::select(finite_l, to_d, wi);
    let query_len = F::select(finite_l, to_len, F::splat(f32::INFINITY));
    let p_light = f(&g.pmf_l) * pdf_l;
    let w = power_heuristic(p_light, pdf_scatter * 1.0);
    let w = F::select(delta_l, F::one(), w);
    let nee_value = V3::select(nee_query, f_nee * li * (w / p_light), V3::zero());

    // ---- Continuation (`Bsdf::sample`, diffuse or smooth dielectric) ----
    let (u_x, u_y) = (f(&g.u_x), f(&g.u_y));
    let (disk, pdf_d) = cosine_hemisphere(u_x, u_y);
    let ok_d = disk.z.gt(F::zero());
    let wi_d = V3::new(
        disk.x,
        disk.y,
        F::select(wo_l.z.lt(F::zero()), -disk.z, disk.z),
    );
    let (f_r, cos_t, eta_rel) = fresnel_dielectric(wo_l.z, f(&g.eta));
    let reflect = f(&g.u_lobe).lt(f_r);
    let wi_r = V3::new(-wo_l.x, -wo_l.y, wo_l.z);
    let wi_t = V3::new(
        -wo_l.x / eta_rel,
        -wo_l.y / eta_rel,
        -wo_l.z.signum() * cos_t,
    );
    let t = 1.0 - f_r;
    let f_t = t / wi_t.z.abs() / (eta_rel * eta_rel);
    let f_refl = f_r / wi_r.z.abs();
    let wi_s = V3::select(reflect, wi_r, wi_t);
    let f_s = F::select(reflect, f_refl, f_t);
    let pdf_s = F::select(reflect, f_r, t);

    let conductor = m(&g.conductor);
    let f_mirror = v3(&g.reflectance) / wi_r.z.abs();
    let wi_l = V3::select(diffuse, wi_d, V3::select(conductor, wi_r, wi_s));
    let f_bsdf = V3::select(
        diffuse,
        albedo * F::splat(INV_PI),
        V3::select(conductor, f_mirror, V3::splat(f_s)),
    );
    let pdf = F::select(diffuse, pdf_d, F::select(conductor, F::one(), pdf_s));
    let transmission = !diffuse & !conductor & !reflect;
    let wi = frame.to_world(wi_l);
    let weight = f_bsdf * wi_l.z.abs() / pdf;
    let cont = m(&g.scatter)
        & !wo_l.z.eq(F::zero())
        & (!diffuse | ok_d)
        & geometry_agrees(ng, wo, wi, transmission)
        & weight.is_finite()
        & pdf.gt(F::zero())
        & !weight.is_zero();
    Shaded {
        l,
        nee_value,
        nee_query,
        query_o,
        query_d,
        query_len,
        cont,
        beta: beta * weight,
        pdf,
        delta: !diffuse,
        origin: offset_origin(p, p_err, ng, wi),
        wi,
    }
}
