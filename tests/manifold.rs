//! The specular-chain step of the guided sampler (`integrators/guided/manifold/`): the
//! Newton walk against analytic refraction chains, its Jacobian against independent finite
//! differences, and the density's normalisation (with a control that leaves the Jacobian out).

// The 2x2 Jacobians read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use crate::util;

use glam::{DVec3, Vec3};
use lodestar::integrators::guided::cache::GuideCache;
use lodestar::integrators::guided::manifold::{self, Chain, Far, From, Goal, ManifoldSettings};
use lodestar::integrators::guided::sampler;
use lodestar::integrators::paths::{Kind, Vertex};
use lodestar::math::{IndependentSampler, Sampler};
use lodestar::path::{Vertex as PathVertex, VertexKind};
use lodestar::scene::Scene;
use util::caustics::{floor_scene, glass_sphere, sun};

/// Flat water (ior 1.33) at y = 0 over a diffuse floor at y = -2, a sun.
fn flat_water() -> String {
    let water = r#"
[[shape]]
type = "quad"
origin = [-4, 0, -4]
edge_u = [0, 0, 8]
edge_v = [8, 0, 0]
material = "water"
"#;
    floor_scene(
        [0.0, 1.5, 2.5],
        [0.0, -2.0, 0.0],
        50.0,
        [32, 24],
        -2.0,
        water,
    ) + &sun([0.25, 1.0, -0.35], 4.0)
}

/// A glass sphere (ior 1.5) of radius 0.5 at the origin above a diffuse floor at y = -2.
fn glass_sphere_scene() -> String {
    floor_scene(
        [0.0, 1.5, 4.0],
        [0.0, -1.0, 0.0],
        50.0,
        [32, 24],
        -2.0,
        &glass_sphere([0.0; 3], 0.5),
    ) + &sun([0.1, 1.0, 0.05], 4.0)
}

/// Refraction of the travelling unit direction `d` at unit normal `n` (either side) with
/// `eta` = index inside / outside (the side `n` points away from is inside): written out
/// here, independently of the renderer's.
fn snell(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let (n, eta) = if d.dot(n) < 0.0 {
        (n, eta)
    } else {
        (-n, 1.0 / eta)
    };
    let cos_i = -d.dot(n);
    let k = 1.0 - (1.0 - cos_i * cos_i) / (eta * eta);
    (k > 0.0).then(|| (d / eta + n * (cos_i / eta - k.sqrt())).normalize())
}

/// Where the ray `o + t d` from a point on the sphere of radius `r` at the origin leaves it
/// again (the far root), and the outward normal there.
fn sphere_exit(o: DVec3, d: DVec3, r: f64) -> Option<(DVec3, DVec3)> {
    let b = o.dot(d);
    let c = o.length_squared() - r * r;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -b + disc.sqrt();
    (t > 1e-9).then(|| {
        let p = o + d * t;
        (p, p / r)
    })
}

fn flat_out(xa: DVec3, x: DVec3) -> Option<DVec3> {
    snell((x - xa).normalize(), DVec3::Y, 1.33)
}

fn sphere_out(xa: DVec3, x: DVec3) -> Option<DVec3> {
    sphere_chain(xa, x, DVec3::ZERO).map(|c| c.1)
}

/// The chain from `xa` through `x` on the glass sphere (radius 0.5, ior 1.5) at `c`: where it
/// leaves the sphere and along which direction.
fn sphere_chain(xa: DVec3, x: DVec3, c: DVec3) -> Option<(DVec3, DVec3)> {
    let d = (x - xa).normalize();
    let n = (x - c) / 0.5;
    let d1 = snell(d, n, 1.5)?;
    let (p2, n2) = sphere_exit(x - c, d1, 0.5)?;
    Some((p2 + c, snell(d1, n2, 1.5)?))
}

