//! Statistical tests of the lights' sampling routines against their densities (see
//! `common/chi2.rs` for the harness, the sample counts and the significance level).
//!
//! * `sample_li` against `pdf_li`, as a solid-angle density over directions at a reference
//!   point: area lights on a quad, on a cube scaled to unequal faces and on an irregular fan
//!   (unequal triangles), spheres seen from outside (near, far, and tiny and distant) and from
//!   inside, and the constant environment. The density of a direction is the sum of `pdf_li`
//!   over the front-facing points of the light along it (found by ray casting here); area
//!   lights emit on their front side only, so `sample_li` fails for back-facing points and the
//!   pdf's mass must equal the share of successful samples.
//! * `sample_le` against `pdf_le`: origins (uniform by area: a grid on the quad, a grid over an
//!   irregular polygon, the faces of the scaled cube, the sphere's normals, the environment's
//!   disk) and directions (cosine around the normal for area lights, uniform for point lights
//!   and the environment).
//! * Point lights (delta) and the power-proportional light selection.

use crate::common;

use common::chi2::{self, SphereDomain};
use common::{Failures, close, close3};
use glam::{DVec3, Vec2, Vec3};
use lodestar::geometry::{Sphere, TriangleMesh, mesh::MeshSampler};
use lodestar::light::{
    AreaLight, AreaShape, EnvironmentLight, Light, LightSample, LightSampler, PointLight,
};
use lodestar::math::{Frame, Sampler};
use std::f64::consts::PI;

/// Samples per chi-square case.
const N: usize = 1_000_000;

const RADIANCE: Vec3 = Vec3::new(4.0, 2.0, 1.0);

// ------------------------------------------------------------------------------------------
// Scene pieces
// ------------------------------------------------------------------------------------------

fn mesh_light(mesh: &TriangleMesh, radiance: Vec3) -> Light {
    Light::Area(AreaLight::new(
        0,
        radiance,
        AreaShape::Mesh {
            mesh: Box::new(mesh.clone()),
            sampler: MeshSampler::new(mesh),
        },
    ))
}

fn sphere_light(center: Vec3, radius: f32, radiance: Vec3) -> Light {
    Light::Area(AreaLight::new(
        0,
        radiance,
        AreaShape::Sphere(Sphere { center, radius }),
    ))
}

/// A parallelogram light above the origin, tilted, facing down (front along u x v).
fn quad() -> (TriangleMesh, Vec3, Vec3, Vec3) {
    let (o, u, v) = (
        Vec3::new(-0.5, -0.4, 2.0),
        Vec3::new(0.0, 1.0, 0.2),
        Vec3::new(1.2, 0.1, 0.0),
    );
    (TriangleMesh::quad(o, u, v), o, u, v)
}

/// The cube scaled to [-0.5, 0.5] x [-1, 1] x [-1.5, 1.5] and moved: faces of areas 2, 3
/// and 6.
fn scaled_cube() -> TriangleMesh {
    let mut m = TriangleMesh::cube();
    for p in &mut m.positions {
        *p = *p * Vec3::new(0.5, 1.0, 1.5) + Vec3::new(1.0, -0.5, 0.5);
    }
    m
}

/// A star-shaped polygon in the plane z = 0.5, front +z, as a fan of unequal triangles.
fn irregular_fan() -> TriangleMesh {
    let angles = [0.0f32, 30.0, 100.0, 150.0, 220.0, 300.0];
    let radii = [1.0f32, 0.6, 1.2, 0.9, 1.1, 0.7];
    let mut positions = vec![Vec3::new(0.1, -0.1, 0.5)];
    for (a, r) in angles.iter().zip(radii) {
        let a = a.to_radians();
        positions.push(Vec3::new(0.1 + r * a.cos(), -0.1 + r * a.sin(), 0.5));
    }
    let k = angles.len() as u32;
    let indices = (0..k).map(|i| [0, 1 + i, 1 + (i + 1) % k]).collect();
    TriangleMesh {
        positions,
        normals: None,
        uvs: None,
        grid: None,
        indices,
    }
}

