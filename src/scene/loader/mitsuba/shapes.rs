//! Mitsuba's `<shape>` plugins: meshes, analytic shapes, their emitters, BSDFs and media,
//! and `shapegroup` / `instance` (drawn by the builder, `groups.rs`).

use super::super::{ShapeDesc, TransformDesc};
use super::Xml;
use super::materials::{bsdf, material_desc, medium, texture_desc};
use super::out::{Out, kind, s};
use crate::error::Result;
use glam::Mat4;
use roxmltree::Node;
use toml::Spanned;

/// Segments of the triangle fan standing for an analytic disk.
const DISK_SEGMENTS: u32 = 1024;

pub(super) fn shape_desc(n: Node, kind: &str) -> ShapeDesc {
    ShapeDesc {
        kind: s(n, kind.to_string()),
        name: None,
        material: None,
        emission: None,
        emission_texture: None,
        transform: None,
        origin: None,
        edge_u: None,
        edge_v: None,
        center: None,
        normal: None,
        radius: None,
        segments: None,
        file: None,
        size: None,
        grid: None,
        waves: None,
        tiles: None,
        tile_material: None,
        interior: None,
        exterior: None,
        cone_angle: None,
        cone_delta: None,
        normals: None,
        flip_normals: None,
        group: None,
        shape_index: None,
    }
}

pub(super) fn matrix_desc(at: Node, m: Mat4) -> Spanned<TransformDesc> {
    s(
        at,
        TransformDesc {
            matrix: Some(s(at, m.transpose().to_cols_array_2d())),
            scale: None,
            rotate: None,
            translate: None,
        },
    )
}

/// `<shape type="shapegroup" id>`: its shapes belong to the group, drawn where instances
/// place it (`groups.rs`).
pub(super) fn shapegroup(xml: &Xml, n: Node, out: &mut Out) -> Result<()> {
    let Some(id) = xml.attr(n, "id")? else {
        return xml.err(n, "a shapegroup needs an 'id' (its instances refer to it)");
    };
    let mut p = xml.props(n)?;
    let members = p.nested(xml, "shape")?;
    p.finish(xml)?;
    for m in members {
        match kind(xml, m)?.as_str() {
            "shapegroup" | "instance" => {
                return xml.err(
                    m,
                    "a shapegroup holds plain shapes (no nested groups or instances)",
                );
            }
            _ => shape(xml, m, out, Some(s(n, id.clone())))?,
        }
    }
    Ok(())
}

/// `<shape type="instance">`: a `<ref>` to a shapegroup, placed by `to_world`.
pub(super) fn instance(xml: &Xml, n: Node, out: &mut Out) -> Result<()> {
    let mut p = xml.props(n)?;
    let to_world = p.take_to_world(xml)?;
    let groups = p.nested(xml, "shape")?;
    p.finish(xml)?;
    let group = match groups.as_slice() {
        [g] if kind(xml, *g)? == "shapegroup" => *g,
        _ => return xml.err(n, "an instance needs one <ref id> to a shapegroup"),
    };
    let id = xml.attr(group, "id")?.unwrap_or_default();
    let mut d = shape_desc(n, "instance");
    d.name = xml.attr(n, "id")?;
    d.group = Some(s(n, id));
    if let Some((at, m)) = to_world {
        d.transform = Some(matrix_desc(at, m));
    }
    out.desc.shape.push(s(n, d));
    Ok(())
}

