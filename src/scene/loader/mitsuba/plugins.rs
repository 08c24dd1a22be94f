//! Mitsuba plugins to the scene description: the scene element, sensor (camera, film,
//! sampler), integrator and emitters; shapes are in `shapes.rs`, BSDFs and media in
//! `materials.rs`. Each
//! function reads its plugin's properties through [`Props`], which makes any property it did
//! not read an error.

use super::super::{CameraDesc, FilterDesc, LightDesc, RenderDesc, SceneDesc};
use super::materials::{bsdf, medium, texture_desc};
use super::out::{Out, kind, s};
use super::shapes::{instance, matrix_desc, shape, shapegroup};
use super::{Props, SensorMedium, Xml, span};
use crate::error::Result;
use glam::{Mat4, Vec3};
use roxmltree::Node;
use std::collections::HashMap;
use toml::Spanned;

/// A scene description from the `<scene>` element, and the medium the sensor says the
/// camera is in (checked against the geometry once the scene is built).
pub(super) fn scene(xml: &Xml, root: Node) -> Result<(SceneDesc, Option<SensorMedium>)> {
    let mut out = Out {
        desc: SceneDesc {
            world_medium: None,
            camera: s(root, default_camera()),
            render: None,
            material: Vec::new(),
            medium: Vec::new(),
            shape: Vec::new(),
            light: Vec::new(),
        },
        bsdfs: HashMap::new(),
        media: HashMap::new(),
        default_bsdf: None,
        sensor_medium: None,
    };
    let mut sensor = None;
    let mut integrator = None;
    for n in root.children().filter(Node::is_element) {
        match n.tag_name().name() {
            "default" => {}
            "integrator" => {
                if integrator.replace(n).is_some() {
                    return xml.err(n, "a scene has at most one <integrator>");
                }
            }
            "sensor" => {
                if sensor.replace(n).is_some() {
                    return xml.err(n, "lodestar renders one <sensor> per scene; this is a second");
                }
            }
            "bsdf" => {
                bsdf(xml, n, &mut out)?;
            }
            "medium" => {
                medium(xml, n, &mut out)?;
            }
            "shape" => match kind(xml, n)?.as_str() {
                "shapegroup" => shapegroup(xml, n, &mut out)?,
                "instance" => instance(xml, n, &mut out)?,
                _ => shape(xml, n, &mut out, None)?,
            },
            // An area emitter declared at the top level and referenced from shapes by its id
            // (as Mitsuba 3's own Cornell box does) is read where a shape refers to it.
            "emitter" if kind(xml, n)? == "area" && referenced(xml, n)? => {}
            "emitter" => emitter(xml, n, &mut out)?,
            // Read where a BSDF refers to it (`materials.rs`), and checked there.
            "texture" => {}
            // Read before the plugins (`<path>`) or expanded before the document is read.
            "path" | "include" => {}
            other => return xml.err(n, format!("<{other}> is not supported at the top level of a scene (expected default, integrator, sensor, bsdf, medium, shape or emitter)")),
        }
    }
    let mut render = RenderDesc {
        max_depth: Some(s(root, -1)),
        spp: None,
        integrator: Some(s(root, "pt".to_string())),
    };
    if let Some(n) = integrator {
        integrator_plugin(xml, n, &mut render)?;
    }
    match sensor {
        Some(n) => sensor_plugin(xml, n, &mut out, &mut render)?,
        None => {
            return xml.err(
                root,
                "the scene has no <sensor> (lodestar needs a perspective camera)",
            );
        }
    }
    out.desc.render = Some(render);
    // The sensor's medium fills the world unless it is the inside of some shape (then the
    // geometry says where the camera is, and the loader checks that it agrees).
    if let Some((name, at)) = &out.sensor_medium {
        let inside_a_shape = out.desc.shape.iter().any(|sh| {
            sh.get_ref()
                .interior
                .as_ref()
                .is_some_and(|i| i.get_ref() == name)
        });
        if !inside_a_shape {
            out.desc.world_medium = Some(Spanned::new(at.clone(), name.clone()));
        }
    }
    Ok((out.desc, out.sensor_medium))
}