/// Bounding ball (centre of the bounding box, largest distance to it) of a mesh.
fn bounding_ball(mesh: &TriangleMesh) -> (Vec3, f64) {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for &p in &mesh.positions {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let c = 0.5 * (lo + hi);
    let r = mesh
        .positions
        .iter()
        .map(|&p| (p - c).as_dvec3().length())
        .fold(0.0, f64::max);
    (c, r)
}

/// A triangle prepared for [`intersect_triangle`]: its first vertex and its two edges from it,
/// in f64.
#[derive(Clone, Copy)]
struct Tri {
    a: DVec3,
    e1: DVec3,
    e2: DVec3,
}

impl Tri {
    fn new([a, b, c]: [DVec3; 3]) -> Tri {
        Tri {
            a,
            e1: b - a,
            e2: c - a,
        }
    }
}

/// Ray / triangle (Moller-Trumbore) in f64: the distance along unit `d`, if hit.
fn intersect_triangle(o: DVec3, d: DVec3, tri: &Tri) -> Option<f64> {
    let (e1, e2) = (tri.e1, tri.e2);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-15 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = o - tri.a;
    let u = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qv = tv.cross(e1);
    let v = d.dot(qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(qv) * inv;
    (t > 0.0).then_some(t)
}

/// Whether the ray from `o` along `d` meets the box `[lo, hi]` (slabs in f64).
fn ray_meets_box(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3) -> bool {
    let inv = d.recip();
    let (t0, t1) = ((lo - o) * inv, (hi - o) * inv);
    let near = t0.min(t1).max_element();
    let far = t0.max(t1).min_element();
    // A zero component of d puts that slab at infinite distances (NaN only for an origin on
    // its plane, which min and max skip).
    !(near > far || far < 0.0)
}

/// Solid-angle density of `sample_li` at `p` in direction `w` for a mesh light: the sum of
/// `pdf_li` over the mesh's front-facing points along the ray. The triangles are converted to
/// f64 once, outside the returned closure (the cubature calls it millions of times), and
/// rays that miss the mesh's bounding box (widened far beyond rounding) are 0 without a
/// triangle test.
fn mesh_dir_pdf<'a>(light: &'a Light, mesh: &TriangleMesh, p: Vec3) -> impl Fn(Vec3) -> f64 + 'a {
    let tris: Vec<(Tri, DVec3, Vec3)> = (0..mesh.indices.len())
        .map(|i| {
            let n = mesh.geometric_normal(i);
            (
                Tri::new(mesh.triangle(i).map(|v| v.as_dvec3())),
                n.as_dvec3(),
                n,
            )
        })
        .collect();
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for &v in &mesh.positions {
        lo = lo.min(v.as_dvec3());
        hi = hi.max(v.as_dvec3());
    }
    let pad = 1e-6 * (hi - lo).max_element() + 1e-9;
    let (lo, hi) = (lo - pad, hi + pad);
    let o = p.as_dvec3();
    move |w| {
        let d = w.as_dvec3().normalize();
        if !ray_meets_box(o, d, lo, hi) {
            return 0.0;
        }
        let mut sum = 0.0;
        for (tri, nd, n) in &tris {
            if nd.dot(d) < 0.0
                && let Some(t) = intersect_triangle(o, d, tri)
            {
                let p_l = (o + t * d).as_vec3();
                sum += light.pdf_li(p, p_l, *n, d.as_vec3()) as f64;
            }
        }
        sum
    }
}

// ------------------------------------------------------------------------------------------
// sample_li
// ------------------------------------------------------------------------------------------

/// Chi-square test of `light.sample_li(p, .)` against the direction density `dir_pdf`, with
/// the per-sample checks shared by all finite area lights.
fn li_case(
    name: &str,
    light: &Light,
    p: Vec3,
    domain: &SphereDomain,
    dir_pdf: impl Fn(Vec3) -> f64,
) -> chi2::Report {
    let mut fails = Failures::new();
    // The density of the last sample's direction, which the harness asks for next.
    let last = std::cell::Cell::new(None::<(Vec3, f64)>);
    let report = chi2::spherical(
        name,
        N,
        domain,
        |s: &mut dyn Sampler| {
            let ls = light.sample_li(p, s.next_2d())?;
            check_area_li(&mut fails, light, p, &ls);
            let d = dir_pdf(ls.wi);
            last.set(Some((ls.wi, d)));
            fails.check(close(ls.pdf as f64, d, 2e-3, 0.0), || {
                format!("sample pdf {} != density of its direction {d}", ls.pdf)
            });
            Some(ls.wi)
        },
        |w| match last.get() {
            Some((lw, d)) if lw == w => d,
            _ => dir_pdf(w),
        },
    );
    report.assert_ok();
    // A few samples exactly on an edge or silhouette may be missed by the ray casting.
    fails.assert_at_most(N / 100_000, name);
    report
}

