//! Rays, shapes and the acceleration structure.
//!
//! Every shape is either a triangle mesh or an analytic sphere. All of them go into one obvhs
//! `CwBvh` (see [`bvh::Accel`]), or, in a scene of at most 32 primitives, into a flat list
//! tested eight triangles at a time, or sixteen rays at a time against each triangle
//! (`flat.rs`, `flat/packet.rs`); heightfields are walked cell by cell instead
//! (`grid.rs`), with the same hits. A hit reports the geometric normal `ng` (the
//! shape's front side: triangle winding, or authored vertex normals when present; outward for
//! spheres and cubes) and a shading normal `ns` on the same side as `ng`. Points queried
//! within a fixed radius (the photons merging looks up: vcm, guided-vcm) go into a hash grid
//! ([`HashGrid`], `hash_grid.rs`).
//!
//! Self-intersection is avoided without a scene-dependent epsilon: each hit carries a bound on
//! the floating-point error of its position (`p_err`, in the style of pbrt's error analysis),
//! and rays leave a surface from a point pushed along `ng` just past that bound. The bound is
//! relative to the magnitudes involved, so it holds at any scene scale.

pub mod bvh;
mod flat;
mod grid;
pub mod hash_grid;
pub mod heightfield;
pub mod interleaved;
pub mod mesh;
mod node_avx2;
mod prim;
pub mod sphere;
pub mod transform;

pub use bvh::Accel;
pub use hash_grid::HashGrid;
pub use interleaved::LANES as INTERLEAVED_LANES;
pub use mesh::TriangleMesh;
pub use sphere::Sphere;
pub use transform::Transform;

use glam::{Vec2, Vec3};

/// A ray `o + t d` with `d` normalised and `t` in `(0, t_max)`.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    /// Origin.
    pub o: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// Upper end of the open parameter interval that counts as a hit.
    pub t_max: f32,
}

impl Ray {
    /// A ray from `o` along unit `d` without an upper bound.
    pub fn new(o: Vec3, d: Vec3) -> Ray {
        Ray {
            o,
            d,
            t_max: f32::INFINITY,
        }
    }

    /// The point `o + t d`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// A ray-surface intersection.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// Ray parameter of the hit (its distance, `d` being unit).
    pub t: f32,
    /// Position of the hit.
    pub p: Vec3,
    /// Absolute error bound of `p`, per axis.
    pub p_err: Vec3,
    /// Geometric normal, unit length, on the shape's front side.
    pub ng: Vec3,
    /// Shading normal, unit length, `dot(ns, ng) > 0`.
    pub ns: Vec3,
    /// Barycentric coordinates (b1, b2) of the hit in its triangle, in the mesh's vertex
    /// order (zero for spheres).
    pub uv: Vec2,
    /// Index of the shape in the scene.
    pub shape: u32,
    /// Triangle index within the shape's mesh (0 for spheres).
    pub prim: u32,
}

/// Unit roundoff of f32 arithmetic.
pub const MACHINE_EPS: f32 = f32::EPSILON * 0.5;

/// pbrt's gamma(n) = n u / (1 - n u): the error bound of n chained floating-point operations.
#[inline]
pub const fn gamma(n: i32) -> f32 {
    (n as f32 * MACHINE_EPS) / (1.0 - n as f32 * MACHINE_EPS)
}

/// Move `p` off its surface (normal `n`, error bound `p_err`) to the side `w` points to, so a
/// ray from the result towards `w` cannot hit the surface it starts on.
#[inline(always)]
pub fn offset_origin(p: Vec3, p_err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    // Distance along n that clears the error box, doubled for the rounding of the addition.
    let d = n.abs().dot(p_err) * 2.0 + f32::MIN_POSITIVE;
    let offset = if w.dot(n) < 0.0 { -d * n } else { d * n };
    let q = p + offset;
    // Round away from p so the offset is never lost to rounding.
    Vec3::new(
        next_away(q.x, offset.x),
        next_away(q.y, offset.y),
        next_away(q.z, offset.z),
    )
}

/// `x` moved by one ulp in the direction of `dir` (unchanged for `dir == 0`). `x` is finite
/// and the offset was just added to it, so the NaN and infinity cases of `f32::next_up` are
/// not needed: the bit pattern steps by one (away from zero if `x` and `dir` share a sign).
/// Written with selects rather than early returns (the three cases compile to conditional
/// moves; ray offsets call it three times a point, with `dir == 0` on some axes and not others).
#[inline(always)]
pub(crate) fn next_away(x: f32, dir: f32) -> f32 {
    const SIGN: u32 = 0x8000_0000;
    let (bits, dir_bits) = (x.to_bits(), dir.to_bits());
    // x and dir nonzero: one step up in magnitude when their signs agree, one down otherwise.
    let stepped = if (bits ^ dir_bits) & SIGN == 0 {
        bits.wrapping_add(1)
    } else {
        bits.wrapping_sub(1)
    };
    // x = +-0: the smallest subnormal with dir's sign.
    let moved = if x == 0.0 {
        1 | (dir_bits & SIGN)
    } else {
        stepped
    };
    if dir == 0.0 { x } else { f32::from_bits(moved) }
}

/// Shadow-ray tolerance: a fraction of the segment left out at its far end.
pub const SHADOW_EPS: f32 = 1e-4;

/// Below this |cos| between a direction and the normal, [`Hit::spawn_along`] offsets along the
/// normal like [`Hit::spawn`].
pub const SPAWN_ALONG_MIN_COS: f32 = 0.01;

impl Hit {
    /// Ray leaving this hit in direction `d` (unit).
    pub fn spawn(&self, d: Vec3) -> Ray {
        Ray::new(offset_origin(self.p, self.p_err, self.ng, d), d)
    }

    /// Ray leaving this hit in direction `d` (unit) from a point on the line through the hit
    /// point itself: the origin is moved along `d` (not along the normal) until it clears the
    /// error box, so whatever the ray hits lies on the line from `p` in direction `d`, and a
    /// density recomputed from the two hit points sees the direction that was drawn. Falls
    /// back to [`Hit::spawn`] below [`SPAWN_ALONG_MIN_COS`], where the step along `d` would
    /// be long: the segment it skips lies within the normal offset of the surface's plane and
    /// is at most 100 times that offset long.
    pub fn spawn_along(&self, d: Vec3) -> Ray {
        let cos = d.dot(self.ng).abs();
        let clear = self.ng.abs().dot(self.p_err) * 2.0 + f32::MIN_POSITIVE;
        if cos < SPAWN_ALONG_MIN_COS {
            return self.spawn(d);
        }
        let step = clear / cos;
        let q = self.p + d * step;
        let o = Vec3::new(
            next_away(q.x, d.x),
            next_away(q.y, d.y),
            next_away(q.z, d.z),
        );
        Ray::new(o, d)
    }
}

#[cfg(test)]
mod next_away_tests {
    use super::next_away;

    #[test]
    fn matches_next_up_and_down() {
        for x in [
            1.0f32,
            -1.0,
            3.5e-3,
            -7.25e6,
            1e-30,
            -1e-30,
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
        ] {
            assert_eq!(next_away(x, 1.0).to_bits(), x.next_up().to_bits(), "{x} up");
            assert_eq!(
                next_away(x, -1.0).to_bits(),
                x.next_down().to_bits(),
                "{x} down"
            );
            assert_eq!(next_away(x, 0.0).to_bits(), x.to_bits());
        }
    }
}
