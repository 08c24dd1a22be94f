//! Tests of the accelerator (hits, occlusion, axis-parallel rays, self-intersection at any
//! scale, the flat test against the BVH) and the closed box the other geometry tests share.

use super::*;

/// Both accelerators: the BVH (`flat_max` 0) and the flat test of small scenes.
const BOTH: [usize; 2] = [0, FLAT_MAX_PRIMS];

fn unit_quad_scene(scale: f32, flat_max: usize) -> (Vec<ShapeGeometry>, Accel) {
    let q = TriangleMesh::quad(
        Vec3::new(-1.0, 0.0, -1.0) * scale,
        Vec3::new(0.0, 0.0, 2.0) * scale,
        Vec3::new(2.0, 0.0, 0.0) * scale,
    );
    let s = Sphere {
        center: Vec3::new(0.0, 2.0, 0.0) * scale,
        radius: 0.5 * scale,
    };
    let shapes = vec![ShapeGeometry::Mesh(q), ShapeGeometry::Sphere(s)];
    let accel = Accel::build_with(&shapes, flat_max, true);
    assert_eq!(matches!(accel.index, Index::Flat(_)), flat_max > 0);
    (shapes, accel)
}

#[test]
fn closest_hit_and_occlusion() {
    for flat_max in BOTH {
        closest_hit_and_occlusion_with(flat_max);
    }
}

fn closest_hit_and_occlusion_with(flat_max: usize) {
    let (shapes, accel) = unit_quad_scene(1.0, flat_max);
    let h = accel
        .intersect(&Ray::new(Vec3::new(0.1, 5.0, 0.1), -Vec3::Y), &shapes)
        .unwrap();
    assert_eq!(h.shape, 1);
    assert!((h.t - (5.0 - 2.0 - (0.5f32.powi(2) - 0.02).sqrt())).abs() < 1e-4);
    let h2 = accel
        .intersect(&Ray::new(Vec3::new(0.9, 5.0, 0.9), -Vec3::Y), &shapes)
        .unwrap();
    assert_eq!(h2.shape, 0);
    assert!((h2.ng - Vec3::Y).length() < 1e-6);
    assert!(!accel.unoccluded(Vec3::new(0.0, 5.0, 0.0), -Vec3::Y, 10.0));
    assert!(accel.unoccluded(Vec3::new(0.0, 5.0, 0.0), Vec3::Y, 10.0));
}

/// Axis-parallel rays with -0.0 components (e.g. `-Vec3::Y`) used to miss everything.
#[test]
fn axis_parallel_rays_with_negative_zero_hit() {
    let q = TriangleMesh::quad(
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::new(2.0, 0.0, 0.0),
    );
    let shapes = vec![ShapeGeometry::Mesh(q)];
    for flat_max in BOTH {
        let accel = Accel::build_with(&shapes, flat_max, true);
        for d in [
            -Vec3::Y,
            Vec3::new(-0.0, -1.0, 0.0),
            Vec3::new(0.0, -1.0, -0.0),
        ] {
            let h = accel.intersect(&Ray::new(Vec3::new(0.3, 5.0, -0.2), d), &shapes);
            assert!(h.is_some_and(|h| (h.t - 5.0).abs() < 1e-5), "{d:?}");
            assert!(!accel.unoccluded(Vec3::new(0.3, 5.0, -0.2), d, 10.0));
        }
    }
}

/// Bounce rays off the quad and out of the sphere at scales from 1e-4 to 1e4: the spawned
/// ray must never hit the surface it starts on.
#[test]
fn spawned_rays_do_not_self_intersect_at_any_scale() {
    for (scale, flat_max) in [1e-4f32, 1e-2, 1.0, 1e2, 1e4]
        .into_iter()
        .flat_map(|s| BOTH.map(|f| (s, f)))
    {
        let (shapes, accel) = unit_quad_scene(scale, flat_max);
        let mut rng = crate::math::IndependentSampler::new(7, 0, scale.to_bits() as u64);
        use crate::math::Sampler;
        let mut self_hits = 0;
        for _ in 0..2000 {
            let u = rng.next_2d();
            let origin = Vec3::new(u.x * 1.6 - 0.8, 1.0, u.y * 1.6 - 0.8) * scale;
            let Some(h) = accel.intersect(&Ray::new(origin, -Vec3::Y), &shapes) else {
                continue;
            };
            // Reflect into a random upper direction that avoids the sphere mostly.
            let w = crate::math::warp::square_to_cosine_hemisphere(rng.next_2d());
            let w = Vec3::new(w.x, w.z, w.y);
            let r = h.spawn(w);
            if let Some(h2) = accel.intersect(&r, &shapes)
                && h2.shape == h.shape
            {
                self_hits += 1;
            }
            // Leave the sphere after refraction-like entry: start inside, go out.
            let into = Ray::new(
                Vec3::new(0.0, 4.0, 0.0) * scale
                    + Vec3::new(u.x - 0.5, 0.0, u.y - 0.5) * 0.4 * scale,
                -Vec3::Y,
            );
            if let Some(hs) = accel.intersect(&into, &shapes) {
                let inside = hs.spawn(-hs.ng);
                let exit = accel.intersect(&inside, &shapes).unwrap();
                assert_eq!(exit.shape, 1);
                assert!(
                    exit.t > 1e-3 * scale,
                    "scale {scale}: re-hit the entry point at t = {}",
                    exit.t
                );
            }
        }
        assert_eq!(self_hits, 0, "scale {scale}");
    }
}

