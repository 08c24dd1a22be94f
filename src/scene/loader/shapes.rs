//! `[[shape]]` tables (quads, tiled quads, cubes, spheres, disks, OBJ meshes, heightfields)
//! and their transforms to geometry.

use super::*;

/// A quad with `tiles` and `tile_material`, as [`Builder::tiled_quad`] reads it.
pub(super) struct TiledQuad<'a> {
    pub quad: ShapeGeometry,
    /// Origin and the two edges after the transform.
    pub corner_edges: [Vec3; 3],
    pub tiles: [u32; 2],
    pub tile_material: &'a Spanned<String>,
}

impl Builder<'_> {
    pub(super) fn transform(&self, t: Option<&Spanned<TransformDesc>>) -> Result<Transform> {
        let src = self.src;
        let Some(t) = t else {
            return Ok(Transform::IDENTITY);
        };
        let d = t.get_ref();
        if let Some(m) = &d.matrix {
            if d.scale.is_some() || d.rotate.is_some() || d.translate.is_some() {
                return src.err(
                    t.span(),
                    "a transform's 'matrix' excludes 'scale', 'rotate' and 'translate'",
                );
            }
            let rows = *m.get_ref();
            let m4 = glam::Mat4::from_cols_array_2d(&rows).transpose();
            let Some(tr) = Transform::from_matrix(m4) else {
                return src.err(
                    m.span(),
                    format!("'matrix' must be an affine, invertible matrix of finite numbers with last row [0, 0, 0, 1], got {rows:?}"),
                );
            };
            return Ok(tr);
        }
        let scale = match &d.scale {
            None => Vec3::ONE,
            Some(s) => {
                let v = match s.get_ref() {
                    ScaleDesc::Uniform(x) => Vec3::splat(*x),
                    ScaleDesc::PerAxis(a) => Vec3::from(*a),
                };
                let (lo, hi) = SCALE_RANGE;
                if !v.is_finite() || v.abs().min_element() < lo || v.abs().max_element() > hi {
                    return src.err(
                        s.span(),
                        format!("'scale' must be finite with every |component| in [{lo:e}, {hi:e}], got {v}"),
                    );
                }
                v
            }
        };
        let (axis, degrees) = match &d.rotate {
            None => (Vec3::Y, 0.0),
            Some(r) => {
                let a = Vec3::from(r.get_ref().axis);
                let deg = r.get_ref().degrees;
                let (Some(a), true) = (unit_vector(a), deg.is_finite()) else {
                    return src.err(
                        r.span(),
                        "'rotate' needs a finite non-zero 'axis' and finite 'degrees'",
                    );
                };
                (a, deg)
            }
        };
        let translate = match &d.translate {
            Some(v) => src.finite3(v, "translate")?,
            None => Vec3::ZERO,
        };
        Ok(Transform::new(scale, axis, degrees, translate))
    }

    /// A quad with `tiles` and `tile_material`: the quad and the origin, edges and tile counts
    /// of its checkerboard; `None` for any other shape (whose keys [`Self::shape`] checks).
    pub(super) fn tiled_quad<'a>(
        &self,
        s: &'a Spanned<ShapeDesc>,
        placement: &Transform,
    ) -> Result<Option<TiledQuad<'a>>> {
        let src = self.src;
        let d = s.get_ref();
        if d.kind.get_ref() != "quad" || (d.tiles.is_none() && d.tile_material.is_none()) {
            return Ok(None);
        }
        let (Some(tiles), Some(tile_material)) = (&d.tiles, &d.tile_material) else {
            let (present, missing) = if d.tiles.is_some() {
                ("tiles", "tile_material")
            } else {
                ("tile_material", "tiles")
            };
            let at = at(&d.tiles).or(at(&d.tile_material)).unwrap_or(s.span());
            return src.err(
                at,
                format!("a tiled quad's '{present}' needs '{missing}' too (a checkerboard of 'material' and 'tile_material')"),
            );
        };
        let [nu, nv] = *tiles.get_ref();
        if !(1..=1024).contains(&nu) || !(1..=1024).contains(&nv) {
            return src.err(
                tiles.span(),
                format!("'tiles' must be two integers in [1, 1024], got [{nu}, {nv}]"),
            );
        }
        if let Some(at) = at(&d.emission).or(at(&d.emission_texture)) {
            return src.err(at, "a tiled quad cannot emit ('emission' with 'tiles')");
        }
        if d.material.is_none() {
            return src.err(
                s.span(),
                "a tiled quad needs a 'material' (for the cell at 'origin') beside 'tile_material'",
            );
        }
        // The quad itself (its keys, edges and transform) is checked by `shape`.
        let quad = self.shape(s, placement)?;
        let ShapeGeometry::Mesh(m) = &quad else {
            unreachable!("a quad is a mesh")
        };
        let [o, a, _, b] = [0, 1, 2, 3].map(|i| m.positions[i]);
        Ok(Some(TiledQuad {
            quad,
            corner_edges: [o, a - o, b - o],
            tiles: [nu, nv],
            tile_material,
        }))
    }

    /// The geometry of shape `s`, its own transform applied and then `placement` (an
    /// instance's, for a member of a group; the identity otherwise).
    pub(super) fn shape(
        &self,
        s: &Spanned<ShapeDesc>,
        placement: &Transform,
    ) -> Result<ShapeGeometry> {
        let src = self.src;
        let d = s.get_ref();
        let span = s.span();
        let kind = d.kind.get_ref().as_str();
        let what = format!("shape of type '{kind}'");
        let t = placement.after(&self.transform(d.transform.as_ref())?);
        let keys = d.geometry_keys();
        let allowed: &[&str] =
            match kind {
                "quad" => &["origin", "edge_u", "edge_v", "tiles", "tile_material", "flip_normals"],
                "cube" => &["flip_normals"],
                "sphere" => &["center", "radius"],
                "disk" => &["center", "normal", "radius", "segments", "flip_normals"],
                "obj" | "ply" => &["file", "normals", "flip_normals"],
                "serialized" => &["file", "shape_index", "normals", "flip_normals"],
                "heightfield" => &["size", "grid", "waves", "flip_normals"],
                other => return src.err(
                    d.kind.span(),
                    format!(
                        "unknown shape type '{other}' (expected quad, cube, sphere, disk, heightfield, obj, ply or serialized)"
                    ),
                ),
            };
        self.only(&what, &keys, allowed)?;
        let radius = |default: f32| -> Result<f32> {
            match &d.radius {
                None => Ok(default),
                Some(r) => {
                    let v = *r.get_ref();
                    if !(v.is_finite() && v > 0.0) {
                        return src.err(
                            r.span(),
                            format!("'radius' must be a finite number > 0, got {v}"),
                        );
                    }
                    Ok(v)
                }
            }
        };
        let opt3 = |v: &Option<V3>, key: &str, default: Vec3| -> Result<Vec3> {
            match v {
                Some(v) => src.finite3(v, key),
                None => Ok(default),
            }
        };
        let geometry = match kind {
            "quad" => {
                let o = opt3(&d.origin, "origin", Vec3::new(-1.0, -1.0, 0.0))?;
                let u = opt3(&d.edge_u, "edge_u", Vec3::new(2.0, 0.0, 0.0))?;
                let v = opt3(&d.edge_v, "edge_v", Vec3::new(0.0, 2.0, 0.0))?;
                if u.cross(v).length_squared() == 0.0 {
                    return src.err(
                        span,
                        "'edge_u' and 'edge_v' of a quad must be non-zero and not parallel",
                    );
                }
                ShapeGeometry::Mesh(TriangleMesh::quad(o, u, v).transformed(&t))
            }
            "cube" => ShapeGeometry::Mesh(TriangleMesh::cube().transformed(&t)),
            "sphere" => {
                let c = opt3(&d.center, "center", Vec3::ZERO)?;
                let r = radius(1.0)?;
                let Some(scale) = t.uniform_scale() else {
                    return src.err(
                        d.transform.as_ref().map_or(span, |t| t.span()),
                        "an analytic sphere's transform must scale uniformly",
                    );
                };
                ShapeGeometry::Sphere(Sphere {
                    center: t.point(c),
                    radius: r * scale,
                })
            }
            "disk" => {
                let c = opt3(&d.center, "center", Vec3::ZERO)?;
                let n = opt3(&d.normal, "normal", Vec3::Z)?;
                let Some(n) = unit_vector(n) else {
                    return src.err(
                        d.normal.as_ref().unwrap().span(),
                        "'normal' must be non-zero",
                    );
                };
                let r = radius(1.0)?;
                let segments = d.segments.as_ref().map_or(64, |s| *s.get_ref());
                if !(3..=100_000).contains(&segments) {
                    return src.err(
                        d.segments.as_ref().unwrap().span(),
                        "'segments' must be in [3, 100000]",
                    );
                }
                let f = Frame::from_z(n);
                let mut m = TriangleMesh::disk(segments);
                for p in &mut m.positions {
                    *p = c + f.to_world(*p * r);
                }
                ShapeGeometry::Mesh(m.transformed(&t))
            }
            "obj" | "ply" | "serialized" => {
                let index = match &d.shape_index {
                    None => 0,
                    Some(i) => match u32::try_from(*i.get_ref()) {
                        Ok(v) => v,
                        Err(_) => {
                            return src.err(
                                i.span(),
                                format!("'shape_index' must be >= 0, got {}", i.get_ref()),
                            );
                        }
                    },
                };
                let file = src.required(&d.file, span, "file", &what)?;
                let path = match &self.dir {
                    Some(dir) => dir.join(file.get_ref()),
                    None => PathBuf::from(file.get_ref()),
                };
                let normals = match &d.normals {
                    None => mesh_files::Normals::File,
                    Some(n) => match n.get_ref().as_str() {
                        "file" => mesh_files::Normals::File,
                        "faces" => mesh_files::Normals::Faces,
                        "smooth" => mesh_files::Normals::Smooth,
                        other => {
                            return src.err(
                                n.span(),
                                format!("'normals' must be \"file\", \"faces\" or \"smooth\", got \"{other}\""),
                            );
                        }
                    },
                };
                let mesh = mesh_files::load(&path, kind, index, normals).or_else(|e| {
                    src.err(
                        file.span(),
                        format!("cannot load mesh '{}': {e}", path.display()),
                    )
                })?;
                ShapeGeometry::Mesh(mesh.transformed(&t))
            }
            "heightfield" => {
                let size = match &d.size {
                    Some(sz) => {
                        let [x, z] = *sz.get_ref();
                        if !(x.is_finite() && z.is_finite() && x > 0.0 && z > 0.0) {
                            return src.err(
                                sz.span(),
                                format!("'size' must be two finite numbers > 0, got [{x}, {z}]"),
                            );
                        }
                        Vec2::new(x, z)
                    }
                    None => Vec2::splat(2.0),
                };
                let grid = match &d.grid {
                    Some(g) => {
                        let [x, z] = *g.get_ref();
                        if !(1..=4096).contains(&x) || !(1..=4096).contains(&z) {
                            return src.err(
                                g.span(),
                                format!("'grid' must be two integers in [1, 4096], got [{x}, {z}]"),
                            );
                        }
                        if 2 * x as usize * z as usize > MAX_TRIANGLES {
                            return src.err(
                                g.span(),
                                format!("'grid' = [{x}, {z}] makes {} triangles; a scene may have at most {MAX_TRIANGLES} (2^24)", 2 * x as usize * z as usize),
                            );
                        }
                        UVec2::new(x, z)
                    }
                    None => UVec2::new(128, 128),
                };
                let mut waves = Vec::new();
                if let Some(ws) = &d.waves {
                    for (k, w) in ws.get_ref().iter().enumerate() {
                        let dir = Vec2::from(w.direction);
                        let ok = w.amplitude.is_finite()
                            && w.phase.is_finite()
                            && w.wavelength.is_finite()
                            && w.wavelength > 0.0
                            && dir.is_finite()
                            && dir.length_squared() > 0.0;
                        if !ok {
                            return src.err(ws.span(), format!("wave #{}: needs finite 'amplitude' and 'phase', 'wavelength' > 0 and a non-zero 'direction'", k + 1));
                        }
                        waves.push(Wave {
                            amplitude: w.amplitude,
                            wavelength: w.wavelength,
                            direction: dir.normalize(),
                            phase: w.phase,
                        });
                    }
                }
                ShapeGeometry::Mesh(heightfield(size, grid, &waves).transformed(&t))
            }
            _ => unreachable!("shape types are checked above"),
        };
        let flip = d.flip_normals.as_ref().is_some_and(|f| *f.get_ref());
        Ok(match geometry {
            ShapeGeometry::Mesh(m) if flip => ShapeGeometry::Mesh(m.flipped()),
            g => g,
        })
    }
}
