//! Mitsuba BSDFs to lodestar materials and homogeneous media to lodestar media, each element
//! converted once (references share it). See the module documentation of `mitsuba` for the
//! subset and its defaults.

use super::super::{MaterialDesc, MediumDesc, TextureDesc};
use super::out::{Out, kind, s};
use super::{Props, Xml, span};
use crate::error::Result;
use glam::Vec3;
use roxmltree::Node;
use toml::Spanned;

pub(super) fn material_desc(n: Node, name: String, kind: &str) -> MaterialDesc {
    MaterialDesc {
        name: s(n, name),
        kind: s(n, kind.to_string()),
        albedo: None,
        reflectance: None,
        ior: None,
        alpha: None,
        alpha_texture: None,
        alpha_u: None,
        alpha_v: None,
        distribution: None,
        eta: None,
        k: None,
        one_sided: None,
        specular: None,
        nonlinear: None,
        albedo_texture: None,
        specular_texture: None,
        normal_map: None,
        bump_map: None,
        bump_scale: None,
        opacity: None,
        opacity_texture: None,
        first: None,
        second: None,
        weight: None,
        weight_texture: None,
    }
}

/// A `<texture>` read for a scalar property (a roughness, an opacity): [`texture_desc`] with a
/// checkerboard's two colours swapped. Mitsuba 3 looks scalars up with `eval_1`, and its
/// checkerboard's `eval_1` takes `color0` where the fractional parts of u and v lie on
/// different sides of 1/2, where its colour lookup `eval` takes `color1`
/// (`src/textures/checkerboard.cpp`, 3.9.1); swapped, the file renders as in Mitsuba.
fn scalar_texture_desc(xml: &Xml, n: Node) -> Result<TextureDesc> {
    let mut d = texture_desc(xml, n)?;
    if d.kind.get_ref() == "checkerboard" {
        let c0 = d.color0.take().unwrap_or_else(|| s(n, [0.4; 3]));
        let c1 = d.color1.take().unwrap_or_else(|| s(n, [0.2; 3]));
        (d.color0, d.color1) = (Some(c1), Some(c0));
    }
    Ok(d)
}

/// A `<texture>`: `bitmap` (`filename`, `raw` false, `filter_type` "bilinear" or "nearest",
/// `wrap_mode` "repeat", "mirror" or "clamp", `to_uv`) or `checkerboard` (`color0` 0.4,
/// `color1` 0.2, `to_uv`); `to_uv` keeps the transform's action on (u, v).
pub(super) fn texture_desc(xml: &Xml, n: Node) -> Result<TextureDesc> {
    let k = kind(xml, n)?;
    let mut p = xml.props(n)?;
    let mut d = TextureDesc {
        kind: s(n, k.clone()),
        filename: None,
        raw: None,
        filter: None,
        wrap: None,
        color0: None,
        color1: None,
        scale: None,
        offset: None,
        to_uv: None,
    };
    match k.as_str() {
        "bitmap" => {
            d.filename = match p.string(xml, "filename")? {
                Some((at, f)) => Some(s(at, xml.find_file(&f))),
                None => return xml.err(n, "texture 'bitmap' needs 'filename'"),
            };
            d.raw = p.boolean(xml, "raw")?;
            // Mitsuba 0.x's MIP-mapped lookups ("trilinear", "ewa") are bilinear in Mitsuba 3.
            d.filter = p
                .string(xml, "filter_type")?
                .map(|(at, v)| match v.as_str() {
                    "trilinear" | "ewa" if xml.before_2 => s(at, "bilinear".to_string()),
                    _ => s(at, v),
                });
            p.float(xml, "max_anisotropy")?;
            p.float(xml, "gamma")?;
            d.wrap = p.string(xml, "wrap_mode")?.map(|(at, v)| s(at, v));
            // Read: the lookup is the same in every precision and colour format.
            p.string(xml, "format")?;
        }
        "checkerboard" => {
            for (key, slot) in [("color0", &mut d.color0), ("color1", &mut d.color1)] {
                *slot = p.color(xml, key)?.map(|(at, c)| s(at, c.to_array()));
            }
        }
        other => {
            return xml.err(
                n,
                format!("texture '{other}' is not supported (expected bitmap or checkerboard)"),
            );
        }
    }
    // Mitsuba 0.x: `uscale`, `vscale`, `uoffset`, `voffset` (Mitsuba 3 makes them `to_uv`).
    let mut legacy = [1.0f32, 1.0, 0.0, 0.0];
    let mut given = false;
    for (key, slot) in ["uscale", "vscale", "uoffset", "voffset"]
        .iter()
        .zip(&mut legacy)
    {
        if let Some((_, v)) = p.float(xml, key)? {
            *slot = v;
            given = true;
        }
    }
    if given {
        d.to_uv = Some(glam::Affine2::from_scale_angle_translation(
            glam::Vec2::new(legacy[0], legacy[1]),
            0.0,
            glam::Vec2::new(legacy[2], legacy[3]),
        ));
    }
    if let Some(t) = p.take("to_uv") {
        if t.tag_name().name() != "transform" {
            return xml.err(t, "'to_uv' must be a <transform>");
        }
        let m = xml.transform(t)?;
        d.to_uv = Some(glam::Affine2::from_cols_array(&[
            m.x_axis.x, m.x_axis.y, m.y_axis.x, m.y_axis.y, m.w_axis.x, m.w_axis.y,
        ]));
    }
    p.finish(xml)?;
    Ok(d)
}