/// Solid angle per area of `out` at `x` on a surface with normal `n` (central differences in
/// an orthonormal tangent basis).
fn solid_angle_per_area(out: impl Fn(DVec3) -> DVec3, x: DVec3, n: DVec3) -> f64 {
    let a = if n.x.abs() > 0.5 { DVec3::Y } else { DVec3::X };
    let e1 = n.cross(a).normalize();
    let e2 = n.cross(e1);
    let h = 1e-6;
    let d1 = (out(x + e1 * h) - out(x - e1 * h)) / (2.0 * h);
    let d2 = (out(x + e2 * h) - out(x - e2 * h)) / (2.0 * h);
    d1.cross(d2).dot(out(x)).abs()
}

fn floor_point(p: DVec3) -> From {
    From {
        p: p.as_vec3(),
        n: Vec3::Y,
        medium: None,
    }
}

/// The walk through flat water lands where Snell's law puts the refraction point, and its
/// determinant is the solid angle per area of the analytic map.
#[test]
fn flat_water_walk_matches_snell_and_its_jacobian() {
    let scene = util::scene(&flat_water());
    let chain = Chain::new(2, 4, Far::Direction { light: 0 }, &[true]);
    let xa = DVec3::new(0.1, -2.0, 0.2);
    let from = floor_point(xa);
    let mut worst_pos: f64 = 0.0;
    let mut worst_det: f64 = 0.0;
    for (i, w) in [
        DVec3::new(0.25, 1.0, -0.35),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(-0.6, 1.0, 0.3),
        DVec3::new(0.9, 0.5, 0.2),
    ]
    .into_iter()
    .enumerate()
    {
        let w = w.normalize();
        // Reverse Snell: the ray from the sun (travelling -w) refracts into the water along
        // r; the walk's x is where the line from x_a against r meets y = 0.
        let r = snell(-w, DVec3::Y, 1.33).unwrap();
        let x = xa + (-r) * (xa.y / r.y);
        // Seeds a little off the solution.
        let seed = x + DVec3::new(0.07, 0.0, -0.05) * (i as f64 + 1.0);
        let goal = Goal::direction(w);
        let sol = manifold::solve(&scene, &from, seed.as_vec3(), &chain, &goal)
            .unwrap_or_else(|e| panic!("direction {w}: {e:?}"));
        let pos = (sol.sp.hit.p.as_dvec3() - x).length();
        worst_pos = worst_pos.max(pos);
        let det_fd = solid_angle_per_area(|p| flat_out(xa, p).unwrap(), x, DVec3::Y);
        let rel = (sol.det - det_fd).abs() / det_fd;
        worst_det = worst_det.max(rel);
        eprintln!(
            "w {w}: |x - x_snell| {pos:e}, det {} vs {det_fd} ({rel:e})",
            sol.det
        );
    }
    // The walk stops within 1e-5 rad of the target: about 1e-5 m at these distances.
    assert!(worst_pos < 1e-4, "walk {worst_pos:e} m from Snell's point");
    assert!(worst_det < 1e-4, "determinant off by {worst_det:e}");
}