fn default_camera() -> CameraDesc {
    let v = |a: [f32; 3]| Spanned::new(0..0, a);
    CameraDesc {
        position: v([0.0; 3]),
        look_at: v([0.0, 0.0, 1.0]),
        up: None,
        fov: Spanned::new(0..0, 39.6),
        resolution: Spanned::new(0..0, [768, 576]),
        filter: Some(Spanned::new(0..0, mitsuba_default_filter(0..0))),
    }
}

/// Mitsuba's film filter when the scene gives none: a Gaussian of standard deviation 0.5.
fn mitsuba_default_filter(at: std::ops::Range<usize>) -> FilterDesc {
    FilterDesc {
        kind: Spanned::new(at, "gaussian".to_string()),
        radius: None,
        stddev: None,
    }
}

fn integrator_plugin(xml: &Xml, n: Node, render: &mut RenderDesc) -> Result<()> {
    let k = kind(xml, n)?;
    let name = match k.as_str() {
        "path" | "volpath" | "volpathmis" | "direct" => "pt",
        "ptracer" => "lt",
        other => {
            return xml.err(n, format!("integrator '{other}' is not supported (path, volpath and volpathmis become lodestar's pt, direct its pt with max_depth 2, ptracer its lt; pick others with --integrator)"));
        }
    };
    let mut p = xml.props(n)?;
    render.integrator = Some(s(n, name.to_string()));
    if k == "direct" {
        // Direct illumination: emitters seen directly and light scattered once.
        render.max_depth = Some(s(n, 2));
        // How many samples of each strategy change the noise, not the image.
        p.integer(xml, "emitter_samples")?;
        p.integer(xml, "bsdf_samples")?;
        p.integer(xml, "shading_samples")?;
        if p.boolean(xml, "hide_emitters")? == Some(true) {
            return xml.err(n, "'hide_emitters' = true is not supported");
        }
        return p.finish(xml);
    }
    if let Some((at, d)) = p.integer(xml, "max_depth")? {
        render.max_depth = Some(s(at, d));
    }
    // Russian roulette's start changes noise, not the expected image.
    p.integer(xml, "rr_depth")?;
    // Paths where the geometric and shading normals disagree about a side: lodestar's BSDFs
    // give them no value either way (`bsdf/mod.rs`), as Mitsuba's `strict_normals` does.
    p.boolean(xml, "strict_normals")?;
    if p.boolean(xml, "hide_emitters")? == Some(true) {
        return xml.err(n, "'hide_emitters' = true is not supported");
    }
    p.finish(xml)
}

