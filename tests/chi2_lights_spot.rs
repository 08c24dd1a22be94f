//! Tests of the spot, spot area, directional and sun lights (see `common/chi2.rs` for the
//! harness and its significance level).
//!
//! * Chi-square of `sample_le` against `pdf_le`: the point spot's directions (uniform in its
//!   cone; the default 30/5 degree profile and a 120 degree one), the spot area light's origins
//!   (uniform on a disk) and directions (cosine-weighted within the cone), the sun's
//!   directions (0.27 and 5 degrees) and origins, the directional light's origins on the
//!   scene's bounding disk.
//! * Chi-square of `sample_li` against `pdf_li`: the spot area light seen from below and from
//!   30 degrees off its axis (where part of the disk shows zero radiance: `sample_li` fails
//!   there, and the density restricted to the profile's support must integrate to the share
//!   of successful samples), and the sun (0.27 and 5 degrees).
//! * Deterministic checks: the spot falloff against pbrt's smoothstep, computed here in f64
//!   (full intensity inside `cone_angle - cone_delta`, zero outside `cone_angle`, smooth and
//!   monotone in between), `power()` of the point spot and the spot area light against a
//!   numerical integral of the intensity / radiance they report (relative 1e-5), the
//!   directional light's `sample_li` / `sample_le` values, the sun's `le` and `pdf_li` inside
//!   and outside its cone.
//! * The sun's irradiance: the mean of `li cos / pdf` over `sample_li` directions on a surface
//!   facing the sun against `L pi sin^2(angle)` (and `E` for `SunLight::from_irradiance`): a
//!   two-sided z-test at the harness's alpha on the sample standard deviation, plus a relative
//!   1e-6 for the f32 rounding of the cone's `1 - cos`.
//! * The power-proportional light selection with every kind of light.
//!
//! Hypothesis tests in this file: 13 chi-square cases (each a shape test and a mass check:
//! 26) and 3 z-tests, 29 in all, plus 3 power controls (6) that must reject. Each runs at the
//! harness's Sidak-corrected `chi2::alpha()` (1.9e-5 with `SUITE_TESTS` = 530, an upper bound
//! on the suite's hypothesis tests, `common/chi2.rs`), so a correct implementation makes
//! *any* test of the whole suite fail with probability at most 1 %; this file's share of that
//! is at most 29 alpha = 5.6e-4. Seeds are fixed, so a run is reproducible. The power controls
//! at the end assert that the tests reject plausible bugs.
//!
//! Samples: 1e6 per chi-square case (2.5e5 for two power controls), 2e5 per irradiance
//! z-test. About 5 s in release on one core.

use crate::common;

use common::chi2::{self, SphereDomain};
use common::{Failures, close, close3};
use glam::{DVec2, DVec3, Vec2, Vec3};
use lodestar::geometry::{TriangleMesh, mesh::MeshSampler};
use lodestar::light::{
    AreaLight, AreaShape, DirectionalLight, EnvironmentLight, Light, LightSampler, PointLight,
    SpotLight, SpotProfile, SunLight,
};
use lodestar::math::{Frame, Sampler};
use statrs::distribution::{ContinuousCDF, Normal};
use std::f64::consts::PI;

/// Samples per chi-square case.
const N: usize = 1_000_000;

const RADIANCE: Vec3 = Vec3::new(4.0, 2.0, 1.0);
const INTENSITY: Vec3 = Vec3::new(10.0, 5.0, 2.0);

fn lum(c: Vec3) -> f64 {
    0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64
}

/// `1 - cos(degrees)` in f64 without cancellation.
fn one_minus_cos_deg(degrees: f64) -> f64 {
    let h = 0.5 * degrees.to_radians();
    2.0 * h.sin() * h.sin()
}