/// Through a glass sphere (two refractions) the walk's chain leaves along the target
/// direction by an independent trace, and its determinant matches that trace's.
#[test]
fn glass_sphere_walk_matches_the_analytic_chain() {
    let scene = util::scene(&glass_sphere_scene());
    let chain = Chain::new(2, 5, Far::Direction { light: 0 }, &[true, true]);
    let xa = DVec3::new(0.15, -2.0, -0.1);
    let from = floor_point(xa);
    let mut solved = 0;
    for (i, w) in [
        DVec3::new(0.1, 1.0, 0.05),
        DVec3::new(0.0, 1.0, 0.0),
        DVec3::new(-0.15, 1.0, 0.1),
    ]
    .into_iter()
    .enumerate()
    {
        let w = w.normalize();
        // Seed: the sphere's bottom, moved a little.
        let seed = DVec3::new(0.05 * i as f64, -0.5, 0.02).normalize() * 0.5;
        let goal = Goal::direction(w);
        let sol = manifold::solve(&scene, &from, seed.as_vec3(), &chain, &goal)
            .unwrap_or_else(|e| panic!("direction {w}: {e:?}"));
        let x = sol.sp.hit.p.as_dvec3();
        let out = sphere_out(xa, x).expect("the chain refracts twice");
        let angle = out.dot(w).clamp(-1.0, 1.0).acos();
        assert!(
            angle < 2e-5,
            "direction {w}: chain leaves {angle:e} rad off"
        );
        let det_fd = solid_angle_per_area(|p| sphere_out(xa, p).unwrap(), x, x / 0.5);
        let rel = (sol.det - det_fd).abs() / det_fd;
        eprintln!(
            "w {w}: angle {angle:e}, det {} vs {det_fd} ({rel:e})",
            sol.det
        );
        assert!(rel < 1e-3, "direction {w}: determinant off by {rel:e}");
        solved += 1;
    }
    assert_eq!(solved, 3);
}

/// On a wavy heightfield (interpolated vertex normals) the chain's derivative equals central
/// differences of the chain map itself, and the walk converges from nearby seeds.
#[test]
fn heightfield_chain_derivative_matches_differences() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/pool.toml"))
        .unwrap()
        .replace("resolution = [320, 240]", "resolution = [32, 24]");
    let scene: Scene = util::scene(&text);
    let chain = Chain::new(2, 4, Far::Direction { light: 0 }, &[true]);
    let xa = DVec3::new(0.3, -1.5, 0.1);
    let from = floor_point(xa);
    let w = DVec3::new(0.25, 1.0, -0.35).normalize();
    let goal = Goal::direction(w);
    let mut checked = 0;
    let mut worst: f64 = 0.0;
    for k in 0..40 {
        let p = DVec3::new(
            0.3 + 0.31 * ((k * 7 % 11) as f64 / 11.0 - 0.5),
            -0.12,
            0.1 + 0.29 * ((k * 5 % 13) as f64 / 13.0 - 0.5),
        );
        let Some(m) = manifold::chain_map(&scene, &from, p, &chain, &goal) else {
            continue;
        };
        // Differences of the residual along the tangent basis (re-cast onto the surface,
        // which moves the point off the tangent plane only to second order).
        let h = 2e-4;
        let mut fd = [[0.0; 2]; 2];
        let mut ok = true;
        for c in 0..2 {
            let e = m.tangent[c];
            let (Some(a), Some(b)) = (
                manifold::chain_map(&scene, &from, m.x1 + e * h, &chain, &goal),
                manifold::chain_map(&scene, &from, m.x1 - e * h, &chain, &goal),
            ) else {
                ok = false;
                break;
            };
            for r in 0..2 {
                fd[r][c] = (a.residual[r] - b.residual[r]) / (2.0 * h);
            }
        }
        if !ok {
            continue;
        }
        let scale = m
            .jacobian
            .iter()
            .flatten()
            .fold(0.0f64, |s, v| s.max(v.abs()));
        for r in 0..2 {
            for c in 0..2 {
                worst = worst.max((fd[r][c] - m.jacobian[r][c]).abs() / scale);
            }
        }
        checked += 1;
    }
    eprintln!("{checked} points, worst relative difference {worst:e}");
    assert!(checked >= 30, "only {checked} chains traced");
    // Triangle edges within h of a point kink the differences; the rest agree closely.
    assert!(worst < 0.05, "derivative off by {worst:e}");
}

/// Two glass spheres side by side above a floor, the sun straight above.
fn two_spheres() -> String {
    let spheres = glass_sphere([-0.6, 0.0, 0.0], 0.5) + &glass_sphere([0.6, 0.0, 0.0], 0.5);
    floor_scene(
        [0.0, 1.5, 4.0],
        [0.0, -1.5, 0.0],
        60.0,
        [32, 24],
        -2.0,
        &spheres,
    ) + &sun([0.0, 1.0, 0.0], 4.0)
}

