//! Mitsuba 3 XML scenes (`lodestar render scene.xml`): the subset that covers the usual research
//! scenes, read into the same scene description as the TOML format and built by the same
//! builder, so every check (and every error's `FILE:LINE:`) is shared.
//!
//! # The subset
//! * `<scene version="3.x">` with `<default name value>` parameters and `$name` substitution
//!   in any attribute, plugin types included (`-D name=value` on `render`, `info` and `bench`
//!   overrides a default); `id` and
//!   `<ref id>` (also `<ref name="interior" id>`) for BSDFs and media.
//! * `sensor` `perspective`: `fov`, `fov_axis` (x, y, diagonal, smaller, larger; default x)
//!   or `focal_length` ("50mm" by default, on 36 x 24 mm film, diagonal),
//!   `to_world`, `near_clip`/`far_clip` (read; lodestar does not clip), `focus_distance` (read,
//!   as the pinhole does), a nested or referenced
//!   medium (the medium the camera is in); `film` `hdrfilm` (or Mitsuba 0.x's `ldrfilm`, its
//!   tone mapping read and the linear image written) `width`/`height` (768 x 576) with
//!   `rfilter` `box`, `tent` (`radius` 1) or `gaussian` (`stddev` 0.5), the Gaussian when none
//!   is given (`filter.rs`), `pixel_format`/`component_format`/`file_format` (output only); `sampler`
//!   `independent`, `stratified`, `multijitter`, `orthogonal`, `ldsampler`, `sobol`, `halton`
//!   or `hammersley`: `sample_count` (4) becomes the default spp (`seed`, `jitter`,
//!   `strength`, `dimension`, `scramble` are read; lodestar draws its own numbers).
//! * Mitsuba 0.x scenes (`version` below 2.0.0) are upgraded as Mitsuba 3 upgrades them:
//!   property names from camelCase to snake_case (`maxDepth`, `intIOR`, `sampleCount`),
//!   `<lookAt>` read as `<lookat>`, the diffuse BSDF's `diffuse_reflectance` as
//!   `reflectance`, a `<spectrum>` of three values as RGB, textures' `uscale`, `vscale`,
//!   `uoffset`, `voffset` as `to_uv` and their "trilinear" or "ewa" filter as bilinear.
//! * `integrator` `direct` (lodestar `pt` with `max_depth` 2; `emitter_samples`,
//!   `bsdf_samples` read: they change noise, not the image),
//!   `path`, `volpath`, `volpathmis` (lodestar `pt`) and `ptracer` (`lt`):
//!   `max_depth` (-1, no limit), `rr_depth` (read: lodestar's roulette starts on its own
//!   schedule, which changes noise, not the image), `strict_normals` (read: lodestar's BSDFs
//!   are strict either way), `hide_emitters` false.
//! * BSDFs: `diffuse` (`reflectance` 0.5, or a texture), `roughdiffuse` (Mitsuba 0.6's Oren-Nayar:
//!   `reflectance` or `diffuse_reflectance` 0.5, `alpha` 0.2; `use_fast_approx` refused), `conductor` and `roughconductor` (`material`
//!   "none" with `specular_reflectance`, a named material such as "Au" (`conductors.rs`:
//!   Mitsuba's RGB values), or `eta` and `k`, both scaled by `specular_reflectance` (1, or a
//!   texture: `Bsdf::Tinted`);
//!   rough: `distribution` "beckmann"
//!   (Mitsuba's default) or "ggx", `alpha` 0.1 (a number or a texture) or `alpha_u` along
//!   the surface's `dp/du` and `alpha_v` (numbers; roughplastic takes `alpha` only),
//!   `sample_visible` read: both are sampled by visible normals), `dielectric`, `thindielectric` and `roughdielectric` (`int_ior` 1.5046 "bk7",
//!   `ext_ior` 1.000277 "air", numbers or Mitsuba's named media), `twosided` around one
//!   BSDF, `blendbsdf` (`weight` a number or a texture; two nested BSDFs without delta lobes,
//!   each a material of its own), and `null` on a medium boundary. `roughplastic`: `distribution` and `alpha` as
//!   above, `int_ior` 1.49 "polypropylene", `ext_ior` "air", `diffuse_reflectance` 0.5,
//!   `specular_reflectance` 1, `nonlinear` false (Mitsuba 3's model, `bsdf/rough_plastic.rs`);
//!   `plastic`, its smooth form, with the same properties but the roughness
//!   (`bsdf/plastic.rs`).
//!   Without `twosided`, diffuse, conductors and plastic are black from the back, as in
//!   Mitsuba. `normalmap` around one BSDF (its `normalmap` texture: `scene::perturbed_normal`),
//!   or `bumpmap` (its one texture, any name, a height; `scale` 1: `scene::bumped_normal`),
//!   with `flip_invalid_normals` and `use_shadowing_function` false (Mitsuba's defaults, true,
//!   make the BSDF depend on the viewer's side; refused). `mask` around one BSDF (not a
//!   mask): `opacity` a number (default 0.5) or a texture (its luminance), `bsdf/mask.rs`.
//! * Shapes `obj`, `ply`, `serialized` (`filename`, `face_normals`, `flip_normals`; serialized:
//!   `shape_index` 0, `serialized.rs`), `rectangle`, `cube`,
//!   `disk` (as a fan of 1024 triangles: 6e-6 less area than the disk), `sphere` (`center`,
//!   `radius`), each with `to_world`, a BSDF (default: `diffuse` 0.5, black for emitters), an
//!   `area` emitter (`radiance`, a colour or a texture: `light::AreaLight::texture`; nested, or a `<ref>` to one declared at the top level with
//!   an id) and `interior`/`exterior` media. A mesh without normals gets
//!   Mitsuba's angle-weighted vertex normals unless `face_normals` is true. `shapegroup`
//!   (its shapes, no emitters, no nesting) and `instance` (a `<ref>` to one, `to_world`):
//!   each placement becomes copies of the group's shapes (`groups.rs`).
//! * Emitters `point` (`intensity`, `position` or `to_world`), `spot` (`intensity`,
//!   `cutoff_angle` 20, `beam_width` 3/4 of it, Mitsuba's edge linear in the angle,
//!   `to_world`, a projected `texture` with u and v along the transform's x and y:
//!   `light::Projection`), `directional`
//!   (`irradiance`, `direction` or `to_world`), `constant` (`radiance`), `envmap`
//!   (`filename`, an OpenEXR image found like mesh files, `scale` 1, `to_world` a rotation;
//!   `mis_compensation` read: it changes sampling, not the image).
//! * Textures (for a `diffuse` BSDF's `reflectance`, a `roughplastic`'s
//!   `diffuse_reflectance`, a conductor's `specular_reflectance`, a `normalmap`'s
//!   `normalmap`, a `bumpmap`'s height, a `mask`'s `opacity` and the `alpha` of a
//!   `roughconductor` or `roughdielectric` (`bsdf::Alpha`), nested or by `<ref>` to a top-level
//!   `<texture id>`; `src/texture.rs`): `bitmap` (`filename`, found like mesh files; `raw`
//!   false; `filter_type` "bilinear" or "nearest"; `wrap_mode` "repeat", "mirror" or "clamp";
//!   `format` read) and `checkerboard` (`color0` 0.4, `color1` 0.2; for a number, an opacity
//!   or a roughness, its colours swapped as Mitsuba's `eval_1` has them), both with `to_uv`
//!   (its action on (u, v)). OBJ and PLY texture coordinates are flipped in v, as Mitsuba's
//!   `flip_tex_coords` default does.
//! * Media `homogeneous`: `sigma_t` (1), `albedo` (0.75), `scale` (1), `sample_emitters`,
//!   `phase` `isotropic` or `hg` (`g` 0.8).
//! * Values: `float`, `integer`, `boolean`, `string`, `rgb` (one or three numbers),
//!   `spectrum` (one number: uniform, or `wavelength:value` pairs: linear sRGB as Mitsuba's
//!   RGB variants make it, `math/cie.rs`), `point`, `vector` (`x`/`y`/`z` or `value`),
//!   `transform` with `translate`, `rotate`, `scale`, `matrix` (16 or 9 numbers) and `lookat`,
//!   applied in the order written.
//!
//! * `<include filename>` (its scene's contents in place of the element, recursively;
//!   `include.rs`) and `<path value>` (a directory searched first for mesh files).
//!
//! Anything else (another plugin, an unknown property, a texture elsewhere) is an error naming
//! the file, the line and the plugin: nothing is skipped.
//!
//! Files: this one reads the document (parameters, references, transforms); `props.rs` a
//! plugin's property values;
//! `plugins.rs` turns the scene, sensor, integrator and emitters into the scene description,
//! `shapes.rs` the shapes (groups and instances included), `materials.rs` the BSDFs and media.

