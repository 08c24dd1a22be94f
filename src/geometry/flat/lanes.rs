//! A packet of sixteen rays and the flat list's primitives in the layout the packet tests
//! read (`packet.rs` with AVX-512, `packet_avx.rs` with AVX): rays component by component,
//! one lane each; triangles and spheres as flat records.

use crate::geometry::prim::Prim;
use glam::Vec3A;

/// Rays per packet: one per lane of an AVX-512 register.
pub(super) const PACKET: usize = 16;

/// A ray of a packet: origin, (canonical) direction, and the end of its open interval.
pub type PacketRay = (Vec3A, Vec3A, f32);

/// Up to [`PACKET`] rays, one per lane, component by component; unused lanes have `t_max = 0`
/// (no hit is then strictly closer).
#[derive(Default)]
pub(super) struct Packet {
    pub(super) o: [[f32; PACKET]; 3],
    pub(super) d: [[f32; PACKET]; 3],
    pub(super) t_max: [f32; PACKET],
}

/// A triangle as the packet test reads it: `a`, `b`, `c` (as in [`Prim`]) and its index in
/// the primitive list.
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
pub(super) struct PacketTri {
    pub(super) abc: [[f32; 3]; 3],
    pub(super) prim: u32,
}

/// A sphere as the packet test reads it: centre, radius and its index in the primitive list.
#[derive(Debug, Clone, Copy)]
pub(super) struct PacketSphere {
    pub(super) center: [f32; 3],
    pub(super) radius: f32,
    pub(super) prim: u32,
}

/// The spheres of `indices` (into `prims`), in that order.
pub(super) fn packet_spheres(prims: &[Prim], indices: &[u32]) -> Vec<PacketSphere> {
    let sphere = |i: u32| {
        let p = &prims[i as usize];
        PacketSphere {
            center: p.a.to_array(),
            radius: p.b.x,
            prim: i,
        }
    };
    indices.iter().map(|&i| sphere(i)).collect()
}

/// The triangles in the order [`Flat::closest`] tests them: (group, lane), unused lanes left
/// out.
pub(super) fn packet_tris(prims: &[Prim], lanes: &[u32]) -> Vec<PacketTri> {
    lanes
        .iter()
        .filter(|&&i| i != u32::MAX)
        .map(|&i| {
            let p = &prims[i as usize];
            PacketTri {
                abc: [p.a, p.b, p.c].map(|v| v.to_array()),
                prim: i,
            }
        })
        .collect()
}

impl Packet {
    /// The packet of `ray(0) .. ray(len - 1)`.
    #[inline(always)]
    pub(super) fn new(len: usize, ray: impl Fn(usize) -> PacketRay) -> Packet {
        let mut p = Packet::default();
        for lane in 0..len {
            let (o, d, t_max) = ray(lane);
            for axis in 0..3 {
                p.o[axis][lane] = o[axis];
                p.d[axis][lane] = d[axis];
            }
            p.t_max[lane] = t_max;
        }
        p
    }
}