const CENTRES: [DVec3; 2] = [DVec3::new(-0.6, 0.0, 0.0), DVec3::new(0.6, 0.0, 0.0)];

fn surface(p: DVec3, n: DVec3, material: u32, shape: u32, delta: bool) -> PathVertex {
    PathVertex {
        p: p.as_vec3(),
        n: n.as_vec3(),
        ns: n.as_vec3(),
        uv: glam::Vec2::ZERO,
        tangent: Vec3::ZERO,
        kind: VertexKind::Surface {
            material,
            shape,
            delta,
        },
    }
}

/// A cache holding one guide path: camera, the floor point `xa`, through the left sphere
/// (solved by the walk towards the sun's centre), the sun.
fn two_spheres_cache(scene: &Scene, xa: DVec3, settings: ManifoldSettings) -> GuideCache {
    let chain = Chain::new(1, 4, Far::Direction { light: 0 }, &[true, true]);
    let from = floor_point(xa);
    let seed = CENTRES[0] + DVec3::new(0.0, -0.5, 0.0);
    let sol = manifold::solve(
        scene,
        &from,
        seed.as_vec3(),
        &chain,
        &Goal::direction(DVec3::Y),
    )
    .expect("a chain through the left sphere to the sun's centre");
    let x1 = sol.sp.hit.p.as_dvec3();
    let (x2, w) = sphere_chain(xa, x1, CENTRES[0]).unwrap();
    let cam = scene.camera.position;
    let vertices = vec![
        PathVertex {
            p: cam,
            n: Vec3::ZERO,
            ns: Vec3::ZERO,
            uv: glam::Vec2::ZERO,
            tangent: Vec3::ZERO,
            kind: VertexKind::Camera,
        },
        surface(xa, DVec3::Y, 0, 0, false),
        surface(x1, (x1 - CENTRES[0]) / 0.5, 1, 1, true),
        surface(x2, (x2 - CENTRES[0]) / 0.5, 1, 1, true),
        PathVertex {
            p: (x2 + w).as_vec3(),
            n: w.as_vec3(),
            ns: Vec3::ZERO,
            uv: glam::Vec2::ZERO,
            tangent: Vec3::ZERO,
            kind: VertexKind::Emitter {
                light: 0,
                delta: false,
            },
        },
    ];
    let mut cache = GuideCache::default();
    cache.install(scene, vec![(vertices, 1.0, 1.0, 1.0, 0)], 4);
    assert_eq!(cache.len(), 1);
    cache.manifold = settings;
    cache
}

/// The path camera, `xa`, the chain through the sphere at `c` from `xa` through `x1`, the sun
/// (for the density's arguments), or `None` where the chain misses the sun's cone.
fn chain_path<'s>(xa: DVec3, x1: DVec3, c: DVec3, cam: Vec3) -> Option<[Vertex<'s>; 5]> {
    let (x2, w) = sphere_chain(xa, x1, c)?;
    if w.dot(DVec3::Y) < (4f64).to_radians().cos() {
        return None;
    }
    let v = |p: DVec3, n: DVec3| Vertex::new(Kind::Camera, p.as_vec3(), n.as_vec3());
    Some([
        Vertex::new(Kind::Camera, cam, Vec3::ZERO),
        v(xa, DVec3::Y),
        v(x1, (x1 - c) / 0.5),
        v(x2, (x2 - c) / 0.5),
        v(x2 + w, w),
    ])
}