fn sensor_plugin(xml: &Xml, n: Node, out: &mut Out, render: &mut RenderDesc) -> Result<()> {
    if kind(xml, n)? != "perspective" {
        return xml.err(
            n,
            format!(
                "sensor '{}' is not supported (perspective only)",
                kind(xml, n)?
            ),
        );
    }
    let mut p = xml.props(n)?;
    let focal = p.string(xml, "focal_length")?;
    let mut axis = p.string(xml, "fov_axis")?;
    let (fov_at, fov) = match (p.float(xml, "fov")?, focal) {
        (Some(_), Some((at, _))) => {
            return xml.err(at, "give either 'fov' or 'focal_length', not both");
        }
        (Some(f), None) => f,
        // Mitsuba's default: a 50 mm lens on 36 x 24 mm film, its field of view diagonal.
        (None, focal) => {
            let (at, text) = focal.unwrap_or((n, "50mm".to_string()));
            let mm = text.strip_suffix("mm").unwrap_or(&text).trim();
            let f: f32 = match mm.parse() {
                Ok(f) if f > 0.0 && f32::is_finite(f) => f,
                _ => {
                    return xml.err(
                        at,
                        format!("'focal_length' must be a length such as \"50mm\", got '{text}'"),
                    );
                }
            };
            axis = Some((at, "diagonal".to_string()));
            (
                at,
                2.0 * (36f32.hypot(24.0) / (2.0 * f)).atan().to_degrees(),
            )
        }
    };
    p.float(xml, "near_clip")?;
    p.float(xml, "far_clip")?;
    // A thin lens's focus; Mitsuba's pinhole accepts and ignores it (everything is in focus).
    p.float(xml, "focus_distance")?;
    let to_world = p.take_to_world(xml)?;
    // Film.
    let films = p.nested(xml, "film")?;
    let (mut w, mut h) = (768u32, 576u32);
    let mut res_at = n;
    let mut filter = None;
    if films.len() > 1 {
        return xml.err(films[1], "a sensor has one <film>");
    }
    if let Some(&f) = films.first() {
        let film = kind(xml, f)?;
        if film != "hdrfilm" && film != "ldrfilm" {
            return xml.err(
                f,
                format!("film '{film}' is not supported (hdrfilm, or ldrfilm read as hdrfilm)"),
            );
        }
        res_at = f;
        let mut fp = xml.props(f)?;
        for (key, v) in [("width", &mut w), ("height", &mut h)] {
            if let Some((at, x)) = fp.integer(xml, key)? {
                if !(1..=16384).contains(&x) {
                    return xml.err(at, format!("'{key}' must be in [1, 16384], got {x}"));
                }
                *v = x as u32;
            }
        }
        for key in ["pixel_format", "component_format", "file_format"] {
            fp.string(xml, key)?;
        }
        if film == "ldrfilm" {
            // Mitsuba 0.x's tone-mapped film: lodestar writes the linear image (EXR) and a
            // PNG only on request, so its tone mapping is read and left to the viewer.
            fp.string(xml, "tonemap_method")?;
            for key in ["gamma", "exposure", "key", "burn"] {
                fp.float(xml, key)?;
            }
            fp.boolean(xml, "high_quality_edges")?;
        }
        // Mitsuba 0.x's text stamped on the image: lodestar writes none.
        fp.boolean(xml, "banner")?;
        // Whether Mitsuba traces samples for the border beyond the image: lodestar's
        // camera samples always look as far as the filter reaches (`filter.rs`).
        fp.boolean(xml, "sample_border")?;
        let rfilters = fp.nested(xml, "rfilter")?;
        if rfilters.len() > 1 {
            return xml.err(rfilters[1], "a film has one <rfilter>");
        }
        if let Some(&r) = rfilters.first() {
            filter = Some(rfilter_plugin(xml, r)?);
        }
        fp.finish(xml)?;
    }
    // Sampler.
    for smp in p.nested(xml, "sampler")? {
        let k = kind(xml, smp)?;
        let k = k.as_str();
        const SAMPLERS: [&str; 8] = [
            "independent",
            "stratified",
            "multijitter",
            "orthogonal",
            "ldsampler",
            "sobol",
            "halton",
            "hammersley",
        ];
        if !SAMPLERS.contains(&k) {
            return xml.err(
                smp,
                format!(
                    "sampler '{k}' is not supported (expected one of {})",
                    SAMPLERS.join(", ")
                ),
            );
        }
        let mut sp = xml.props(smp)?;
        // How a sampler places its numbers changes the noise, not the image: lodestar reads
        // the sample count and draws its own numbers (`-O sampler=sobol` for stratified ones).
        for key in ["seed", "strength", "dimension", "scramble"] {
            sp.integer(xml, key)?;
        }
        sp.boolean(xml, "jitter")?;
        if let Some((at, c)) = sp.integer(xml, "sample_count")? {
            if !(1..=u32::MAX as i64).contains(&c) {
                return xml.err(at, format!("'sample_count' must be at least 1, got {c}"));
            }
            render.spp = Some(s(at, c as u32));
        }
        sp.finish(xml)?;
    }
    if render.spp.is_none() {
        render.spp = Some(s(n, 4));
    }
    // The medium the camera is in.
    let media = p.nested(xml, "medium")?;
    if let Some(&m) = media.first() {
        let name = medium(xml, m, out)?;
        out.sensor_medium = Some((name, span(m)));
    }
    p.finish(xml)?;

    // Camera frame: Mitsuba's camera looks along +z with +x to the left of the image.
    let (t_at, m) = to_world.unwrap_or((n, Mat4::IDENTITY));
    let position = m.transform_point3(Vec3::ZERO);
    let forward = m.transform_vector3(Vec3::Z);
    let up = m.transform_vector3(Vec3::Y);
    let left = m.transform_vector3(Vec3::X);
    let Some(forward) = forward.try_normalize() else {
        return xml.err(t_at, "the sensor's to_world is singular");
    };
    if left.dot(up.cross(forward)) <= 0.0 {
        return xml.err(t_at, "the sensor's to_world mirrors the image (a negative scale); lodestar's camera does not");
    }
    let tan = (fov.to_radians() / 2.0).tan();
    let (wf, hf) = (w as f32, h as f32);
    let axis_name = axis.as_ref().map_or("x", |(_, a)| a.as_str());
    let tan_y = match axis_name {
        "x" => tan * hf / wf,
        "y" => tan,
        "diagonal" => tan * hf / (wf * wf + hf * hf).sqrt(),
        "smaller" if w < h => tan * hf / wf,
        "larger" if w > h => tan * hf / wf,
        "smaller" | "larger" => tan,
        other => {
            return xml.err(
                axis.as_ref().unwrap().0,
                format!("'fov_axis' must be x, y, diagonal, smaller or larger, got '{other}'"),
            );
        }
    };
    out.desc.camera = s(
        n,
        CameraDesc {
            position: s(t_at, position.to_array()),
            look_at: s(t_at, (position + forward).to_array()),
            up: Some(s(t_at, up.to_array())),
            fov: s(fov_at, 2.0 * tan_y.atan().to_degrees()),
            resolution: s(res_at, [w, h]),
            filter: Some(s(
                res_at,
                filter.unwrap_or_else(|| mitsuba_default_filter(span(res_at))),
            )),
        },
    );
    Ok(())
}