/// The material name of a `<bsdf>` (converted once per element), `None` for `null`.
pub(super) fn bsdf(xml: &Xml, n: Node, out: &mut Out) -> Result<Option<String>> {
    if let Some(done) = out.bsdfs.get(&n.id()) {
        return Ok(done.clone());
    }
    let name = match xml.attr(n, "id")? {
        Some(id) => id,
        None => format!("{} (line {})", kind(xml, n)?, xml.src.line(n.range().start)),
    };
    let desc = bsdf_desc(xml, n, name.clone(), true, out)?;
    let result = desc.map(|d| {
        out.desc.material.push(s(n, d));
        name
    });
    out.bsdfs.insert(n.id(), result.clone());
    Ok(result)
}

/// A material description; `one_sided` unless inside `twosided`. Materials it refers to
/// (a `blendbsdf`'s two) go to `out` first.
fn bsdf_desc<'a, 'i>(
    xml: &Xml<'a, 'i>,
    n: Node<'a, 'i>,
    name: String,
    one_sided: bool,
    out: &mut Out,
) -> Result<Option<MaterialDesc>> {
    let k = kind(xml, n)?;
    let k = k.as_str();
    let mut p = xml.props(n)?;
    let mut d = material_desc(n, name, k);
    let unit = |v: Option<(Node, Vec3)>, default: f32| {
        v.map_or(Spanned::new(span(n), [default; 3]), |(at, c)| {
            s(at, c.to_array())
        })
    };
    let ior = |p: &mut Props| -> Result<f32> {
        let int = p.ior(xml, "int_ior", 1.5046)?;
        let ext = p.ior(xml, "ext_ior", 1.000277)?;
        if !(int > 0.0 && ext > 0.0) {
            return xml.err(n, "'int_ior' and 'ext_ior' must be > 0");
        }
        Ok(int / ext)
    };
    let white_only = |p: &mut Props, key: &str| -> Result<()> {
        if let Some((at, c)) = p.color(xml, key)?
            && c != Vec3::ONE
        {
            return xml.err(
                at,
                format!("'{key}' other than 1 is not supported on a dielectric"),
            );
        }
        Ok(())
    };
    // The microfacet distribution (Mitsuba's default: Beckmann) and roughness.
    // The roughness, a number (`alpha`, or equal `alpha_u` and `alpha_v`) or, where `full`
    // (roughconductor, roughdielectric), a texture (`alpha`, kept in `alpha_texture`) or two
    // numbers (`alpha_u` and `alpha_v`, kept in the material's); `None` returned for those.
    let rough = |p: &mut Props<'a, 'i>,
                 d: &mut MaterialDesc,
                 full: bool|
     -> Result<Option<Spanned<f32>>> {
        d.distribution = Some(match p.string(xml, "distribution")? {
            Some((at, dist)) if dist == "ggx" || dist == "beckmann" => s(at, dist),
            Some((at, dist)) => {
                return xml.err(
                    at,
                    format!("distribution '{dist}' is not supported (expected ggx or beckmann)"),
                );
            }
            None => s(n, "beckmann".to_string()),
        });
        // Both are sampled by their visible normals.
        p.boolean(xml, "sample_visible")?;
        if let Some(t) = p.texture(xml, "alpha")? {
            if !full {
                return xml.err(t, format!("{k}: a textured 'alpha' is not supported here (Mitsuba 3 takes a number; roughconductor and roughdielectric take a texture)"));
            }
            d.alpha_texture = Some(s(t, scalar_texture_desc(xml, t)?));
            return Ok(None);
        }
        let a = p.float(xml, "alpha")?;
        let (au, av) = (p.float(xml, "alpha_u")?, p.float(xml, "alpha_v")?);
        match (a, au, av) {
            (Some((at, a)), None, None) => Ok(Some(s(at, a))),
            (None, Some((at, u)), Some((_, v))) if u == v => Ok(Some(s(at, u))),
            (None, Some((at_u, u)), Some((at_v, v))) if full => {
                d.alpha_u = Some(s(at_u, u));
                d.alpha_v = Some(s(at_v, v));
                Ok(None)
            }
            (None, Some(_), Some(_)) => xml.err(n, format!("{k}: anisotropic roughness is not supported here (Mitsuba's {k} takes one 'alpha'; roughconductor and roughdielectric take 'alpha_u' and 'alpha_v')")),
            (None, None, None) => Ok(Some(s(n, 0.1))),
            _ => xml.err(n, "expected one roughness: 'alpha', or both 'alpha_u' and 'alpha_v'"),
        }
    };
    match k {
        "diffuse" => {
            match p.texture(xml, "reflectance")? {
                Some(t) => d.albedo_texture = Some(s(t, texture_desc(xml, t)?)),
                None => d.albedo = Some(unit(p.color(xml, "reflectance")?, 0.5)),
            }
            d.one_sided = Some(s(n, one_sided));
        }
        "roughdiffuse" => {
            // Mitsuba 0.6's plugin: `reflectance` or `diffuse_reflectance`, `alpha` 0.2.
            let r = match p.color(xml, "reflectance")? {
                Some(c) => Some(c),
                None => p.color(xml, "diffuse_reflectance")?,
            };
            d.albedo = Some(unit(r, 0.5));
            d.alpha = Some(match p.float(xml, "alpha")? {
                Some((at, a)) => s(at, a),
                None => s(n, 0.2),
            });
            if let Some((at, true)) = p.boolean(xml, "use_fast_approx")?.map(|v| (n, v)) {
                return xml.err(at, "roughdiffuse's 'use_fast_approx' is not supported (lodestar evaluates the full Oren-Nayar model)");
            }
            d.one_sided = Some(s(n, one_sided));
        }
        "conductor" | "roughconductor" => {
            if k == "roughconductor" {
                d.alpha = rough(&mut p, &mut d, true)?;
            }
            let material = p.string(xml, "material")?;
            let (eta, kk) = (p.color(xml, "eta")?, p.color(xml, "k")?);
            let spec = match p.texture(xml, "specular_reflectance")? {
                Some(t) => {
                    d.specular_texture = Some(s(t, texture_desc(xml, t)?));
                    None
                }
                None => p.color(xml, "specular_reflectance")?,
            };
            match (material, eta, kk) {
                (m, None, None) if m.as_ref().is_none_or(|(_, m)| m == "none") => {
                    d.reflectance = Some(unit(spec, 1.0));
                }
                (Some((at, m)), None, None) => {
                    let Some((eta, kv)) = super::conductors::named(&m) else {
                        return xml.err(at, format!("conductor material '{m}' is not known (Mitsuba's: none, {}; or give 'eta' and 'k')", super::conductors::names()));
                    };
                    if let Some((sat, c)) = spec {
                        d.specular = Some(s(sat, c.to_array()));
                    }
                    d.eta = Some(s(at, eta));
                    d.k = Some(s(at, kv));
                }
                (None, Some((ea, e)), Some((ka, kv))) => {
                    if let Some((at, c)) = spec {
                        d.specular = Some(s(at, c.to_array()));
                    }
                    d.eta = Some(s(ea, e.to_array()));
                    d.k = Some(s(ka, kv.to_array()));
                }
                _ => return xml.err(n, "a conductor needs both 'eta' and 'k' (or neither)"),
            }
            d.one_sided = Some(s(n, one_sided));
        }
        "dielectric" | "roughdielectric" | "thindielectric" => {
            if k == "roughdielectric" {
                d.alpha = rough(&mut p, &mut d, true)?;
            }
            d.ior = Some(s(n, ior(&mut p)?));
            white_only(&mut p, "specular_reflectance")?;
            white_only(&mut p, "specular_transmittance")?;
        }
        "normalmap" | "bumpmap" => {
            // The nested BSDF with the map on its material (`scene::NormalMap`).
            let (map, scale) = if k == "normalmap" {
                let Some(t) = p.texture(xml, "normalmap")? else {
                    return xml.err(n, "normalmap needs a <texture name=\"normalmap\">");
                };
                (s(t, texture_desc(xml, t)?), None)
            } else {
                let [t] = p.any_textures(xml)?[..] else {
                    return xml.err(n, "bumpmap needs one nested <texture> (the height)");
                };
                let scale = match p.float(xml, "scale")? {
                    Some((at, v)) => s(at, v),
                    None => s(n, 1.0),
                };
                (s(t, texture_desc(xml, t)?), Some(scale))
            };
            // Mitsuba 3 by default mirrors a normal that faces away from the viewer and damps
            // the response by a shadowing term (Estevez et al. 2019): both make the BSDF depend
            // on which side the camera is, which lodestar's maps (a turned shading normal, the
            // same for both directions of transport) do not model.
            for key in ["flip_invalid_normals", "use_shadowing_function"] {
                if p.boolean(xml, key)?.unwrap_or(true) {
                    return xml.err(n, format!("{k}: '{key}' true (Mitsuba's default) is not supported: lodestar's {k} turns the shading normal only; give <boolean name=\"{key}\" value=\"false\"/> to render that"));
                }
            }
            let inner = p.nested(xml, "bsdf")?;
            p.finish(xml)?;
            let [b] = inner.as_slice() else {
                return xml.err(n, format!("{k} needs one nested <bsdf>"));
            };
            let Some(mut desc) = bsdf_desc(xml, *b, d.name.into_inner(), one_sided, out)? else {
                return xml.err(*b, format!("{k} cannot wrap a 'null' BSDF"));
            };
            if desc.normal_map.is_some() || desc.bump_map.is_some() {
                return xml.err(*b, format!("{k} cannot wrap another normalmap or bumpmap"));
            }
            match scale {
                None => desc.normal_map = Some(map),
                Some(scale) => {
                    desc.bump_map = Some(map);
                    desc.bump_scale = Some(scale);
                }
            }
            return Ok(Some(desc));
        }
        "mask" => {
            // The nested BSDF with the opacity on its material (`bsdf/mask.rs`).
            let opacity = match p.texture(xml, "opacity")? {
                Some(t) => Err(s(t, scalar_texture_desc(xml, t)?)),
                None => Ok(match p.float(xml, "opacity")? {
                    Some((at, a)) => s(at, a),
                    None => s(n, 0.5),
                }),
            };
            let inner = p.nested(xml, "bsdf")?;
            p.finish(xml)?;
            let [b] = inner.as_slice() else {
                return xml.err(n, "mask needs one nested <bsdf>");
            };
            let Some(mut desc) = bsdf_desc(xml, *b, d.name.into_inner(), one_sided, out)? else {
                return xml.err(*b, "mask cannot wrap a 'null' BSDF");
            };
            if desc.opacity.is_some() || desc.opacity_texture.is_some() {
                return xml.err(*b, "mask cannot wrap another mask");
            }
            match opacity {
                Ok(a) => desc.opacity = Some(a),
                Err(t) => desc.opacity_texture = Some(t),
            }
            return Ok(Some(desc));
        }
        "twosided" => {
            let inner = p.nested(xml, "bsdf")?;
            p.finish(xml)?;
            return match inner.as_slice() {
                [b] if matches!(kind(xml, *b)?.as_str(), "dielectric" | "roughdielectric" | "thindielectric" | "twosided" | "null") => xml.err(*b, format!("twosided cannot wrap '{}'", kind(xml, *b)?)),
                [b] => bsdf_desc(xml, *b, d.name.into_inner(), false, out),
                [] => xml.err(n, "twosided needs one nested <bsdf>"),
                _ => xml.err(inner[1], "twosided with a different BSDF per side is not supported"),
            };
        }
        "null" => {
            p.finish(xml)?;
            return Ok(None);
        }
        "blendbsdf" => {
            // The two nested BSDFs as materials of their own, named after the blend
            // (`bsdf/blend.rs`); `weight` the second's share, as in Mitsuba 3.
            d.kind = s(n, "blend".to_string());
            match p.texture(xml, "weight")? {
                Some(t) => d.weight_texture = Some(s(t, scalar_texture_desc(xml, t)?)),
                None => match p.float(xml, "weight")? {
                    Some((at, w)) => d.weight = Some(s(at, w)),
                    None => return xml.err(n, "blendbsdf needs a 'weight' (a number or a texture)"),
                },
            }
            let inner = p.nested(xml, "bsdf")?;
            p.finish(xml)?;
            let [b0, b1] = inner.as_slice() else {
                return xml.err(n, format!("blendbsdf needs two nested <bsdf>, it has {}", inner.len()));
            };
            for (b, key) in [(*b0, "first"), (*b1, "second")] {
                let part = format!("{}/{key}", d.name.get_ref());
                let Some(desc) = bsdf_desc(xml, b, part.clone(), one_sided, out)? else {
                    return xml.err(b, "blendbsdf cannot blend a 'null' BSDF");
                };
                out.desc.material.push(s(b, desc));
                let name = Some(s(b, part));
                if key == "first" {
                    d.first = name;
                } else {
                    d.second = name;
                }
            }
            return Ok(Some(d));
        }
        // Smooth or rough: the same coating and base.
        "roughplastic" | "plastic" => {
            if k == "roughplastic" {
                d.alpha = rough(&mut p, &mut d, false)?;
            }
            let int = p.ior(xml, "int_ior", 1.49)?;
            let ext = p.ior(xml, "ext_ior", 1.000277)?;
            if !(int > 0.0 && ext > 0.0) || int == ext {
                return xml.err(n, "'int_ior' and 'ext_ior' must be > 0 and differ");
            }
            d.ior = Some(s(n, int / ext));
            match p.texture(xml, "diffuse_reflectance")? {
                Some(t) => d.albedo_texture = Some(s(t, texture_desc(xml, t)?)),
                None => d.albedo = Some(unit(p.color(xml, "diffuse_reflectance")?, 0.5)),
            }
            d.specular = Some(unit(p.color(xml, "specular_reflectance")?, 1.0));
            d.nonlinear = Some(s(n, p.boolean(xml, "nonlinear")?.unwrap_or(false)));
            d.one_sided = Some(s(n, one_sided));
        }
        other => return xml.err(n, format!("bsdf '{other}' is not supported (diffuse, roughdiffuse, conductor, roughconductor, dielectric, thindielectric, roughdielectric, plastic, roughplastic, twosided, normalmap, bumpmap, mask, blendbsdf, null)")),
    }
    p.finish(xml)?;
    Ok(Some(d))
}

