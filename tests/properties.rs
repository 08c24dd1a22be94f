//! Property tests (proptest) of the maths every integrator stands on: orthonormal frames, the
//! sampling warps and their densities, Fresnel terms, MIS weights, alias tables and discrete
//! distributions.
//!
//! Every property runs a fixed number of cases from a fixed seed (`config`), so a run is
//! reproducible and these tests are deterministic: they either always pass or always fail.
//! None is statistical; the sampling checks enumerate stratified grids of u exactly.

use glam::{Vec2, Vec3};
use lodestar::bsdf::fresnel;
use lodestar::bsdf::{ShadingFrame, TransportMode};
use lodestar::integrators::paths::{Heuristic, PathTerms};
use lodestar::math::warp;
use lodestar::math::{AliasTable, Distribution1D, Frame, power_heuristic};
use lodestar::path::MAX_VERTICES;
use proptest::prelude::*;
use proptest::test_runner::{RngAlgorithm, RngSeed};

/// A fixed seed and a modest number of cases; no failure files are written.
fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(0x10de_57a2),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// The largest f32 below 1.
const ONE_MINUS: f32 = 1.0 - f32::EPSILON / 2.0;

/// A uniform in [0, 1), with the edges 0 and 1 - ulp and tiny values drawn often.
fn unit() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => 0.0f32..1.0,
        1 => Just(0.0f32),
        1 => Just(ONE_MINUS),
        1 => Just(0.5f32),
        1 => 0.0f32..1e-6,
        1 => (0.0f32..1e-6).prop_map(|x| ONE_MINUS - x),
    ]
}

fn unit2() -> impl Strategy<Value = Vec2> {
    (unit(), unit()).prop_map(|(x, y)| Vec2::new(x, y))
}

/// A unit vector: random directions, and ones close to the poles, the axes and the +-z
/// singularity of branchless frame constructions (n.z near -1, -0.0, tiny x and y).
fn unit_vector() -> impl Strategy<Value = Vec3> {
    let tiny = prop_oneof![
        Just(0.0f32),
        Just(-0.0f32),
        -1e-3f32..1e-3,
        -1e-20f32..1e-20
    ];
    let near_pole = (
        tiny.clone(),
        tiny.clone(),
        prop_oneof![Just(1.0f32), Just(-1.0f32)],
    )
        .prop_map(|(x, y, z)| Vec3::new(x, y, z));
    let near_axis =
        (tiny.clone(), tiny.clone(), 0usize..3, prop::bool::ANY).prop_map(|(a, b, axis, neg)| {
            let s = if neg { -1.0 } else { 1.0 };
            match axis {
                0 => Vec3::new(s, a, b),
                1 => Vec3::new(a, s, b),
                _ => Vec3::new(a, b, s),
            }
        });
    let general = (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0);
    prop_oneof![
        2 => general.prop_map(|(x, y, z)| Vec3::new(x, y, z)),
        1 => near_pole,
        1 => near_axis,
        // Just below the -z pole, where 1 / (1 + n.z) is largest.
        1 => (-1e-3f32..1e-3, -1e-3f32..1e-3).prop_map(|(x, y)| Vec3::new(x, y, -1.0)),
    ]
    .prop_filter_map("non-zero", |v: Vec3| v.try_normalize())
}

fn assert_orthonormal(f: &Frame, n: Vec3) -> Result<(), TestCaseError> {
    let tol = 1e-5;
    prop_assert!(f.n == n, "n is not the input normal");
    for (name, v) in [("s", f.s), ("t", f.t), ("n", f.n)] {
        prop_assert!(v.is_finite(), "{name} not finite for n = {n:?}: {f:?}");
        prop_assert!(
            (v.length() - 1.0).abs() < tol,
            "|{name}| = {} for n = {n:?}",
            v.length()
        );
    }
    prop_assert!(f.s.dot(f.t).abs() < tol, "s.t for n = {n:?}: {f:?}");
    prop_assert!(f.s.dot(f.n).abs() < tol, "s.n for n = {n:?}: {f:?}");
    prop_assert!(f.t.dot(f.n).abs() < tol, "t.n for n = {n:?}: {f:?}");
    // Right-handed: s x t = n.
    prop_assert!(
        (f.s.cross(f.t) - f.n).length() < tol,
        "not right-handed: {f:?}"
    );
    Ok(())
}

