//! Assembling the scene from its description: materials, media, shapes, lights, the
//! accelerator and the features every integrator asks about, with cross-checks between them.

use super::*;
use crate::scene::Checker;

impl Builder<'_> {
    pub(super) fn build(&self, desc: SceneDesc) -> Result<Scene> {
        let src = self.src;
        let camera = self.camera(&desc.camera)?;
        let render = self.render(desc.render.as_ref())?;

        // Materials, by name.
        let mut materials = Vec::new();
        let mut by_name: HashMap<String, u32> = HashMap::new();
        for m in &desc.material {
            let name = m.get_ref().name.get_ref().clone();
            if by_name.contains_key(&name) {
                return src.err(
                    m.get_ref().name.span(),
                    format!("material '{name}' is defined twice"),
                );
            }
            let (bsdf, one_sided) = self.material(m, &materials)?;
            let normal_map = self.normal_map(m.get_ref(), &format!("material '{name}'"))?;
            by_name.insert(name.clone(), materials.len() as u32);
            materials.push(Material {
                name,
                bsdf,
                one_sided,
                normal_map,
            });
        }
        let mut black = None;

        // Media, by name.
        let mut media: Vec<HomogeneousMedium> = Vec::new();
        for m in &desc.medium {
            let d = m.get_ref();
            let name = d.name.get_ref().clone();
            if media.iter().any(|x| x.name == name) {
                return src.err(d.name.span(), format!("medium '{name}' is defined twice"));
            }
            let sigma_a = src.non_negative3(&d.sigma_a, "sigma_a")?;
            let sigma_s = src.non_negative3(&d.sigma_s, "sigma_s")?;
            let g = match &d.g {
                Some(g) => {
                    let v = *g.get_ref();
                    if !(v > -1.0 && v < 1.0) {
                        return src.err(g.span(), format!("'g' must be in (-1, 1), got {v}"));
                    }
                    v
                }
                None => 0.0,
            };
            media.push(HomogeneousMedium::new(name, sigma_a, sigma_s, g));
        }
        let medium_ref = |r: &Spanned<String>| -> Result<u32> {
            match media.iter().position(|m| &m.name == r.get_ref()) {
                Some(i) => Ok(i as u32),
                None => {
                    let known: Vec<&str> = media.iter().map(|m| m.name.as_str()).collect();
                    let known = if known.is_empty() {
                        "none".to_string()
                    } else {
                        known.join(", ")
                    };
                    src.err(
                        r.span(),
                        format!("unknown medium '{}' (defined: {known})", r.get_ref()),
                    )
                }
            }
        };
        let world_medium = desc.world_medium.as_ref().map(&medium_ref).transpose()?;

        // Shapes, and area lights for emissive ones.
        let mut shapes = Vec::new();
        let mut shape_info = Vec::new();
        let mut lights = Vec::new();
        let mut triangles = 0usize;
        let material_id = |m: &Spanned<String>, materials: &[Material]| -> Result<u32> {
            match by_name.get(m.get_ref()) {
                Some(&id) => Ok(id),
                None => {
                    let known: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
                    src.err(
                        m.span(),
                        format!(
                            "unknown material '{}' (defined: {})",
                            m.get_ref(),
                            if known.is_empty() {
                                "none".to_string()
                            } else {
                                known.join(", ")
                            }
                        ),
                    )
                }
            }
        };
        for placed in self.placed_shapes(&desc.shape)? {
            let (i, s) = (placed.index, &desc.shape[placed.index]);
            let d = s.get_ref();
            let mut label = d
                .name
                .clone()
                .unwrap_or_else(|| format!("shape #{} ({})", i + 1, d.kind.get_ref()));
            if let Some(instance) = &placed.instance {
                label = format!("{label} in {instance}");
            }
            // A tiled quad is one quad whose material follows a checkerboard.
            let (geometry, tiling) = match self.tiled_quad(s, &placed.placement)? {
                Some(t) => (t.quad, Some((t.corner_edges, t.tiles, t.tile_material))),
                None => (self.shape(s, &placed.placement)?, None),
            };
            {
                if let ShapeGeometry::Mesh(m) = &geometry {
                    triangles += m.indices.len();
                    if triangles > MAX_TRIANGLES {
                        return src.err(
                            s.span(),
                            format!("{label} brings the scene to {triangles} triangles; at most {MAX_TRIANGLES} (2^24) are supported"),
                        );
                    }
                }
                let outside = match &geometry {
                    ShapeGeometry::Mesh(m) => m.positions.iter().copied().find(|&p| !in_bounds(p)),
                    ShapeGeometry::Sphere(sp) => [sp.center - sp.radius, sp.center + sp.radius]
                        .into_iter()
                        .find(|&p| !in_bounds(p)),
                };
                if let Some(p) = outside {
                    return src.err(
                        s.span(),
                        format!("{label} reaches {p} (after its transform); every point of a shape must lie within +-{MAX_COORDINATE:e} per axis"),
                    );
                }
            }
            let emission = match (&d.emission, &d.emission_texture) {
                (Some(e), _) => Some((self.src.non_negative3(e, "emission")?, e.span())),
                (None, Some(t)) => Some((Vec3::ONE, t.span())),
                (None, None) => None,
            };
            // Media on either side; an unnamed side is the world medium.
            let interface = match (&d.interior, &d.exterior) {
                (None, None) => None,
                (inside, outside) => Some(MediumInterface {
                    inside: inside
                        .as_ref()
                        .map(&medium_ref)
                        .transpose()?
                        .or(world_medium),
                    outside: outside
                        .as_ref()
                        .map(&medium_ref)
                        .transpose()?
                        .or(world_medium),
                }),
            };
            let null = d.material.is_none() && emission.is_none() && interface.is_some();
            if let (None, Some(c)) = (&emission, d.cone_angle.as_ref().or(d.cone_delta.as_ref())) {
                return src.err(c.span(), "'cone_angle' and 'cone_delta' make an emissive shape a spot light; this shape has no 'emission'");
            }
            {
                let material = match d.material.as_ref() {
                    Some(m) => material_id(m, &materials)?,
                    None if emission.is_some() || null => *black.get_or_insert_with(|| {
                        materials.push(Material {
                            name: "<black>".into(),
                            bsdf: Bsdf::Black,
                            one_sided: false,
                            normal_map: None,
                        });
                        materials.len() as u32 - 1
                    }),
                    None => {
                        return src.err(
                        s.span(),
                        format!("{label} needs a 'material' (or an 'emission', or 'interior'/'exterior' media for an index-matched boundary)"),
                    );
                    }
                };
                let checker = match tiling {
                    Some(([origin, u, v], tiles, odd)) => {
                        Checker::new(origin, u, v, tiles, material_id(odd, &materials)?)
                    }
                    None => None,
                };
                let shape_id = shapes.len() as u32;
                let light = match emission {
                    Some((le, _)) if le != Vec3::ZERO => {
                        let area = match &geometry {
                            ShapeGeometry::Mesh(m) => AreaShape::Mesh {
                                sampler: MeshSampler::new(m),
                                mesh: Box::new(m.clone()),
                            },
                            ShapeGeometry::Sphere(sp) => AreaShape::Sphere(*sp),
                        };
                        let light = if d.cone_angle.is_some() || d.cone_delta.is_some() {
                            let profile =
                                self.spot_profile(&d.cone_angle, &d.cone_delta, s.span(), true)?;
                            AreaLight::with_spot(shape_id, le, area, profile)
                        } else {
                            AreaLight::new(shape_id, le, area)
                        };
                        let light = match &d.emission_texture {
                            None => light,
                            Some(t) => {
                                let texture = self.texture(t, false)?;
                                if texture.range().0 < 0.0 {
                                    return src.err(
                                        t.span(),
                                        format!(
                                            "{label}: 'emission_texture' holds negative values"
                                        ),
                                    );
                                }
                                light.with_texture(std::sync::Arc::new(texture))
                            }
                        };
                        let power = light.power();
                        if !power.is_finite() {
                            return src.err(
                                d.emission.as_ref().map_or(s.span(), |e| e.span()),
                                format!("{label}: the emitted power (emission x area) overflows to {power}; lower 'emission' or the shape's size"),
                            );
                        }
                        lights.push(Light::Area(light));
                        Some(lights.len() as u32 - 1)
                    }
                    _ => None,
                };
                shapes.push(geometry);
                shape_info.push(ShapeInfo {
                    index: shape_id,
                    name: label,
                    material,
                    light,
                    interface,
                    null,
                    checker,
                });
            }
        }

        let mut environment = false;
        let n_shape_lights = lights.len();
        for l in &desc.light {
            let light = self.light(l)?;
            if matches!(light, Light::Environment(_) | Light::EnvMap(_)) {
                if environment {
                    return src.err(l.span(), "only one environment light is allowed");
                }
                environment = true;
            }
            lights.push(light);
        }

        // Bounding sphere of the geometry (the camera if there is none).
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for s in &shapes {
            match s {
                ShapeGeometry::Mesh(m) => {
                    for p in &m.positions {
                        lo = lo.min(*p);
                        hi = hi.max(*p);
                    }
                }
                ShapeGeometry::Sphere(sp) => {
                    lo = lo.min(sp.center - sp.radius);
                    hi = hi.max(sp.center + sp.radius);
                }
            }
        }
        let (center, radius) = if lo.x <= hi.x {
            (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-6))
        } else {
            (camera.position, 1.0)
        };
        for l in &mut lights {
            l.set_scene_bounds(center, radius);
        }
        // Lights are chosen in proportion to their power; that of lights at infinity grows
        // with the scene's bounding sphere, so check it now.
        for (l, d) in lights[n_shape_lights..].iter().zip(&desc.light) {
            let power = l.power();
            if !power.is_finite() {
                return src.err(
                    d.span(),
                    format!("the light's power overflows to {power}; lower its 'intensity', 'radiance' or 'irradiance' (or the scene's size, for lights at infinity)"),
                );
            }
        }

        let uses_media = world_medium.is_some()
            || shape_info.iter().any(|s| {
                s.interface
                    .is_some_and(|i| i.inside.is_some() || i.outside.is_some())
            });
        let infinite_lights: Vec<usize> = (0..lights.len())
            .filter(|&i| lights[i].is_infinite())
            .collect();
        let features = SceneFeatures {
            media: uses_media,
            delta_lights: lights.iter().any(|l| l.is_delta()),
            specular_surfaces: shape_info
                .iter()
                .flat_map(|s| [Some(s.material), s.checker.map(|c| c.odd)])
                .flatten()
                .any(|m| materials[m as usize].bsdf.has_delta_lobe()),
            environment: !infinite_lights.is_empty(),
            emissive_geometry: lights.iter().any(|l| matches!(l, Light::Area(_))),
            normal_maps: materials.iter().any(|m| m.normal_map.is_some()),
        };
        let accel = Accel::build(&shapes);
        let light_count = lights.len();
        let mut scene = Scene {
            source: src.name.to_string(),
            light_sampler: LightSampler::new(&lights),
            camera,
            shapes,
            shape_info,
            materials,
            lights,
            infinite_lights,
            media,
            world_medium,
            camera_medium: world_medium,
            light_media: vec![world_medium; light_count],
            accel,
            features,
            center,
            radius,
            render,
            filled_pixels: Default::default(),
        };
        scene.locate_media();
        Ok(scene)
    }

    /// Reject keys that are present but not `allowed` for this type, at the line of the first.
    pub(super) fn only(
        &self,
        what: &str,
        keys: &[(&str, Option<std::ops::Range<usize>>)],
        allowed: &[&str],
    ) -> Result<()> {
        for (key, span) in keys {
            if let (Some(span), false) = (span, allowed.contains(key)) {
                return self.src.err(
                    span.clone(),
                    format!("{what} does not take the key '{key}'"),
                );
            }
        }
        Ok(())
    }
}