/// The step's density of x_{a+1} integrated over both spheres (directions from `xa` drawn
/// uniformly in the cone around each sphere; area = solid angle x d² / cos) against the share
/// of its draws that succeed: the mean and its standard error.
fn integral_and_success(scene: &Scene, cache: &GuideCache, xa: DVec3) -> ((f64, f64), (f64, f64)) {
    let chain = Chain::new(1, 4, Far::Direction { light: 0 }, &[true, true]);
    let cam = scene.camera.position;
    let mut s = IndependentSampler::new(5, 0, 0);
    let n = 60_000;
    let (mut sum, mut sum2) = (0.0, 0.0);
    for c in CENTRES {
        let axis = (c - xa).normalize();
        let cos_max = (1.0 - 0.25 / (c - xa).length_squared()).sqrt();
        let omega = 2.0 * std::f64::consts::PI * (1.0 - cos_max);
        let a = if axis.x.abs() > 0.5 {
            DVec3::Y
        } else {
            DVec3::X
        };
        let (e1, e2) = (
            axis.cross(a).normalize(),
            axis.cross(axis.cross(a).normalize()),
        );
        for _ in 0..n {
            let (u1, u2) = (s.next_f64(), s.next_f64());
            let cos = 1.0 - u1 * (1.0 - cos_max);
            let sin = (1.0 - cos * cos).sqrt();
            let phi = 2.0 * std::f64::consts::PI * u2;
            let u = axis * cos + (e1 * phi.cos() + e2 * phi.sin()) * sin;
            // The sphere's near intersection.
            let o = xa - c;
            let b = o.dot(u);
            let disc = b * b - (o.length_squared() - 0.25);
            let mut value = 0.0;
            if disc > 0.0 {
                let t = -b - disc.sqrt();
                let x1 = xa + u * t;
                let n1 = (x1 - c) / 0.5;
                if let Some(y) = chain_path(xa, x1, c, cam) {
                    let q = manifold::density(scene, cache, 0, &y, &chain, &cache.manifold);
                    value = q * t * t / n1.dot(u).abs() * omega;
                }
            }
            sum += value;
            sum2 += value * value;
        }
    }
    let total = (2 * n) as f64;
    // Two independent halves of n draws each: the sum of their means.
    let mean = sum / n as f64;
    let var = (sum2 / total - (sum / total).powi(2)) * 2.0 / n as f64 * 2.0;
    // The step itself: draw the sun direction, walk, and keep what the density holds.
    let from = floor_point(xa);
    let (mut ok, draws) = (0u32, 4000u32);
    for _ in 0..draws {
        let goal = manifold::draw_goal(scene, cache, 0, &chain, xa.as_vec3(), &mut s).unwrap();
        let seed = manifold::seed(scene, cache, 0, 1, xa.as_vec3());
        let Ok(sol) = manifold::solve(scene, &from, seed, &chain, &goal) else {
            continue;
        };
        let x1 = sol.sp.hit.p.as_dvec3();
        let c = CENTRES[sol.sp.hit.shape as usize - 1];
        if let Some(y) = chain_path(xa, x1, c, cam)
            && manifold::density(scene, cache, 0, &y, &chain, &cache.manifold) > 0.0
        {
            ok += 1;
        }
    }
    let p = ok as f64 / draws as f64;
    (
        (mean, var.sqrt()),
        (p, (p * (1.0 - p) / draws as f64).sqrt()),
    )
}