proptest! {
    #![proptest_config(config(4000))]

    /// `Frame::from_z` is orthonormal and right-handed for any unit normal, and
    /// `to_local` / `to_world` are inverses.
    #[test]
    fn frame_is_orthonormal(n in unit_vector(), v in (-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0)) {
        let f = Frame::from_z(n);
        assert_orthonormal(&f, n)?;
        let v = Vec3::new(v.0, v.1, v.2);
        let scale = v.length().max(1.0);
        prop_assert!((f.to_local(f.to_world(v)) - v).length() < 1e-5 * scale);
        prop_assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5 * scale);
        // The normal maps to +z and back.
        prop_assert!((f.to_local(n) - Vec3::Z).length() < 1e-5);
    }

    /// The shading frame of a hit is the same orthonormal frame around the shading normal.
    #[test]
    fn shading_frame_is_orthonormal(ns in unit_vector(), ng in unit_vector()) {
        let sf = ShadingFrame::new(ns, ng);
        assert_orthonormal(&sf.frame, ns)?;
        prop_assert_eq!(sf.ng, ng);
        let v = Vec3::new(0.3, -0.4, 0.866);
        prop_assert!((sf.frame.to_local(sf.frame.to_world(v)) - v).length() < 1e-5);
    }

    /// The concentric disk map lands in the closed unit disk (uniform density 1 / pi).
    #[test]
    fn disk_warp_in_domain(u in unit2()) {
        let d = warp::square_to_disk_concentric(u);
        prop_assert!(d.is_finite());
        prop_assert!(d.length() <= 1.0 + 1e-6, "{u:?} -> {d:?}");
    }

    /// Cosine-weighted hemisphere: a unit vector with z >= 0 and a finite pdf cos / pi that
    /// is positive everywhere but the rim z = 0, which only u.x = 0 or u.y = 0 reaches (the
    /// callers reject a zero pdf; see `diffuse_rejects_the_rim`).
    #[test]
    fn cosine_hemisphere_in_domain(u in unit2()) {
        let w = warp::square_to_cosine_hemisphere(u);
        prop_assert!(w.is_finite());
        prop_assert!((w.length() - 1.0).abs() < 1e-5, "{u:?} -> |w| = {}", w.length());
        prop_assert!(w.z >= 0.0);
        let pdf = warp::cosine_hemisphere_pdf(w.z);
        prop_assert!(pdf.is_finite() && pdf >= 0.0);
        prop_assert!((pdf - w.z * std::f32::consts::FRAC_1_PI).abs() <= 1e-7);
        if u.x > 0.0 && u.y > 0.0 {
            prop_assert!(pdf > 0.0, "{u:?} -> {w:?} has pdf 0");
        }
    }

    /// Uniform sphere: a unit vector with the constant pdf 1 / (4 pi).
    #[test]
    fn uniform_sphere_in_domain(u in unit2()) {
        let w = warp::square_to_uniform_sphere(u);
        prop_assert!(w.is_finite());
        prop_assert!((w.length() - 1.0).abs() < 1e-5, "{u:?} -> |w| = {}", w.length());
        let pdf = warp::uniform_sphere_pdf();
        prop_assert!(pdf.is_finite() && pdf > 0.0);
        prop_assert!((pdf - 0.25 * std::f32::consts::FRAC_1_PI).abs() < 1e-9);
    }

    /// Uniform cone around +z: a unit vector within the cone, finite positive pdf
    /// 1 / (2 pi (1 - cos_max)) whatever the opening (down to 1e-3 in cosine).
    #[test]
    fn uniform_cone_in_domain(u in unit2(), cos_max in prop_oneof![-1.0f32..0.999, Just(-1.0f32), Just(0.0f32), 0.99f32..0.999]) {
        let w = warp::square_to_uniform_cone(u, cos_max);
        prop_assert!(w.is_finite());
        prop_assert!((w.length() - 1.0).abs() < 1e-5, "{u:?} -> |w| = {}", w.length());
        prop_assert!(w.z >= cos_max - 1e-6 && w.z <= 1.0, "z = {} outside cone {cos_max}", w.z);
        let pdf = warp::uniform_cone_pdf(cos_max);
        prop_assert!(pdf.is_finite() && pdf > 0.0);
        let expected = 1.0 / (2.0 * std::f64::consts::PI * (1.0 - cos_max as f64));
        prop_assert!(((pdf as f64 - expected) / expected).abs() < 1e-5);
    }

    /// Uniform triangle: valid barycentrics (non-negative, summing to at most 1).
    #[test]
    fn triangle_warp_in_domain(u in unit2()) {
        let b = warp::square_to_uniform_triangle(u);
        prop_assert!(b.is_finite());
        prop_assert!(b.x >= 0.0 && b.y >= 0.0, "{u:?} -> {b:?}");
        prop_assert!(b.x + b.y <= 1.0, "{u:?} -> {b:?}");
    }

    /// Dielectric Fresnel: F in [0, 1], |cos_t| in [0, 1], all finite, for any cosine in
    /// [-1, 1] and any relative index in [1e-3, 1e3].
    #[test]
    fn dielectric_fresnel_in_range(cos in prop_oneof![-1.0f32..=1.0, Just(0.0f32), Just(-0.0f32), Just(1.0f32), Just(-1.0f32)], eta in log_uniform(1e-3, 1e3)) {
        let (f, cos_t, eta_rel) = fresnel::dielectric(cos, eta);
        prop_assert!(f.is_finite() && (0.0..=1.0).contains(&f), "F = {f} at cos {cos}, eta {eta}");
        prop_assert!(cos_t.is_finite() && (0.0..=1.0).contains(&cos_t), "cos_t = {cos_t}");
        prop_assert!(eta_rel.is_finite() && eta_rel > 0.0);
    }

    /// Conductor Fresnel: every channel in [0, 1] and finite for any cosine and complex index
    /// eta + i k with eta in [1e-3, 1e3] and k in {0} u [1e-3, 1e3].
    #[test]
    fn conductor_fresnel_in_range(
        cos in prop_oneof![-1.0f32..=1.0, Just(0.0f32), Just(1.0f32), Just(-1.0f32)],
        eta in (log_uniform(1e-3, 1e3), log_uniform(1e-3, 1e3), log_uniform(1e-3, 1e3)),
        k in (prop_oneof![Just(0.0f32), log_uniform(1e-3, 1e3)], log_uniform(1e-3, 1e3), Just(0.0f32)),
    ) {
        let f = fresnel::conductor(cos, Vec3::new(eta.0, eta.1, eta.2), Vec3::new(k.0, k.1, k.2));
        for c in f.to_array() {
            prop_assert!(c.is_finite() && (0.0..=1.0).contains(&c), "F = {f:?} at cos {cos}, eta {eta:?}, k {k:?}");
        }
    }

    /// Power heuristic of two strategies: weights in [0, 1] that sum to 1 (f32 rounding).
    #[test]
    fn power_heuristic_partitions_unity(a in log_uniform(1e-18, 1e18), b in log_uniform(1e-18, 1e18)) {
        let (wa, wb) = (power_heuristic(a, b), power_heuristic(b, a));
        prop_assert!((0.0..=1.0).contains(&wa) && (0.0..=1.0).contains(&wb), "{wa} {wb}");
        prop_assert!((wa + wb - 1.0).abs() < 4.0 * f32::EPSILON, "{a} {b}: {wa} + {wb}");
    }

    /// BDPT's MIS weights (balance and power) of all techniques of one path: each in [0, 1],
    /// summing to 1 within 1e-9 relative, for random positive per-vertex densities; a
    /// directly seen emitter through vacuum (k = 1, `direct_by_camera`) is s = 0's alone.
    #[test]
    fn bdpt_weights_partition_unity(
        k in 1usize..12,
        pc in prop::collection::vec(log_uniform64(1e-8, 1e8), MAX_VERTICES),
        pl in prop::collection::vec(log_uniform64(1e-8, 1e8), MAX_VERTICES),
        nee in log_uniform64(1e-8, 1e8),
        power in prop::bool::ANY,
        direct_by_camera in prop::bool::ANY,
    ) {
        let mut t = PathTerms::new(k);
        t.pc.copy_from_slice(&pc[..=k]);
        t.pl.copy_from_slice(&pl[..=k]);
        t.nee_k = nee;
        t.connectible.fill(true);
        t.hittable = true;
        t.direct_by_camera = direct_by_camera;
        let h = if power { Heuristic::Power } else { Heuristic::Balance };
        let mut sum = 0.0;
        for s in 0..=k {
            let w = t.weight(s, h);
            prop_assert!((0.0..=1.0).contains(&w), "weight {w} of s = {s}");
            sum += w;
        }
        prop_assert!((sum - 1.0).abs() < 1e-9, "weights sum to {sum}");
        if k == 1 && direct_by_camera {
            let (w0, w1) = (t.weight(0, h), t.weight(1, h));
            prop_assert!(w0 == 1.0 && w1 == 0.0, "direct emitter: s = 0 weighs {w0}, s = 1 {w1}");
        }
    }
}