fn check_area_li(fails: &mut Failures, light: &Light, p: Vec3, ls: &LightSample) {
    let v = ls.p - p;
    let pdf = light.pdf_li(p, ls.p, ls.n, ls.wi);
    fails.check(close(ls.pdf as f64, pdf as f64, 1e-3, 0.0), || {
        format!("sample pdf {} != pdf_li {pdf}", ls.pdf)
    });
    fails.check(close3(ls.wi, v.normalize(), 0.0, 1e-5), || {
        format!("wi {} != direction to the point {}", ls.wi, v.normalize())
    });
    fails.check(close(ls.dist as f64, v.length() as f64, 1e-5, 0.0), || {
        format!("dist {} != |p_l - p| {}", ls.dist, v.length())
    });
    fails.check(
        (ls.n.length() - 1.0).abs() < 1e-5 && ls.n.dot(-ls.wi) > 0.0,
        || format!("normal {} not unit or not facing the point", ls.n),
    );
    fails.check(!ls.delta && ls.li == RADIANCE, || {
        format!("delta {} li {}", ls.delta, ls.li)
    });
}

#[test]
fn quad_light_sample_li() {
    let (mesh, o, u, v) = quad();
    let light = mesh_light(&mesh, RADIANCE);
    let (c, r) = bounding_ball(&mesh);
    for (k, p) in [
        Vec3::new(0.1, 0.2, 0.0),
        Vec3::new(3.0, -2.0, 0.5), // oblique (cos 0.27 at the light)
        Vec3::new(0.2, 0.1, 1.8),  // close: the quad fills most of a hemisphere
        Vec3::new(-8.0, 5.0, -20.0),
    ]
    .into_iter()
    .enumerate()
    {
        let front = u.cross(v).dot(p - o) > 0.0;
        assert!(front, "reference point {k} must face the quad");
        let r = li_case(
            &format!("quad light sample_li #{k}"),
            &light,
            p,
            &SphereDomain::covering_ball(p, c, r),
            mesh_dir_pdf(&light, &mesh, p),
        );
        assert!(r.share() > 0.99, "{r}");
    }
    // Behind the quad: the back side emits nothing, every sample fails.
    let p = Vec3::new(0.0, 0.0, 3.0);
    let r = li_case(
        "quad light sample_li from behind",
        &light,
        p,
        &SphereDomain::covering_ball(p, c, r),
        mesh_dir_pdf(&light, &mesh, p),
    );
    assert_eq!(r.successes, 0, "{r}");
}

#[test]
fn cube_light_sample_li() {
    // Faces of unequal area; from outside, the samples on back faces fail, so only part of the
    // samples succeed and the density must integrate to that share.
    let mesh = scaled_cube();
    let light = mesh_light(&mesh, RADIANCE);
    let (c, r) = bounding_ball(&mesh);
    for (k, p) in [
        Vec3::new(4.0, -3.0, 2.5),
        Vec3::new(1.0, -0.5, 3.0), // straight above the top face
        Vec3::new(-1.0, 1.5, -0.5),
    ]
    .into_iter()
    .enumerate()
    {
        let r = li_case(
            &format!("cube light sample_li #{k}"),
            &light,
            p,
            &SphereDomain::covering_ball(p, c, r),
            mesh_dir_pdf(&light, &mesh, p),
        );
        assert!(r.share() > 0.05 && r.share() < 0.95, "{r}");
    }
}

#[test]
fn fan_light_sample_li() {
    let mesh = irregular_fan();
    let light = mesh_light(&mesh, RADIANCE);
    let (c, r) = bounding_ball(&mesh);
    for (k, p) in [Vec3::new(0.3, 0.2, 1.5), Vec3::new(-2.0, 1.0, 0.9)]
        .into_iter()
        .enumerate()
    {
        li_case(
            &format!("fan light sample_li #{k}"),
            &light,
            p,
            &SphereDomain::covering_ball(p, c, r),
            mesh_dir_pdf(&light, &mesh, p),
        );
    }
}

/// Density of a sphere light's `sample_li` from outside: `pdf_li` inside the cone the sphere
/// subtends (decided in f64 on the exact cone), zero outside.
fn sphere_dir_pdf(light: &Light, s: Sphere, p: Vec3, domain: &SphereDomain, w: Vec3) -> f64 {
    let d2 = (s.center - p).as_dvec3().length_squared();
    let sin2 = (s.radius as f64).powi(2) / d2;
    let z_max = sin2 / (1.0 + (1.0 - sin2).sqrt());
    let Some(x) = domain.to_param(w) else {
        return 0.0;
    };
    if x.x > z_max {
        return 0.0;
    }
    let t = s.intersect(p, w, f32::INFINITY);
    // On the rim a ray may numerically miss; the tangent point is then the light point.
    let t = if t.is_finite() {
        t
    } else {
        (d2 - (s.radius as f64).powi(2)).sqrt() as f32
    };
    let n_l = (p + t * w - s.center).normalize();
    light.pdf_li(p, s.center + s.radius * n_l, n_l, w) as f64
}

