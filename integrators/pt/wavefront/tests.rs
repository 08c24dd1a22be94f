//! The lanes against their scalar twins (compiled once per instruction set, beside each
//! kernel: `avx512::tests`, `avx2::tests`) on the values a render rarely meets: signed zeros,
//! NaN, infinities, subnormals, grazing and total-internal-reflection angles. The image test
//! (`tests/pt_batch.rs`) covers typical values; here every lane must give its twin's bits.

use super::lanes::{F, M, Soa3, V3, W};
use super::math;
use crate::bsdf::fresnel;
use crate::geometry::bvh::shadow_segment;
use crate::geometry::{next_away, offset_origin};
use crate::math::{Frame, power_heuristic, warp};
use glam::Vec3;

/// Awkward numbers, repeated to fill the lanes.
const SPECIAL: [f32; 14] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    -2.5,
    1e-40,
    -1e-40,
    f32::MIN_POSITIVE,
    3.4e38,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    std::f32::consts::FRAC_1_SQRT_2,
];

fn lanes(offset: usize) -> [f32; W] {
    std::array::from_fn(|i| SPECIAL[(i + offset) % SPECIAL.len()])
}

fn same(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// Whether the CPU has the instructions of the lanes under test (`super::ISA`); when it has
/// not, says that `test` was skipped.
fn available(test: &str) -> bool {
    let has = super::ISA.on_this_cpu();
    if !has {
        eprintln!(
            "{test}: skipped: this CPU has no {:?}, so these lanes cannot run",
            super::ISA
        );
    }
    has
}

/// Every pair of special values through each two-argument operation.
#[test]
fn operations_are_their_scalar_twins_lane_by_lane() {
    if !available("operations_are_their_scalar_twins_lane_by_lane") {
        return;
    }
    type Lane = fn(F, F) -> F;
    type Scalar = fn(f32, f32) -> f32;
    let ops: [(&str, Lane, Scalar); 8] = [
        ("add", |a, b| a + b, |a, b| a + b),
        ("mul", |a, b| a * b, |a, b| a * b),
        ("div", |a, b| a / b, |a, b| a / b),
        ("copysign", F::copysign, f32::copysign),
        ("next_away", F::next_away, next_away),
        ("sqrt", |a, _| a.sqrt(), |a, _| a.sqrt()),
        ("signum", |a, _| a.signum(), |a, _| a.signum()),
        ("neg abs", |a, _| -a.abs(), |a, _| -a.abs()),
    ];
    for shift in 0..SPECIAL.len() {
        let (a, b) = (lanes(0), lanes(shift));
        for (name, lane, scalar) in ops {
            let got = lane(F::from_array(&a), F::from_array(&b)).to_array();
            for i in 0..W {
                let want = scalar(a[i], b[i]);
                assert!(
                    same(got[i], want),
                    "{name}({}, {}): {} != {want}",
                    a[i],
                    b[i],
                    got[i]
                );
            }
        }
        // min and max: the same value (either zero for a pair of zeros, as f32::min may).
        let (fa, fb) = (F::from_array(&a), F::from_array(&b));
        let (mn, mx) = (fa.min(fb).to_array(), fa.max(fb).to_array());
        for i in 0..W {
            let (want_mn, want_mx) = (a[i].min(b[i]), a[i].max(b[i]));
            assert!(
                same(mn[i], want_mn) || mn[i] == want_mn,
                "min({}, {})",
                a[i],
                b[i]
            );
            assert!(
                same(mx[i], want_mx) || mx[i] == want_mx,
                "max({}, {})",
                a[i],
                b[i]
            );
        }
        type Compare = fn(f32, f32) -> bool;
        let masks: [(&str, M, Compare); 5] = [
            ("lt", fa.lt(fb), |a, b| a < b),
            ("le", fa.le(fb), |a, b| a <= b),
            ("gt", fa.gt(fb), |a, b| a > b),
            ("ge", fa.ge(fb), |a, b| a >= b),
            ("eq", fa.eq(fb), |a, b| a == b),
        ];
        for (name, m, scalar) in masks {
            for i in 0..W {
                assert_eq!(m.lane(i), scalar(a[i], b[i]), "{name}({}, {})", a[i], b[i]);
            }
        }
        let finite = fa.is_finite();
        let picked = F::select(finite, fa, fb).to_array();
        for i in 0..W {
            assert_eq!(finite.lane(i), a[i].is_finite());
            let want = if a[i].is_finite() { a[i] } else { b[i] };
            assert!(same(picked[i], want));
        }
    }
}

/// Sixteen vectors from the special values (and unit vectors where a twin needs them).
fn vectors(offset: usize, unit: bool) -> [Vec3; W] {
    let (x, y, z) = (lanes(offset), lanes(offset + 3), lanes(offset + 7));
    std::array::from_fn(|i| {
        let v = Vec3::new(x[i], y[i], z[i]);
        if unit {
            let v = if v.is_finite() && v.length_squared() > 1e-30 {
                v
            } else {
                Vec3::new(0.3, -0.4, (i as f32 - 7.5) / 8.0)
            };
            v.normalize()
        } else {
            v
        }
    })
}

fn soa(v: &[Vec3; W]) -> V3 {
    let mut s = Soa3::default();
    for (i, v) in v.iter().enumerate() {
        s.set(i, *v);
    }
    V3::load(&s)
}

fn same3(a: Vec3, b: Vec3) -> bool {
    same(a.x, b.x) && same(a.y, b.y) && same(a.z, b.z)
}

/// The helpers of `math.rs` against the scalar functions they mirror.
#[test]
fn helpers_are_their_scalar_twins_lane_by_lane() {
    if !available("helpers_are_their_scalar_twins_lane_by_lane") {
        return;
    }
    for shift in 0..SPECIAL.len() {
        let (a, b) = (lanes(shift), lanes(shift + 5));
        let w = math::power_heuristic(F::from_array(&a), F::from_array(&b)).to_array();
        for i in 0..W {
            assert!(
                same(w[i], power_heuristic(a[i], b[i])),
                "power_heuristic({}, {})",
                a[i],
                b[i]
            );
        }
        // Cosines over [-1, 1] and beyond, with the relative indices of glass both ways.
        let cos: [f32; W] = std::array::from_fn(|i| (i as f32 - 7.5) / 7.0 + 0.01 * shift as f32);
        let eta: [f32; W] = std::array::from_fn(|i| [1.5, 1.0 / 1.5, 1.33, 1.0][i % 4]);
        let (f, cos_t, eta_rel) =
            math::fresnel_dielectric(F::from_array(&cos), F::from_array(&eta));
        let (f, cos_t, eta_rel) = (f.to_array(), cos_t.to_array(), eta_rel.to_array());
        for i in 0..W {
            let want = fresnel::dielectric(cos[i], eta[i]);
            assert!(
                same(f[i], want.0) && same(cos_t[i], want.1) && same(eta_rel[i], want.2),
                "fresnel({}, {})",
                cos[i],
                eta[i]
            );
        }
        // The square's centre, edges and corners, and points in between.
        let grid = |k: usize| [0.0, 0.5, 1.0 - f32::EPSILON / 2.0, 0.25, 0.7, 1e-9][k % 6];
        let ux: [f32; W] = std::array::from_fn(|i| grid(i + shift));
        let uy: [f32; W] = std::array::from_fn(|i| grid(i / 3 + 2 * shift));
        let (d, pdf) = math::cosine_hemisphere(F::from_array(&ux), F::from_array(&uy));
        let (d, pdf) = (d.store(), pdf.to_array());
        for i in 0..W {
            let want = warp::square_to_cosine_hemisphere(glam::Vec2::new(ux[i], uy[i]));
            assert!(
                same3(d.get(i), want),
                "cosine_hemisphere({}, {})",
                ux[i],
                uy[i]
            );
            assert!(same(pdf[i], warp::cosine_hemisphere_pdf(want.z)));
        }
        let n = vectors(shift, true);
        let frame = math::Frame::from_z(soa(&n));
        let v = vectors(shift + 2, false);
        let (local, world) = (
            frame.to_local(soa(&v)).store(),
            frame.to_world(soa(&v)).store(),
        );
        for i in 0..W {
            let f = Frame::from_z(n[i]);
            assert!(
                same3(local.get(i), f.to_local(v[i])),
                "to_local at n = {}",
                n[i]
            );
            assert!(
                same3(world.get(i), f.to_world(v[i])),
                "to_world at n = {}",
                n[i]
            );
        }
        let (p, err, w) = (
            vectors(shift, false),
            vectors(shift + 4, false),
            vectors(shift + 1, true),
        );
        let p: [Vec3; W] = std::array::from_fn(|i| if p[i].is_finite() { p[i] } else { Vec3::ONE });
        let err = err.map(|e| e.abs().min(Vec3::splat(1e-3)));
        let o = math::offset_origin(soa(&p), soa(&err), soa(&n), soa(&w)).store();
        for i in 0..W {
            let want = offset_origin(p[i], err[i], n[i], w[i]);
            assert!(
                same3(o.get(i), want),
                "offset_origin({}, {}, {}, {})",
                p[i],
                err[i],
                n[i],
                w[i]
            );
        }
        // Segments to points with and without a normal (a point light has none).
        let q: [Vec3; W] = std::array::from_fn(|i| p[(i + 5) % W] + Vec3::new(0.5, 1.0, -0.25));
        let nq: [Vec3; W] = std::array::from_fn(|i| if i % 3 == 0 { Vec3::ZERO } else { -n[i] });
        let (so, sd, sl) =
            math::shadow_segment(soa(&p), soa(&err), soa(&n), soa(&q), soa(&err), soa(&nq));
        let (so, sd, sl) = (so.store(), sd.store(), sl.to_array());
        for i in 0..W {
            let (wo, wd, wl) = shadow_segment(p[i], err[i], n[i], q[i], err[i], nq[i]);
            assert!(
                same3(so.get(i), wo) && same3(sd.get(i), wd) && same(sl[i], wl),
                "segment {i}"
            );
        }
    }
}

/// The spherical light's sampler: `sin_cos_turn` over the unit interval's ends, quarter
/// turns and special values; the sphere's intersection from outside, inside, on it and with
/// special directions; and the whole cone sample (`AreaLight::sample_li` of a sphere light,
/// from points outside it, near its tangent cone and far away, with numbers at the unit
/// square's edges) must give the scalar code's bits in every lane.
#[test]
fn sphere_light_samplers_are_their_scalar_twins_lane_by_lane() {
    use crate::geometry::Sphere;
    use crate::light::{AreaLight, AreaShape};
    use crate::math::Spectrum;
    if !available("sphere_light_samplers_are_their_scalar_twins_lane_by_lane") {
        return;
    }
    let grid = |k: usize| {
        let g = [
            0.0,
            0.25,
            0.5,
            0.75,
            1.0 - f32::EPSILON / 2.0,
            1e-9,
            0.125,
            0.6,
            0.999,
            1.0,
        ];
        g[k % g.len()]
    };
    for shift in 0..SPECIAL.len() {
        for u in [std::array::from_fn(|i| grid(i + shift)), lanes(shift)] {
            let (s, c) = math::sin_cos_turn(F::from_array(&u));
            let (s, c) = (s.to_array(), c.to_array());
            for i in 0..W {
                let want = warp::sin_cos_turn(u[i]);
                assert!(
                    same(s[i], want.0) && same(c[i], want.1),
                    "sin_cos_turn({})",
                    u[i]
                );
            }
        }
        let sphere = Sphere {
            center: Vec3::new(0.3, -10.0, 2.0),
            radius: [0.1, 1.0, 2.5][shift % 3],
        };
        let (c, r) = (soa(&[sphere.center; W]), F::from_array(&[sphere.radius; W]));
        // Origins: far, near the surface, on it, inside, and special ones.
        let o: [Vec3; W] = std::array::from_fn(|i| match i % 4 {
            0 => Vec3::new(0.0, 0.0, 0.0),
            1 => sphere.center + Vec3::new(sphere.radius * 1.001, 0.0, 0.0),
            2 => sphere.center + Vec3::new(0.0, 0.0, sphere.radius * 0.5),
            _ => Vec3::splat(SPECIAL[(i + shift) % SPECIAL.len()]),
        });
        let d = vectors(shift + 3, true);
        let t = math::sphere_intersect(c, r, soa(&o), soa(&d)).to_array();
        for i in 0..W {
            let want = sphere.intersect(o[i], d[i], f32::INFINITY);
            assert!(same(t[i], want), "intersect from {} along {}", o[i], d[i]);
        }
        // Shading points outside the sphere (the lanes' case), at several distances.
        let p: [Vec3; W] = std::array::from_fn(|i| {
            let dir = Vec3::new(0.3 + i as f32, -1.0, 0.7 * shift as f32 - 2.0).normalize();
            sphere.center + dir * sphere.radius * [1.0001, 1.5, 40.0, 1e4][i % 4]
        });
        let ux: [f32; W] = std::array::from_fn(|i| grid(i + shift));
        let uy: [f32; W] = std::array::from_fn(|i| grid(i / 2 + 3 * shift));
        let (p_l, n_l, pdf) =
            math::sphere_sample_li(c, r, soa(&p), F::from_array(&ux), F::from_array(&uy));
        let (p_l, n_l, pdf) = (p_l.store(), n_l.store(), pdf.to_array());
        let light = AreaLight::new(0, Spectrum::ONE, AreaShape::Sphere(sphere));
        let mut compared = 0;
        for i in 0..W {
            assert!((sphere.center - p[i]).length_squared() > sphere.radius * sphere.radius);
            // `sample_li` returns the sampler's point, normal and density unchanged (None
            // only where the point faces away, which then has zero radiance).
            let Some(ls) = light.sample_li(p[i], glam::Vec2::new(ux[i], uy[i])) else {
                continue;
            };
            assert!(
                same3(p_l.get(i), ls.p) && same3(n_l.get(i), ls.n) && same(pdf[i], ls.pdf),
                "sphere sample from {} with ({}, {})",
                p[i],
                ux[i],
                uy[i]
            );
            compared += 1;
        }
        assert!(compared >= W - 2, "only {compared} samples compared");
    }
}
