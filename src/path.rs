//! Complete light transport paths: the currency between integrators and the guider.
//!
//! A path runs from the camera `x_0` to an emitter `x_k`; it has `k` segments. Vertices are
//! stored inline (at most [`MAX_VERTICES`]), so building a path never allocates. Directions
//! and densities are not stored: any technique recomputes them from the positions, normals and
//! vertex kinds (DESIGN.md §2-3); `paths::path_terms` does, for `pdf_unguided`. Beyond
//! DESIGN.md, surface vertices also keep their shading normal and shape (BSDF densities and
//! medium interfaces need them).

use crate::math::Spectrum;
use glam::{Vec2, Vec3};

/// Maximum number of vertices of a stored path: what keeps whole paths (the guided
/// integrators, mmlt) take `max_depth` up to `MAX_VERTICES - 1`; pt, lt, bdpt and vcm take any.
pub const MAX_VERTICES: usize = 64;

/// `max_depth` meaning "no limit" (Mitsuba's -1): Russian roulette alone ends paths (every
/// continuation probability is capped below 1 on long paths, so they do end: see
/// `integrators::paths::roulette` and vcm's `deep_continuation`).
pub const UNLIMITED_DEPTH: u32 = u32::MAX;

/// A `max_depth` as users write it: an integer >= 1, or -1 for no limit.
pub fn parse_max_depth(v: i64) -> Result<u32, String> {
    match v {
        -1 => Ok(UNLIMITED_DEPTH),
        1.. if v < UNLIMITED_DEPTH as i64 => Ok(v as u32),
        _ => Err(format!(
            "must be an integer >= 1 (below {UNLIMITED_DEPTH}), or -1 for no limit; got {v}"
        )),
    }
}

/// `max_depth` for messages and file headers: the number, or "unlimited".
pub fn depth_label(d: u32) -> String {
    if d == UNLIMITED_DEPTH {
        "unlimited".to_string()
    } else {
        d.to_string()
    }
}

/// What a path vertex is: it decides the vertex's measure (area, volume or solid angle) and
/// how the densities at it are evaluated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum VertexKind {
    /// The pinhole.
    Camera,
    /// A scattering surface of scene shape `shape`; `delta` if the path takes a delta lobe
    /// of its BSDF here (always on a mirror or smooth glass; by the lobe taken on smooth
    /// plastic).
    Surface {
        /// Index of the surface's material in `Scene::materials`.
        material: u32,
        /// Index of the shape in `Scene::shapes` and `Scene::shape_info`.
        shape: u32,
        /// Whether the path takes a Dirac lobe here (`paths::Vertex::delta`).
        delta: bool,
    },
    /// A scattering point inside a medium.
    Medium {
        /// Index of the medium in `Scene::media`.
        medium: u32,
    },
    /// The emitter the path ends on.
    Emitter {
        /// Index of the light in `Scene::lights`.
        light: u32,
        /// Whether the light is a delta one (point, spot, directional): reached only by a
        /// deterministic connection, never by a sampled direction.
        delta: bool,
    },
}

/// One vertex of a complete path: its geometry and kind, from which every density and the
/// path's contribution can be recomputed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vertex {
    /// Position; for a light at infinity, the previous vertex plus its direction.
    pub p: Vec3,
    /// Geometric normal; zero for medium vertices, point lights and the camera; for a light
    /// at infinity the direction towards it.
    pub n: Vec3,
    /// Shading normal of surface vertices (zero otherwise): needed to re-evaluate BSDF
    /// densities, so a path's density can be recomputed exactly from the path.
    pub ns: Vec3,
    /// Texture coordinates of surface vertices whose material reads them (zero otherwise).
    pub uv: Vec2,
    /// The shading frame's first tangent (`s`) at surface vertices whose BSDF is anisotropic
    /// (zero otherwise, where the frame is the one around `ns`): [`Vertex::tangent_of`].
    pub tangent: Vec3,
    /// What the vertex is (camera, surface, medium, emitter) with its scene indices.
    pub kind: VertexKind,
}