#[test]
fn sphere_light_sample_li_from_outside() {
    let axis = Vec3::new(1.0, 2.0, 3.0).normalize();
    for (k, (radius, dist)) in [
        (0.5f32, 0.75f32), // near: 1 - cos = 0.25
        (0.5, 5.0),        // far: 1 - cos = 5e-3
        (0.01, 100.0),     // tiny and distant: 1 - cos = 5e-9, below f32 epsilon
    ]
    .into_iter()
    .enumerate()
    {
        let s = Sphere {
            center: Vec3::new(0.3, -0.2, 0.1),
            radius,
        };
        let light = sphere_light(s.center, s.radius, RADIANCE);
        let p = s.center - dist * axis;
        // The exact cone as the domain, so its edge is a bin edge. The f32 sampling code
        // places directions to ~6e-8 rad, ~6e-4 of the tiny sphere's 1e-4 rad cone: samples
        // that rounding pushed up to 3e-3 (in 1 - cos) past the edge count as on it.
        let domain = SphereDomain::ball_cap(p, s.center, radius as f64).with_edge_slack(3e-3);
        let name = format!("sphere light sample_li from outside #{k}");
        let mut fails = Failures::new();
        let report = chi2::spherical(
            &name,
            N,
            &domain,
            |smp: &mut dyn Sampler| {
                let ls = light.sample_li(p, smp.next_2d())?;
                check_area_li(&mut fails, &light, p, &ls);
                fails.check(
                    close((ls.p - s.center).length() as f64, radius as f64, 1e-4, 0.0),
                    || format!("point {} not on the sphere", ls.p),
                );
                Some(ls.wi)
            },
            |w| sphere_dir_pdf(&light, s, p, &domain, w),
        );
        report.assert_ok();
        fails.assert_none(&name);
    }
}

#[test]
fn sphere_light_from_inside_is_back_facing() {
    // Inside, the sphere shows its back side: nothing is emitted towards the point, so every
    // sample fails; pdf_li (the density of the underlying uniform-area sampler, in solid angle)
    // still integrates to one over the sphere of directions.
    let s = Sphere {
        center: Vec3::new(0.3, -0.2, 0.1),
        radius: 1.5,
    };
    let light = sphere_light(s.center, s.radius, RADIANCE);
    let mut sampler = chi2::sampler_for("sphere inside");
    for p in [s.center, s.center + Vec3::new(0.9, -0.5, 0.6)] {
        for _ in 0..100_000 {
            assert!(light.sample_li(p, sampler.next_2d()).is_none());
        }
        let mass = chi2::integrate_sphere(&SphereDomain::full(), |w| {
            let t = s.intersect(p, w, f32::INFINITY);
            let n_l = (p + t * w - s.center).normalize();
            light.pdf_li(p, s.center + s.radius * n_l, n_l, w) as f64
        });
        assert!(
            (mass - 1.0).abs() < 1e-3,
            "pdf_li from inside integrates to {mass}"
        );
    }
}

#[test]
fn environment_sample_li() {
    let light = Light::Environment(EnvironmentLight {
        radiance: Vec3::new(0.5, 0.7, 1.0),
        center: Vec3::new(1.0, 2.0, 3.0),
        radius: 10.0,
    });
    let p = Vec3::new(0.5, -1.0, 2.0);
    let mut fails = Failures::new();
    chi2::spherical(
        "environment sample_li",
        N,
        &SphereDomain::full_around(Vec3::new(0.2, 0.9, -0.3)),
        |s| {
            let ls = light.sample_li(p, s.next_2d())?;
            let pdf = light.pdf_li(p, ls.p, ls.n, ls.wi);
            fails.check(close(ls.pdf as f64, pdf as f64, 1e-6, 0.0), || {
                format!("pdf {} != pdf_li {pdf}", ls.pdf)
            });
            fails.check(
                !ls.delta && ls.dist == f32::INFINITY && ls.li == Vec3::new(0.5, 0.7, 1.0),
                || format!("{ls:?}"),
            );
            Some(ls.wi)
        },
        |w| light.pdf_li(p, Vec3::ZERO, Vec3::ZERO, w) as f64,
    )
    .assert_ok();
    fails.assert_none("environment sample_li");
}