/// pbrt's spot falloff, in f64: `smoothstep(cos(cone), cos(cone - delta), cos_theta)` (a
/// step at `cos(cone)` for `delta = 0`).
fn falloff_ref(cos_theta: f64, cone: f64, delta: f64) -> f64 {
    let a = cone.to_radians().cos();
    let b = (cone - delta).to_radians().cos();
    if delta == 0.0 {
        return if cos_theta < a { 0.0 } else { 1.0 };
    }
    let t = ((cos_theta - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The unit direction at angle `theta` (radians) from `axis`, azimuth `phi`, built in f64.
fn dir_at(axis: Vec3, theta: f64, phi: f64) -> Vec3 {
    let z = 2.0 * (0.5 * theta).sin().powi(2);
    SphereDomain::full_around(axis).to_dir(DVec2::new(z, phi))
}

/// Composite midpoint rule of `f` over `[a, b]` with `n` points (no endpoint is evaluated, so
/// a jump at an endpoint costs nothing).
fn midpoint(a: f64, b: f64, n: usize, mut f: impl FnMut(f64) -> f64) -> f64 {
    let h = (b - a) / n as f64;
    (0..n).map(|k| f(a + (k as f64 + 0.5) * h)).sum::<f64>() * h
}

/// `∫_0^pi f(theta) dtheta`, split at the profile's breakpoints.
fn integrate_theta(cone: f64, delta: f64, f: impl Fn(f64) -> f64) -> f64 {
    let (t0, t1) = ((cone - delta).to_radians(), cone.to_radians());
    let mut sum = 0.0;
    for (a, b) in [(0.0, t0), (t0, t1), (t1, PI)] {
        if b > a {
            sum += midpoint(a, b, 20_000, &f);
        }
    }
    sum
}

// ------------------------------------------------------------------------------------------
// Scene pieces
// ------------------------------------------------------------------------------------------

const DISK_CENTER: Vec3 = Vec3::new(0.2, -0.1, 2.0);
const DISK_RADIUS: f32 = 0.3;

const DISK_SEGMENTS: u32 = 64;

/// A disk (64-gon) of radius 0.3 in the plane z = 2, facing down (-z).
fn disk_mesh() -> TriangleMesh {
    let k = DISK_SEGMENTS;
    let mut positions = vec![DISK_CENTER];
    positions.extend((0..k).map(disk_vertex));
    // Clockwise seen from above: the geometric normal points down.
    let indices = (0..k).map(|i| [0, 1 + (i + 1) % k, 1 + i]).collect();
    let m = TriangleMesh {
        positions,
        normals: None,
        uvs: None,
        grid: None,
        indices,
    };
    assert!(close3(m.geometric_normal(0), -Vec3::Z, 0.0, 1e-6));
    m
}

fn spot_area_light(mesh: &TriangleMesh, profile: SpotProfile) -> Light {
    Light::Area(AreaLight::with_spot(
        0,
        RADIANCE,
        AreaShape::Mesh {
            mesh: Box::new(mesh.clone()),
            sampler: MeshSampler::new(mesh),
        },
        profile,
    ))
}

/// Vertex `i` of the disk's rim, exactly as [`disk_mesh`] computes it.
fn disk_vertex(i: u32) -> Vec3 {
    let phi = 2.0 * std::f32::consts::PI * (i % DISK_SEGMENTS) as f32 / DISK_SEGMENTS as f32;
    DISK_CENTER + DISK_RADIUS * Vec3::new(phi.cos(), phi.sin(), 0.0)
}

/// Is `p` (in the disk's plane, xy) inside the 64-gon? Inside the triangle of the sector it
/// lies in, i.e. left of that sector's rim edge (the rim runs counter-clockwise in xy).
fn in_disk(p: DVec2) -> bool {
    let c = DISK_CENTER.truncate().as_dvec2();
    let sector = 2.0 * PI / DISK_SEGMENTS as f64;
    let phi = (p.y - c.y).atan2(p.x - c.x).rem_euclid(2.0 * PI);
    let k = (phi / sector) as u32;
    let a = disk_vertex(k).truncate().as_dvec2();
    let b = disk_vertex(k + 1).truncate().as_dvec2();
    (b - a).perp_dot(p - a) >= 0.0
}

/// Where the ray from `o` along unit `d` meets the front (lower) side of the disk, in f64.
fn hit_disk(o: DVec3, d: DVec3) -> Option<DVec3> {
    let c = DISK_CENTER.as_dvec3();
    if d.z <= 0.0 || o.z >= c.z {
        return None;
    }
    let hit = o + (c.z - o.z) / d.z * d;
    in_disk(hit.truncate()).then_some(hit)
}

// ------------------------------------------------------------------------------------------
// Spot falloff and power
// ------------------------------------------------------------------------------------------

/// (cone_angle, cone_delta) of the profiles checked: the default, a hard edge, an edge as wide
/// as the cone, a cone wider than a hemisphere, and a narrow one.
const PROFILES: [(f32, f32); 5] = [
    (30.0, 5.0),
    (45.0, 0.0),
    (60.0, 60.0),
    (120.0, 30.0),
    (2.0, 1.0),
];

#[test]
fn spot_falloff_and_power() {
    let d = SpotProfile::default();
    assert_eq!((d.cone_angle(), d.cone_delta()), (30.0, 5.0));
    assert!(SpotProfile::check(30.0, 31.0).is_err() && SpotProfile::check(0.0, 0.0).is_err());
    assert!(SpotProfile::check(181.0, 5.0).is_err() && SpotProfile::check(120.0, 5.0).is_ok());
    assert!(SpotProfile::check_area(120.0, 5.0).is_err());
    let position = Vec3::new(1.0, 2.0, 3.0);
    let axis = Vec3::new(0.3, -0.8, 0.5).normalize();
    for (cone, delta) in PROFILES {
        let (c, dl) = (cone as f64, delta as f64);
        let light = Light::Spot(SpotLight::new(
            position,
            axis * 2.0, // normalised by the constructor
            INTENSITY,
            SpotProfile::new(cone, delta),
        ));
        assert!(light.is_delta() && !light.is_infinite());
        // Intensity along the direction at angle theta, measured through sample_li from a
        // point 3 away along it (li * dist^2), per channel / I.
        let measure = |theta: f64, phi: f64| -> Option<f64> {
            let w = dir_at(axis, theta, phi);
            let p = position + 3.0 * w;
            let ls = light.sample_li(p, Vec2::splat(0.5))?;
            assert!(ls.delta && ls.pdf == 1.0 && ls.p == position && ls.n == Vec3::ZERO);
            assert!(close3(ls.wi, -w, 0.0, 1e-6), "wi {} != {}", ls.wi, -w);
            assert_eq!(light.pdf_li(p, ls.p, ls.n, ls.wi), 0.0);
            let i = ls.li.as_dvec3() * (ls.dist as f64).powi(2);
            let f = i.x / INTENSITY.x as f64;
            assert!(
                close3(i.as_vec3(), INTENSITY * f as f32, 1e-5, 0.0),
                "not a multiple of I: {i}"
            );
            Some(f)
        };
        let name = format!("spot {cone}/{delta}");
        let (t_start, t_end) = ((c - dl).to_radians(), c.to_radians());
        let steps = 4000;
        let mut prev = 1.0f64;
        for k in 0..=steps {
            let theta = PI * k as f64 / steps as f64;
            let phi = 2.0 * PI * (k as f64 * 0.618_033_988_75).fract();
            let f = measure(theta, phi).unwrap_or(0.0);
            let want = falloff_ref(theta.cos(), c, dl);
            // Away from a hard edge (where f32 may fall either side), within 1e-4.
            let near_step = delta == 0.0 && (theta - t_end).abs() < 1e-5;
            assert!(
                near_step || (f - want).abs() < 1e-4,
                "{name}: I({:.4} deg) / I = {f}, want {want}",
                theta.to_degrees()
            );
            let margin = 1e-5;
            if theta < t_start - margin {
                assert!(close(f, 1.0, 1e-5, 0.0), "{name}: {f} inside the full cone");
            } else if theta > t_end + margin {
                assert!(
                    measure(theta, phi).is_none(),
                    "{name}: emits outside the cone"
                );
            } else {
                assert!((0.0..=1.0 + 1e-6).contains(&f), "{name}: {f} on the edge");
                if want > 1e-3 && want < 1.0 - 1e-3 {
                    assert!(f > 0.0 && f < 1.0, "{name}: {f} on the smooth edge");
                }
            }
            assert!(f <= prev + 1e-5, "{name}: not monotone at {theta}");
            prev = f;
        }
        // Power: luminance of ∫ I dω = 2 pi ∫ I(theta) sin(theta) dtheta.
        let integral = 2.0
            * PI
            * lum(INTENSITY)
            * integrate_theta(c, dl, |theta| {
                measure(theta, 1.3 + 7.0 * theta).unwrap_or(0.0) * theta.sin()
            });
        let closed = 2.0
            * PI
            * lum(INTENSITY)
            * (one_minus_cos_deg(c - dl)
                + 0.5 * (one_minus_cos_deg(c) - one_minus_cos_deg(c - dl)));
        println!(
            "{name}: power {} numerical {integral} closed form {closed}",
            light.power()
        );
        assert!(
            close(light.power() as f64, integral, 1e-5, 0.0),
            "{name}: power {} != numerical integral {integral}",
            light.power()
        );
        assert!(close(light.power() as f64, closed, 1e-5, 0.0));
    }
}

#[test]
fn spot_area_light_falloff_and_power() {
    let mesh = disk_mesh();
    let area = mesh.area() as f64;
    let n = -Vec3::Z;
    for (cone, delta) in PROFILES
        .into_iter()
        .filter(|p| p.0 <= 90.0)
        .chain([(90.0, 0.0)])
    {
        let (c, dl) = (cone as f64, delta as f64);
        let light = spot_area_light(&mesh, SpotProfile::new(cone, delta));
        assert!(!light.is_delta() && !light.is_infinite());
        let name = format!("spot area {cone}/{delta}");
        let le = |theta: f64, phi: f64| -> f64 {
            let w = dir_at(n, theta, phi);
            let l = light.le(Vec3::ZERO, n, w);
            assert!(close3(l, RADIANCE * (l.x / RADIANCE.x), 1e-6, 0.0));
            l.x as f64 / RADIANCE.x as f64
        };
        for k in 0..=2000 {
            let theta = PI * k as f64 / 2000.0;
            let f = le(theta, 0.1 * k as f64);
            let want = if theta < 0.5 * PI {
                falloff_ref(theta.cos(), c, dl)
            } else {
                0.0
            };
            let near_step = delta == 0.0 && (theta - c.to_radians()).abs() < 1e-5;
            assert!(
                near_step || (f - want).abs() < 1e-4,
                "{name}: L({:.4} deg) / L = {f}, want {want}",
                theta.to_degrees()
            );
        }
        // Power: area * luminance of ∫ L(theta) cos(theta) dω over the front hemisphere.
        let integral = area
            * 2.0
            * PI
            * lum(RADIANCE)
            * integrate_theta(c, dl, |theta| {
                le(theta, 0.7 + 5.0 * theta) * theta.cos().max(0.0) * theta.sin()
            });
        println!("{name}: power {} numerical {integral}", light.power());
        assert!(
            close(light.power() as f64, integral, 1e-5, 0.0),
            "{name}: power {} != numerical integral {integral}",
            light.power()
        );
    }
    // Without a profile nothing changed: pi A L.
    let plain = Light::Area(AreaLight::new(
        0,
        RADIANCE,
        AreaShape::Mesh {
            mesh: Box::new(mesh.clone()),
            sampler: MeshSampler::new(&mesh),
        },
    ));
    assert!(close(
        plain.power() as f64,
        PI * area * lum(RADIANCE),
        1e-6,
        0.0
    ));
    assert_eq!(plain.le(Vec3::ZERO, n, dir_at(n, 1.5, 0.0)), RADIANCE);
}

// ------------------------------------------------------------------------------------------
// Point spot: sample_le
// ------------------------------------------------------------------------------------------

#[test]
fn spot_light_sample_le() {
    let position = Vec3::new(1.0, 2.0, 3.0);
    let axis = Vec3::new(0.3, -0.8, 0.5).normalize();
    for (cone, delta) in [(30.0f32, 5.0f32), (120.0, 30.0)] {
        let light = Light::Spot(SpotLight::new(
            position,
            axis,
            INTENSITY,
            SpotProfile::new(cone, delta),
        ));
        let z_end = one_minus_cos_deg(cone as f64);
        let name = format!("spot {cone}/{delta} sample_le directions");
        let mut fails = Failures::new();
        // The cone as the domain (directions outside it fail the test); f32 rounding may place
        // a direction a relative 1e-6 (in 1 - cos) past the edge.
        let domain = SphereDomain::around(axis, z_end).with_edge_slack(1e-6);
        chi2::spherical(
            &name,
            N,
            &domain,
            |s: &mut dyn Sampler| {
                let e = light.sample_le(s.next_2d(), s.next_2d())?;
                let (pp, pd) = light.pdf_le(e.n, e.dir);
                fails.check(
                    e.p == position && e.n == Vec3::ZERO && e.pdf_pos == 1.0 && pp == 1.0,
                    || format!("{e:?}"),
                );
                fails.check(close(e.pdf_dir as f64, pd as f64, 1e-6, 0.0), || {
                    format!("pdf_dir {} != pdf_le {pd}", e.pdf_dir)
                });
                fails.check(
                    close(pd as f64, 1.0 / (2.0 * PI * z_end), 1e-5, 0.0),
                    || format!("pdf_le {pd} is not uniform in the cone"),
                );
                let cos = e.dir.as_dvec3().normalize().dot(axis.as_dvec3());
                let want = INTENSITY * falloff_ref(cos, cone as f64, delta as f64) as f32;
                fails.check(close3(e.le, want, 0.0, 1e-3), || {
                    format!("le {} != I(theta) {want}", e.le)
                });
                Some(e.dir)
            },
            |w| light.pdf_le(Vec3::ZERO, w).1 as f64,
        )
        .assert_ok();
        fails.assert_none(&name);
        // Nothing outside the cone.
        assert_eq!(light.pdf_le(Vec3::ZERO, -axis).1, 0.0);
    }
}

// ------------------------------------------------------------------------------------------
// Spot area light
// ------------------------------------------------------------------------------------------

#[test]
fn spot_area_light_sample_le() {
    let (cone, delta) = (30.0f32, 5.0f32);
    let mesh = disk_mesh();
    let light = spot_area_light(&mesh, SpotProfile::new(cone, delta));
    let n = -Vec3::Z;
    let inv_area = 1.0 / mesh.area() as f64;
    let z_end = one_minus_cos_deg(cone as f64);
    let sin2 = z_end * (2.0 - z_end);
    let check = |fails: &mut Failures, e: &lodestar::light::EmissionSample| {
        let (pp, pd) = light.pdf_le(e.n, e.dir);
        fails.check(
            close(e.pdf_pos as f64, pp as f64, 1e-6, 0.0)
                && close(pp as f64, inv_area, 1e-5, 0.0)
                && close(e.pdf_dir as f64, pd as f64, 1e-4, 0.0),
            || {
                format!(
                    "sample pdfs ({}, {}) != pdf_le ({pp}, {pd})",
                    e.pdf_pos, e.pdf_dir
                )
            },
        );
        let cos = e.dir.as_dvec3().normalize().dot(n.as_dvec3());
        fails.check(close(pd as f64, cos / (PI * sin2), 1e-4, 0.0), || {
            format!("pdf_le {pd} is not cos / (pi sin^2) at cos {cos}")
        });
        let want = RADIANCE * falloff_ref(cos, cone as f64, delta as f64) as f32;
        fails.check(close3(e.le, want, 0.0, 1e-3), || {
            format!("le {} != L(theta) {want}", e.le)
        });
        fails.check(
            close3(e.n, n, 0.0, 1e-6) && (e.p.z - DISK_CENTER.z).abs() < 1e-6,
            || format!("point {} normal {}", e.p, e.n),
        );
    };
    // Origins: uniform on the disk (the 64-gon), seen in the xy plane.
    let mut fails = Failures::new();
    let c = DISK_CENTER.truncate();
    chi2::planar(
        "spot area light sample_le positions",
        N,
        c - Vec2::splat(0.31),
        c + Vec2::splat(0.31),
        [32, 32],
        |s| {
            let e = light.sample_le(s.next_2d(), s.next_2d())?;
            check(&mut fails, &e);
            Some(e.p.truncate())
        },
        |p| {
            if in_disk(p.as_dvec2()) { inv_area } else { 0.0 }
        },
    )
    .assert_ok();
    fails.assert_none("spot area light sample_le positions");
    // Directions, in the frame of the normal: cosine-weighted within the cone.
    let mut fails = Failures::new();
    chi2::spherical(
        "spot area light sample_le directions",
        N,
        &SphereDomain::around(Vec3::Z, z_end).with_edge_slack(1e-6),
        |s| {
            let e = light.sample_le(s.next_2d(), s.next_2d())?;
            check(&mut fails, &e);
            Some(Frame::from_z(e.n).to_local(e.dir))
        },
        |w| light.pdf_le(Vec3::Z, w).1 as f64,
    )
    .assert_ok();
    fails.assert_none("spot area light sample_le directions");
}

/// Density of the spot area light's `sample_li` at `p` along `w`: `pdf_li` at the disk's
/// point along the ray, where the profile of half-angle `cone` (decided here in f64) is
/// non-zero.
fn spot_area_dir_pdf(light: &Light, cone: f64, p: Vec3, w: Vec3) -> f64 {
    let d = w.as_dvec3().normalize();
    match hit_disk(p.as_dvec3(), d) {
        // The disk faces -z: the cosine at the light is d.z.
        Some(hit) if d.z > cone.to_radians().cos() => {
            light.pdf_li(p, hit.as_vec3(), -Vec3::Z, d.as_vec3()) as f64
        }
        _ => 0.0,
    }
}

#[test]
fn spot_area_light_sample_li() {
    let (cone, delta) = (30.0f32, 5.0f32);
    let mesh = disk_mesh();
    let light = spot_area_light(&mesh, SpotProfile::new(cone, delta));
    // Straight below (every point of the disk sees it within 8.5 degrees: full radiance), and
    // 30 degrees off the axis (seen at 22-37 degrees: full, smooth edge and dark parts).
    let below = DISK_CENTER - 2.0 * Vec3::Z;
    let off = DISK_CENTER + 2.0 * Vec3::new(0.5, 0.0, -(0.75f32).sqrt());
    for (k, p) in [below, off].into_iter().enumerate() {
        let name = format!("spot area light sample_li #{k}");
        let mut fails = Failures::new();
        let domain = if k == 0 {
            // The cone through the disk's rim, on which the 64-gon's vertices lie.
            let (r, h) = (DISK_RADIUS as f64, (DISK_CENTER - p).length() as f64);
            let sin2 = r * r / (r * r + h * h);
            SphereDomain::around(Vec3::Z, sin2 / (1.0 + (1.0 - sin2).sqrt())).with_edge_slack(1e-5)
        } else {
            SphereDomain::covering_ball(p, DISK_CENTER, DISK_RADIUS as f64 * 1.01)
        };
        let dir_pdf = |w: Vec3| spot_area_dir_pdf(&light, cone as f64, p, w);
        let report = chi2::spherical(
            &name,
            N,
            &domain,
            |s: &mut dyn Sampler| {
                let ls = light.sample_li(p, s.next_2d())?;
                let v = ls.p - p;
                let pdf = light.pdf_li(p, ls.p, ls.n, ls.wi);
                fails.check(close(ls.pdf as f64, pdf as f64, 1e-4, 0.0), || {
                    format!("sample pdf {} != pdf_li {pdf}", ls.pdf)
                });
                let d = dir_pdf(ls.wi);
                fails.check(close(ls.pdf as f64, d, 2e-3, 0.0), || {
                    format!("sample pdf {} != density of its direction {d}", ls.pdf)
                });
                fails.check(
                    close3(ls.wi, v.normalize(), 0.0, 1e-5)
                        && close(ls.dist as f64, v.length() as f64, 1e-5, 0.0)
                        && !ls.delta
                        && close3(ls.n, -Vec3::Z, 0.0, 1e-6),
                    || format!("{ls:?}"),
                );
                let cos = -ls.wi.as_dvec3().normalize().dot(ls.n.as_dvec3());
                let want = RADIANCE * falloff_ref(cos, cone as f64, delta as f64) as f32;
                fails.check(
                    close3(ls.li, want, 0.0, 1e-3) && ls.li != Vec3::ZERO,
                    || format!("li {} != L(theta) {want} at cos {cos}", ls.li),
                );
                Some(ls.wi)
            },
            dir_pdf,
        );
        report.assert_ok();
        // A sample exactly on an edge may be missed by the ray casting.
        fails.assert_at_most(N / 100_000, &name);
        if k == 0 {
            assert!(report.share() > 0.999, "{report}");
        } else {
            assert!(report.share() > 0.2 && report.share() < 0.8, "{report}");
        }
    }
}

// ------------------------------------------------------------------------------------------
// Directional light
// ------------------------------------------------------------------------------------------

#[test]
fn directional_light() {
    let e = Vec3::new(3.0, 2.5, 2.0);
    let direction = Vec3::new(0.2, -0.9, -0.4).normalize();
    let mut light = Light::Directional(DirectionalLight::new(direction * 3.0, e));
    let (center, radius) = (Vec3::new(1.0, 2.0, 3.0), 7.0f32);
    light.set_scene_bounds(center, radius);
    assert!(light.is_delta() && light.is_infinite());
    assert!(close(
        light.power() as f64,
        lum(e) * PI * (radius as f64).powi(2),
        1e-6,
        0.0
    ));
    let mut s = chi2::sampler_for("directional light");
    for _ in 0..10_000 {
        let p = (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * 20.0;
        let ls = light.sample_li(p, s.next_2d()).unwrap();
        assert!(close3(ls.wi, -direction, 0.0, 1e-6));
        assert!(ls.li == e && ls.pdf == 1.0 && ls.delta && ls.dist == f32::INFINITY);
        assert_eq!(light.pdf_li(p, ls.p, ls.n, ls.wi), 0.0);
        assert_eq!(light.le(Vec3::ZERO, Vec3::ZERO, ls.wi), Vec3::ZERO);
    }
    // Origins: uniform on the disk of the bounding sphere's radius, centred at
    // center - radius * direction, perpendicular to the direction. In units of the radius.
    let frame = Frame::from_z(-direction);
    let mut fails = Failures::new();
    chi2::planar(
        "directional light sample_le positions",
        N,
        Vec2::splat(-1.0),
        Vec2::splat(1.0),
        [32, 32],
        |s| {
            let em = light.sample_le(s.next_2d(), s.next_2d())?;
            let (pp, pd) = light.pdf_le(em.n, em.dir);
            fails.check(
                close3(em.dir, direction, 0.0, 1e-6)
                    && em.n == em.dir
                    && em.le == e
                    && em.pdf_dir == 1.0
                    && pd == 1.0
                    && em.pdf_pos == pp
                    && close(pp as f64, 1.0 / (PI * (radius as f64).powi(2)), 1e-6, 0.0),
                || format!("{em:?}"),
            );
            let d = em.p - center + radius * direction;
            fails.check(d.dot(direction).abs() < 1e-5 * radius, || {
                format!("origin {} not on the disk", em.p)
            });
            Some(Vec2::new(d.dot(frame.s), d.dot(frame.t)) / radius)
        },
        |x| {
            if x.length_squared() < 1.0 {
                1.0 / PI
            } else {
                0.0
            }
        },
    )
    .assert_ok();
    fails.assert_none("directional sample_le positions");
}

// ------------------------------------------------------------------------------------------
// Sun
// ------------------------------------------------------------------------------------------

fn sun_dir() -> Vec3 {
    Vec3::new(0.3, 0.5, 0.8).normalize()
}

fn sun(angle: f32) -> Light {
    let mut l = Light::Sun(SunLight::new(sun_dir(), angle, RADIANCE));
    l.set_scene_bounds(Vec3::new(1.0, 2.0, 3.0), 10.0);
    l
}

/// The sun's exact cone as the domain. The f32 sampling code places directions to ~6e-8 rad,
/// 1.3e-5 of the 0.27 degree cone: directions that rounding pushed up to 3e-3 (in 1 - cos)
/// past the edge count as on it.
fn sun_domain(angle: f32) -> SphereDomain {
    SphereDomain::around(sun_dir(), one_minus_cos_deg(angle as f64)).with_edge_slack(3e-3)
}

#[test]
fn sun_sample_li() {
    for angle in [0.27f32, 5.0] {
        let light = sun(angle);
        assert!(!light.is_delta() && light.is_infinite());
        let cone_pdf = 1.0 / (2.0 * PI * one_minus_cos_deg(angle as f64));
        let p = Vec3::new(0.5, -1.0, 2.0);
        let name = format!("sun {angle} sample_li");
        let mut fails = Failures::new();
        let mut off_cone = 0;
        chi2::spherical(
            &name,
            N,
            &sun_domain(angle),
            |s: &mut dyn Sampler| {
                let ls = light.sample_li(p, s.next_2d())?;
                fails.check(close(ls.pdf as f64, cone_pdf, 1e-5, 0.0), || {
                    format!("pdf {} != cone pdf {cone_pdf}", ls.pdf)
                });
                fails.check(
                    !ls.delta && ls.dist == f32::INFINITY && ls.li == RADIANCE,
                    || format!("{ls:?}"),
                );
                // pdf_li and le agree with the sample, but for rounding on the cone's edge.
                let pdf = light.pdf_li(p, ls.p, ls.n, ls.wi);
                if pdf != ls.pdf || light.le(Vec3::ZERO, Vec3::ZERO, ls.wi) != RADIANCE {
                    off_cone += 1;
                }
                Some(ls.wi)
            },
            |w| light.pdf_li(p, Vec3::ZERO, Vec3::ZERO, w) as f64,
        )
        .assert_ok();
        fails.assert_none(&name);
        assert!(
            off_cone <= N / 10_000,
            "{name}: {off_cone} samples off the cone"
        );
    }
}

#[test]
fn sun_sample_le() {
    for angle in [0.27f32, 5.0] {
        let light = sun(angle);
        let (center, radius) = (Vec3::new(1.0, 2.0, 3.0), 10.0f32);
        let cone_pdf = 1.0 / (2.0 * PI * one_minus_cos_deg(angle as f64));
        let pos_pdf = 1.0 / (PI * (radius as f64).powi(2));
        let check = |fails: &mut Failures, e: &lodestar::light::EmissionSample| {
            fails.check(
                close(e.pdf_dir as f64, cone_pdf, 1e-5, 0.0)
                    && close(e.pdf_pos as f64, pos_pdf, 1e-6, 0.0)
                    && e.le == RADIANCE
                    && e.n == e.dir,
                || format!("{e:?}"),
            );
            let w = -e.dir;
            let d = e.p - center - radius * w;
            fails.check(d.dot(w).abs() < 1e-4 * radius, || {
                format!("origin {} not on the disk facing {w}", e.p)
            });
        };
        // Directions: uniform in the cone (towards the sun, reversed).
        let name = format!("sun {angle} sample_le directions");
        let mut fails = Failures::new();
        let mut off_cone = 0;
        chi2::spherical(
            &name,
            N,
            &sun_domain(angle),
            |s: &mut dyn Sampler| {
                let e = light.sample_le(s.next_2d(), s.next_2d())?;
                check(&mut fails, &e);
                let (pp, pd) = light.pdf_le(e.n, e.dir);
                fails.check(pp == e.pdf_pos, || format!("pdf_pos {pp} != {}", e.pdf_pos));
                if pd != e.pdf_dir {
                    off_cone += 1;
                }
                Some(-e.dir)
            },
            |w| light.pdf_le(Vec3::ZERO, -w).1 as f64,
        )
        .assert_ok();
        fails.assert_none(&name);
        assert!(
            off_cone <= N / 10_000,
            "{name}: {off_cone} samples off the cone"
        );
        if angle < 1.0 {
            continue;
        }
        // Origins: uniform on the disk of the bounding sphere's radius perpendicular to the
        // sampled direction, centred at center + radius * w. In units of the radius.
        let name = format!("sun {angle} sample_le positions");
        let mut fails = Failures::new();
        chi2::planar(
            &name,
            N,
            Vec2::splat(-1.0),
            Vec2::splat(1.0),
            [32, 32],
            |s| {
                let e = light.sample_le(s.next_2d(), s.next_2d())?;
                check(&mut fails, &e);
                let w = -e.dir;
                let f = Frame::from_z(w);
                let d = e.p - center - radius * w;
                Some(Vec2::new(d.dot(f.s), d.dot(f.t)) / radius)
            },
            |x| {
                if x.length_squared() < 1.0 {
                    1.0 / PI
                } else {
                    0.0
                }
            },
        )
        .assert_ok();
        fails.assert_none(&name);
    }
}

#[test]
fn sun_le_and_pdf_inside_and_outside_its_cone() {
    for angle in [0.27f32, 5.0] {
        let light = sun(angle);
        let z_max = one_minus_cos_deg(angle as f64);
        let domain = SphereDomain::full_around(sun_dir());
        for k in 0..64 {
            let phi = 2.0 * PI * k as f64 / 64.0;
            for (rel, inside) in [(0.0, true), (0.5, true), (0.99, true), (1.01, false)] {
                let w = domain.to_dir(DVec2::new(rel * z_max, phi));
                let (le, pdf) = (
                    light.le(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0), w),
                    light.pdf_li(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, w),
                );
                if inside {
                    assert!(
                        le == RADIANCE && pdf > 0.0,
                        "sun {angle}: {le} {pdf} inside"
                    );
                } else {
                    assert!(
                        le == Vec3::ZERO && pdf == 0.0,
                        "sun {angle}: {le} {pdf} outside"
                    );
                }
            }
            // Far off the sun, and the opposite direction.
            for w in [domain.to_dir(DVec2::new(0.5, phi)), -sun_dir()] {
                assert_eq!(light.le(Vec3::ZERO, Vec3::ZERO, w), Vec3::ZERO);
                assert_eq!(light.pdf_li(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, w), 0.0);
            }
        }
        // Power: L * solid angle * pi R^2.
        let want = lum(RADIANCE) * 2.0 * PI * z_max * PI * 100.0;
        assert!(
            close(light.power() as f64, want, 1e-5, 0.0),
            "{}",
            light.power()
        );
    }
}

/// Two-sided z-test that `mean(li cos / pdf)` over `sample_li` directions on a surface facing
/// the sun equals `want` (per channel: the red channel, the others being multiples).
fn assert_irradiance(name: &str, light: &Light, want: Vec3) {
    let n_samples = 200_000;
    let mut s = chi2::sampler_for(name);
    let normal = sun_dir().as_dvec3().normalize();
    let (mut sum, mut sum2) = (DVec3::ZERO, 0.0f64);
    let p = Vec3::new(0.3, 0.1, -0.2);
    for _ in 0..n_samples {
        let ls = light.sample_li(p, s.next_2d()).expect("sun sample");
        let cos = ls.wi.as_dvec3().normalize().dot(normal).max(0.0);
        let v = ls.li.as_dvec3() * cos / ls.pdf as f64;
        sum += v;
        sum2 += v.x * v.x;
    }
    let n = n_samples as f64;
    let mean = sum / n;
    let sd = ((sum2 / n - mean.x * mean.x).max(0.0) * n / (n - 1.0)).sqrt();
    let alpha = chi2::alpha();
    let z = Normal::new(0.0, 1.0)
        .unwrap()
        .inverse_cdf(1.0 - 0.5 * alpha);
    let want = want.as_dvec3();
    // Statistical bound plus a relative 1e-6 for the f32 rounding of 1 - cos(angle).
    let tol = z * sd / n.sqrt() + 1e-6 * want.x;
    println!(
        "{name}: irradiance {mean} want {want}, |diff| {:.3e} tol {tol:.3e} (sd {sd:.3e})",
        (mean.x - want.x).abs()
    );
    assert!(
        (mean.x - want.x).abs() <= tol,
        "{name}: irradiance {mean} != {want} (tolerance {tol:.3e})"
    );
    for i in 1..3 {
        assert!(close(mean[i] / mean.x, want[i] / want.x, 1e-6, 0.0));
    }
}

#[test]
fn sun_irradiance() {
    for angle in [0.27f32, 5.0] {
        let light = sun(angle);
        let sin2 = (angle as f64).to_radians().sin().powi(2);
        let want = (RADIANCE.as_dvec3() * PI * sin2).as_vec3();
        assert_irradiance(&format!("sun {angle} irradiance"), &light, want);
        if let Light::Sun(s) = &light {
            assert!(close3(s.irradiance(), want, 1e-5, 0.0));
        }
    }
    // From irradiance: L = E / (pi sin^2).
    let e = Vec3::new(1000.0, 900.0, 800.0);
    let sun = SunLight::from_irradiance(sun_dir(), 0.53, e);
    let sin2 = 0.53f64.to_radians().sin().powi(2);
    assert!(close3(
        sun.radiance,
        (e.as_dvec3() / (PI * sin2)).as_vec3(),
        1e-6,
        0.0
    ));
    assert!(close3(sun.irradiance(), e, 1e-5, 0.0));
    assert_eq!(sun.angle(), 0.53);
    assert_irradiance("sun from irradiance", &Light::Sun(sun), e);
}

// ------------------------------------------------------------------------------------------
// Light selection
// ------------------------------------------------------------------------------------------

#[test]
fn light_sampler_includes_the_new_lights() {
    let mesh = disk_mesh();
    let area = mesh.area() as f64;
    let (center, radius) = (Vec3::new(0.5, 0.5, 1.0), 4.0f32);
    let r2 = (radius as f64).powi(2);
    let mut lights = vec![
        Light::Point(PointLight {
            position: Vec3::ZERO,
            intensity: Vec3::new(2.0, 1.0, 0.5),
        }),
        Light::Spot(SpotLight::new(
            Vec3::ONE,
            -Vec3::Y,
            INTENSITY,
            SpotProfile::default(),
        )),
        spot_area_light(&mesh, SpotProfile::new(40.0, 10.0)),
        Light::Area(AreaLight::new(
            0,
            RADIANCE,
            AreaShape::Mesh {
                mesh: Box::new(mesh.clone()),
                sampler: MeshSampler::new(&mesh),
            },
        )),
        Light::Directional(DirectionalLight::new(-Vec3::Y, Vec3::new(0.2, 0.3, 0.1))),
        Light::Sun(SunLight::new(sun_dir(), 5.0, Vec3::splat(40.0))),
        Light::Environment(EnvironmentLight {
            radiance: Vec3::splat(0.02),
            center: Vec3::ZERO,
            radius: 1.0,
        }),
        Light::Spot(SpotLight::new(
            Vec3::ONE,
            Vec3::X,
            Vec3::ZERO,
            SpotProfile::default(),
        )), // black: never chosen
    ];
    for l in &mut lights {
        l.set_scene_bounds(center, radius);
    }
    // Power by hand.
    let spot = |cone: f64, delta: f64| {
        let (a, b) = (cone.to_radians().cos(), (cone - delta).to_radians().cos());
        2.0 * PI * ((1.0 - b) + 0.5 * (b - a))
    };
    let spot_cos = |cone: f64, delta: f64| {
        // 2 pi ∫ smoothstep(a, b, x) x dx over [a, 1], numerically on the edge.
        let (a, b) = (cone.to_radians().cos(), (cone - delta).to_radians().cos());
        let edge = midpoint(a, b, 100_000, |x| {
            let t = (x - a) / (b - a);
            t * t * (3.0 - 2.0 * t) * x
        });
        2.0 * PI * (0.5 * (1.0 - b * b) + edge)
    };
    let powers = [
        4.0 * PI * lum(Vec3::new(2.0, 1.0, 0.5)),
        lum(INTENSITY) * spot(30.0, 5.0),
        area * lum(RADIANCE) * spot_cos(40.0, 10.0),
        PI * area * lum(RADIANCE),
        lum(Vec3::new(0.2, 0.3, 0.1)) * PI * r2,
        lum(Vec3::splat(40.0)) * 2.0 * PI * one_minus_cos_deg(5.0) * PI * r2,
        4.0 * PI * PI * r2 * lum(Vec3::splat(0.02)),
        0.0,
    ];
    for (k, (l, &p)) in lights.iter().zip(&powers).enumerate() {
        assert!(
            close(l.power() as f64, p, 1e-5, 0.0),
            "light {k}: power {} != {p}",
            l.power()
        );
    }
    let infinite: Vec<bool> = lights.iter().map(|l| l.is_infinite()).collect();
    let probs = crate::common::light_selection_probs(&powers, &infinite);
    let sampler = LightSampler::new(&lights);
    for (i, &p) in probs.iter().enumerate() {
        assert!(
            close(sampler.pmf(i) as f64, p, 1e-5, 0.0),
            "pmf({i}) {} != {p}",
            sampler.pmf(i)
        );
    }
    let mut fails = Failures::new();
    chi2::discrete(
        "light selection with spot and distant lights",
        N,
        &probs,
        |s| {
            let (i, pmf) = sampler.sample(s.next_1d())?;
            fails.check(pmf == sampler.pmf(i), || format!("pmf {pmf} != pmf({i})"));
            Some(i)
        },
    )
    .assert_ok();
    fails.assert_none("light selection");
}

// ------------------------------------------------------------------------------------------
// The tests must be able to fail
// ------------------------------------------------------------------------------------------

#[test]
fn mismatched_spot_and_sun_densities_are_rejected() {
    // A spot whose emitted directions are checked against a density proportional to the
    // falloff (a plausible alternative sampler) instead of uniform in the cone.
    let axis = Vec3::new(0.3, -0.8, 0.5).normalize();
    let profile = SpotProfile::new(30.0, 15.0);
    let light = Light::Spot(SpotLight::new(Vec3::ZERO, axis, INTENSITY, profile));
    let norm = 2.0
        * PI
        * (one_minus_cos_deg(15.0) + 0.5 * (one_minus_cos_deg(30.0) - one_minus_cos_deg(15.0)));
    let report = chi2::spherical(
        "power: spot checked against a falloff-proportional density",
        N,
        &SphereDomain::around(axis, one_minus_cos_deg(30.0)).with_edge_slack(1e-6),
        |s| Some(light.sample_le(s.next_2d(), s.next_2d())?.dir),
        |w| falloff_ref(w.as_dvec3().normalize().dot(axis.as_dvec3()), 30.0, 15.0) / norm,
    );
    println!("{report}");
    assert!(report.chi2_rejects(), "{report}");

    // The spot area light's sample_li from 30 degrees off the axis against pdf_li over the
    // whole disk (forgetting that samples where the profile is zero fail): the mass check
    // must see it.
    let mesh = disk_mesh();
    let light = spot_area_light(&mesh, SpotProfile::new(30.0, 5.0));
    let p = DISK_CENTER + 2.0 * Vec3::new(0.5, 0.0, -(0.75f32).sqrt());
    let report = chi2::spherical(
        "power: spot area light without the profile's support",
        N / 4,
        &SphereDomain::covering_ball(p, DISK_CENTER, DISK_RADIUS as f64 * 1.01),
        |s| Some(light.sample_li(p, s.next_2d())?.wi),
        |w| spot_area_dir_pdf(&light, 90.0, p, w),
    );
    println!("{report}");
    assert!(report.mass_mismatch(), "{report}");

    // The tiny sun's cone density computed naively in f32 as 1 / (2 pi (1 - cos)): for
    // 1 - cos = 1.1e-5 the f32 cos, spaced 6e-8 apart near 1, puts the mass 0.15 % off.
    let light = sun(0.27);
    let naive = 1.0 / (2.0 * PI * (1.0 - 0.27f32.to_radians().cos()) as f64);
    let report = chi2::spherical(
        "power: sun with a cancelling cone pdf",
        N / 4,
        &sun_domain(0.27),
        |s| Some(light.sample_li(Vec3::ZERO, s.next_2d())?.wi),
        |w| {
            if light.pdf_li(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, w) > 0.0 {
                naive
            } else {
                0.0
            }
        },
    );
    println!("{report}");
    assert!(report.mass_mismatch(), "{report}");
}