mod conductors;
mod include;
mod materials;
mod out;
mod plugins;
mod props;
mod shapes;
mod transform;
mod upgrade;

pub(super) use include::{Origins, expand as expand_includes};

use super::{SceneDesc, Source};
use crate::error::{Error, Result};
use glam::Vec3;
use props::{Item, Props};
use roxmltree::{Document, Node};
use std::collections::{HashMap, HashSet};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Parse Mitsuba XML `src.text` into a scene description, and the medium the sensor is in
/// (name and position; see [`plugins::scene`]). `defines` override `<default>`s.
pub(super) fn parse(
    src: &Source,
    defines: &[(String, String)],
    dir: Option<&Path>,
) -> Result<(SceneDesc, Option<SensorMedium>)> {
    let doc = Document::parse(src.text).map_err(|e| {
        let pos = e.pos();
        Error::new(format!(
            "{}:{}: not well-formed XML: {e}",
            src.name, pos.row
        ))
    })?;
    let root = doc.root_element();
    let mut xml = Xml {
        src,
        params: defines.iter().cloned().collect(),
        ids: HashMap::new(),
        before_2: false,
        search: Vec::new(),
    };
    if root.tag_name().name() != "scene" {
        return xml.err(
            root,
            format!(
                "the root element must be <scene>, got <{}>",
                root.tag_name().name()
            ),
        );
    }
    if let Some(v) = root.attribute("version") {
        xml.before_2 = match upgrade::version(v) {
            Some((major, _, _)) => major < 2,
            None => {
                return xml.err(
                    root,
                    format!("version '{v}': expected three numbers separated by periods (3.0.0)"),
                );
            }
        };
    }
    // Parameters first (a default never overrides a command-line definition), then ids.
    for n in root.children().filter(Node::is_element) {
        if n.tag_name().name() == "default" {
            let (name, value) = (xml.raw(n, "name")?, xml.raw(n, "value")?);
            xml.params
                .entry(name.to_string())
                .or_insert(value.to_string());
        }
    }
    // Mitsuba searches the directories of `<path>` for files, the last given first, before
    // the scene's own directory.
    for n in root.children().filter(|n| n.has_tag_name("path")) {
        let value = xml.subst(n, xml.raw(n, "value")?)?;
        let p = PathBuf::from(&value);
        let p = dir.map_or_else(|| p.clone(), |d| d.join(&p));
        xml.search.insert(0, p);
    }
    for n in root.descendants().filter(Node::is_element) {
        if let (Some(id), false) = (n.attribute("id"), n.tag_name().name() == "ref") {
            let id = xml.subst(n, id)?;
            if let Some(prev) = xml.ids.insert(id.clone(), n) {
                return xml.err(
                    n,
                    format!(
                        "id '{id}' is used twice (first at line {})",
                        src.line(prev.range().start)
                    ),
                );
            }
        }
    }
    plugins::scene(&xml, root)
}

