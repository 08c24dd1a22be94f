//! A plugin's properties as the Mitsuba reader takes them: each named property read once
//! (values, colours, textures, transforms, nested objects), and what is left unread an error.

use super::Xml;
use crate::error::Result;
use crate::math::cie::{SpectrumUse, spectrum_to_srgb, uniform_spectrum_to_srgb};
use glam::{Mat4, Vec3};
use roxmltree::Node;

/// A plugin's children: named properties (used at most once each) and nested objects.
pub(super) struct Props<'a, 'input> {
    pub(super) plugin: String,
    pub(super) items: Vec<Item<'a, 'input>>,
}

pub(super) struct Item<'a, 'input> {
    pub(super) node: Node<'a, 'input>,
    pub(super) name: Option<String>,
    pub(super) used: bool,
}

/// Mitsuba's named indices of refraction (its `ior.h`).
const NAMED_IOR: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.00004),
    ("hydrogen", 1.00013),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.47),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

impl<'a, 'input> Props<'a, 'input> {
    /// The property element called `name`, marked as used.
    pub(super) fn take(&mut self, name: &str) -> Option<Node<'a, 'input>> {
        let it = self
            .items
            .iter_mut()
            .find(|it| it.name.as_deref() == Some(name))?;
        it.used = true;
        Some(it.node)
    }

    /// Unnamed nested objects with tag `tag` (after `<ref>`s are resolved), marked as used.
    pub(super) fn nested(
        &mut self,
        xml: &Xml<'a, 'input>,
        tag: &str,
    ) -> Result<Vec<Node<'a, 'input>>> {
        let mut out = Vec::new();
        for it in &mut self.items {
            // Named children are properties (or named objects such as `interior`).
            if it.name.as_deref().is_some_and(|n| n != tag) {
                continue;
            }
            let target = xml.deref(it.node)?;
            if target.tag_name().name() == tag {
                it.used = true;
                out.push(target);
            }
        }
        Ok(out)
    }

    /// A named nested object (e.g. `<medium name="interior">` or `<ref name="interior">`).
    pub(super) fn named_object(
        &mut self,
        xml: &Xml<'a, 'input>,
        name: &str,
        tag: &str,
    ) -> Result<Option<Node<'a, 'input>>> {
        let Some(n) = self.take(name) else {
            return Ok(None);
        };
        let target = xml.deref(n)?;
        if target.tag_name().name() != tag {
            return xml.err(
                n,
                format!(
                    "{}: '{name}' must be a <{tag}>, got <{}>",
                    self.plugin,
                    target.tag_name().name()
                ),
            );
        }
        Ok(Some(target))
    }

    pub(super) fn value(
        &mut self,
        xml: &Xml,
        name: &str,
        tags: &[&str],
    ) -> Result<Option<(Node<'a, 'input>, String)>> {
        let Some(n) = self.take(name) else {
            return Ok(None);
        };
        let tag = n.tag_name().name();
        if !tags.contains(&tag) {
            return xml.err(
                n,
                format!(
                    "{}: '{name}' must be given as <{}>, got <{tag}>",
                    self.plugin,
                    tags.join("> or <")
                ),
            );
        }
        let v = match xml.attr(n, "value")? {
            Some(v) => v,
            None => return xml.err(n, format!("<{tag} name=\"{name}\"> needs a 'value'")),
        };
        Ok(Some((n, v)))
    }

    pub(super) fn float(
        &mut self,
        xml: &Xml,
        name: &str,
    ) -> Result<Option<(Node<'a, 'input>, f32)>> {
        match self.value(xml, name, &["float", "integer"])? {
            Some((n, v)) => Ok(Some((n, xml.number(n, &v)?))),
            None => Ok(None),
        }
    }

    pub(super) fn integer(
        &mut self,
        xml: &Xml,
        name: &str,
    ) -> Result<Option<(Node<'a, 'input>, i64)>> {
        match self.value(xml, name, &["integer"])? {
            Some((n, v)) => match v.trim().parse::<i64>() {
                Ok(i) => Ok(Some((n, i))),
                Err(_) => xml.err(n, format!("'{name}' must be an integer, got '{v}'")),
            },
            None => Ok(None),
        }
    }

