//! Where a guided walk is (`At`): the stored path vertex, the surface point behind it (for
//! spawning rays and scattering) and the medium, with the conversions the sampler needs.

use crate::geometry::Ray;
use crate::integrators::paths::{Kind, Vertex};
use crate::path::{Vertex as PathVertex, VertexKind};
use crate::scene::{Endpoint, Scene, SurfacePoint};
use glam::Vec3;

/// The vertex the walk is at.
pub(super) struct At<'s> {
    pub(super) pv: PathVertex,
    pub(super) sp: Option<SurfacePoint<'s>>,
    /// Medium of a medium vertex; for others the medium the walk arrived through.
    pub(super) medium: Option<u32>,
}

impl<'s> At<'s> {
    /// A point in `medium`.
    pub(super) fn medium(p: Vec3, medium: u32) -> At<'s> {
        At {
            pv: PathVertex {
                p,
                n: Vec3::ZERO,
                ns: Vec3::ZERO,
                uv: glam::Vec2::ZERO,
                tangent: Vec3::ZERO,
                kind: VertexKind::Medium { medium },
            },
            sp: None,
            medium: Some(medium),
        }
    }

    /// A non-delta emitter vertex at `p` (for lights at infinity `p` = previous + direction and
    /// `n` the direction), reached through `medium`.
    pub(super) fn emitter(p: Vec3, n: Vec3, light: u32, medium: Option<u32>) -> At<'s> {
        At {
            pv: PathVertex {
                p,
                n,
                ns: Vec3::ZERO,
                uv: glam::Vec2::ZERO,
                tangent: Vec3::ZERO,
                kind: VertexKind::Emitter {
                    light,
                    delta: false,
                },
            },
            sp: None,
            medium,
        }
    }

    pub(super) fn ray(&self, d: Vec3) -> Ray {
        match &self.sp {
            Some(sp) => sp.hit.spawn_along(d),
            None => Ray::new(self.pv.p, d),
        }
    }

    pub(super) fn endpoint(&self) -> Endpoint {
        match &self.sp {
            Some(sp) => Endpoint::surface(&sp.hit),
            None => Endpoint::point(self.pv.p),
        }
    }

    /// Medium a segment leaving along `d` starts in.
    pub(super) fn medium_towards(&self, scene: &Scene, d: Vec3) -> Option<u32> {
        match &self.sp {
            Some(sp) => scene.medium_after(sp, d, self.medium),
            None => self.medium,
        }
    }

    /// As a BDPT vertex (for the branch densities shared with evaluation).
    pub(super) fn vertex(&self) -> Vertex<'s> {
        let kind = match (&self.sp, self.pv.kind) {
            (Some(sp), _) => Kind::Surface {
                bsdf: sp.bsdf,
                frame: sp.frame,
                info: sp.info,
                material: sp.material,
            },
            (None, VertexKind::Medium { medium }) => Kind::Medium { medium },
            _ => Kind::Camera,
        };
        Vertex::new(kind, self.pv.p, self.pv.n)
    }
}

/// First non-null surface along `ray` (index-matched boundaries crossed), and the medium the
/// ray arrives through.
pub(in crate::integrators::guided) fn trace<'s>(
    scene: &'s Scene,
    mut ray: Ray,
    mut medium: Option<u32>,
) -> (Option<SurfacePoint<'s>>, Option<u32>) {
    for _ in 0..256 {
        match scene.intersect(&ray) {
            None => return (None, medium),
            Some(sp) if sp.is_null() => {
                medium = scene.medium_after(&sp, ray.d, medium);
                ray = sp.hit.spawn_along(ray.d);
            }
            Some(sp) => return (Some(sp), medium),
        }
    }
    (None, medium)
}

/// A surface point as a stored path vertex.
pub(super) fn surface_vertex(sp: &SurfacePoint) -> PathVertex {
    PathVertex {
        p: sp.hit.p,
        n: sp.hit.ng,
        ns: sp.hit.ns,
        uv: sp.frame.uv,
        tangent: PathVertex::tangent_of(sp.bsdf, &sp.frame),
        kind: VertexKind::Surface {
            material: sp.material,
            shape: sp.info.index,
            delta: sp.bsdf.is_delta(),
        },
    }
}

/// The walk's vertex `a` as a BDPT vertex, emitters included.
pub(super) fn as_vertex<'s>(scene: &'s Scene, a: &At<'s>) -> Vertex<'s> {
    match a.pv.kind {
        VertexKind::Emitter { light, .. } => {
            let _ = scene;
            Vertex::new(
                Kind::Light {
                    light: light as usize,
                },
                a.pv.p,
                a.pv.n,
            )
        }
        _ => a.vertex(),
    }
}