/// Log-uniform f32 in [lo, hi].
fn log_uniform(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
    (lo.ln()..=hi.ln()).prop_map(move |x: f32| x.exp().clamp(lo, hi))
}

fn log_uniform64(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo.ln()..=hi.ln()).prop_map(move |x: f64| x.exp().clamp(lo, hi))
}

/// Diffuse sampling rejects the rim direction (z = 0, pdf 0) the warp gives at u.x = 0.
#[test]
fn diffuse_rejects_the_rim() {
    let w = warp::square_to_cosine_hemisphere(Vec2::new(0.0, 0.5));
    assert_eq!(w.z, 0.0, "the rim is reached at u = (0, 0.5)");
    let bsdf = lodestar::bsdf::Bsdf::Diffuse {
        albedo: Vec3::splat(0.5),
    };
    let sf = ShadingFrame::new(Vec3::Z, Vec3::Z);
    let s = bsdf.sample(
        &sf,
        Vec3::new(0.0, 0.6, 0.8),
        0.5,
        Vec2::new(0.0, 0.5),
        TransportMode::Radiance,
    );
    assert!(s.is_none(), "a pdf-0 direction must not be returned: {s:?}");
}

/// Weight vectors that stress discrete distributions: zeros, a single non-zero entry, and a
/// dynamic range of 1e-30 .. 1e30.
fn weights() -> impl Strategy<Value = Vec<f64>> {
    let w = prop_oneof![
        3 => Just(0.0f64),
        3 => log_uniform64(1e-30, 1e30),
        2 => 0.0f64..10.0,
        1 => Just(1.0f64),
    ];
    let single = (1usize..40, 0usize..40, log_uniform64(1e-30, 1e30)).prop_map(|(n, i, v)| {
        let mut w = vec![0.0; n];
        w[i % n] = v;
        w
    });
    prop_oneof![
        3 => prop::collection::vec(w, 1..40),
        1 => single,
    ]
    .prop_filter("some weight > 0", |w| w.iter().any(|&x| x > 0.0))
}