/// The name of a `<medium>` (converted once per element).
pub(super) fn medium(xml: &Xml, n: Node, out: &mut Out) -> Result<String> {
    if let Some(done) = out.media.get(&n.id()) {
        return Ok(done.clone());
    }
    if kind(xml, n)? != "homogeneous" {
        return xml.err(
            n,
            format!(
                "medium '{}' is not supported (homogeneous only)",
                kind(xml, n)?
            ),
        );
    }
    let name = match xml.attr(n, "id")? {
        Some(id) => id,
        None => format!("medium (line {})", xml.src.line(n.range().start)),
    };
    let mut p = xml.props(n)?;
    let sigma_t = p.color(xml, "sigma_t")?.map_or(Vec3::ONE, |(_, c)| c);
    let albedo = match p.color(xml, "albedo")? {
        Some((at, a)) if a.min_element() < 0.0 || a.max_element() > 1.0 => {
            return xml.err(at, format!("'albedo' must lie in [0, 1], got {a}"));
        }
        Some((_, a)) => a,
        None => Vec3::splat(0.75),
    };
    let scale = p.float(xml, "scale")?.map_or(1.0, |(_, v)| v);
    p.boolean(xml, "sample_emitters")?;
    let mut g = 0.0;
    for ph in p.nested(xml, "phase")? {
        let mut pp = xml.props(ph)?;
        g = match kind(xml, ph)?.as_str() {
            "isotropic" => 0.0,
            "hg" => pp.float(xml, "g")?.map_or(0.8, |(_, g)| g),
            other => {
                return xml.err(
                    ph,
                    format!("phase function '{other}' is not supported (isotropic, hg)"),
                );
            }
        };
        pp.finish(xml)?;
    }
    p.finish(xml)?;
    let sigma_t = sigma_t * scale;
    out.desc.medium.push(s(
        n,
        MediumDesc {
            name: s(n, name.clone()),
            sigma_a: s(n, ((Vec3::ONE - albedo) * sigma_t).to_array()),
            sigma_s: s(n, (albedo * sigma_t).to_array()),
            g: Some(s(n, g)),
        },
    ));
    out.media.insert(n.id(), name.clone());
    Ok(name)
}