impl Default for Vertex {
    /// [`Vertex::EMPTY`].
    fn default() -> Self {
        Vertex::EMPTY
    }
}

impl Vertex {
    /// A placeholder vertex (a camera vertex at the origin) filling unused slots.
    pub const EMPTY: Vertex = Vertex {
        p: Vec3::ZERO,
        n: Vec3::ZERO,
        ns: Vec3::ZERO,
        uv: Vec2::ZERO,
        tangent: Vec3::ZERO,
        kind: VertexKind::Camera,
    };

    /// What a surface vertex with BSDF `bsdf` evaluated in `frame` keeps as its `tangent`:
    /// the frame's `s` axis where the BSDF is anisotropic (the frame then follows the
    /// surface's `dp/du`, which the stored vertex cannot recompute), else zero.
    #[inline]
    pub fn tangent_of(bsdf: &crate::bsdf::Bsdf, frame: &crate::bsdf::ShadingFrame) -> Vec3 {
        if bsdf.is_anisotropic() {
            frame.frame.s
        } else {
            Vec3::ZERO
        }
    }

    /// Mark a surface vertex as one where the path takes a delta lobe (a walk that recorded
    /// the vertex on arrival and then left it through smooth plastic's coating).
    pub fn set_delta(&mut self, on: bool) {
        if let VertexKind::Surface { delta, .. } = &mut self.kind {
            *delta = on;
        }
    }
}

/// A complete path x_0 (camera) .. x_k (emitter), vertices stored inline, with its
/// contribution and pixel.
#[derive(Debug, Clone)]
pub struct Path {
    vertices: [Vertex; MAX_VERTICES],
    len: usize,
    /// RGB contribution f(X), including We.
    pub f: Spectrum,
    /// Pixel (row-major index) that x_1 projects to.
    pub pixel: u32,
}

impl Default for Path {
    fn default() -> Self {
        Path {
            vertices: [Vertex::EMPTY; MAX_VERTICES],
            len: 0,
            f: Spectrum::ZERO,
            pixel: 0,
        }
    }
}

impl Path {
    /// Empty the path (no vertices, zero contribution) for reuse; `pixel` is kept.
    pub fn clear(&mut self) {
        self.len = 0;
        self.f = Spectrum::ZERO;
    }

    /// The last vertex, to be changed.
    pub fn last_mut(&mut self) -> Option<&mut Vertex> {
        self.vertices[..self.len].last_mut()
    }

    /// Append a vertex; returns false (and leaves the path unchanged) when full.
    pub fn push(&mut self, v: Vertex) -> bool {
        if self.len == MAX_VERTICES {
            return false;
        }
        self.vertices[self.len] = v;
        self.len += 1;
        true
    }

    /// Remove the last vertex.
    pub fn pop(&mut self) -> Option<Vertex> {
        self.len = self.len.checked_sub(1)?;
        Some(self.vertices[self.len])
    }

    /// The vertices, camera first.
    pub fn vertices(&self) -> &[Vertex] {
        &self.vertices[..self.len]
    }

    /// The vertices, camera first, to be changed.
    pub fn vertices_mut(&mut self) -> &mut [Vertex] {
        &mut self.vertices[..self.len]
    }

    /// Number of segments (vertices - 1).
    pub fn segments(&self) -> usize {
        self.len.saturating_sub(1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_until_full() {
        let mut p = Path::default();
        for i in 0..MAX_VERTICES {
            assert!(p.push(Vertex {
                p: Vec3::splat(i as f32),
                ..Vertex::EMPTY
            }));
        }
        assert!(!p.push(Vertex::EMPTY));
        assert_eq!(p.segments(), MAX_VERTICES - 1);
        p.clear();
        assert_eq!(p.vertices().len(), 0);
    }
}
