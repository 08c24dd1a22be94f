//! `[[light]]` tables (and area-light spot profiles) to lights.

use super::*;

impl Builder<'_> {
    pub(super) fn light(&self, l: &Spanned<LightDesc>) -> Result<Light> {
        let src = self.src;
        let d = l.get_ref();
        let span = l.span();
        let kind = d.kind.get_ref().as_str();
        let what = format!("light of type '{kind}'");
        let keys = [
            ("position", at(&d.position)),
            ("intensity", at(&d.intensity)),
            ("radiance", at(&d.radiance)),
            ("irradiance", at(&d.irradiance)),
            ("direction", at(&d.direction)),
            ("cone_angle", at(&d.cone_angle)),
            ("cone_delta", at(&d.cone_delta)),
            ("cone_edge", at(&d.cone_edge)),
            ("angle", at(&d.angle)),
            ("filename", at(&d.filename)),
            ("scale", at(&d.scale)),
            ("transform", at(&d.transform)),
            ("texture", at(&d.texture)),
            ("up", at(&d.up)),
        ];
        let allowed: &[&str] = match kind {
            "point" => &["position", "intensity"],
            "spot" => &[
                "position",
                "intensity",
                "direction",
                "cone_angle",
                "cone_delta",
                "cone_edge",
                "texture",
                "up",
            ],
            "environment" => &["radiance"],
            "envmap" => &["filename", "scale", "transform"],
            "directional" => &["direction", "irradiance"],
            "sun" => &["direction", "angle", "radiance", "irradiance"],
            other => {
                return src.err(d.kind.span(), format!("unknown light type '{other}' (expected point, spot, environment, envmap, directional or sun)"));
            }
        };
        self.only(&what, &keys, allowed)?;
        let position = || -> Result<Vec3> {
            let v = src.required(&d.position, span.clone(), "position", &what)?;
            let p = src.finite3(v, "position")?;
            if !in_bounds(p) {
                return src.err(
                    v.span(),
                    format!("'position' must lie within +-{MAX_COORDINATE:e} per axis, got {p}"),
                );
            }
            Ok(p)
        };
        let direction = || -> Result<Vec3> {
            let v = src.required(&d.direction, span.clone(), "direction", &what)?;
            let dir = src.finite3(v, "direction")?;
            match unit_vector(dir) {
                Some(d) => Ok(d),
                None => src.err(v.span(), "'direction' must be non-zero"),
            }
        };
        Ok(match kind {
            "point" => Light::Point(PointLight {
                position: position()?,
                intensity: src.non_negative3(
                    src.required(&d.intensity, span.clone(), "intensity", &what)?,
                    "intensity",
                )?,
            }),
            "spot" => {
                let intensity = src.non_negative3(
                    src.required(&d.intensity, span.clone(), "intensity", &what)?,
                    "intensity",
                )?;
                let mut profile =
                    self.spot_profile(&d.cone_angle, &d.cone_delta, span.clone(), false)?;
                if let Some(e) = &d.cone_edge {
                    profile = profile.with_edge(match e.get_ref().as_str() {
                        "smoothstep" => SpotEdge::Smoothstep,
                        "linear" => SpotEdge::LinearAngle,
                        other => {
                            return src.err(
                                e.span(),
                                format!("'cone_edge' must be \"smoothstep\" or \"linear\", got \"{other}\""),
                            );
                        }
                    });
                }
                let direction = direction()?;
                let light = SpotLight::new(position()?, direction, intensity, profile);
                match (&d.texture, &d.up) {
                    (None, Some(u)) => {
                        return src.err(
                            u.span(),
                            format!("{what}: 'up' orients a 'texture'; give one or neither"),
                        );
                    }
                    (None, None) => Light::Spot(light),
                    (Some(t), up) => {
                        let texture = std::sync::Arc::new(self.texture(t, false)?);
                        let up_at = up.as_ref().map_or(t.span(), |u| u.span());
                        let up = match up {
                            Some(u) => src.finite3(u, "up")?,
                            None => Vec3::Y,
                        };
                        let Some(projection) =
                            Projection::new(texture, direction, up, profile.cone_angle())
                        else {
                            return src.err(up_at, format!("{what}: 'up' ({up}) must not be parallel to the direction ({direction})"));
                        };
                        Light::Spot(light.with_projection(projection))
                    }
                }
            }
            "environment" => Light::Environment(EnvironmentLight {
                radiance: src.non_negative3(
                    src.required(&d.radiance, span.clone(), "radiance", &what)?,
                    "radiance",
                )?,
                center: Vec3::ZERO,
                radius: 1.0,
            }),
            "envmap" => self.envmap(d, span.clone(), &what)?,
            "directional" => Light::Directional(DirectionalLight::new(
                direction()?,
                src.non_negative3(
                    src.required(&d.irradiance, span.clone(), "irradiance", &what)?,
                    "irradiance",
                )?,
            )),
            "sun" => {
                let angle = match &d.angle {
                    Some(a) => {
                        SunLight::check_angle(*a.get_ref())
                            .or_else(|e| src.err(a.span(), format!("'angle': {e}")))?;
                        *a.get_ref()
                    }
                    None => SunLight::DEFAULT_ANGLE,
                };
                match (&d.radiance, &d.irradiance) {
                    (Some(r), None) => Light::Sun(SunLight::new(
                        direction()?,
                        angle,
                        src.non_negative3(r, "radiance")?,
                    )),
                    (None, Some(e)) => Light::Sun(SunLight::from_irradiance(
                        direction()?,
                        angle,
                        src.non_negative3(e, "irradiance")?,
                    )),
                    _ => {
                        return src.err(
                            span,
                            "a sun light needs exactly one of 'radiance' and 'irradiance'",
                        );
                    }
                }
            }
            _ => unreachable!("light types are checked above"),
        })
    }

    /// An environment map: its image (OpenEXR, linear RGB), `scale` and orientation.
    fn envmap(&self, d: &LightDesc, span: std::ops::Range<usize>, what: &str) -> Result<Light> {
        let src = self.src;
        let file = src.required(&d.filename, span, "filename", what)?;
        let path = match &self.dir {
            Some(dir) => dir.join(file.get_ref()),
            None => PathBuf::from(file.get_ref()),
        };
        let is_exr = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        if !is_exr {
            return src.err(
                file.span(),
                format!(
                    "environment map '{}': only OpenEXR images (.exr) are read",
                    path.display()
                ),
            );
        }
        let (image, _) = crate::film::Image::read_exr(&path)
            .or_else(|e| src.err(file.span(), format!("environment map: {e}")))?;
        let scale = match &d.scale {
            None => 1.0,
            Some(v) => {
                let x = *v.get_ref();
                if !(x.is_finite() && x >= 0.0) {
                    return src.err(
                        v.span(),
                        format!("'scale' must be finite and >= 0, got {x}"),
                    );
                }
                x
            }
        };
        let t = self.transform(d.transform.as_ref())?;
        let m = glam::Mat3::from(t.m.matrix3);
        let rotation = (m.transpose() * m - glam::Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .all(|x| x.abs() < 1e-4)
            && m.determinant() > 0.0;
        if !rotation {
            let at = d.transform.as_ref().map_or(file.span(), |t| t.span());
            return src.err(
                at,
                "an environment map's transform must be a rotation (no scale or mirror)",
            );
        }
        let light = EnvMapLight::new(
            &image.pixels,
            image.width as usize,
            image.height as usize,
            scale,
            m,
        )
        .or_else(|e| src.err(file.span(), format!("'{}': {e}", path.display())))?;
        Ok(Light::EnvMap(light))
    }

    /// A spot profile from optional `cone_angle` / `cone_delta` keys (degrees).
    pub(super) fn spot_profile(
        &self,
        angle: &Option<Spanned<f32>>,
        delta: &Option<Spanned<f32>>,
        span: std::ops::Range<usize>,
        area: bool,
    ) -> Result<SpotProfile> {
        let a = angle
            .as_ref()
            .map_or(SpotProfile::DEFAULT_CONE_ANGLE, |a| *a.get_ref());
        let d = delta
            .as_ref()
            .map_or(SpotProfile::DEFAULT_CONE_DELTA.min(a), |d| *d.get_ref());
        let check = if area {
            SpotProfile::check_area(a, d)
        } else {
            SpotProfile::check(a, d)
        };
        if let Err(e) = check {
            let at = angle.as_ref().or(delta.as_ref()).map_or(span, |s| s.span());
            return self.src.err(at, format!("spot cone: {e}"));
        }
        Ok(SpotProfile::new(a, d))
    }
}