/// The medium a sensor says the camera is in: its name and where the sensor says so.
type SensorMedium = (String, Range<usize>);

/// The document being read: its source (for line numbers), parameters and ids.
struct Xml<'a, 'input> {
    src: &'a Source<'a>,
    params: HashMap<String, String>,
    ids: HashMap<String, Node<'a, 'input>>,
    /// A Mitsuba 0.x scene (`version` below 2.0.0), upgraded as it is read, as Mitsuba 3 does:
    /// property names from camelCase, `<lookAt>` as `<lookat>`, the diffuse BSDF's
    /// `diffuse_reflectance` as `reflectance`.
    before_2: bool,
    /// Directories `<path>` elements add, searched first (the last given first).
    search: Vec<PathBuf>,
}

impl<'a, 'input> Xml<'a, 'input> {
    fn err<T>(&self, node: Node, msg: impl std::fmt::Display) -> Result<T> {
        self.src.err(node.range(), msg)
    }

    /// An attribute as written (no substitution), required.
    fn raw<'n>(&self, node: Node<'n, 'input>, key: &str) -> Result<&'n str> {
        match node.attribute(key) {
            Some(v) => Ok(v),
            None => self.err(
                node,
                format!("<{}> needs the attribute '{key}'", node.tag_name().name()),
            ),
        }
    }

