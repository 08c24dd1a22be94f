//! The specular-chain step of the guided sampler (`integrators/guided/manifold.rs`): the
//! Newton walk against analytic refraction chains, its Jacobian against independent finite
//! differences, and the density's normalisation (with a control that leaves the Jacobian out).

mod util;

use glam::{DVec3, Vec3};
use lodestar::integrators::guided::manifold::{self, Chain, Far, From, Goal};
use lodestar::scene::Scene;

/// Flat water (ior 1.33) at y = 0 over a diffuse floor at y = -2, a sun.
const FLAT_WATER: &str = r#"
[camera]
position = [0, 1.5, 2.5]
look_at = [0, -2, 0]
up = [0, 1, 0]
fov = 50
resolution = [32, 24]

[[material]]
name = "floor"
type = "diffuse"
albedo = [0.8, 0.8, 0.8]

[[material]]
name = "water"
type = "dielectric"
ior = 1.33

[[shape]]
type = "quad"
origin = [-4, -2, -4]
edge_u = [0, 0, 8]
edge_v = [8, 0, 0]
material = "floor"

[[shape]]
type = "quad"
origin = [-4, 0, -4]
edge_u = [0, 0, 8]
edge_v = [8, 0, 0]
material = "water"

[[light]]
type = "sun"
direction = [0.25, 1, -0.35]
angle = 4
irradiance = [3, 3, 3]
"#;

/// A glass sphere (ior 1.5) of radius 0.5 at the origin above a diffuse floor at y = -2.
const GLASS_SPHERE: &str = r#"
[camera]
position = [0, 1.5, 4]
look_at = [0, -1, 0]
up = [0, 1, 0]
fov = 50
resolution = [32, 24]

[[material]]
name = "floor"
type = "diffuse"
albedo = [0.8, 0.8, 0.8]

[[material]]
name = "glass"
type = "dielectric"
ior = 1.5

[[shape]]
type = "quad"
origin = [-4, -2, -4]
edge_u = [0, 0, 8]
edge_v = [8, 0, 0]
material = "floor"

[[shape]]
type = "sphere"
center = [0, 0, 0]
radius = 0.5
material = "glass"

[[light]]
type = "sun"
direction = [0.1, 1, 0.05]
angle = 4
irradiance = [3, 3, 3]
"#;

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
    let d = (x - xa).normalize();
    let n = x / 0.5;
    let d1 = snell(d, n, 1.5)?;
    let (_, n2) = sphere_exit(x, d1, 0.5)?;
    snell(d1, n2, 1.5)
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
    let scene = util::scene(FLAT_WATER);
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
    let scene = util::scene(GLASS_SPHERE);
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

#[test]
fn debug_pool_rate() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/pool.toml"))
        .unwrap()
        .replace("resolution = [320, 240]", "resolution = [32, 24]");
    let scene: Scene = util::scene(&text);
    let chain = Chain::new(2, 4, Far::Direction { light: 0 }, &[true]);
    let sun = DVec3::new(0.25, 1.0, -0.35).normalize();
    let mut ok = 0;
    let mut n = 0;
    let mut errs = std::collections::BTreeMap::new();
    for k in 0..400u64 {
        let h = |i: u64| ((k * 2654435761 + i * 40503) % 1000) as f64 / 1000.0;
        let xa = DVec3::new(-1.5 + 3.0 * h(1), -1.5, -1.2 + 2.4 * h(2));
        let from = floor_point(xa);
        // a solution for the sun's centre from a seed above x_a
        let seed = xa + DVec3::new(0.0, 1.4, 0.0);
        let Ok(s0) = manifold::solve(&scene, &from, seed.as_vec3(), &chain, &Goal::direction(sun))
        else {
            *errs.entry("seed0").or_insert(0) += 1;
            continue;
        };
        let w = (sun + DVec3::new(0.05 * (h(3) - 0.5), 0.0, 0.05 * (h(4) - 0.5))).normalize();
        n += 1;
        match manifold::solve(&scene, &from, s0.sp.hit.p, &chain, &Goal::direction(w)) {
            Ok(_) => ok += 1,
            Err(e) => {
                *errs
                    .entry(if format!("{e:?}").is_empty() {
                        "x"
                    } else {
                        "nc"
                    })
                    .or_insert(0) += 1
            }
        }
    }
    eprintln!("{ok} / {n} converged; {errs:?}");
}