/// The flat test of small scenes reports, for every ray, the hit the BVH reports (shape,
/// triangle, distance and barycentrics bit for bit) and the same occlusion, in a closed box
/// of quads with two spheres inside, from random origins inside it in random directions.
#[test]
fn flat_and_bvh_agree_bit_for_bit() {
    use crate::math::{Sampler, warp::square_to_uniform_sphere};
    let shapes = closed_box_with_spheres();
    let bvh = Accel::build_with(&shapes, 0, true);
    let flat = Accel::build_with(&shapes, FLAT_MAX_PRIMS, true);
    assert!(matches!(bvh.index, Index::Bvh(_)) && matches!(flat.index, Index::Flat(_)));
    // The flat list tested by the x86-64 baseline's code, and by the AVX code without
    // AVX-512, whatever this CPU has (the default above uses the most the CPU has).
    let variant = |limit: fn(Flat) -> Flat| {
        let mut a = Accel::build_with(&shapes, FLAT_MAX_PRIMS, true);
        if let Index::Flat(f) = &mut a.index {
            *f = limit(f.clone());
        }
        a
    };
    let variants = [variant(Flat::without_avx), variant(Flat::without_avx512)];
    let mut rng = crate::math::IndependentSampler::new(11, 0, 0);
    let mut hits = 0;
    for _ in 0..20_000 {
        let origin = (Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) - 0.5) * 1.9;
        let d = square_to_uniform_sphere(rng.next_2d());
        let mut ray = Ray::new(origin, d);
        ray.t_max = 0.5 + 3.0 * rng.next_1d();
        let (a, b) = (bvh.intersect(&ray, &shapes), flat.intersect(&ray, &shapes));
        let key = |h: Option<Hit>| {
            h.map(|h| {
                (
                    h.shape,
                    h.prim,
                    h.t.to_bits(),
                    h.uv.x.to_bits(),
                    h.uv.y.to_bits(),
                )
            })
        };
        assert_eq!(key(a), key(b), "ray {ray:?}");
        for v in &variants {
            assert_eq!(key(a), key(v.intersect(&ray, &shapes)), "ray {ray:?}");
        }
        hits += a.is_some() as u32;
        let unoccluded = bvh.unoccluded(origin, d, ray.t_max);
        assert_eq!(
            unoccluded,
            flat.unoccluded(origin, d, ray.t_max),
            "ray {ray:?}"
        );
        for v in &variants {
            assert_eq!(
                unoccluded,
                v.unoccluded(origin, d, ray.t_max),
                "ray {ray:?}"
            );
        }
    }
    // Both outcomes occur often enough to mean something.
    assert!((5_000..19_000).contains(&hits), "{hits} hits");
}

/// The six quads of the closed box [-1, 1]^3, facing inwards.
pub(in crate::geometry) fn closed_box() -> Vec<ShapeGeometry> {
    let wall = |o: Vec3, u: Vec3, v: Vec3| ShapeGeometry::Mesh(TriangleMesh::quad(o, u, v));
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    let o = Vec3::splat(-1.0);
    vec![
        wall(o, z, x),
        wall(o + y, x, z),
        wall(o, x, y),
        wall(o + z, y, x),
        wall(o, y, z),
        wall(o + x, z, y),
    ]
}

/// [`closed_box`] with two spheres inside.
pub(in crate::geometry) fn closed_box_with_spheres() -> Vec<ShapeGeometry> {
    let mut shapes = closed_box();
    for (c, r) in [
        (Vec3::new(-0.4, -0.5, 0.2), 0.45),
        (Vec3::new(0.5, -0.3, -0.3), 0.3),
    ] {
        shapes.push(ShapeGeometry::Sphere(Sphere {
            center: c,
            radius: r,
        }));
    }
    shapes
}