#[test]
fn point_light_sample_li() {
    let intensity = Vec3::new(10.0, 5.0, 2.0);
    let position = Vec3::new(1.0, 2.0, 3.0);
    let light = Light::Point(PointLight {
        position,
        intensity,
    });
    assert!(light.is_delta());
    let mut s = chi2::sampler_for("point light");
    for _ in 0..10_000 {
        let p = (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * 20.0;
        let ls = light.sample_li(p, s.next_2d()).unwrap();
        let v = position - p;
        assert!(close3(ls.wi, v.normalize(), 0.0, 1e-6));
        assert!(close(ls.dist as f64, v.length() as f64, 1e-6, 0.0));
        assert!(close3(ls.li, intensity / v.length_squared(), 1e-5, 0.0));
        assert!(ls.pdf == 1.0 && ls.delta && ls.p == position);
        // No direction is hit with non-zero density.
        assert_eq!(light.pdf_li(p, ls.p, ls.n, ls.wi), 0.0);
    }
    assert!(light.sample_li(position, Vec2::splat(0.5)).is_none());
}

// ------------------------------------------------------------------------------------------
// sample_le
// ------------------------------------------------------------------------------------------

/// The per-sample checks of an emitted ray of an area light.
fn check_le(fails: &mut Failures, light: &Light, e: &lodestar::light::EmissionSample) {
    let (pdf_pos, pdf_dir) = light.pdf_le(e.n, e.dir);
    fails.check(
        close(e.pdf_pos as f64, pdf_pos as f64, 1e-5, 0.0)
            && close(e.pdf_dir as f64, pdf_dir as f64, 1e-3, 1e-7),
        || {
            format!(
                "sample pdfs ({}, {}) != pdf_le ({pdf_pos}, {pdf_dir})",
                e.pdf_pos, e.pdf_dir
            )
        },
    );
    fails.check((e.dir.length() - 1.0).abs() < 1e-5, || {
        format!("|dir| = {}", e.dir.length())
    });
    fails.check(e.le == RADIANCE, || format!("le {}", e.le));
}

#[test]
fn quad_light_sample_le() {
    let (mesh, o, u, v) = quad();
    let light = mesh_light(&mesh, RADIANCE);
    let n = u.cross(v).normalize();
    let area = u.cross(v).length() as f64;
    // Positions: uniform in (s, t) with p = o + s u + t v; density pdf_pos * |u x v|.
    let mut fails = Failures::new();
    let (uu, uv, vv) = (u.dot(u) as f64, u.dot(v) as f64, v.dot(v) as f64);
    let det = uu * vv - uv * uv;
    chi2::planar(
        "quad light sample_le positions",
        N,
        Vec2::ZERO,
        Vec2::ONE,
        [32, 32],
        |s| {
            let e = light.sample_le(s.next_2d(), s.next_2d())?;
            check_le(&mut fails, &light, &e);
            fails.check(close3(e.n, n, 0.0, 1e-6), || {
                format!("normal {} != {n}", e.n)
            });
            let d = e.p - o;
            fails.check(d.dot(n).abs() < 1e-5, || {
                format!("point {} off the plane", e.p)
            });
            let (du, dv) = (d.dot(u) as f64, d.dot(v) as f64);
            let st = Vec2::new(
                ((vv * du - uv * dv) / det) as f32,
                ((uu * dv - uv * du) / det) as f32,
            );
            Some(st)
        },
        |_| light.pdf_le(n, n).0 as f64 * area,
    )
    .assert_ok();
    fails.assert_none("quad sample_le positions");
    // Directions: cosine around the normal.
    let mut fails = Failures::new();
    chi2::spherical(
        "quad light sample_le directions",
        N,
        &SphereDomain::full_around(n),
        |s| {
            let e = light.sample_le(s.next_2d(), s.next_2d())?;
            check_le(&mut fails, &light, &e);
            Some(e.dir)
        },
        |w| light.pdf_le(n, w).1 as f64,
    )
    .assert_ok();
    fails.assert_none("quad sample_le directions");
}

/// Is a point of the fan's plane inside one of the fan's triangles? (The triangles are
/// converted to f64 once, outside the returned closure.)
fn inside_fan(mesh: &TriangleMesh) -> impl Fn(Vec2) -> bool + use<> {
    let tris: Vec<[glam::DVec2; 3]> = (0..mesh.indices.len())
        .map(|i| mesh.triangle(i).map(|v| v.truncate().as_dvec2()))
        .collect();
    move |p| {
        let p = p.as_dvec2();
        tris.iter().any(|&[a, b, c]| {
            let e = |a: glam::DVec2, b: glam::DVec2| (b - a).perp_dot(p - a);
            let (x, y, z) = (e(a, b), e(b, c), e(c, a));
            (x >= 0.0 && y >= 0.0 && z >= 0.0) || (x <= 0.0 && y <= 0.0 && z <= 0.0)
        })
    }
}

#[test]
fn fan_light_sample_le_positions_are_uniform_by_area() {
    // Unequal triangles: a wrong triangle choice or a non-uniform map inside a triangle shows
    // up on the grid. The density is 1 / area inside the polygon, zero outside.
    let mesh = irregular_fan();
    let light = mesh_light(&mesh, RADIANCE);
    let areas: Vec<f32> = (0..mesh.indices.len())
        .map(|i| mesh.triangle_area(i))
        .collect();
    let max_ratio = areas.iter().cloned().fold(0.0, f32::max)
        / areas.iter().cloned().fold(f32::INFINITY, f32::min);
    assert!(
        max_ratio > 2.0,
        "the fan's triangles should differ in area: {areas:?}"
    );
    let inv_area = 1.0 / areas.iter().map(|&a| a as f64).sum::<f64>();
    let mut fails = Failures::new();
    let inside = inside_fan(&mesh);
    chi2::planar(
        "fan light sample_le positions",
        N,
        Vec2::new(-1.2, -1.4),
        Vec2::new(1.2, 1.2),
        [32, 32],
        |s| {
            let e = light.sample_le(s.next_2d(), s.next_2d())?;
            check_le(&mut fails, &light, &e);
            fails.check(
                close3(e.n, Vec3::Z, 0.0, 1e-6) && (e.p.z - 0.5).abs() < 1e-6,
                || format!("point {} normal {}", e.p, e.n),
            );
            Some(e.p.truncate())
        },
        |p| {
            if inside(p) { inv_area } else { 0.0 }
        },
    )
    .assert_ok();
    fails.assert_none("fan sample_le");
}

#[test]
fn cube_light_sample_le() {
    // Origins: the six faces (areas 2, 3, 6 twice each) in proportion to area.
    let mesh = scaled_cube();
    let light = mesh_light(&mesh, RADIANCE);
    let total = mesh.area() as f64;
    let half = Vec3::new(0.5, 1.0, 1.5);
    let centre = Vec3::new(1.0, -0.5, 0.5);
    let face_area = |axis: usize| {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        4.0 * half[a] as f64 * half[b] as f64
    };
    let probs: Vec<f64> = (0..6).map(|f| face_area(f / 2) / total).collect();
    let mut fails = Failures::new();
    chi2::discrete("cube light sample_le faces", N, &probs, |s| {
        let e = light.sample_le(s.next_2d(), s.next_2d())?;
        check_le(&mut fails, &light, &e);
        let axis = (0..3).max_by(|&a, &b| e.n[a].abs().total_cmp(&e.n[b].abs()))?;
        let positive = e.n[axis] > 0.0;
        let on_face =
            ((e.p - centre)[axis] - if positive { half[axis] } else { -half[axis] }).abs();
        fails.check(on_face < 1e-5, || {
            format!("point {} not on the face of normal {}", e.p, e.n)
        });
        Some(2 * axis + positive as usize)
    })
    .assert_ok();
    fails.assert_none("cube sample_le faces");
    // Directions, in the frame of each sample's normal: cosine-weighted.
    let mut fails = Failures::new();
    chi2::spherical(
        "cube light sample_le directions",
        N,
        &SphereDomain::full(),
        |s| {
            let e = light.sample_le(s.next_2d(), s.next_2d())?;
            check_le(&mut fails, &light, &e);
            Some(Frame::from_z(e.n).to_local(e.dir))
        },
        |w| light.pdf_le(Vec3::Z, w).1 as f64,
    )
    .assert_ok();
    fails.assert_none("cube sample_le directions");
}

#[test]
fn sphere_light_sample_le() {
    let s = Sphere {
        center: Vec3::new(0.3, -0.2, 0.1),
        radius: 1.5,
    };
    let light = sphere_light(s.center, s.radius, RADIANCE);
    let r2 = (s.radius as f64).powi(2);
    // Origins uniform on the sphere: over the unit normals the density is pdf_pos * r^2.
    let mut fails = Failures::new();
    chi2::spherical(
        "sphere light sample_le positions",
        N,
        &SphereDomain::full_around(Vec3::new(-0.3, 0.4, 0.5)),
        |smp| {
            let e = light.sample_le(smp.next_2d(), smp.next_2d())?;
            check_le(&mut fails, &light, &e);
            fails.check(close3(e.p, s.center + s.radius * e.n, 0.0, 1e-5), || {
                format!("point {} is not centre + r n {}", e.p, e.n)
            });
            Some(e.n)
        },
        |n| light.pdf_le(n, n).0 as f64 * r2,
    )
    .assert_ok();
    fails.assert_none("sphere sample_le positions");
    let mut fails = Failures::new();
    chi2::spherical(
        "sphere light sample_le directions",
        N,
        &SphereDomain::full(),
        |smp| {
            let e = light.sample_le(smp.next_2d(), smp.next_2d())?;
            check_le(&mut fails, &light, &e);
            Some(Frame::from_z(e.n).to_local(e.dir))
        },
        |w| light.pdf_le(Vec3::Z, w).1 as f64,
    )
    .assert_ok();
    fails.assert_none("sphere sample_le directions");
}

#[test]
fn point_light_sample_le() {
    let (position, intensity) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(10.0, 5.0, 2.0));
    let light = Light::Point(PointLight {
        position,
        intensity,
    });
    let mut fails = Failures::new();
    chi2::spherical(
        "point light sample_le",
        N,
        &SphereDomain::full_around(Vec3::new(0.5, -0.5, 0.2)),
        |s| {
            let e = light.sample_le(s.next_2d(), s.next_2d())?;
            let (pp, pd) = light.pdf_le(e.n, e.dir);
            fails.check(
                e.p == position && e.le == intensity && e.pdf_pos == 1.0 && pp == 1.0,
                || format!("{e:?}"),
            );
            fails.check(close(e.pdf_dir as f64, pd as f64, 1e-6, 0.0), || {
                format!("pdf_dir {} != pdf_le {pd}", e.pdf_dir)
            });
            Some(e.dir)
        },
        |w| light.pdf_le(Vec3::ZERO, w).1 as f64,
    )
    .assert_ok();
    fails.assert_none("point sample_le");
}