    pub(super) fn boolean(&mut self, xml: &Xml, name: &str) -> Result<Option<bool>> {
        match self.value(xml, name, &["boolean"])? {
            Some((n, v)) => match v.trim() {
                "true" => Ok(Some(true)),
                "false" => Ok(Some(false)),
                _ => xml.err(n, format!("'{name}' must be true or false, got '{v}'")),
            },
            None => Ok(None),
        }
    }

    pub(super) fn string(
        &mut self,
        xml: &Xml,
        name: &str,
    ) -> Result<Option<(Node<'a, 'input>, String)>> {
        self.value(xml, name, &["string"])
    }

    /// A `<texture>` (nested, or a `<ref>` to one) given as property `name`, marked as used;
    /// `None` when the property is absent or not a texture.
    pub(super) fn texture(
        &mut self,
        xml: &Xml<'a, 'input>,
        name: &str,
    ) -> Result<Option<Node<'a, 'input>>> {
        let Some(it) = self
            .items
            .iter_mut()
            .find(|it| it.name.as_deref() == Some(name))
        else {
            return Ok(None);
        };
        if !matches!(it.node.tag_name().name(), "texture" | "ref") {
            return Ok(None);
        }
        let target = xml.deref(it.node)?;
        if target.tag_name().name() != "texture" {
            return Ok(None);
        }
        it.used = true;
        Ok(Some(target))
    }

    /// Every `<texture>` child (nested, or a `<ref>` to one) whatever its name, marked as
    /// used: for plugins that take their one texture by kind, not by name (`bumpmap`).
    pub(super) fn any_textures(&mut self, xml: &Xml<'a, 'input>) -> Result<Vec<Node<'a, 'input>>> {
        let mut out = Vec::new();
        for it in &mut self.items {
            if !matches!(it.node.tag_name().name(), "texture" | "ref") {
                continue;
            }
            let target = xml.deref(it.node)?;
            if target.tag_name().name() == "texture" {
                it.used = true;
                out.push(target);
            }
        }
        Ok(out)
    }

    /// An RGB value from `<rgb>` (one or three numbers), `<spectrum>` or `<float>` (one
    /// number: uniform).
    pub(super) fn color(
        &mut self,
        xml: &Xml,
        name: &str,
    ) -> Result<Option<(Node<'a, 'input>, Vec3)>> {
        if let Some(it) = self
            .items
            .iter()
            .find(|it| it.name.as_deref() == Some(name))
            && (it.node.tag_name().name() == "texture"
                || xml.deref(it.node)?.tag_name().name() == "texture")
        {
            return xml.err(it.node, format!("{}: '{name}' is a texture; lodestar reads textures for a diffuse BSDF's reflectance, a rough plastic's diffuse_reflectance and a conductor's specular_reflectance, and constant colours (rgb, spectrum or float) here", self.plugin));
        }
        let Some((n, v)) = self.value(xml, name, &["rgb", "spectrum", "float"])? else {
            return Ok(None);
        };
        let usage = if self.plugin.starts_with("emitter") {
            SpectrumUse::Emission
        } else {
            SpectrumUse::Reflectance
        };
        if n.tag_name().name() == "spectrum" && v.contains(':') {
            return Ok(Some((n, sampled_spectrum(xml, n, &v, usage)?)));
        }
        // Mitsuba 3: one value is a uniform spectrum, on an emitter the equal-energy white.
        if n.tag_name().name() == "spectrum"
            && let [x] = xml.numbers(n, &v)?.as_slice()
        {
            return Ok(Some((
                n,
                uniform_spectrum_to_srgb(*x as f64, usage).as_vec3(),
            )));
        }
        let c = match xml.numbers(n, &v)?.as_slice() {
            [s] => Vec3::splat(*s),
            [r, g, b] if n.tag_name().name() == "rgb" => Vec3::new(*r, *g, *b),
            // Mitsuba 0.x in RGB mode: a spectrum of three samples is red, green, blue.
            [r, g, b] if xml.before_2 => Vec3::new(*r, *g, *b),
            _ => {
                return xml.err(
                    n,
                    format!("'{name}' must be one number (or three for <rgb>), got '{v}'"),
                );
            }
        };
        Ok(Some((n, c)))
    }