/// `<rfilter type="box|tent|gaussian">` (`radius` for the tent, `stddev` for the Gaussian).
fn rfilter_plugin(xml: &Xml, r: Node) -> Result<FilterDesc> {
    let k = kind(xml, r)?;
    if !["box", "tent", "gaussian"].contains(&k.as_str()) {
        return xml.err(
            r,
            format!("rfilter '{k}' is not supported (box, tent or gaussian)"),
        );
    }
    let mut p = xml.props(r)?;
    let mut number = |key: &str| -> Result<Option<Spanned<f32>>> {
        Ok(p.float(xml, key)?.map(|(at, v)| s(at, v)))
    };
    let (radius, stddev) = match k.as_str() {
        "tent" => (number("radius")?, None),
        "gaussian" => (None, number("stddev")?),
        _ => (None, None),
    };
    p.finish(xml)?;
    Ok(FilterDesc {
        kind: s(r, k),
        radius,
        stddev,
    })
}

fn light_desc(n: Node, kind: &str) -> LightDesc {
    LightDesc {
        kind: s(n, kind.to_string()),
        position: None,
        intensity: None,
        radiance: None,
        irradiance: None,
        direction: None,
        cone_angle: None,
        cone_delta: None,
        cone_edge: None,
        angle: None,
        filename: None,
        scale: None,
        transform: None,
        texture: None,
        up: None,
    }
}