/// The step's density integrates to the probability that it succeeds (it is a density of
/// what it draws); leaving out the Jacobian, or the basin indicator (which gives the chains
/// through the right sphere, where the walk from the left one never goes, a density too),
/// breaks that. |z| < 4 for the real density (false-failure rate 6e-5, fixed seed); the
/// controls must reach |z| > 8.
#[test]
fn chain_density_integrates_to_the_success_rate_and_the_controls_fail() {
    let scene = util::scene(&two_spheres());
    let xa = DVec3::new(0.0, -2.0, 0.1);
    let z = |settings: ManifoldSettings| {
        let cache = two_spheres_cache(&scene, xa, settings);
        let ((i, si), (p, sp)) = integral_and_success(&scene, &cache, xa);
        let z = (i - p) / (si * si + sp * sp).sqrt();
        eprintln!("{settings:?}: integral {i} ± {si}, success {p} ± {sp}, z {z}");
        z
    };
    let exact = z(ManifoldSettings::default());
    assert!(exact.abs() < 4.0, "z {exact}");
    let no_jacobian = z(ManifoldSettings {
        jacobian: 0.0,
        ..ManifoldSettings::default()
    });
    assert!(
        no_jacobian.abs() > 8.0,
        "without the Jacobian: z {no_jacobian}"
    );
    let no_basin = z(ManifoldSettings {
        basin: false,
        ..ManifoldSettings::default()
    });
    assert!(
        no_basin.abs() > 8.0,
        "without the basin indicator: z {no_basin}"
    );
}

/// The chain step's density of the vertex it drew, from sampling-time quantities (the
/// drawn direction's density times the walk's determinant), equals its evaluation from the
/// finished path (a new walk towards the path's own far end) to 2e-5 (both walks end on f32
/// hit points about 1e-7 m apart, where the determinant varies by up to 5e-6; the Newton
/// tolerance alone would allow 1e-5 m); and the sampler's
/// density of whole guided paths equals p(X | l) evaluated from their vertices to 1e-5 (the
/// first-vertex kernel is drawn as an f64 point and evaluated at the f32 hit point, about
/// 1e-6 apart).
#[test]
fn sampled_density_equals_evaluated_density() {
    let scene = util::scene(&two_spheres());
    let xa = DVec3::new(0.0, -2.0, 0.1);
    let mut cache = two_spheres_cache(&scene, xa, ManifoldSettings::default());
    let chain = Chain::new(1, 4, Far::Direction { light: 0 }, &[true, true]);
    let from = floor_point(xa);
    let cam = scene.camera.position;
    let cone_pdf = 1.0 / (2.0 * std::f64::consts::PI * (1.0 - (4f64).to_radians().cos()));
    let (mut n, mut worst_step) = (0, 0.0f64);
    let mut s = IndependentSampler::new(3, 0, 0);
    for _ in 0..2000 {
        let goal = manifold::draw_goal(&scene, &cache, 0, &chain, xa.as_vec3(), &mut s).unwrap();
        let seed = manifold::seed(&scene, &cache, 0, 1, xa.as_vec3());
        let Ok(sol) = manifold::solve(&scene, &from, seed, &chain, &goal) else {
            continue;
        };
        let x1 = sol.sp.hit.p.as_dvec3();
        let Some(y) = chain_path(xa, x1, CENTRES[0], cam) else {
            continue;
        };
        let sampled = cone_pdf * sol.det;
        let evaluated = manifold::density(&scene, &cache, 0, &y, &chain, &cache.manifold);
        worst_step = worst_step.max((sampled - evaluated).abs() / sampled);
        n += 1;
    }
    eprintln!("{n} chain steps, worst relative difference {worst_step:e}");
    assert!(n > 1500, "only {n} chain steps converged");
    assert!(worst_step < 2e-5, "chain step: {worst_step:e}");

    cache.manifold.share = 1.0;
    let (mut ok, mut worst) = (0, 0.0f64);
    for i in 0..3000u64 {
        let mut s = IndependentSampler::new(9, 0, i);
        let Ok(g) = sampler::sample_path(&scene, &cache, &mut s) else {
            continue;
        };
        let y = lodestar::integrators::paths::from_path(&scene, &g.path).unwrap();
        let term = cache.pdf_given(&scene, g.guide, &y);
        if term > 0.0 {
            ok += 1;
            worst = worst.max((term - g.density).abs() / term);
        }
    }
    eprintln!("{ok} paths, worst relative difference {worst:e}");
    assert!(ok > 300, "only {ok} guided paths");
    assert!(
        worst < 1e-5,
        "sampled and evaluated densities differ by {worst:e}"
    );
}
