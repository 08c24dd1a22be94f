//! `[[material]]` tables to BSDFs.

use super::*;
use crate::bsdf::{Alpha, Mask, Opacity};
use crate::scene::NormalMap;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MaterialDesc {
    pub(super) name: Spanned<String>,
    #[serde(rename = "type")]
    pub(super) kind: Spanned<String>,
    pub(super) albedo: Option<V3>,
    pub(super) reflectance: Option<V3>,
    pub(super) ior: Option<Spanned<f32>>,
    pub(super) alpha: Option<Spanned<f32>>,
    /// `roughconductor`, `roughdielectric`: the roughness as a texture's luminance, in place of
    /// `alpha`.
    pub(super) alpha_texture: Option<Spanned<TextureDesc>>,
    /// `roughconductor`, `roughdielectric`: anisotropic roughness, in place of `alpha`: along
    /// the shading frame's first tangent, which follows the surface's `dp/du` (Mitsuba's
    /// `alpha_u`), and along the second (`alpha_v`); both or neither.
    pub(super) alpha_u: Option<Spanned<f32>>,
    pub(super) alpha_v: Option<Spanned<f32>>,
    /// Microfacet distribution of the rough materials: `ggx` (default) or `beckmann`.
    pub(super) distribution: Option<Spanned<String>>,
    pub(super) eta: Option<V3>,
    pub(super) k: Option<V3>,
    /// Black when seen from the back of the shape (Mitsuba's non-`twosided` BSDFs).
    pub(super) one_sided: Option<Spanned<bool>>,
    /// `plastic`, `roughplastic`: the coating's reflectance scale (default 1).
    pub(super) specular: Option<V3>,
    /// `plastic`, `roughplastic`: the base's reflectance in the interreflection sum (false).
    pub(super) nonlinear: Option<Spanned<bool>>,
    /// `diffuse`: the albedo as a texture, in place of `albedo`.
    pub(super) albedo_texture: Option<Spanned<TextureDesc>>,
    /// `conductor`, `roughconductor`: a texture multiplying the reflectance, in place of
    /// `specular`.
    pub(super) specular_texture: Option<Spanned<TextureDesc>>,
    /// Any material but `black`: a tangent-space normal map (`scene::perturbed_normal`).
    pub(super) normal_map: Option<Spanned<TextureDesc>>,
    /// Any material but `black`: a bump map, the texture's luminance a height
    /// (`scene::bumped_normal`), in place of `normal_map`.
    pub(super) bump_map: Option<Spanned<TextureDesc>>,
    /// With `bump_map`: the height's scale (default 1).
    pub(super) bump_scale: Option<Spanned<f32>>,
    /// Any material but `black`: an opacity in [0, 1] (Mitsuba's `mask`, `bsdf/mask.rs`).
    pub(super) opacity: Option<Spanned<f32>>,
    /// Any material but `black`: the opacity as a texture's luminance, in place of
    /// `opacity`.
    pub(super) opacity_texture: Option<Spanned<TextureDesc>>,
    /// `blend`: the names of the two materials mixed (defined before it).
    pub(super) first: Option<Spanned<String>>,
    pub(super) second: Option<Spanned<String>>,
    /// `blend`: the second material's weight in [0, 1] ...
    pub(super) weight: Option<Spanned<f32>>,
    /// ... or a texture's luminance, clipped to [0, 1].
    pub(super) weight_texture: Option<Spanned<TextureDesc>>,
}

