//! `--save-guides` / `--load-guides`: a learned guide-path cache as a versioned binary file.
//!
//! Layout (little endian): magic `LSGUIDES`, format version (u32), a fingerprint of the scene
//! (u64: camera, counts of shapes, triangles, materials, lights, media, bounds), the learning
//! iteration (u32), the kernel widths (f64: regression, first vertex, since version 2; first
//! vertex where g_1 is specular, since version 5),
//! the guided share the learning run chose (f64 ratio n_g / n_u, -1 for none; since version
//! 3), the number of guide paths (u32), then per guide path: vertex count (u8),
//! age (u16), f (f64 since version 4, f32 before), p_u (f64), weight (f64) and its vertices (position, normal, shading
//! normal as 9 f32, then the shading frame's tangent of an anisotropic surface, zero
//! otherwise, as 3 f32 since version 7, texture coordinates as 2 f32 since version 6, kind tag
//! u8, two u32 ids, delta flag u8). Kernels, neighbours and the
//! pruning BVH are rebuilt on load, deterministically, so a loaded cache renders exactly like
//! the one that was saved. A wrong magic or version, a truncated file, a cache learned on
//! another scene, ids out of range, non-finite numbers, a guide path that is not a complete
//! path or trailing bytes are errors naming the file.

use super::cache::{GuideCache, KernelWidths};
use crate::error::{Error, Result};
use crate::integrators::paths::structure::structure;
use crate::path::{Vertex as PathVertex, VertexKind};
use crate::scene::Scene;
use glam::Vec3;
use std::path::Path;

const MAGIC: &[u8; 8] = b"LSGUIDES";
/// The file format version this build writes and reads.
pub const VERSION: u32 = 7;

/// A hash of what a cache depends on in the scene.
pub fn scene_fingerprint(scene: &Scene) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |x: u64| {
        for b in x.to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    let c = &scene.camera;
    for v in [c.position, c.forward, c.up, scene.center] {
        for x in v.to_array() {
            eat(x.to_bits() as u64);
        }
    }
    eat(c.resolution.x as u64);
    eat(c.resolution.y as u64);
    eat(c.fov_y_degrees.to_bits() as u64);
    eat(scene.radius.to_bits() as u64);
    eat(scene.shapes.len() as u64);
    eat(scene.triangle_count() as u64);
    eat(scene.materials.len() as u64);
    eat(scene.lights.len() as u64);
    eat(scene.media.len() as u64);
    h
}

/// Write `cache`, learned on `scene`, to `file` (atomically, in the module's layout).
pub fn save(scene: &Scene, cache: &GuideCache, file: &Path) -> Result<()> {
    let mut b: Vec<u8> = Vec::new();
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&VERSION.to_le_bytes());
    b.extend_from_slice(&scene_fingerprint(scene).to_le_bytes());
    b.extend_from_slice(&cache.iteration.to_le_bytes());
    b.extend_from_slice(&cache.widths.regression.to_le_bytes());
    b.extend_from_slice(&cache.widths.first_vertex.to_le_bytes());
    b.extend_from_slice(&cache.widths.first_vertex_specular.to_le_bytes());
    b.extend_from_slice(&cache.learned_ratio.unwrap_or(-1.0).to_le_bytes());
    b.extend_from_slice(&(cache.guides.len() as u32).to_le_bytes());
    for (l, g) in cache.guides.iter().enumerate() {
        b.push(g.len);
        b.extend_from_slice(&g.age.to_le_bytes());
        b.extend_from_slice(&g.f.to_le_bytes());
        b.extend_from_slice(&g.p_u.to_le_bytes());
        b.extend_from_slice(&g.weight.to_le_bytes());
        for v in 1..g.len as usize {
            let pv = cache.vertex(scene, l, v);
            for x in [pv.p, pv.n, pv.ns, pv.tangent] {
                for c in x.to_array() {
                    b.extend_from_slice(&c.to_le_bytes());
                }
            }
            for c in pv.uv.to_array() {
                b.extend_from_slice(&c.to_le_bytes());
            }
            let (tag, a, c, d) = match pv.kind {
                VertexKind::Camera => (0u8, 0u32, 0u32, false),
                VertexKind::Surface {
                    material,
                    shape,
                    delta,
                } => (1, material, shape, delta),
                VertexKind::Medium { medium } => (2, medium, 0, false),
                VertexKind::Emitter { light, delta } => (3, light, 0, delta),
            };
            b.push(tag);
            b.extend_from_slice(&a.to_le_bytes());
            b.extend_from_slice(&c.to_le_bytes());
            b.push(d as u8);
        }
    }
    crate::film::atomic_write(file, |tmp| {
        std::fs::write(tmp, &b).map_err(|e| e.to_string())
    })
}

struct Reader<'a> {
    data: &'a [u8],
    at: usize,
    file: &'a Path,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8]> {
        if self.at + n > self.data.len() {
            return Err(Error::new(format!(
                "{}: truncated guide cache (needs more than {} bytes)",
                self.file.display(),
                self.data.len()
            )));
        }
        let s = &self.data[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }
    fn u8(&mut self) -> Result<u8> {
        Ok(self.take(1)?[0])
    }
    fn u16(&mut self) -> Result<u16> {
        Ok(u16::from_le_bytes(
            self.take(2)?.try_into().unwrap_or_default(),
        ))
    }
    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().unwrap_or_default(),
        ))
    }
    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().unwrap_or_default(),
        ))
    }
    fn f32(&mut self) -> Result<f32> {
        Ok(f32::from_bits(self.u32()?))
    }
    fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn vec3(&mut self) -> Result<Vec3> {
        Ok(Vec3::new(self.f32()?, self.f32()?, self.f32()?))
    }
}

