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
            ],
            "environment" => &["radiance"],
            "directional" => &["direction", "irradiance"],
            "sun" => &["direction", "angle", "radiance", "irradiance"],
            other => {
                return src.err(d.kind.span(), format!("unknown light type '{other}' (expected point, spot, environment, directional or sun)"));
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
                Light::Spot(SpotLight::new(
                    position()?,
                    direction()?,
                    intensity,
                    profile,
                ))
            }
            "environment" => Light::Environment(EnvironmentLight {
                radiance: src.non_negative3(
                    src.required(&d.radiance, span.clone(), "radiance", &what)?,
                    "radiance",
                )?,
                center: Vec3::ZERO,
                radius: 1.0,
            }),
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