    /// A `<point>` or `<vector>`.
    pub(super) fn point(
        &mut self,
        xml: &Xml,
        name: &str,
    ) -> Result<Option<(Node<'a, 'input>, Vec3)>> {
        let Some(n) = self.take(name) else {
            return Ok(None);
        };
        if !matches!(n.tag_name().name(), "point" | "vector") {
            return xml.err(
                n,
                format!("{}: '{name}' must be a <point> or <vector>", self.plugin),
            );
        }
        Ok(Some((n, xml.xyz(n, 0.0)?)))
    }

    /// The `to_world` transform, if given.
    pub(super) fn take_to_world(&mut self, xml: &Xml) -> Result<Option<(Node<'a, 'input>, Mat4)>> {
        let Some(n) = self.take("to_world") else {
            return Ok(None);
        };
        if n.tag_name().name() != "transform" {
            return xml.err(
                n,
                format!("{}: 'to_world' must be a <transform>", self.plugin),
            );
        }
        Ok(Some((n, xml.transform(n)?)))
    }

    /// An index of refraction: a number or one of Mitsuba's named media.
    pub(super) fn ior(&mut self, xml: &Xml, name: &str, default: f32) -> Result<f32> {
        let Some(n) = self.take(name) else {
            return Ok(default);
        };
        let v = xml.attr(n, "value")?.unwrap_or_default();
        match n.tag_name().name() {
            "float" => xml.number(n, &v),
            "string" => match NAMED_IOR.iter().find(|(k, _)| *k == v.to_lowercase()) {
                Some((_, ior)) => Ok(*ior),
                None => {
                    let names: Vec<&str> = NAMED_IOR.iter().map(|(k, _)| *k).collect();
                    xml.err(
                        n,
                        format!(
                            "unknown medium '{v}' for '{name}' (known: {})",
                            names.join(", ")
                        ),
                    )
                }
            },
            t => xml.err(
                n,
                format!("'{name}' must be a <float> or a <string>, got <{t}>"),
            ),
        }
    }

    /// Fail on the first child nothing read.
    pub(super) fn finish(&self, xml: &Xml) -> Result<()> {
        match self.items.iter().find(|it| !it.used) {
            None => Ok(()),
            Some(it) => {
                let tag = it.node.tag_name().name();
                let what = match &it.name {
                    Some(n) => format!("the property '{n}' (<{tag}>)"),
                    None => format!("a nested <{tag}>"),
                };
                xml.err(it.node, format!("{} does not take {what} (see `lodestar render --help` and the Mitsuba subset in src/scene/loader/mitsuba/mod.rs)", self.plugin))
            }
        }
    }
}

/// A `<spectrum>` given as `wavelength:value` pairs (nm, increasing; separated by commas or
/// spaces) in linear sRGB, as Mitsuba 3's RGB variants convert it ([`spectrum_to_srgb`]).
fn sampled_spectrum(xml: &Xml, n: Node, v: &str, usage: SpectrumUse) -> Result<Vec3> {
    let (mut wavelengths, mut values) = (Vec::new(), Vec::new());
    for pair in v
        .split([',', ' ', '\t', '\n', '\r'])
        .filter(|t| !t.is_empty())
    {
        let parsed = pair.split_once(':').and_then(|(w, x)| {
            Some((w.trim().parse::<f64>().ok()?, x.trim().parse::<f64>().ok()?))
        });
        let Some((w, x)) = parsed.filter(|(w, x)| w.is_finite() && x.is_finite()) else {
            return xml.err(
                n,
                format!("a sampled spectrum is 'wavelength:value' pairs, got '{pair}'"),
            );
        };
        if wavelengths.last().is_some_and(|&last| w <= last) {
            return xml.err(
                n,
                format!(
                    "a sampled spectrum's wavelengths must increase, got {w} after {}",
                    wavelengths.last().unwrap()
                ),
            );
        }
        wavelengths.push(w);
        values.push(x);
    }
    if wavelengths.len() < 2 {
        return xml.err(
            n,
            format!("a sampled spectrum needs at least two 'wavelength:value' pairs, got '{v}'"),
        );
    }
    Ok(spectrum_to_srgb(&wavelengths, &values, usage).as_vec3())
}