/// Read a cache saved for `scene` from `file` and rebuild its kernels, neighbours and BVHs;
/// any fault of the file is an error naming it.
pub fn load(scene: &Scene, file: &Path) -> Result<GuideCache> {
    let data = std::fs::read(file)
        .map_err(|e| Error::new(format!("{}: cannot read guide cache: {e}", file.display())))?;
    let mut r = Reader {
        data: &data,
        at: 0,
        file,
    };
    let bad = |what: String| Error::new(format!("{}: {what}", file.display()));
    if data.len() < MAGIC.len() || &data[..MAGIC.len()] != MAGIC {
        return Err(bad("not a lodestar guide cache (bad magic)".into()));
    }
    r.take(MAGIC.len())?;
    let version = r.u32()?;
    if version != VERSION {
        return Err(bad(format!(
            "guide cache format version {version}, this lodestar reads version {VERSION}"
        )));
    }
    if r.u64()? != scene_fingerprint(scene) {
        return Err(bad(format!(
            "guide cache was learned on another scene (not {})",
            scene.source
        )));
    }
    let iteration = r.u32()?;
    let widths = KernelWidths {
        regression: r.f64()?,
        first_vertex: r.f64()?,
        first_vertex_specular: r.f64()?,
    };
    if !widths.is_valid() {
        return Err(bad(format!(
            "invalid kernel widths {widths:?} (expected finite numbers > 0)"
        )));
    }
    let ratio = r.f64()?;
    let learned_ratio = if ratio == -1.0 {
        None
    } else if ratio.is_finite() && ratio >= 0.0 {
        Some(ratio)
    } else {
        return Err(bad(format!(
            "invalid guided share ratio {ratio} (expected a finite number >= 0, or -1 for none)"
        )));
    };
    let count = r.u32()? as usize;
    let mut entries = Vec::with_capacity(count.min(1 << 20));
    for i in 0..count {
        let len = r.u8()? as usize;
        if !(3..=crate::path::MAX_VERTICES).contains(&len) {
            return Err(bad(format!(
                "guide path {i} has {len} vertices (expected 3 to {})",
                crate::path::MAX_VERTICES
            )));
        }
        let age = r.u16()?;
        let f = r.f64()?;
        let p_u = r.f64()?;
        let weight = r.f64()?;
        let mut vertices = vec![PathVertex {
            p: scene.camera.position,
            n: Vec3::ZERO,
            ns: Vec3::ZERO,
            uv: glam::Vec2::ZERO,
            tangent: Vec3::ZERO,
            kind: VertexKind::Camera,
        }];
        for v in 1..len {
            let (p, n, ns, tangent) = (r.vec3()?, r.vec3()?, r.vec3()?, r.vec3()?);
            let uv = glam::Vec2::new(r.f32()?, r.f32()?);
            let (tag, a, c, d) = (r.u8()?, r.u32()?, r.u32()?, r.u8()? != 0);
            let vertex = |what: String| bad(format!("guide path {i}, vertex {v}: {what}"));
            // An id of the scene's `what`, of which it has `n`.
            let id = |x: u32, what: &str, n: usize| {
                if (x as usize) < n {
                    Ok(x)
                } else {
                    Err(vertex(format!("{what} {x}, but the scene has {n}")))
                }
            };
            let kind = match tag {
                1 => VertexKind::Surface {
                    material: id(a, "material", scene.materials.len())?,
                    shape: id(c, "shape", scene.shapes.len())?,
                    delta: d,
                },
                2 => VertexKind::Medium {
                    medium: id(a, "medium", scene.media.len())?,
                },
                3 => VertexKind::Emitter {
                    light: id(a, "light", scene.lights.len())?,
                    delta: d,
                },
                _ => {
                    return Err(vertex(format!(
                        "kind {tag} (expected 1 surface, 2 medium or 3 emitter)"
                    )));
                }
            };
            if !(p.is_finite()
                && n.is_finite()
                && ns.is_finite()
                && tangent.is_finite()
                && uv.is_finite())
            {
                return Err(vertex(format!(
                    "position {p}, normal {n}, shading normal {ns}, tangent {tangent}, texture \
                     coordinates {uv} (expected finite numbers)"
                )));
            }
            vertices.push(PathVertex {
                p,
                n,
                ns,
                uv,
                tangent,
                kind,
            });
        }
        if !(f.is_finite() && p_u.is_finite() && weight.is_finite() && weight >= 0.0) {
            return Err(bad(format!(
                "guide path {i} has f = {f}, p_u = {p_u}, weight = {weight} (expected finite \
                 numbers, weight >= 0)"
            )));
        }
        // The guider keeps complete paths only (an emitter ends them, and only it); the cache
        // would drop any other path, and the weights would no longer be the ones saved.
        let mut path = crate::path::Path::default();
        for x in &vertices {
            path.push(*x);
        }
        if structure(scene, &path, crate::path::MAX_VERTICES).is_none() {
            return Err(bad(format!(
                "guide path {i} is not a complete path (expected an emitter as its last vertex \
                 and only there)"
            )));
        }
        entries.push((vertices, f, p_u, weight, age));
    }
    let total: f64 = entries.iter().map(|e| e.3).sum();
    if count > 0 && (total - 1.0).abs() > 1e-6 {
        return Err(bad(format!("guide path weights sum to {total}, not 1")));
    }
    if r.at != data.len() {
        return Err(bad(format!(
            "{} trailing bytes after the {count} guide paths the file declares",
            data.len() - r.at
        )));
    }
    let mut cache = GuideCache::with_widths(widths);
    cache.install(scene, entries, iteration);
    cache.learned_ratio = learned_ratio;
    Ok(cache)
}