pub(super) fn shape(
    xml: &Xml,
    n: Node,
    out: &mut Out,
    group: Option<toml::Spanned<String>>,
) -> Result<()> {
    let k = kind(xml, n)?;
    let k = k.as_str();
    let mut p = xml.props(n)?;
    let to_world = p.take_to_world(xml)?;
    let flip = p.boolean(xml, "flip_normals")?.unwrap_or(false);
    let mut d = match k {
        "obj" | "ply" | "serialized" => {
            let mut d = shape_desc(n, k);
            d.file = match p.string(xml, "filename")? {
                Some((at, f)) => Some(s(at, xml.find_file(&f))),
                None => return xml.err(n, format!("shape '{k}' needs 'filename'")),
            };
            if k == "serialized"
                && let Some((at, i)) = p.integer(xml, "shape_index")?
            {
                d.shape_index = Some(s(at, i));
            }
            let faces = p.boolean(xml, "face_normals")?.unwrap_or(false);
            d.normals = Some(s(n, if faces { "faces" } else { "smooth" }.to_string()));
            // Texture coordinates are not used by lodestar.
            p.boolean(xml, "flip_tex_coords")?;
            d
        }
        "rectangle" => {
            let mut d = shape_desc(n, "quad");
            d.origin = Some(s(n, [-1.0, -1.0, 0.0]));
            d.edge_u = Some(s(n, [2.0, 0.0, 0.0]));
            d.edge_v = Some(s(n, [0.0, 2.0, 0.0]));
            d
        }
        "cube" => shape_desc(n, "cube"),
        "disk" => {
            let mut d = shape_desc(n, "disk");
            d.segments = Some(s(n, DISK_SEGMENTS));
            d
        }
        "sphere" => {
            let mut d = shape_desc(n, "sphere");
            if let Some((at, c)) = p.point(xml, "center")? {
                d.center = Some(s(at, c.to_array()));
            }
            if let Some((at, r)) = p.float(xml, "radius")? {
                d.radius = Some(s(at, r));
            }
            if flip {
                return xml.err(n, "'flip_normals' on a sphere is not supported (lodestar's spheres face outwards)");
            }
            d
        }
        other => {
            return xml.err(
                n,
                format!(
                    "shape '{other}' is not supported (obj, ply, serialized, rectangle, cube, disk, sphere)"
                ),
            );
        }
    };
    if flip {
        d.flip_normals = Some(s(n, true));
    }
    // The builder checks the matrix (affine, invertible, finite) at the same element.
    if let Some((at, m)) = to_world {
        d.transform = Some(matrix_desc(at, m));
    }
    d.name = xml.attr(n, "id")?;
    // Emitter.
    let emitters = p.nested(xml, "emitter")?;
    if emitters.len() > 1 {
        return xml.err(emitters[1], "a shape has at most one emitter");
    }
    if let Some(&e) = emitters.first() {
        if kind(xml, e)? != "area" {
            return xml.err(
                e,
                format!("emitter '{}' inside a shape (area only)", kind(xml, e)?),
            );
        }
        let mut ep = xml.props(e)?;
        if let Some(t) = ep.texture(xml, "radiance")? {
            d.emission_texture = Some(s(t, texture_desc(xml, t)?));
            d.emission = Some(s(t, [1.0; 3]));
        } else {
            let (at, radiance) = match ep.color(xml, "radiance")? {
                Some(r) => r,
                None => return xml.err(e, "the area emitter needs 'radiance'"),
            };
            d.emission = Some(s(at, radiance.to_array()));
        }
        ep.finish(xml)?;
    }
    // Media.
    for side in ["interior", "exterior"] {
        if let Some(m) = p.named_object(xml, side, "medium")? {
            let name = Some(s(m, medium(xml, m, out)?));
            if side == "interior" {
                d.interior = name;
            } else {
                d.exterior = name;
            }
        }
    }
    // BSDF: Mitsuba's default is a one-sided diffuse of reflectance 0.5, black on emitters.
    let bsdfs = p.nested(xml, "bsdf")?;
    if bsdfs.len() > 1 {
        return xml.err(bsdfs[1], "a shape has at most one bsdf");
    }
    p.finish(xml)?;
    let material = match bsdfs.first() {
        Some(&b) => match bsdf(xml, b, out)? {
            Some(name) => Some(s(b, name)),
            None if d.interior.is_none() && d.exterior.is_none() => {
                return xml.err(b, "a 'null' BSDF is an index-matched medium boundary in lodestar: give the shape an interior or exterior medium");
            }
            None if d.emission.is_some() => {
                return xml.err(b, "an emitter with a 'null' BSDF is not supported");
            }
            None => None,
        },
        None if d.emission.is_some() => None,
        None => {
            let name = out.default_bsdf.get_or_insert_with(|| {
                let name = "<mitsuba default diffuse>".to_string();
                let mut m = material_desc(n, name.clone(), "diffuse");
                m.albedo = Some(s(n, [0.5; 3]));
                m.one_sided = Some(s(n, true));
                out.desc.material.push(s(n, m));
                name
            });
            Some(s(n, name.clone()))
        }
    };
    d.material = material;
    d.group = group;
    out.desc.shape.push(s(n, d));
    Ok(())
}