#[test]
fn environment_sample_le() {
    let (center, radius) = (Vec3::new(1.0, 2.0, 3.0), 10.0f32);
    let light = Light::Environment(EnvironmentLight {
        radiance: RADIANCE,
        center,
        radius,
    });
    // Directions: uniform.
    let mut fails = Failures::new();
    chi2::spherical(
        "environment sample_le directions",
        N,
        &SphereDomain::full(),
        |s| {
            let e = light.sample_le(s.next_2d(), s.next_2d())?;
            let (pp, pd) = light.pdf_le(e.n, e.dir);
            fails.check(
                e.pdf_pos == pp && e.pdf_dir == pd && e.le == RADIANCE,
                || format!("{e:?}"),
            );
            fails.check(e.n == e.dir, || format!("n {} != dir {}", e.n, e.dir));
            Some(e.dir)
        },
        |w| light.pdf_le(Vec3::ZERO, w).1 as f64,
    )
    .assert_ok();
    fails.assert_none("environment sample_le directions");
    // Origins: uniform on the disk of the bounding sphere's radius, centred at
    // centre + radius w and facing w = -dir. Coordinates in units of the radius.
    let mut fails = Failures::new();
    chi2::planar(
        "environment sample_le positions",
        N,
        Vec2::splat(-1.0),
        Vec2::splat(1.0),
        [32, 32],
        |s| {
            let e = light.sample_le(s.next_2d(), s.next_2d())?;
            let w = -e.dir;
            let f = Frame::from_z(w);
            let d = e.p - center - radius * w;
            fails.check(d.dot(w).abs() < 1e-4 * radius, || {
                format!("origin {} not on the disk facing {w}", e.p)
            });
            Some(Vec2::new(d.dot(f.s), d.dot(f.t)) / radius)
        },
        |x| {
            if x.length_squared() < 1.0 {
                light.pdf_le(Vec3::ZERO, Vec3::Z).0 as f64 * (radius as f64).powi(2)
            } else {
                0.0
            }
        },
    )
    .assert_ok();
    fails.assert_none("environment sample_le positions");
}

