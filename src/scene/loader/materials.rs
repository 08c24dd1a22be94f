//! `[[material]]` tables to BSDFs.

use super::*;

/// The keys of a smooth conductor; a rough one adds `alpha` and `distribution`.
const CONDUCTOR_KEYS: &[&str] = &[
    "reflectance",
    "eta",
    "k",
    "specular",
    "specular_texture",
    "one_sided",
];

impl Builder<'_> {
    /// The BSDF of a material, and whether it is one-sided (black seen from the back).
    pub(super) fn material(&self, m: &Spanned<MaterialDesc>) -> Result<(Bsdf, bool)> {
        let src = self.src;
        let d = m.get_ref();
        let kind = d.kind.get_ref().as_str();
        let what = format!("material '{}' of type '{kind}'", d.name.get_ref());
        let span = m.span();
        let keys = [
            ("albedo", at(&d.albedo)),
            ("reflectance", at(&d.reflectance)),
            ("ior", at(&d.ior)),
            ("alpha", at(&d.alpha)),
            ("distribution", at(&d.distribution)),
            ("eta", at(&d.eta)),
            ("k", at(&d.k)),
            ("one_sided", at(&d.one_sided)),
            ("specular", at(&d.specular)),
            ("nonlinear", at(&d.nonlinear)),
            ("albedo_texture", at(&d.albedo_texture)),
            ("specular_texture", at(&d.specular_texture)),
            ("normal_map", at(&d.normal_map)),
        ];
        let allowed: &[&str] = match kind {
            "diffuse" => &["albedo", "albedo_texture", "one_sided"],
            "roughdiffuse" => &["albedo", "alpha", "one_sided"],
            "conductor" => CONDUCTOR_KEYS,
            "dielectric" | "thindielectric" => &["ior"],
            // A conductor's keys, added below.
            "roughconductor" => &["alpha", "distribution"],
            "roughdielectric" => &["alpha", "distribution", "ior"],
            "roughplastic" => &[
                "albedo",
                "albedo_texture",
                "specular",
                "ior",
                "alpha",
                "distribution",
                "nonlinear",
                "one_sided",
            ],
            "plastic" => &[
                "albedo",
                "albedo_texture",
                "specular",
                "ior",
                "nonlinear",
                "one_sided",
            ],
            "black" => &[],
            other => {
                return src.err(d.kind.span(), format!("unknown material type '{other}' (expected diffuse, roughdiffuse, conductor, dielectric, thindielectric, roughconductor, roughdielectric, plastic, roughplastic or black)"));
            }
        };
        // A normal map goes with every material that scatters.
        let allowed: Vec<&str> = allowed
            .iter()
            .chain(if kind == "roughconductor" {
                CONDUCTOR_KEYS
            } else {
                &[]
            })
            .copied()
            .chain((kind != "black").then_some("normal_map"))
            .collect();
        self.only(&what, &keys, &allowed)?;
        let ior = || -> Result<f32> {
            let ior = src.required(&d.ior, span.clone(), "ior", &what)?;
            let eta = *ior.get_ref();
            if !(eta.is_finite() && eta > 0.0) {
                return src.err(
                    ior.span(),
                    format!("'ior' must be a finite number > 0, got {eta}"),
                );
            }
            Ok(eta)
        };
        let alpha = || -> Result<f32> {
            let a = src.required(&d.alpha, span.clone(), "alpha", &what)?;
            let v = *a.get_ref();
            if !(v > 0.0 && v <= 1.0) {
                return src.err(
                    a.span(),
                    format!("'alpha' (microfacet roughness) must be in (0, 1], got {v}"),
                );
            }
            Ok(v)
        };
        let distribution = match &d.distribution {
            None => Distribution::Ggx,
            Some(v) => match v.get_ref().as_str() {
                "ggx" => Distribution::Ggx,
                "beckmann" => Distribution::Beckmann,
                other => {
                    return src.err(
                        v.span(),
                        format!("unknown distribution '{other}' (expected ggx or beckmann)"),
                    );
                }
            },
        };
        let one_sided = d.one_sided.as_ref().is_some_and(|o| *o.get_ref());
        let bsdf = match kind {
            "diffuse" => match self.albedo_texture(d, &what)? {
                Some(albedo) => Bsdf::TexturedDiffuse { albedo },
                None => Bsdf::Diffuse {
                    albedo: src
                        .in_unit_range(src.required(&d.albedo, span, "albedo", &what)?, "albedo")?,
                },
            },
            "roughdiffuse" => {
                let albedo = src.required(&d.albedo, span.clone(), "albedo", &what)?;
                Bsdf::RoughDiffuse {
                    albedo: src.in_unit_range(albedo, "albedo")?,
                    alpha: alpha()?,
                }
            }
            "conductor" | "roughconductor" => {
                let fresnel = match (&d.reflectance, &d.eta, &d.k) {
                    (Some(_), None, None) if d.specular.is_some() => {
                        return src.err(at(&d.specular).unwrap_or(span), "'specular' scales the Fresnel reflectance of 'eta' and 'k'; with 'reflectance', give the reflectance itself");
                    }
                    (Some(r), None, None) => ConductorFresnel::Constant(src.in_unit_range(r, "reflectance")?),
                    (None, Some(eta), Some(k)) => {
                        let e = src.finite3(eta, "eta")?;
                        if e.min_element() <= 0.0 {
                            return src.err(eta.span(), "'eta' must be > 0 per channel");
                        }
                        let scale = match &d.specular {
                            Some(c) => src.in_unit_range(c, "specular")?,
                            None => glam::Vec3::ONE,
                        };
                        ConductorFresnel::Complex { eta: e, k: src.non_negative3(k, "k")?, scale }
                    }
                    _ => return src.err(span, format!("{what} needs either 'reflectance' (constant) or both 'eta' and 'k' (complex ior)")),
                };
                let conductor = match (kind, fresnel) {
                    ("roughconductor", fresnel) => Bsdf::rough_conductor(alpha()?, fresnel),
                    (_, ConductorFresnel::Constant(reflectance)) => Bsdf::Conductor { reflectance },
                    (_, ConductorFresnel::Complex { eta, k, scale }) => {
                        Bsdf::FresnelConductor { eta, k, scale }
                    }
                };
                match &d.specular_texture {
                    Some(t) if d.specular.is_some() => {
                        return src.err(
                            t.span(),
                            format!(
                                "{what} has both 'specular' and 'specular_texture' (expected one)"
                            ),
                        );
                    }
                    Some(t) => Bsdf::tinted(conductor, std::sync::Arc::new(self.texture(t, true)?)),
                    None => conductor,
                }
            }
            "dielectric" => Bsdf::Dielectric { eta: ior()? },
            "thindielectric" => Bsdf::ThinDielectric { eta: ior()? },
            "roughdielectric" => {
                let eta = ior()?;
                if eta == 1.0 {
                    let at = d.ior.as_ref().map_or(span, |i| i.span());
                    return src.err(at, "'ior' = 1 is no interface at all; use a shape with media and no material (an index-matched boundary) instead");
                }
                Bsdf::rough_dielectric(eta, alpha()?)
            }
            // Smooth or rough: the same coating and base.
            "plastic" | "roughplastic" => {
                let eta = ior()?;
                if eta == 1.0 {
                    let at = d.ior.as_ref().map_or(span, |i| i.span());
                    return src.err(
                        at,
                        "'ior' = 1: a plastic's coating needs an index other than the outside's",
                    );
                }
                let specular = match &d.specular {
                    Some(c) => src.in_unit_range(c, "specular")?,
                    None => glam::Vec3::ONE,
                };
                let texture = self.albedo_texture(d, &what)?;
                let albedo = match texture {
                    Some(_) => glam::Vec3::ZERO,
                    None => src.in_unit_range(
                        src.required(&d.albedo, span.clone(), "albedo", &what)?,
                        "albedo",
                    )?,
                };
                let nonlinear = d.nonlinear.as_ref().is_some_and(|n| *n.get_ref());
                if kind == "plastic" {
                    let plastic = crate::bsdf::Plastic::new(albedo, specular, eta, nonlinear);
                    Bsdf::Plastic(Box::new(match texture {
                        Some(t) => plastic.with_diffuse_texture(t),
                        None => plastic,
                    }))
                } else {
                    let plastic = crate::bsdf::RoughPlastic::new(
                        albedo,
                        specular,
                        eta,
                        alpha()?,
                        distribution,
                        nonlinear,
                    );
                    Bsdf::RoughPlastic(Box::new(match texture {
                        Some(t) => plastic.with_diffuse_texture(t),
                        None => plastic,
                    }))
                }
            }
            "black" => Bsdf::Black,
            _ => unreachable!("material types are checked above"),
        };
        Ok((bsdf.with_distribution(distribution), one_sided))
    }

    /// A material's `albedo_texture`, if it has one (and not `albedo` as well).
    fn albedo_texture(
        &self,
        d: &MaterialDesc,
        what: &str,
    ) -> Result<Option<std::sync::Arc<Texture>>> {
        match (&d.albedo, &d.albedo_texture) {
            (Some(_), Some(t)) => self.src.err(
                t.span(),
                format!("{what} has both 'albedo' and 'albedo_texture' (expected one)"),
            ),
            (_, Some(t)) => Ok(Some(std::sync::Arc::new(self.texture(t, true)?))),
            _ => Ok(None),
        }
    }

    /// The texture of a `{ type = ... }` table; `reflectance`: every value must lie in [0, 1].
    pub(super) fn texture(&self, t: &Spanned<TextureDesc>, reflectance: bool) -> Result<Texture> {
        let src = self.src;
        let d = t.get_ref();
        let kind = d.kind.get_ref().as_str();
        let what = format!("texture of type '{kind}'");
        let keys = [
            ("filename", at(&d.filename)),
            ("raw", d.raw.map(|_| t.span())),
            ("filter", at(&d.filter)),
            ("wrap", at(&d.wrap)),
            ("color0", at(&d.color0)),
            ("color1", at(&d.color1)),
        ];
        let allowed: &[&str] = match kind {
            "bitmap" => &["filename", "raw", "filter", "wrap"],
            "checkerboard" => &["color0", "color1"],
            other => {
                return src.err(
                    d.kind.span(),
                    format!("unknown texture type '{other}' (expected bitmap or checkerboard)"),
                );
            }
        };
        self.only(&what, &keys, allowed)?;
        let pair = |v: &Option<Spanned<[f32; 2]>>, key: &str, default: Vec2| -> Result<Vec2> {
            match v {
                None => Ok(default),
                Some(v) if v.get_ref().iter().all(|x| x.is_finite()) => {
                    Ok(Vec2::from(*v.get_ref()))
                }
                Some(v) => src.err(v.span(), format!("'{key}' must be two finite numbers")),
            }
        };
        let to_uv = match d.to_uv {
            Some(m) => m,
            None => glam::Affine2::from_scale_angle_translation(
                pair(&d.scale, "scale", Vec2::ONE)?,
                0.0,
                pair(&d.offset, "offset", Vec2::ZERO)?,
            ),
        };
        let choice = |v: &Option<Spanned<String>>, options: &[&str]| -> Result<usize> {
            let Some(v) = v else { return Ok(0) };
            options.iter().position(|o| o == v.get_ref()).map_or_else(
                || {
                    src.err(
                        v.span(),
                        format!("'{}' is not one of {}", v.get_ref(), options.join(", ")),
                    )
                },
                Ok,
            )
        };
        let texture = match kind {
            "bitmap" => {
                let file = src.required(&d.filename, t.span(), "filename", &what)?;
                let path = match &self.dir {
                    Some(dir) => dir.join(file.get_ref()),
                    None => std::path::PathBuf::from(file.get_ref()),
                };
                let bilinear = choice(&d.filter, &["bilinear", "nearest"])? == 0;
                let wrap = [Wrap::Repeat, Wrap::Mirror, Wrap::Clamp]
                    [choice(&d.wrap, &["repeat", "mirror", "clamp"])?];
                let mut bitmap = crate::texture::Bitmap::read(&path, d.raw.unwrap_or(false))
                    .or_else(|e| src.err(file.span(), e))?;
                bitmap.bilinear = bilinear;
                bitmap.wrap = wrap;
                Texture::Bitmap {
                    bitmap: std::sync::Arc::new(bitmap),
                    to_uv,
                }
            }
            _ => {
                let color = |v: &Option<V3>, key: &str, default: f32| match v {
                    None => Ok(Vec3::splat(default)),
                    Some(v) => src.finite3(v, key),
                };
                Texture::Checkerboard {
                    color0: color(&d.color0, "color0", 0.4)?,
                    color1: color(&d.color1, "color1", 0.2)?,
                    to_uv,
                }
            }
        };
        let (lo, hi) = texture.range();
        if reflectance && !(lo >= 0.0 && hi <= 1.0) {
            return src.err(
                t.span(),
                format!("{what}: a reflectance must lie in [0, 1], the texture holds values in [{lo}, {hi}]"),
            );
        }
        Ok(texture)
    }
}