    /// `$name` parameters replaced by their values.
    fn subst(&self, node: Node, value: &str) -> Result<String> {
        let mut out = String::with_capacity(value.len());
        let mut rest = value;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let name = &after[..len];
            match self.params.get(name) {
                Some(v) if !name.is_empty() => out.push_str(v),
                _ => {
                    return self.err(
                        node,
                        format!(
                            "'${name}' is not defined (add <default name=\"{name}\" value=\"...\"/> or pass -D {name}=...)"
                        ),
                    );
                }
            }
            rest = &after[len..];
        }
        out.push_str(rest);
        Ok(out)
    }

    /// A file name as the scene writes it, found where Mitsuba would: in the `<path>`
    /// directories (the last given first), else relative to the scene's directory.
    fn find_file(&self, name: &str) -> String {
        self.search
            .iter()
            .map(|d| d.join(name))
            .find(|p| p.exists())
            // Absolute, so that the loaders do not resolve it against the scene's directory
            // once more (the search directories already include it when it is relative).
            .and_then(|p| std::path::absolute(p).ok())
            .map_or_else(|| name.to_string(), |p| p.display().to_string())
    }

    /// An attribute with parameters substituted.
    fn attr(&self, node: Node, key: &str) -> Result<Option<String>> {
        node.attribute(key).map(|v| self.subst(node, v)).transpose()
    }

    /// The element `<ref id>` points to, or `node` itself.
    fn deref(&self, node: Node<'a, 'input>) -> Result<Node<'a, 'input>> {
        if node.tag_name().name() != "ref" {
            return Ok(node);
        }
        let id = self.subst(node, self.raw(node, "id")?)?;
        match self.ids.get(&id) {
            Some(n) => Ok(*n),
            None => self.err(
                node,
                format!("<ref id=\"{id}\"> refers to no element with that id"),
            ),
        }
    }

    /// The properties and nested objects of a plugin element.
    fn props(&self, node: Node<'a, 'input>) -> Result<Props<'a, 'input>> {
        let kind = match node.attribute("type") {
            Some(t) => self.subst(node, t)?,
            None => "?".to_string(),
        };
        let plugin = format!("{} '{kind}'", node.tag_name().name());
        let diffuse = node.tag_name().name() == "bsdf" && kind == "diffuse";
        let mut items = Vec::new();
        for c in node.children().filter(Node::is_element) {
            let mut name = self.attr(c, "name")?;
            if self.before_2
                && let Some(n) = &mut name
            {
                *n = upgrade::snake_case(n);
                if diffuse && n == "diffuse_reflectance" {
                    *n = "reflectance".to_string();
                }
            }
            items.push(Item {
                node: c,
                name,
                used: false,
            });
        }
        let mut seen = HashSet::new();
        for it in &items {
            if let Some(n) = &it.name
                && !seen.insert(n.clone())
            {
                return self.err(it.node, format!("{plugin}: property '{n}' is given twice"));
            }
        }
        Ok(Props { plugin, items })
    }

    /// Numbers separated by commas and/or spaces.
    fn numbers(&self, node: Node, text: &str) -> Result<Vec<f32>> {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|w| !w.is_empty())
            .map(|w| match w.parse::<f32>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => self.err(node, format!("'{w}' is not a finite number")),
            })
            .collect()
    }

    /// A `value` attribute, or `x`, `y`, `z` attributes (each defaulting to `default`).
    fn xyz(&self, node: Node, default: f32) -> Result<Vec3> {
        if let Some(v) = self.attr(node, "value")? {
            let n = self.numbers(node, &v)?;
            return match n.as_slice() {
                [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
                [s] => Ok(Vec3::splat(*s)),
                _ => self.err(
                    node,
                    format!("'value' must be one or three numbers, got '{v}'"),
                ),
            };
        }
        let mut out = Vec3::splat(default);
        for (k, key) in ["x", "y", "z"].iter().enumerate() {
            if let Some(v) = self.attr(node, key)? {
                out[k] = self.number(node, &v)?;
            }
        }
        Ok(out)
    }

    fn number(&self, node: Node, text: &str) -> Result<f32> {
        match self.numbers(node, text)?.as_slice() {
            [v] => Ok(*v),
            _ => self.err(node, format!("expected one number, got '{text}'")),
        }
    }
}

/// A byte range for `Spanned` values: the element's.
fn span(node: Node) -> Range<usize> {
    node.range()
}