// ------------------------------------------------------------------------------------------
// Light selection
// ------------------------------------------------------------------------------------------

/// Lights are picked by power within two groups, the lights at infinity taking `n / (n + 1)`
/// together (`common::light_selection_probs`): the pmf and a chi-square of the choices.
#[test]
fn light_sampler_picks_lights_by_power_within_their_group() {
    let (quad_mesh, ..) = quad();
    let lights = vec![
        mesh_light(&quad_mesh, RADIANCE),
        sphere_light(Vec3::new(0.0, 1.0, 0.0), 0.3, Vec3::new(1.0, 1.0, 1.0)),
        mesh_light(&quad_mesh, Vec3::ZERO), // black: never chosen
        Light::Point(PointLight {
            position: Vec3::ZERO,
            intensity: Vec3::new(2.0, 1.0, 0.5),
        }),
        Light::Environment(EnvironmentLight {
            radiance: Vec3::splat(0.02),
            center: Vec3::ZERO,
            radius: 5.0,
        }),
        mesh_light(&scaled_cube(), Vec3::new(0.1, 0.2, 0.3)),
    ];
    // Power by hand: pi A L for area lights, 4 pi I for points, 4 pi^2 R^2 L for the
    // environment (luminance of the RGB values).
    let lum = |c: Vec3| 0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64;
    let quad_area = quad_mesh.area() as f64;
    let powers = [
        PI * quad_area * lum(RADIANCE),
        PI * 4.0 * PI * 0.09 * 1.0,
        0.0,
        4.0 * PI * lum(Vec3::new(2.0, 1.0, 0.5)),
        4.0 * PI * PI * 25.0 * lum(Vec3::splat(0.02)),
        PI * 22.0 * lum(Vec3::new(0.1, 0.2, 0.3)),
    ];
    let infinite: Vec<bool> = lights.iter().map(|l| l.is_infinite()).collect();
    let probs = crate::common::light_selection_probs(&powers, &infinite);
    for (l, &p) in lights.iter().zip(&powers) {
        assert!(
            close(l.power() as f64, p, 1e-5, 0.0),
            "power {} != {p}",
            l.power()
        );
    }
    let sampler = LightSampler::new(&lights);
    for (i, &p) in probs.iter().enumerate() {
        assert!(
            close(sampler.pmf(i) as f64, p, 1e-5, 0.0),
            "pmf({i}) != {p}"
        );
    }
    let mut fails = Failures::new();
    chi2::discrete("light selection", N, &probs, |s| {
        let (i, pmf) = sampler.sample(s.next_1d())?;
        fails.check(pmf == sampler.pmf(i), || format!("pmf {pmf} != pmf({i})"));
        Some(i)
    })
    .assert_ok();
    fails.assert_none("light selection");
    assert!(LightSampler::new(&[]).sample(0.5).is_none());
}