fn emitter(xml: &Xml, n: Node, out: &mut Out) -> Result<()> {
    let k = kind(xml, n)?;
    let k = k.as_str();
    let mut p = xml.props(n)?;
    let color = |p: &mut Props, key: &str| -> Result<Spanned<[f32; 3]>> {
        Ok(p.color(xml, key)?
            .map_or(s(n, [1.0; 3]), |(at, c)| s(at, c.to_array())))
    };
    let d = match k {
        "point" | "spot" => {
            let mut d = light_desc(n, k);
            d.intensity = Some(color(&mut p, "intensity")?);
            let position = p.point(xml, "position")?;
            let to_world = p.take_to_world(xml)?;
            let (at, m) = match (position, to_world) {
                (Some(_), Some((at, _))) => return xml.err(at, "give 'position' or 'to_world', not both"),
                (Some((at, pos)), None) => (at, Mat4::from_translation(pos)),
                (None, Some(t)) => t,
                (None, None) => (n, Mat4::IDENTITY),
            };
            d.position = Some(s(at, m.transform_point3(Vec3::ZERO).to_array()));
            if k == "spot" {
                let dir = m.transform_vector3(Vec3::Z);
                d.direction = Some(s(at, dir.to_array()));
                let (c_at, cutoff) = p.float(xml, "cutoff_angle")?.unwrap_or((n, 20.0));
                let (b_at, beam) = p.float(xml, "beam_width")?.unwrap_or((n, 0.75 * cutoff));
                if !(beam >= 0.0 && beam <= cutoff) {
                    return xml.err(b_at, format!("'beam_width' must be in [0, cutoff_angle = {cutoff}], got {beam}"));
                }
                d.cone_angle = Some(s(c_at, cutoff));
                d.cone_delta = Some(s(b_at, cutoff - beam));
                d.cone_edge = Some(s(n, "linear".to_string()));
                if let Some(t) = p.texture(xml, "texture")? {
                    // The image's axes are the transform's x and y: `up` x `direction` is x
                    // for a rotation.
                    d.texture = Some(s(t, texture_desc(xml, t)?));
                    d.up = Some(s(at, m.transform_vector3(Vec3::Y).to_array()));
                }
            }
            d
        }
        "directional" => {
            let mut d = light_desc(n, k);
            d.irradiance = Some(color(&mut p, "irradiance")?);
            let direction = p.point(xml, "direction")?;
            let to_world = p.take_to_world(xml)?;
            let (at, dir) = match (direction, to_world) {
                (Some(_), Some((at, _))) => return xml.err(at, "give 'direction' or 'to_world', not both"),
                (Some(v), None) => v,
                (None, Some((at, m))) => (at, m.transform_vector3(Vec3::Z)),
                (None, None) => (n, Vec3::Z),
            };
            d.direction = Some(s(at, dir.to_array()));
            d
        }
        "constant" => {
            let mut d = light_desc(n, "environment");
            d.radiance = Some(color(&mut p, "radiance")?);
            d
        }
        "envmap" => {
            let mut d = light_desc(n, k);
            d.filename = match p.string(xml, "filename")? {
                Some((at, f)) => Some(s(at, xml.find_file(&f))),
                None => return xml.err(n, "emitter 'envmap' needs 'filename'"),
            };
            if let Some((at, scale)) = p.float(xml, "scale")? {
                d.scale = Some(s(at, scale));
            }
            if let Some((at, m)) = p.take_to_world(xml)? {
                d.transform = Some(matrix_desc(at, m));
            }
            // Read (MIS compensation changes sampling, not the image; lodestar's is its own).
            p.boolean(xml, "mis_compensation")?;
            d
        }
        "area" => return xml.err(n, "an area emitter belongs inside a <shape> (or, with an id, is referenced from one by <ref id>)"),
        other => return xml.err(n, format!("emitter '{other}' is not supported (point, spot, directional, constant, envmap; area inside shapes)")),
    };
    p.finish(xml)?;
    out.desc.light.push(s(n, d));
    Ok(())
}

/// Whether some `<ref id>` in the document refers to element `n` by its id.
fn referenced(xml: &Xml, n: Node) -> Result<bool> {
    let Some(id) = xml.attr(n, "id")? else {
        return Ok(false);
    };
    for r in n.document().descendants().filter(|r| r.has_tag_name("ref")) {
        if xml.attr(r, "id")?.as_deref() == Some(id.as_str()) {
            return Ok(true);
        }
    }
    Ok(false)
}