/// A texture (`src/texture.rs`): `type = "bitmap"` with `filename` and optionally `raw`,
/// `filter` (`bilinear`, `nearest`), `wrap` (`repeat`, `mirror`, `clamp`); or
/// `type = "checkerboard"` with `color0`, `color1` (defaults 0.4, 0.2); both with `scale` and
/// `offset` of the texture coordinates (`to_uv`: uv * scale + offset).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TextureDesc {
    #[serde(rename = "type")]
    pub(super) kind: Spanned<String>,
    pub(super) filename: Option<Spanned<String>>,
    pub(super) raw: Option<bool>,
    pub(super) filter: Option<Spanned<String>>,
    pub(super) wrap: Option<Spanned<String>>,
    pub(super) color0: Option<V3>,
    pub(super) color1: Option<V3>,
    pub(super) scale: Option<Spanned<[f32; 2]>>,
    pub(super) offset: Option<Spanned<[f32; 2]>>,
    /// A Mitsuba `to_uv` transform (in place of `scale` and `offset`; not a TOML key).
    #[serde(skip)]
    pub(super) to_uv: Option<glam::Affine2>,
}

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
    pub(super) fn material(
        &self,
        m: &Spanned<MaterialDesc>,
        earlier: &[Material],
    ) -> Result<(Bsdf, bool)> {
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
            ("alpha_texture", at(&d.alpha_texture)),
            ("alpha_u", at(&d.alpha_u)),
            ("alpha_v", at(&d.alpha_v)),
            ("distribution", at(&d.distribution)),
            ("eta", at(&d.eta)),
            ("k", at(&d.k)),
            ("one_sided", at(&d.one_sided)),
            ("specular", at(&d.specular)),
            ("nonlinear", at(&d.nonlinear)),
            ("albedo_texture", at(&d.albedo_texture)),
            ("specular_texture", at(&d.specular_texture)),
            ("normal_map", at(&d.normal_map)),
            ("bump_map", at(&d.bump_map)),
            ("bump_scale", at(&d.bump_scale)),
            ("opacity", at(&d.opacity)),
            ("opacity_texture", at(&d.opacity_texture)),
            ("first", at(&d.first)),
            ("second", at(&d.second)),
            ("weight", at(&d.weight)),
            ("weight_texture", at(&d.weight_texture)),
        ];
        let allowed: &[&str] = match kind {
            "diffuse" => &["albedo", "albedo_texture", "one_sided"],
            "roughdiffuse" => &["albedo", "alpha", "one_sided"],
            "conductor" => CONDUCTOR_KEYS,
            "dielectric" | "thindielectric" => &["ior"],
            // A conductor's keys, added below.
            "roughconductor" => &[
                "alpha",
                "alpha_texture",
                "alpha_u",
                "alpha_v",
                "distribution",
            ],
            "roughdielectric" => &[
                "alpha",
                "alpha_texture",
                "alpha_u",
                "alpha_v",
                "distribution",
                "ior",
            ],
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
            "blend" => &["first", "second", "weight", "weight_texture"],
            "black" => &[],
            other => {
                return src.err(d.kind.span(), format!("unknown material type '{other}' (expected diffuse, roughdiffuse, conductor, dielectric, thindielectric, roughconductor, roughdielectric, plastic, roughplastic, blend or black)"));
            }
        };
        // A normal or bump map and an opacity go with every material that scatters.
        let allowed: Vec<&str> = allowed
            .iter()
            .chain(if kind == "roughconductor" {
                CONDUCTOR_KEYS
            } else {
                &[]
            })
            .copied()
            .chain(
                [
                    "normal_map",
                    "bump_map",
                    "bump_scale",
                    "opacity",
                    "opacity_texture",
                ]
                .into_iter()
                .filter(|_| kind != "black"),
            )
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
        let roughness = |key: &str, a: &Spanned<f32>| -> Result<f32> {
            let v = *a.get_ref();
            if !(v > 0.0 && v <= 1.0) {
                return src.err(
                    a.span(),
                    format!("'{key}' (microfacet roughness) must be in (0, 1], got {v}"),
                );
            }
            Ok(v)
        };
        let alpha = || -> Result<f32> {
            roughness(
                "alpha",
                src.required(&d.alpha, span.clone(), "alpha", &what)?,
            )
        };
        // A rough conductor's or dielectric's roughness: `alpha`, `alpha_texture`, or
        // `alpha_u` with `alpha_v`.
        let textured_alpha = || -> Result<Alpha> {
            if let Some(u) = d.alpha_u.as_ref().or(d.alpha_v.as_ref()) {
                let (Some(au), Some(av)) = (&d.alpha_u, &d.alpha_v) else {
                    return src.err(
                        u.span(),
                        format!("{what} has one of 'alpha_u' and 'alpha_v' (expected both)"),
                    );
                };
                if d.alpha.is_some() || d.alpha_texture.is_some() {
                    return src.err(
                        u.span(),
                        format!(
                            "{what} has 'alpha_u' and 'alpha_v' beside 'alpha' or \
                             'alpha_texture' (expected one roughness)"
                        ),
                    );
                }
                return Ok(Alpha::anisotropic(
                    roughness("alpha_u", au)?,
                    roughness("alpha_v", av)?,
                ));
            }
            let Some(t) = &d.alpha_texture else {
                return Ok(Alpha::from(alpha()?));
            };
            if d.alpha.is_some() {
                return src.err(
                    t.span(),
                    format!("{what} has both 'alpha' and 'alpha_texture' (expected one)"),
                );
            }
            let texture = self.texture(t, false)?;
            let (lo, hi) = texture.range();
            if !(lo >= 0.0 && hi.is_finite()) {
                return src.err(
                    t.span(),
                    format!("{what}: 'alpha_texture' must hold finite roughnesses >= 0, it holds values in [{lo}, {hi}]"),
                );
            }
            Ok(Alpha::Texture(std::sync::Arc::new(texture)))
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
        let mut one_sided = d.one_sided.as_ref().is_some_and(|o| *o.get_ref());
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
                    ("roughconductor", fresnel) => {
                        Bsdf::rough_conductor(textured_alpha()?, fresnel)
                    }
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
                Bsdf::rough_dielectric(eta, textured_alpha()?)
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
            "blend" => {
                let (bsdf, sided) = self.blend(m, earlier, &what)?;
                one_sided = sided;
                bsdf
            }
            _ => unreachable!("material types are checked above"),
        };
        let bsdf = bsdf.with_distribution(distribution);
        match self.opacity(d, &what)? {
            // The mask is two-sided: its null lobe lets light through from either side.
            Some(opacity) => Ok((
                Bsdf::Mask(Box::new(Mask::new(bsdf, opacity, one_sided))),
                false,
            )),
            None => Ok((bsdf, one_sided)),
        }
    }

    /// A material's `normal_map` or `bump_map` (with `bump_scale`), if it has one (not both).
    pub(super) fn normal_map(&self, d: &MaterialDesc, what: &str) -> Result<Option<NormalMap>> {
        let src = self.src;
        if let (None, Some(s)) = (&d.bump_map, &d.bump_scale) {
            return src.err(s.span(), format!("{what}: 'bump_scale' needs a 'bump_map'"));
        }
        match (&d.normal_map, &d.bump_map) {
            (Some(_), Some(b)) => src.err(
                b.span(),
                format!("{what} has both 'normal_map' and 'bump_map' (expected one)"),
            ),
            (Some(t), None) => Ok(Some(NormalMap::Tangent(std::sync::Arc::new(
                self.texture(t, true)?,
            )))),
            (None, Some(t)) => {
                let scale = match &d.bump_scale {
                    None => 1.0,
                    Some(s) if s.get_ref().is_finite() => *s.get_ref(),
                    Some(s) => return src.err(s.span(), "'bump_scale' must be a finite number"),
                };
                Ok(Some(NormalMap::Bump {
                    height: std::sync::Arc::new(self.texture(t, false)?),
                    scale,
                }))
            }
            (None, None) => Ok(None),
        }
    }

    /// A material's `opacity` or `opacity_texture`, if it has one (not both).
    fn opacity(&self, d: &MaterialDesc, what: &str) -> Result<Option<Opacity>> {
        self.fraction(("opacity", &d.opacity), &d.opacity_texture, what)
    }

    /// A fraction in [0, 1] given as the number `key` or as the texture `{key}_texture` (its
    /// luminance, clipped to [0, 1] where it is read, as in Mitsuba), if either is given (not
    /// both): a mask's opacity, a blend's weight.
    pub(super) fn fraction(
        &self,
        (key, value): (&str, &Option<Spanned<f32>>),
        texture: &Option<Spanned<TextureDesc>>,
        what: &str,
    ) -> Result<Option<Opacity>> {
        let src = self.src;
        match (value, texture) {
            (Some(_), Some(t)) => src.err(
                t.span(),
                format!("{what} has both '{key}' and '{key}_texture' (expected one)"),
            ),
            (Some(a), None) => {
                let v = *a.get_ref();
                if !(0.0..=1.0).contains(&v) {
                    return src.err(a.span(), format!("'{key}' must be in [0, 1], got {v}"));
                }
                Ok(Some(Opacity::Constant(v)))
            }
            (None, Some(t)) => Ok(Some(Opacity::Texture(std::sync::Arc::new(
                self.texture(t, false)?,
            )))),
            (None, None) => Ok(None),
        }
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