// ------------------------------------------------------------------------------------------
// The tests must be able to fail
// ------------------------------------------------------------------------------------------

#[test]
fn a_mesh_sampler_ignoring_triangle_areas_is_rejected() {
    // A plausible bug: triangles chosen uniformly instead of by area, while pdf_li and pdf_le
    // still say 1 / area. Both the direction test and the position test must catch it.
    let bad = |mesh: &TriangleMesh| {
        let mut sampler = MeshSampler::new(mesh);
        sampler.tri_distribution =
            lodestar::math::Distribution1D::new(&vec![1.0; mesh.indices.len()]);
        Light::Area(AreaLight::new(
            0,
            RADIANCE,
            AreaShape::Mesh {
                mesh: Box::new(mesh.clone()),
                sampler,
            },
        ))
    };
    let mesh = scaled_cube();
    let light = bad(&mesh);
    let (c, r) = bounding_ball(&mesh);
    let p = Vec3::new(4.0, -3.0, 2.5);
    let report = chi2::spherical(
        "power: cube light, uniform triangle choice",
        N,
        &SphereDomain::covering_ball(p, c, r),
        |s| Some(light.sample_li(p, s.next_2d())?.wi),
        mesh_dir_pdf(&light, &mesh, p),
    );
    println!("{report}");
    assert!(report.rejected(), "{report}");

    let mesh = irregular_fan();
    let light = bad(&mesh);
    let inv_area = 1.0 / mesh.area() as f64;
    let inside = inside_fan(&mesh);
    let report = chi2::planar(
        "power: fan positions, uniform triangle choice",
        N,
        Vec2::new(-1.2, -1.4),
        Vec2::new(1.2, 1.2),
        [32, 32],
        |s| Some(light.sample_le(s.next_2d(), s.next_2d())?.p.truncate()),
        |p| {
            if inside(p) { inv_area } else { 0.0 }
        },
    );
    println!("{report}");
    assert!(report.chi2_rejects(), "{report}");
}

#[test]
fn a_sphere_cone_with_a_cancelling_one_minus_cos_is_rejected() {
    // The cone density of a small distant sphere computed naively in f32 as
    // 1 / (2 pi (1 - cos)), with cos from sqrt(1 - sin^2): for 1 - cos = 1.25e-7 the f32 cos
    // rounds to 1 - 1.19e-7, and the pdf is 5 % off (for 5e-9 it would be infinite). The mass
    // check must see it.
    let axis = Vec3::new(1.0, 2.0, 3.0).normalize();
    let s = Sphere {
        center: Vec3::new(0.3, -0.2, 0.1),
        radius: 0.02,
    };
    let light = sphere_light(s.center, s.radius, RADIANCE);
    let p = s.center - 40.0 * axis;
    let sin2 = 0.02f32 * 0.02 / (40.0 * 40.0);
    let naive_pdf = 1.0 / (2.0 * PI * (1.0 - (1.0 - sin2).sqrt()) as f64);
    let domain = SphereDomain::ball_cap(p, s.center, 0.02).with_edge_slack(3e-3);
    let report = chi2::spherical(
        "power: naive cone pdf",
        N,
        &domain,
        |smp| Some(light.sample_li(p, smp.next_2d())?.wi),
        |w| {
            if sphere_dir_pdf(&light, s, p, &domain, w) > 0.0 {
                naive_pdf
            } else {
                0.0
            }
        },
    );
    println!("{report}");
    assert!(report.mass_mismatch(), "{report}");
}