proptest! {
    #![proptest_config(config(300))]

    /// Alias table: pmf(i) = w_i / sum w, and sampling over a stratified grid of (u1, u2)
    /// (every u1 stratum of width 1/(n M), M u2 values each) picks item i exactly
    /// pmf(i) of the time up to the grid resolution; zero weights are never picked.
    #[test]
    fn alias_table_matches_weights(w in weights()) {
        let t = AliasTable::new(&w);
        let total: f64 = w.iter().sum();
        let n = w.len();
        prop_assert_eq!(t.len(), n);
        for (i, &wi) in w.iter().enumerate() {
            let expected = wi / total;
            prop_assert!((t.pmf(i) - expected).abs() <= 1e-15 * expected.max(f64::MIN_POSITIVE), "pmf({i}) = {} != {expected}", t.pmf(i));
            if wi == 0.0 {
                prop_assert_eq!(t.pmf(i), 0.0);
            }
        }
        // Grid: m1 strata of u1 per item, m2 values of u2.
        let (m1, m2) = (4usize, 1000usize);
        let mut counts = vec![0usize; n];
        for a in 0..n * m1 {
            let u1 = (a as f64 + 0.5) / (n * m1) as f64;
            for b in 0..m2 {
                let u2 = (b as f64 + 0.5) / m2 as f64;
                let i = t.sample(u1, u2);
                prop_assert!(i < n);
                prop_assert!(w[i] > 0.0, "sampled zero-weight item {i} at ({u1}, {u2})");
                counts[i] += 1;
            }
        }
        let cells = (n * m1 * m2) as f64;
        for (i, &count) in counts.iter().enumerate() {
            let freq = count as f64 / cells;
            // Within each u1 stratum, bucket j gives u2 < prob[j] to j and the rest to its
            // alias; the grid of u2 misses that split by at most one step (1 / m2) of the
            // stratum's mass. Buckets hold 1 / n of the mass each and at most all n feed one
            // item, so an item's frequency is off its pmf by at most 1 / m2.
            let tol = 1.0 / m2 as f64 + 1e-12;
            prop_assert!((freq - t.pmf(i)).abs() <= tol, "item {i}: freq {freq} vs pmf {}", t.pmf(i));
        }
    }

    /// Distribution1D: pmf(i) = w_i / sum w (to f32 rounding), the pmf returned by `sample`
    /// is that of the item, a stratified grid of u reproduces the pmf to the grid resolution
    /// plus f32 rounding of the CDF, zero weights have pmf 0 and are never sampled, and the
    /// remapped u lies in [0, 1).
    #[test]
    fn distribution_matches_weights(w in weights()) {
        let wf: Vec<f32> = w.iter().map(|&x| x as f32).collect();
        let d = Distribution1D::new(&wf);
        let total: f64 = wf.iter().map(|&x| x as f64).sum();
        let n = wf.len();
        prop_assert_eq!(d.len(), n);
        for (i, &wi) in wf.iter().enumerate() {
            let expected = wi as f64 / total;
            let p = d.pmf(i) as f64;
            prop_assert!((p - expected).abs() <= 1e-6 * expected + 1e-38, "pmf({i}) = {p} != {expected}");
            if wi == 0.0 {
                prop_assert_eq!(d.pmf(i), 0.0);
            }
        }
        let m = 100_000usize;
        let mut counts = vec![0usize; n];
        for a in 0..m {
            let u = ((a as f64 + 0.5) / m as f64) as f32;
            let (i, p, u_re) = d.sample(u);
            prop_assert!(i < n);
            prop_assert!(wf[i] > 0.0, "sampled zero-weight item {i} at u = {u}");
            prop_assert_eq!(p, d.pmf(i));
            prop_assert!((0.0..1.0).contains(&u_re), "remapped u = {u_re}");
            counts[i] += 1;
        }
        for (i, &count) in counts.iter().enumerate() {
            let freq = count as f64 / m as f64;
            // One grid step at each end of the item's interval, plus f32 rounding of the CDF.
            let tol = 2.0 / m as f64 + 4.0 * n as f64 * f32::EPSILON as f64;
            prop_assert!((freq - d.pmf(i) as f64).abs() <= tol, "item {i}: freq {freq} vs pmf {}", d.pmf(i));
        }
    }
}
