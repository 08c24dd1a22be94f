//! Mitsuba 3 XML scenes: the Cornell box family written in XML renders the same image as the
//! TOML scenes (tile by tile), and parameters (in plugin types too), Mitsuba 0.x scenes,
//! references, transforms, one-sided BSDFs, the microfacet distributions, PLY and OBJ meshes
//! and the error messages (file, line and plugin) each have a case.

use crate::util;

use glam::Vec3;
use lodestar::bsdf::{Alpha, Bsdf, Distribution};
use lodestar::geometry::bvh::ShapeGeometry;
use lodestar::scene::Scene;
use lodestar::scene::loader::{load_file, load_file_with, load_mitsuba_str};
use std::path::{Path, PathBuf};
use util::{assert_same_image, differs, seeded_renders};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn xml(text: &str) -> lodestar::error::Result<Scene> {
    load_mitsuba_str(text, "test.xml", None, &[])
}

fn xml_err(text: &str) -> String {
    match xml(text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// A scene around `body` with a 16 x 16 camera at z = 4 looking at the origin.
fn wrap(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/><rfilter type="box"/></film>
    </sensor>
{body}
</scene>"#
    )
}

fn mesh_positions(scene: &Scene, shape: usize) -> Vec<Vec3> {
    match &scene.shapes[shape] {
        ShapeGeometry::Mesh(m) => m
            .indices
            .iter()
            .flatten()
            .map(|&i| m.positions[i as usize])
            .collect(),
        ShapeGeometry::Sphere(_) => panic!("not a mesh"),
    }
}

/// Every scene of the family, in XML at 32 x 32 (through `-D res=32`) against the TOML file at
/// 32 x 32: four seeds a side, 8 x 8 tiles, Welch's t per tile and channel at a family-wise
/// false-failure rate of 1e-4 (see `util::assert_same_image`). The TOML renders use seeds
/// 100.. so the two sides are independent. Controls: the XML box with its light turned to face
/// up, and a left-right mirror of the XML renders, both fail the same comparison.
#[test]
fn cornell_family_in_xml_renders_the_toml_image() {
    let defines = [("res".to_string(), "32".to_string())];
    for name in ["cornell-box", "cornell-glossy", "cornell-fog"] {
        let path = root().join(format!("scenes/mitsuba/{name}.xml"));
        let from_xml = load_file_with(&path, &defines).unwrap();
        let text = std::fs::read_to_string(root().join(format!("scenes/{name}.toml"))).unwrap();
        let from_toml =
            util::scene(&text.replace("resolution = [256, 256]", "resolution = [32, 32]"));
        assert_eq!(from_xml.camera.resolution, from_toml.camera.resolution);
        assert!((from_xml.camera.fov_y_degrees - from_toml.camera.fov_y_degrees).abs() < 1e-4);
        assert_eq!(from_xml.render.max_depth, 8);
        assert_eq!(from_xml.render.spp, 64);
        let a = seeded_renders(&from_xml, "pt", 8, &[], 64, 4, 0);
        let b = seeded_renders(&from_toml, "pt", 8, &[], 64, 4, 100);
        assert_same_image(&a, &b, 8, name);
        if name == "cornell-box" {
            let mirrored: Vec<_> = a.iter().map(util::mirrored).collect();
            assert!(differs(&mirrored, &b, 8), "mirror control passed");
            let text = std::fs::read_to_string(&path).unwrap();
            let up = text.replace(
                "<rotate x=\"1\" angle=\"90\"/>\n            <translate y=\"0.99\"/>",
                "<rotate x=\"1\" angle=\"-90\"/>\n            <translate y=\"0.99\"/>",
            );
            assert_ne!(up, text);
            let turned = load_mitsuba_str(&up, "up.xml", None, &defines).unwrap();
            let c = seeded_renders(&turned, "pt", 8, &[], 64, 4, 0);
            assert!(differs(&c, &b, 8), "turned-light control passed");
        }
    }
}

#[test]
fn parameters_take_defaults_and_command_line_definitions() {
    let text = wrap(
        r#"<default name="r" value="0.25"/>
    <shape type="sphere"><float name="radius" value="$r"/></shape>"#,
    );
    let radius = |s: &Scene| match &s.shapes[0] {
        ShapeGeometry::Sphere(sp) => sp.radius,
        _ => panic!(),
    };
    assert_eq!(radius(&xml(&text).unwrap()), 0.25);
    let d = [("r".to_string(), "2".to_string())];
    assert_eq!(
        radius(&load_mitsuba_str(&text, "t.xml", None, &d).unwrap()),
        2.0
    );
    let e = xml_err(&wrap(
        r#"
    <shape type="sphere"><float name="radius" value="$missing"/></shape>"#,
    ));
    assert!(
        e.starts_with("test.xml:8:") && e.contains("$missing"),
        "{e}"
    );
}

#[test]
fn refs_share_one_material_and_name_media() {
    let s = xml(&wrap(
        r#"<bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.2"/></bsdf>
    <medium type="homogeneous" id="fog"><float name="sigma_t" value="2"/><float name="albedo" value="0.5"/></medium>
    <shape type="cube"><ref id="grey"/></shape>
    <shape type="sphere"><ref id="grey"/></shape>
    <shape type="rectangle"><bsdf type="null"/><ref name="interior" id="fog"/></shape>"#,
    ))
    .unwrap();
    assert_eq!(s.shape_info[0].material, s.shape_info[1].material);
    assert_eq!(s.materials[s.shape_info[0].material as usize].name, "grey");
    assert!(s.shape_info[2].null);
    assert_eq!(s.media.len(), 1);
    let m = &s.media[0];
    assert_eq!(m.name, "fog");
    let e = xml_err(&wrap(
        r#"
    <shape type="cube"><ref id="nothing"/></shape>"#,
    ));
    assert!(e.starts_with("test.xml:8:") && e.contains("nothing"), "{e}");
}

/// Each transform operation against the same geometry written with another one.
#[test]
fn transforms_compose_in_the_order_written() {
    let rect = |ops: &str| {
        let s = xml(&wrap(&format!(
            r#"<shape type="rectangle"><transform name="to_world">{ops}</transform></shape>"#
        )))
        .unwrap();
        mesh_positions(&s, 0)
    };
    let close = |a: &[Vec3], b: &[Vec3]| a.iter().zip(b).all(|(p, q)| (*p - *q).length() < 1e-5);
    // scale, then rotate 90 degrees about +y, then translate.
    let ops =
        rect(r#"<scale x="2" y="3"/><rotate y="1" angle="90"/><translate x="1" y="-1" z="0.5"/>"#);
    let expected: Vec<Vec3> = rect("")
        .iter()
        .map(|p| {
            let s = Vec3::new(2.0 * p.x, 3.0 * p.y, p.z);
            Vec3::new(s.z, s.y, -s.x) + Vec3::new(1.0, -1.0, 0.5)
        })
        .collect();
    assert!(close(&ops, &expected), "{ops:?} vs {expected:?}");
    // The same as one matrix (row by row), and translate-then-scale differs.
    let m = rect(r#"<matrix value="0 0 1 1  0 3 0 -1  -2 0 0 0.5  0 0 0 1"/>"#);
    assert!(close(&m, &expected));
    let swapped = rect(r#"<translate x="1"/><scale x="2"/>"#);
    let scaled_first = rect(r#"<scale x="2"/><translate x="1"/>"#);
    assert!(!close(&swapped, &scaled_first));
    // lookat: the rectangle's normal (+z) turned towards the target.
    let s = xml(&wrap(
        r#"<shape type="rectangle"><transform name="to_world"><lookat origin="0, 0, 0" target="1, 0, 0" up="0, 1, 0"/></transform></shape>"#,
    ))
    .unwrap();
    let ShapeGeometry::Mesh(m) = &s.shapes[0] else {
        panic!()
    };
    assert!((m.geometric_normal(0) - Vec3::X).length() < 1e-5);
    // A projective matrix is refused at its line.
    let e = xml_err(&wrap(
        r#"
    <shape type="cube"><transform name="to_world"><matrix value="1 0 0 0 0 1 0 0 0 0 1 0 1 0 0 1"/></transform></shape>"#,
    ));
    assert!(
        e.starts_with("test.xml:8:") && e.contains("projective"),
        "{e}"
    );
}

/// `fov_axis` on a 2:1 film: the vertical field of view lodestar's camera gets.
#[test]
fn fov_axis_converts_to_the_vertical_field_of_view() {
    let fov_y = |axis: &str| {
        let text = wrap("").replace(
            r#"<float name="fov" value="40"/>"#,
            &format!(r#"<float name="fov" value="40"/><string name="fov_axis" value="{axis}"/>"#),
        );
        let text = text.replace(
            r#"<integer name="width" value="16"/>"#,
            r#"<integer name="width" value="32"/>"#,
        );
        xml(&text).unwrap().camera.fov_y_degrees
    };
    let half = |deg: f32| (deg.to_radians() / 2.0).tan();
    let y_of = |t: f32| 2.0 * t.atan().to_degrees();
    assert!((fov_y("y") - 40.0).abs() < 1e-4);
    assert!((fov_y("x") - y_of(half(40.0) / 2.0)).abs() < 1e-4);
    assert!((fov_y("smaller") - 40.0).abs() < 1e-4);
    assert!((fov_y("larger") - fov_y("x")).abs() < 1e-4);
    assert!((fov_y("diagonal") - y_of(half(40.0) / 5f32.sqrt())).abs() < 1e-4);
}

/// Without `fov`, Mitsuba's lens: `focal_length` (default 50 mm) on 36 x 24 mm film gives a
/// diagonal field of view; both given is an error naming the line.
#[test]
fn focal_length_gives_mitsubas_diagonal_field_of_view() {
    let fov_y = |lens: &str| {
        let text = wrap("").replace(r#"<float name="fov" value="40"/>"#, lens);
        xml(&text.replace(
            r#"<integer name="width" value="16"/>"#,
            r#"<integer name="width" value="32"/>"#,
        ))
        .map(|s| s.camera.fov_y_degrees)
    };
    let diagonal = |f: f32| 2.0 * (36f32.hypot(24.0) / (2.0 * f)).atan();
    // On a 2:1 film the vertical extent is 1 / sqrt(5) of the diagonal.
    let y = |f: f32| {
        2.0 * ((diagonal(f) / 2.0).tan() / 5f32.sqrt())
            .atan()
            .to_degrees()
    };
    assert!((fov_y("").unwrap() - y(50.0)).abs() < 1e-4);
    let f35 = fov_y(r#"<string name="focal_length" value="35mm"/>"#).unwrap();
    assert!((f35 - y(35.0)).abs() < 1e-4);
    let e = fov_y(r#"<float name="fov" value="40"/><string name="focal_length" value="35mm"/>"#)
        .unwrap_err()
        .to_string();
    assert!(e.contains("test.xml:3") && e.contains("not both"), "{e}");
    let e = fov_y(r#"<string name="focal_length" value="wide"/>"#)
        .unwrap_err()
        .to_string();
    assert!(e.contains("'focal_length' must be a length"), "{e}");
}

/// An area emitter declared at the top level with an id and referenced from a shape (as in
/// Mitsuba 3's own `cbox-rgb.xml`) makes that shape emit; one no shape refers to is an error
/// naming its line.
#[test]
fn top_level_area_emitters_are_read_where_shapes_refer_to_them() {
    let body = r#"<emitter type="area" id="lamp"><rgb name="radiance" value="2, 3, 4"/></emitter>
    <shape type="rectangle"><ref id="lamp"/></shape>"#;
    let scene = xml(&wrap(body)).unwrap();
    assert_eq!(scene.lights.len(), 1);
    let unused = xml_err(&wrap(&body.replace(r#"<ref id="lamp"/>"#, "")));
    assert!(
        unused.contains("test.xml:7") && unused.contains("belongs inside a <shape>"),
        "{unused}"
    );
}

/// Mitsuba's `direct` integrator is direct illumination: lodestar's pt with two segments.
#[test]
fn the_direct_integrator_is_pt_with_two_segments() {
    let text = wrap(
        r#"<integrator type="direct"><integer name="emitter_samples" value="4"/></integrator>"#,
    );
    let scene = xml(&text).unwrap();
    assert_eq!(scene.render.integrator, "pt");
    assert_eq!(scene.render.max_depth, 2);
}

/// A diffuse rectangle seen from its back: black unless wrapped in `twosided` (Mitsuba's rule;
/// lodestar's TOML materials are two-sided).
#[test]
fn bsdfs_without_twosided_are_black_from_the_back() {
    let mean = |bsdf: &str| {
        let s = xml(&wrap(&format!(
            r#"<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
    <shape type="rectangle"><transform name="to_world"><scale value="5"/><rotate y="1" angle="180"/></transform>{bsdf}</shape>"#
        )))
        .unwrap();
        let img = util::render(&s, "pt", 4, &[], 4, 0, 2).image;
        img.pixels.iter().map(|p| p.x as f64).sum::<f64>() / img.pixels.len() as f64
    };
    let one = r#"<bsdf type="diffuse"/>"#;
    let two = r#"<bsdf type="twosided"><bsdf type="diffuse"/></bsdf>"#;
    assert_eq!(mean(one), 0.0);
    // The rectangle fills the view with its back, which faces an unoccluded sky of radiance 1:
    // a two-sided diffuse of albedo 0.5 reflects exactly 0.5. The image mean's standard
    // deviation over seeds is 0.0026 (measured over seeds 0..5), so the 0.05 allowance (fixed
    // seed) is about 19 of them: it fails only for a wrong answer, such as a black back (0).
    let m = mean(two);
    assert!((m - 0.5).abs() < 0.05, "{m}");
    // No BSDF: Mitsuba's default diffuse, one-sided.
    assert_eq!(mean(""), 0.0);
}

/// A quad as ASCII PLY, little- and big-endian binary PLY and OBJ: the same triangles.
#[test]
fn ply_and_obj_meshes_load_the_same_geometry() {
    let dir = std::env::temp_dir().join(format!("lodestar-ply-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let v = [
        [-1.0f32, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ];
    let header = |fmt: &str| {
        format!(
            "ply\nformat {fmt} 1.0\ncomment a quad\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    let mut ascii = header("ascii");
    for p in &v {
        ascii += &format!("{} {} {} 255\n", p[0], p[1], p[2]);
    }
    ascii += "4 0 1 2 3\n";
    std::fs::write(dir.join("a.ply"), ascii).unwrap();
    for (name, big) in [("le.ply", false), ("be.ply", true)] {
        let mut b = header(if big {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        })
        .into_bytes();
        for p in &v {
            for x in p {
                b.extend(if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                });
            }
            b.push(255);
        }
        b.push(4);
        for i in 0..4i32 {
            b.extend(if big {
                i.to_be_bytes()
            } else {
                i.to_le_bytes()
            });
        }
        std::fs::write(dir.join(name), b).unwrap();
    }
    std::fs::write(
        dir.join("q.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n",
    )
    .unwrap();
    let load = |file: &str, kind: &str| {
        let text = wrap(&format!(
            r#"<shape type="{kind}"><string name="filename" value="{file}"/><boolean name="face_normals" value="true"/></shape>"#
        ));
        load_mitsuba_str(&text, "t.xml", Some(&dir), &[]).unwrap()
    };
    let reference = mesh_positions(&load("a.ply", "ply"), 0);
    assert_eq!(reference.len(), 6);
    for (file, kind) in [("le.ply", "ply"), ("be.ply", "ply"), ("q.obj", "obj")] {
        let s = load(file, kind);
        let mut p = mesh_positions(&s, 0);
        let mut r = reference.clone();
        let key = |a: &Vec3| (a.x.to_bits(), a.y.to_bits(), a.z.to_bits());
        p.sort_by_key(key);
        r.sort_by_key(key);
        assert_eq!(p, r, "{file}");
    }
    // Without face_normals a mesh with no normals in the file gets smooth vertex normals.
    let text = wrap(r#"<shape type="obj"><string name="filename" value="q.obj"/></shape>"#);
    let s = load_mitsuba_str(&text, "t.xml", Some(&dir), &[]).unwrap();
    let ShapeGeometry::Mesh(m) = &s.shapes[0] else {
        panic!()
    };
    assert!(
        m.normals
            .as_ref()
            .unwrap()
            .iter()
            .all(|n| (*n - Vec3::Z).length() < 1e-6)
    );
    // A truncated binary file is an error naming the file.
    let b = std::fs::read(dir.join("le.ply")).unwrap();
    std::fs::write(dir.join("cut.ply"), &b[..b.len() - 3]).unwrap();
    let text = wrap(
        r#"
    <shape type="ply"><string name="filename" value="cut.ply"/></shape>"#,
    );
    let e = load_mitsuba_str(&text, "t.xml", Some(&dir), &[])
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with("t.xml:8:") && e.contains("cut.ply") && e.contains("ends"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Bad input: each error names the file, the line and what was expected.
#[test]
fn errors_name_the_line_and_the_plugin() {
    let cases: &[(&str, &str)] = &[
        (
            r#"<shape type="cube"><bsdf type="hair"/></shape>"#,
            "bsdf 'hair' is not supported",
        ),
        (
            r#"<shape type="cube"><bsdf type="diffuse"><float name="roughness" value="1"/></bsdf></shape>"#,
            "does not take the property 'roughness'",
        ),
        (
            r#"<shape type="cube"><bsdf type="roughconductor"><string name="distribution" value="phong"/></bsdf></shape>"#,
            "distribution 'phong' is not supported",
        ),
        (
            r#"<shape type="cube"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"/></bsdf></shape>"#,
            "texture",
        ),
        (
            r#"<shape type="cube"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.1, 700"/></bsdf></shape>"#,
            "'wavelength:value' pairs, got '700'",
        ),
        (
            r#"<shape type="cube"><bsdf type="diffuse"><spectrum name="reflectance" value="500:0.1, 400:0.5"/></bsdf></shape>"#,
            "wavelengths must increase",
        ),
        (
            r#"<shape type="cube"><bsdf type="roughconductor"><texture type="checkerboard" name="eta"/></bsdf></shape>"#,
            "'eta' is a texture",
        ),
        (
            r#"<shape type="serialized"/>"#,
            "shape 'serialized' needs 'filename'",
        ),
        (
            r#"<shape type="obj"><string name="filename" value="no-such.obj"/></shape>"#,
            "cannot load mesh",
        ),
        (
            r#"<emitter type="projector"/>"#,
            "emitter 'projector' is not supported",
        ),
        (
            r#"<emitter type="envmap"/>"#,
            "emitter 'envmap' needs 'filename'",
        ),
        (
            r#"<emitter type="spot"><float name="cutoff_angle" value="30"/><float name="beam_width" value="40"/></emitter>"#,
            "beam_width",
        ),
        (
            r#"<shape type="cube"><bsdf type="diffuse"><rgb name="reflectance" value="0.5, x, 1"/></bsdf></shape>"#,
            "'x' is not a finite number",
        ),
        (
            r#"<include filename="no-such-file.xml"/>"#,
            "cannot read included file",
        ),
        (
            r#"<shape type="shapegroup"/>"#,
            "a shapegroup needs an 'id'",
        ),
        (
            r#"<shape type="cube"><bsdf type="null"/></shape>"#,
            "index-matched",
        ),
        (
            r#"<shape type="cube"><transform name="to_world"><scale value="0"/></transform></shape>"#,
            "'matrix' must be an affine, invertible matrix",
        ),
    ];
    for (body, needle) in cases {
        let e = xml_err(&wrap(&format!("\n    {body}")));
        assert!(e.starts_with("test.xml:8:"), "{body}: {e}");
        assert!(e.contains(needle), "{body}: {e}");
    }
    // Malformed XML: the line of the fault.
    let e = xml_err("<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n</scene>");
    assert!(
        e.starts_with("test.xml:3:") && e.contains("not well-formed"),
        "{e}"
    );
    // The medium the sensor claims must be the one the geometry puts it in.
    let e = xml_err(&wrap(r#"<medium type="homogeneous" id="fog"/>
    <shape type="sphere"><float name="radius" value="0.5"/><bsdf type="null"/><ref name="interior" id="fog"/></shape>"#).replace(
        r#"<film type="hdrfilm">"#,
        r#"<ref id="fog"/><film type="hdrfilm">"#,
    ));
    assert!(
        e.contains("the sensor is said to be in medium 'fog'"),
        "{e}"
    );
    // Through the CLI entry point: the file's name.
    let e = load_file(Path::new("/nonexistent/scene.xml"))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("/nonexistent/scene.xml"), "{e}");
}

/// The command line: `render scene.xml -D name=value` (and `info`), and its errors.
#[test]
fn cli_renders_xml_with_definitions() {
    let dir = std::env::temp_dir().join(format!("lodestar-xml-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_lodestar"))
            .args(args)
            .output()
            .unwrap()
    };
    let scene = root().join("scenes/mitsuba/cornell-box.xml");
    let scene = scene.to_str().unwrap();
    let out = dir.join("x.exr");
    let root_toml = root().join("scenes/cornell-box.toml").display().to_string();
    let o = run(&[
        "render",
        scene,
        "-D",
        "res=8",
        "-D",
        "spp=2",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (img, _) = lodestar::film::Image::read_exr(&out).unwrap();
    assert_eq!((img.width, img.height), (8, 8));
    // `bench` takes definitions too: without them the scene is 256 x 256 and the 8 x 8
    // reference does not fit.
    let bench_out = dir.join("bench");
    let bench = |defines: &[&str]| {
        let mut args = vec![
            "bench",
            "--scene",
            scene,
            "--integrators",
            "pt",
            "--time",
            "0.05",
        ];
        args.extend_from_slice(defines);
        args.extend_from_slice(&["--reference", out.to_str().unwrap()]);
        args.extend_from_slice(&["--out", bench_out.to_str().unwrap(), "--quiet"]);
        run(&args)
    };
    let o = bench(&["-D", "res=8"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(bench_out.join("report.csv").exists());
    let o = bench(&[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("reference is 8x8"),
        "{err}"
    );
    // `info` takes definitions too.
    let o = run(&["info", scene, "-D", "res=8"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && text.contains("8 x 8"), "{text}");
    for (args, needle) in [
        (vec!["info", scene, "-D", "res=x"], "cornell-box.xml:24:"),
        (vec!["render", scene, "-D", "res"], "expected NAME=VALUE"),
        (vec!["render", scene, "-D", "res=x"], "cornell-box.xml:24:"),
        (
            vec!["render", root_toml.as_str(), "-D", "res=8"],
            "TOML scene",
        ),
    ] {
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && err.contains(needle),
            "{args:?}: {err}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// A Mitsuba spot (cutoff 20, default beam width 15 degrees, aimed by a lookat along -y):
/// full intensity inside 15 degrees, half at 17.5 (Mitsuba's edge is linear in the angle),
/// none beyond 20.
#[test]
fn spot_has_mitsubas_linear_edge() {
    let s = xml(&wrap(
        r#"<emitter type="spot"><rgb name="intensity" value="4"/><float name="cutoff_angle" value="20"/>
        <transform name="to_world"><lookat origin="0, 2, 0" target="0, 0, 0" up="0, 0, 1"/></transform></emitter>"#,
    ))
    .unwrap();
    let lodestar::light::Light::Spot(spot) = &s.lights[0] else {
        panic!("not a spot light")
    };
    let at = |deg: f32| {
        let r = deg.to_radians();
        spot.intensity_towards(Vec3::new(r.sin(), -r.cos(), 0.0)).x
    };
    assert!((at(10.0) - 4.0).abs() < 1e-5);
    assert!((at(17.5) - 2.0).abs() < 1e-2, "{}", at(17.5));
    assert_eq!(at(20.5), 0.0);
}

/// A spot's projected `texture` (Mitsuba 3's): u along the `to_world`'s x, v along its y. The
/// lookat below aims down -y with up +z, so x = up x direction = +x and y = +z; the
/// checkerboard shifted by 0.1 in u is color0 where u + 0.1 and v lie on the same side of 1/2.
#[test]
fn spot_projects_its_texture_in_the_transforms_frame() {
    let s = xml(&wrap(
        r#"<emitter type="spot"><rgb name="intensity" value="1"/><float name="cutoff_angle" value="30"/>
        <texture name="texture" type="checkerboard"><rgb name="color0" value="0.9"/><rgb name="color1" value="0.1"/>
        <transform name="to_uv"><translate x="0.1"/></transform></texture>
        <transform name="to_world"><lookat origin="0, 2, 0" target="0, 0, 0" up="0, 0, 1"/></transform></emitter>"#,
    ))
    .unwrap();
    let lodestar::light::Light::Spot(spot) = &s.lights[0] else {
        panic!("not a spot light")
    };
    assert!(spot.projection.is_some());
    // Offsets across the image in units of tan(cutoff): u = 1/2 + x / 2, v = 1/2 + z / 2.
    let t = 30f32.to_radians().tan();
    let at = |x: f32, z: f32| {
        spot.intensity_towards(Vec3::new(x * t, -1.0, z * t).normalize())
            .x
    };
    assert!((at(0.3, 0.05) - 0.9).abs() < 1e-6, "{}", at(0.3, 0.05));
    assert!((at(-0.3, 0.05) - 0.1).abs() < 1e-6, "{}", at(-0.3, 0.05));
    assert!((at(0.3, -0.05) - 0.1).abs() < 1e-6, "{}", at(0.3, -0.05));
}

/// An area emitter's `radiance` as a texture (Mitsuba 3 allows it): the light's radiance is
/// the texture at the point (a checkerboard's colours as its colour lookup has them), on a
/// rectangle and on a disk (a mesh of many triangles).
#[test]
fn area_emitters_take_a_textured_radiance() {
    let s = xml(&wrap(
        r#"<shape type="rectangle"><emitter type="area"><texture name="radiance" type="checkerboard">
        <rgb name="color0" value="4"/><rgb name="color1" value="1"/></texture></emitter></shape>"#,
    ))
    .unwrap();
    let lodestar::light::Light::Area(l) = &s.lights[0] else {
        panic!("not an area light")
    };
    assert!(l.texture.is_some());
    // The rectangle's (u, v) = ((x + 1) / 2, (y + 1) / 2), facing +z.
    let le = |x: f32, y: f32| l.le_at(Vec3::new(x, y, 0.0), Vec3::Z, Vec3::Z).x;
    assert_eq!(le(-0.5, -0.5), 4.0);
    assert_eq!(le(0.5, -0.5), 1.0);
    let s = xml(&wrap(
        r#"<shape type="disk"><emitter type="area"><texture name="radiance" type="checkerboard"/></emitter></shape>"#,
    ))
    .unwrap();
    let lodestar::light::Light::Area(l) = &s.lights[0] else {
        panic!("not an area light")
    };
    // Mitsuba's checkerboard: 0.4 and 0.2; both over the disk.
    let values: Vec<f32> = [
        (0.2, 0.1),
        (-0.5, 0.3),
        (0.1, -0.7),
        (0.6, 0.6),
        (-0.2, -0.2),
    ]
    .iter()
    .map(|&(x, y)| l.le_at(Vec3::new(x, y, 0.0), Vec3::Z, Vec3::Z).x)
    .collect();
    assert!(
        values
            .iter()
            .all(|v| (*v - 0.4).abs() < 1e-6 || (*v - 0.2).abs() < 1e-6)
            && values.iter().any(|v| (*v - 0.4).abs() < 1e-6)
            && values.iter().any(|v| (*v - 0.2).abs() < 1e-6),
        "{values:?}"
    );
}

/// `$name` in a plugin's type: the tutorial scenes' `<integrator type="$integrator">`, with its
/// `<default>` and overridden by a definition.
#[test]
fn parameters_substitute_in_plugin_types() {
    let text = wrap(
        r#"<default name="integrator" value="path"/>
    <default name="bsdf" value="diffuse"/>
    <integrator type="$integrator"><integer name="max_depth" value="5"/></integrator>
    <shape type="sphere"><bsdf type="$bsdf"/></shape>"#,
    );
    let scene = xml(&text).unwrap();
    assert_eq!(scene.render.integrator, "pt");
    assert_eq!(scene.render.max_depth, 5);
    let d = [("integrator".to_string(), "ptracer".to_string())];
    let scene = load_mitsuba_str(&text, "t.xml", None, &d).unwrap();
    assert_eq!(scene.render.integrator, "lt");
    let d = [("bsdf".to_string(), "hair".to_string())];
    let e = load_mitsuba_str(&text, "t.xml", None, &d)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("'hair' is not supported"), "{e}");
}

/// A Mitsuba 0.5 scene (camelCase names, `<lookAt>`, `ldrfilm` with its `banner`,
/// `diffuseReflectance` as a three-sample spectrum (RGB), a checkerboard's `uscale`, `vscale`
/// and `uoffset`, `strictNormals`, a `halton` sampler) loads as the same scene written for
/// Mitsuba 3.
#[test]
fn mitsuba_0_5_scenes_are_upgraded_on_load() {
    let scene_v = |version: &str, body: &str| {
        format!(
            r#"<scene version="{version}">
{body}
</scene>"#
        )
    };
    let old = scene_v(
        "0.5.0",
        r#"<integrator type="path"><integer name="maxDepth" value="6"/><boolean name="strictNormals" value="true"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/><string name="fovAxis" value="y"/>
        <transform name="toWorld"><lookAt origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="halton"><integer name="sampleCount" value="32"/><integer name="scramble" value="-1"/></sampler>
        <film type="ldrfilm"><integer name="width" value="16"/><integer name="height" value="8"/><float name="gamma" value="2.2"/><boolean name="banner" value="false"/><rfilter type="box"/></film>
    </sensor>
    <shape type="sphere"><bsdf type="diffuse"><spectrum name="diffuseReflectance" value="0.2 0.4 0.6"/></bsdf></shape>
    <shape type="sphere"><point name="center" x="-2" y="0" z="0"/><bsdf type="diffuse"><texture type="checkerboard" name="reflectance"><float name="uscale" value="4"/><float name="vscale" value="2"/><float name="uoffset" value="0.5"/></texture></bsdf></shape>
    <shape type="sphere"><point name="center" x="2" y="0" z="0"/><bsdf type="roughdielectric"><float name="intIOR" value="1.33"/><float name="extIOR" value="1"/></bsdf></shape>"#,
    );
    let new = scene_v(
        "3.0.0",
        r#"<integrator type="path"><integer name="max_depth" value="6"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/><string name="fov_axis" value="y"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="32"/></sampler>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="8"/><rfilter type="box"/></film>
    </sensor>
    <shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf></shape>
    <shape type="sphere"><point name="center" x="-2" y="0" z="0"/><bsdf type="diffuse"><texture type="checkerboard" name="reflectance"><transform name="to_uv"><scale x="4" y="2"/><translate x="0.5"/></transform></texture></bsdf></shape>
    <shape type="sphere"><point name="center" x="2" y="0" z="0"/><bsdf type="roughdielectric"><float name="int_ior" value="1.33"/><float name="ext_ior" value="1"/></bsdf></shape>"#,
    );
    let (a, b) = (xml(&old).unwrap(), xml(&new).unwrap());
    assert_eq!(
        (a.render.max_depth, a.render.spp, &a.render.integrator),
        (b.render.max_depth, b.render.spp, &b.render.integrator)
    );
    assert_eq!(a.render.spp, 32);
    assert_eq!(a.camera.resolution, b.camera.resolution);
    assert_eq!(a.camera.fov_y_degrees, b.camera.fov_y_degrees);
    let bsdfs = |s: &Scene| {
        s.materials
            .iter()
            .map(|m| m.bsdf.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(bsdfs(&a), bsdfs(&b));
    let ray = |s: &Scene| s.camera.generate_ray(glam::Vec2::new(3.5, 2.5));
    assert_eq!(format!("{:?}", ray(&a)), format!("{:?}", ray(&b)));
    // Not upgraded in a Mitsuba 3 scene, and a malformed version is an error on its line.
    let e = xml_err(&old.replace("0.5.0", "3.0.0"));
    assert!(e.contains("diffuseReflectance"), "{e}");
    let e = xml_err(&new.replace("3.0.0", "three"));
    assert!(
        e.starts_with("test.xml:1:") && e.contains("version 'three'"),
        "{e}"
    );
}

/// Rough BSDFs take Mitsuba's default distribution, Beckmann, unless GGX is written out.
#[test]
fn rough_bsdfs_take_beckmann_by_default_and_ggx_when_asked() {
    let dist = |inner: &str| {
        let text = wrap(&format!(
            r#"<shape type="sphere"><bsdf type="roughconductor">{inner}<float name="alpha" value="0.2"/></bsdf></shape>"#
        ));
        match &xml(&text).unwrap().materials[0].bsdf {
            Bsdf::RoughConductor {
                distribution,
                alpha,
                ..
            } => (*distribution, alpha.clone()),
            other => panic!("{other:?}"),
        }
    };
    assert_eq!(dist(""), (Distribution::Beckmann, Alpha::Constant(0.2)));
    assert_eq!(
        dist(r#"<string name="distribution" value="ggx"/>"#),
        (Distribution::Ggx, Alpha::Constant(0.2))
    );
    assert_eq!(
        dist(r#"<string name="distribution" value="beckmann"/>"#),
        (Distribution::Beckmann, Alpha::Constant(0.2))
    );
}

/// `<include>` puts the included scene's contents in place (its errors name the included
/// file and line), and `<path>` adds a directory where mesh files are found.
#[test]
fn includes_and_search_paths() {
    let dir = std::env::temp_dir().join(format!("lodestar-xml-include-{}", std::process::id()));
    let meshes = dir.join("elsewhere");
    std::fs::create_dir_all(&meshes).unwrap();
    std::fs::write(
        meshes.join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("geometry.xml"),
        r#"<scene version="3.0.0">
    <shape type="obj"><string name="filename" value="tri.obj"/></shape>
    <shape type="sphere"><float name="radius" value="$r"/></shape>
</scene>"#,
    )
    .unwrap();
    let main = wrap(
        r#"<default name="r" value="0.5"/>
    <path value="elsewhere"/>
    <include filename="geometry.xml"/>"#,
    );
    std::fs::write(dir.join("main.xml"), &main).unwrap();
    let scene = load_file(&dir.join("main.xml")).unwrap();
    assert_eq!(scene.shapes.len(), 2);
    assert_eq!(mesh_positions(&scene, 0).len(), 3);
    // The same scene named by a path relative to the working directory (the test's is the
    // crate's root): the search directory is relative too, and a file found there is not
    // resolved against the scene's directory a second time.
    let rel = PathBuf::from(format!(
        "target/lodestar-xml-relative-{}",
        std::process::id()
    ));
    std::fs::create_dir_all(rel.join("elsewhere")).unwrap();
    for f in ["main.xml", "geometry.xml", "elsewhere/tri.obj"] {
        std::fs::copy(dir.join(f), rel.join(f)).unwrap();
    }
    let scene = load_file(&rel.join("main.xml"));
    std::fs::remove_dir_all(&rel).ok();
    assert_eq!(mesh_positions(&scene.unwrap(), 0).len(), 3);
    // An error in the included file names it and its line.
    std::fs::write(
        dir.join("geometry.xml"),
        "<scene version=\"3.0.0\">\n\n    <shape type=\"teapot\"/>\n</scene>",
    )
    .unwrap();
    let e = load_file(&dir.join("main.xml")).err().unwrap().to_string();
    assert!(e.contains("geometry.xml:3:") && e.contains("teapot"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `roughplastic` reads with Mitsuba's defaults (Beckmann, alpha 0.1, int_ior
/// "polypropylene" 1.49 over air, diffuse 0.5, specular 1, linear), one-sided unless inside
/// `twosided`, and its properties when given; TOML's `roughplastic` builds the same BSDF.
#[test]
fn rough_plastic_reads_mitsubas_defaults_and_properties() {
    let plastic = |inner: &str| {
        let text = wrap(&format!(
            r#"<shape type="sphere"><bsdf type="roughplastic">{inner}</bsdf></shape>"#
        ));
        let scene = xml(&text).unwrap();
        let m = &scene.materials[0];
        match &m.bsdf {
            Bsdf::RoughPlastic(p) => ((**p).clone(), m.one_sided),
            other => panic!("{other:?}"),
        }
    };
    let (p, one_sided) = plastic("");
    assert!(one_sided);
    assert_eq!(
        (p.distribution, p.alpha, p.nonlinear),
        (Distribution::Beckmann, 0.1, false)
    );
    assert!((p.eta - 1.49 / 1.000277).abs() < 1e-6, "{}", p.eta);
    assert_eq!((p.diffuse, p.specular), (Vec3::splat(0.5), Vec3::ONE));
    let (p, _) = plastic(
        r#"<string name="distribution" value="ggx"/><float name="alpha" value="0.3"/>
           <float name="int_ior" value="1.6"/><rgb name="diffuse_reflectance" value="0.2, 0.4, 0.6"/>
           <boolean name="nonlinear" value="true"/>"#,
    );
    assert_eq!(
        (p.distribution, p.alpha, p.nonlinear),
        (Distribution::Ggx, 0.3, true)
    );
    assert!((p.eta - 1.6 / 1.000277).abs() < 1e-6);
    assert_eq!(p.diffuse, Vec3::new(0.2, 0.4, 0.6));
    let text = wrap(
        r#"<shape type="sphere"><bsdf type="twosided"><bsdf type="roughplastic"/></bsdf></shape>"#,
    );
    assert!(!xml(&text).unwrap().materials[0].one_sided);
    // The same material from TOML.
    let camera = "[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov = 40\nresolution = [16, 16]\n";
    let toml = util::scene(&format!(
        r#"{camera}
[[material]]
name = "p"
type = "roughplastic"
albedo = [0.2, 0.4, 0.6]
ior = 1.59955
alpha = 0.3
distribution = "ggx"
nonlinear = true
one_sided = true

[[shape]]
type = "sphere"
radius = 1
material = "p"
"#
    ));
    let Bsdf::RoughPlastic(t) = &toml.materials[0].bsdf else {
        panic!("{:?}", toml.materials[0].bsdf)
    };
    assert_eq!(
        (t.distribution, t.alpha, t.nonlinear),
        (p.distribution, p.alpha, p.nonlinear)
    );
    assert!((t.eta - p.eta).abs() < 1e-4);
    // A missing albedo is named.
    let e = lodestar::scene::loader::load_str(
        &format!("{camera}\n[[material]]\nname = \"p\"\ntype = \"roughplastic\"\nior = 1.5\nalpha = 0.3\n"),
        "t.toml",
        None,
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("albedo") && e.starts_with("t.toml:"), "{e}");
}

/// `envmap` reads its file (found like a mesh file), `scale` and `to_world` (Mitsuba's
/// `envmap`; its radiance is checked against Mitsuba's in `tests/envmap.rs`); a missing file
/// is an error naming the element's line.
#[test]
fn envmap_reads_its_file_scale_and_orientation() {
    let dir = std::env::temp_dir().join(format!("lodestar-xml-envmap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let img = lodestar::film::Image {
        width: 4,
        height: 3,
        pixels: (0..12).map(|i| Vec3::splat(1.0 + i as f32)).collect(),
    };
    img.write_exr(&dir.join("sky.exr"), &[]).unwrap();
    let text = wrap(
        r#"<emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="2"/>
           <transform name="to_world"><rotate y="1" angle="90"/></transform></emitter>"#,
    );
    let scene = load_mitsuba_str(&text, "t.xml", Some(&dir), &[]).unwrap();
    let light = scene
        .lights
        .iter()
        .find_map(|l| match l {
            lodestar::light::Light::EnvMap(e) => Some(e),
            _ => None,
        })
        .expect("an envmap light");
    // The same map built directly: scale 2, rotated 90 degrees about y.
    let direct = lodestar::light::EnvMapLight::new(
        &img.pixels,
        4,
        3,
        2.0,
        glam::Mat3::from_rotation_y(90f32.to_radians()),
    )
    .unwrap();
    for w in [
        Vec3::new(0.3, 0.5, -0.8),
        Vec3::new(-0.6, -0.2, 0.4),
        Vec3::new(1.0, 0.1, 0.0),
    ] {
        let w = w.normalize();
        let (a, b) = (light.le(w), direct.le(w));
        assert!(
            (a - b).abs().max_element() < 1e-4 * b.max_element(),
            "{w}: {a} vs {b}"
        );
    }
    // (The rotation matters there: unrotated, the map differs.)
    let unrotated =
        lodestar::light::EnvMapLight::new(&img.pixels, 4, 3, 2.0, glam::Mat3::IDENTITY).unwrap();
    let w = Vec3::new(0.3, 0.5, -0.8).normalize();
    assert!((unrotated.le(w) - light.le(w)).abs().max_element() > 0.1);
    let e = load_mitsuba_str(
        &text.replace("sky.exr", "missing.exr"),
        "t.xml",
        Some(&dir),
        &[],
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.starts_with("t.xml:") && e.contains("missing.exr"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Mitsuba 0.6's `roughdiffuse` (in a 0.6 scene, upgraded: `diffuseReflectance`) reads its
/// reflectance and `alpha` (0.2 by default); `useFastApprox` is refused with the reason.
#[test]
fn rough_diffuse_reads_mitsuba_0_6_names() {
    let scene_06 = |inner: &str| {
        wrap(&format!(
            r#"<shape type="sphere"><bsdf type="roughdiffuse">{inner}</bsdf></shape>"#
        ))
        .replace("version=\"3.0.0\"", "version=\"0.6.0\"")
    };
    let bsdf = |text: &str| xml(text).unwrap().materials[0].bsdf.clone();
    let b = bsdf(&scene_06(
        r#"<rgb name="diffuseReflectance" value="0.2, 0.3, 0.4"/>"#,
    ));
    assert_eq!(
        b,
        Bsdf::RoughDiffuse {
            albedo: Vec3::new(0.2, 0.3, 0.4),
            alpha: 0.2
        }
    );
    let b = bsdf(&scene_06(r#"<float name="alpha" value="0.5"/>"#));
    assert_eq!(
        b,
        Bsdf::RoughDiffuse {
            albedo: Vec3::splat(0.5),
            alpha: 0.5
        }
    );
    let e = xml_err(&scene_06(r#"<boolean name="useFastApprox" value="true"/>"#));
    assert!(
        e.contains("use_fast_approx") && e.starts_with("test.xml:"),
        "{e}"
    );
}

/// Named conductors (`material="Au"`) take Mitsuba's RGB `eta` and `k` (a smooth one becomes
/// the Fresnel mirror, a rough one the complex-index rough conductor); an unknown name is an
/// error listing the known ones.
#[test]
fn named_conductors_take_mitsubas_indices() {
    let bsdf = |inner: &str| {
        xml(&wrap(&format!(r#"<shape type="sphere">{inner}</shape>"#)))
            .map(|s| s.materials[0].bsdf.clone())
    };
    let gold = bsdf(r#"<bsdf type="conductor"><string name="material" value="Au"/></bsdf>"#);
    assert_eq!(
        gold.unwrap(),
        Bsdf::FresnelConductor {
            eta: Vec3::new(0.143036, 0.375307, 1.44205),
            k: Vec3::new(3.983, 2.38556, 1.60336),
            scale: Vec3::ONE,
        }
    );
    // Mitsuba's `specular_reflectance` scales the Fresnel reflectance.
    let tinted = bsdf(
        r#"<bsdf type="conductor"><string name="material" value="Au"/><rgb name="specular_reflectance" value="0.5, 0.6, 0.7"/></bsdf>"#,
    );
    let tinted = tinted.unwrap();
    let Bsdf::FresnelConductor { eta, k, scale } = tinted.clone() else {
        panic!("{tinted:?}")
    };
    assert_eq!(scale, Vec3::new(0.5, 0.6, 0.7));
    let frame = lodestar::bsdf::ShadingFrame::new(Vec3::Z, Vec3::Z);
    let wo = Vec3::new(0.6, 0.0, 0.8);
    let s = tinted
        .sample(
            &frame,
            wo,
            0.5,
            glam::Vec2::splat(0.5),
            lodestar::bsdf::TransportMode::Radiance,
        )
        .unwrap();
    let want = lodestar::bsdf::fresnel::conductor(0.8, eta, k) * scale;
    assert!(
        (s.weight - want).abs().max_element() < 1e-5,
        "{} vs {want}",
        s.weight
    );
    let copper = bsdf(
        r#"<bsdf type="roughconductor"><string name="material" value="Cu"/><float name="alpha" value="0.2"/></bsdf>"#,
    );
    match copper.unwrap() {
        Bsdf::RoughConductor {
            fresnel: lodestar::bsdf::ConductorFresnel::Complex { eta, k, .. },
            ..
        } => {
            assert_eq!(eta, Vec3::new(0.201005, 0.92375, 1.10222));
            assert_eq!(k, Vec3::new(3.91326, 2.45305, 2.14209));
        }
        other => panic!("{other:?}"),
    }
    let e = bsdf(r#"<bsdf type="conductor"><string name="material" value="Unobtainium"/></bsdf>"#)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with("test.xml:") && e.contains("'Unobtainium' is not known") && e.contains("Au"),
        "{e}"
    );
}

/// Spectra given by wavelengths become the linear sRGB colours Mitsuba 3.9.1's RGB variants
/// make of them (`mi.traverse` of the loaded scene): D65-weighted and clamped to [0, 1] for a
/// reflectance, unweighted for an emitter's radiance or intensity.
#[test]
fn sampled_spectra_convert_as_mitsuba_does() {
    let scene = xml(&wrap(
        r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.5, 500:0.6, 600:0.7, 700:0.8"/></bsdf></shape>
    <shape type="rectangle"><emitter type="area"><spectrum name="radiance" value="400:0.5 500:0.6 600:0.7 700:0.8"/></emitter></shape>
    <emitter type="point"><spectrum name="intensity" value="400:5, 500:6, 600:7, 700:8"/><point name="position" x="0" y="0" z="5"/></emitter>"#,
    ))
    .unwrap();
    let close = |got: Vec3, want: [f32; 3]| (got - Vec3::from(want)).abs().max_element() < 1e-5;
    let Bsdf::Diffuse { albedo } = scene.materials[0].bsdf else {
        panic!("{:?}", scene.materials[0].bsdf)
    };
    assert!(close(albedo, [0.738916, 0.642815, 0.538267]), "{albedo}");
    use lodestar::light::Light;
    let find = |f: fn(&Light) -> Option<Vec3>| scene.lights.iter().find_map(f).unwrap();
    let radiance = find(|l| match l {
        Light::Area(a) => Some(a.radiance),
        _ => None,
    });
    assert!(
        close(radiance, [0.881939, 0.611176, 0.485831]),
        "{radiance}"
    );
    let intensity = find(|l| match l {
        Light::Point(p) => Some(p.intensity),
        _ => None,
    });
    assert!(close(intensity, [8.81939, 6.11176, 4.85831]), "{intensity}");
}

/// A `<spectrum>` of one value is uniform: a grey reflectance, and on an emitter the
/// equal-energy white, XYZ (1, 1, 1) in sRGB (Mitsuba 3.9.1's loaded values: radiance 2 ->
/// (2.40959, 1.89658, 1.81783), intensity 3 -> (3.61438, 2.84487, 2.72675)).
#[test]
fn uniform_spectra_convert_as_mitsuba_does() {
    let scene = xml(&wrap(
        r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="0.5"/></bsdf></shape>
    <shape type="rectangle"><emitter type="area"><spectrum name="radiance" value="2"/></emitter></shape>
    <emitter type="point"><spectrum name="intensity" value="3"/><point name="position" x="0" y="0" z="5"/></emitter>"#,
    ))
    .unwrap();
    let close = |got: Vec3, want: [f32; 3]| (got - Vec3::from(want)).abs().max_element() < 2e-5;
    let Bsdf::Diffuse { albedo } = scene.materials[0].bsdf else {
        panic!("{:?}", scene.materials[0].bsdf)
    };
    assert_eq!(albedo, Vec3::splat(0.5));
    use lodestar::light::Light;
    let find = |f: fn(&Light) -> Option<Vec3>| scene.lights.iter().find_map(f).unwrap();
    let radiance = find(|l| match l {
        Light::Area(a) => Some(a.radiance),
        _ => None,
    });
    assert!(close(radiance, [2.40959, 1.89658, 1.81783]), "{radiance}");
    let intensity = find(|l| match l {
        Light::Point(p) => Some(p.intensity),
        _ => None,
    });
    assert!(close(intensity, [3.61438, 2.84487, 2.72675]), "{intensity}");
}

/// Mitsuba's smooth `plastic` with its defaults (int_ior "polypropylene" 1.49 over air,
/// diffuse_reflectance 0.5, specular_reflectance 1, linear), one-sided as Mitsuba's, and
/// with its parameters given.
#[test]
fn plastic_reads_as_mitsuba_defines_it() {
    let scene = xml(&wrap(
        r#"<shape type="sphere"><bsdf type="plastic"/></shape>
    <shape type="sphere"><bsdf type="twosided"><bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/>
        <float name="int_ior" value="1.7"/><boolean name="nonlinear" value="true"/></bsdf></bsdf></shape>"#,
    ))
    .unwrap();
    let Bsdf::Plastic(a) = &scene.materials[0].bsdf else {
        panic!("{:?}", scene.materials[0].bsdf)
    };
    assert_eq!(a.diffuse, Vec3::splat(0.5));
    assert_eq!(a.specular, Vec3::ONE);
    assert!((a.eta - 1.49 / 1.000277).abs() < 1e-6 && !a.nonlinear);
    assert!(scene.materials[0].one_sided);
    let Bsdf::Plastic(b) = &scene.materials[1].bsdf else {
        panic!("{:?}", scene.materials[1].bsdf)
    };
    assert_eq!(b.diffuse, Vec3::new(0.1, 0.2, 0.3));
    assert!((b.eta - 1.7 / 1.000277).abs() < 1e-6 && b.nonlinear);
    assert!(!scene.materials[1].one_sided);
    assert!(
        scene.features.specular_surfaces,
        "the coating is a delta lobe"
    );
}

/// `mask`: the opacity a number (default 0.5) or a texture (a checkerboard's colours swapped,
/// as Mitsuba's scalar lookup has them), around one BSDF whose sidedness it keeps (the mask itself lets light through from both sides); a mask in a mask and a
/// mask without a BSDF are errors naming the line.
#[test]
fn mask_reads_as_mitsuba_defines_it() {
    use lodestar::bsdf::Opacity;
    let scene = xml(&wrap(
        r#"<shape type="sphere"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></shape>
    <shape type="sphere"><bsdf type="twosided"><bsdf type="mask"><float name="opacity" value="0.25"/><bsdf type="roughconductor"/></bsdf></bsdf></shape>
    <shape type="sphere"><bsdf type="mask"><texture name="opacity" type="checkerboard"><rgb name="color0" value="1"/><rgb name="color1" value="0"/></texture>
        <bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf></shape>"#,
    ))
    .unwrap();
    let mask = |i: usize| match &scene.materials[i].bsdf {
        Bsdf::Mask(m) => m.clone(),
        other => panic!("material {i}: {other:?}"),
    };
    let (a, b, c) = (mask(0), mask(1), mask(2));
    assert_eq!(a.opacity, Opacity::Constant(0.5));
    assert!(a.inner_one_sided && matches!(a.inner, Bsdf::Diffuse { .. }));
    assert_eq!(b.opacity, Opacity::Constant(0.25));
    assert!(!b.inner_one_sided && matches!(b.inner, Bsdf::RoughConductor { .. }));
    assert!(!c.inner_one_sided);
    // Mitsuba's scalar lookup of a checkerboard (`eval_1`) takes color0 where its colour
    // lookup takes color1: 0 where both coordinates lie on one side of 1/2.
    assert_eq!(c.opacity.at(glam::Vec2::new(0.1, 0.1)), 0.0);
    assert_eq!(c.opacity.at(glam::Vec2::new(0.6, 0.1)), 1.0);
    assert!(scene.materials.iter().all(|m| !m.one_sided));
    assert!(
        scene.features.specular_surfaces,
        "the null lobe is a delta lobe"
    );

    let e = xml_err(&wrap(
        r#"<shape type="sphere"><bsdf type="mask"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf></shape>"#,
    ));
    assert!(
        e.contains("mask cannot wrap another mask") && e.contains(".xml:7:"),
        "{e}"
    );
    let e = xml_err(&wrap(r#"<shape type="sphere"><bsdf type="mask"/></shape>"#));
    assert!(e.contains("mask needs one nested <bsdf>"), "{e}");
}

/// A conductor's `specular_reflectance` given as a texture tints its value point by point
/// (`Bsdf::Tinted` over the conductor Mitsuba's other properties make).
#[test]
fn conductors_take_a_textured_specular_reflectance() {
    let scene = xml(&wrap(
        r#"<shape type="sphere"><bsdf type="roughconductor"><float name="alpha" value="0.1"/><string name="distribution" value="ggx"/>
        <texture name="specular_reflectance" type="checkerboard"><rgb name="color0" value="0.8, 0.8, 0.8"/><rgb name="color1" value="0.2, 0.2, 0.2"/></texture>
        <rgb name="eta" value="1.65746, 0.880369, 0.521229"/><rgb name="k" value="9.22387, 6.26952, 4.837"/></bsdf></shape>"#,
    ))
    .unwrap();
    let Bsdf::Tinted { base, tint } = &scene.materials[0].bsdf else {
        panic!("{:?}", scene.materials[0].bsdf)
    };
    assert!(matches!(
        **base,
        Bsdf::RoughConductor {
            alpha: Alpha::Constant(0.1),
            fresnel: lodestar::bsdf::ConductorFresnel::Complex {
                scale: Vec3::ONE,
                ..
            },
            distribution: lodestar::bsdf::Distribution::Ggx,
        }
    ));
    assert_eq!(tint.eval(glam::Vec2::new(0.1, 0.1)), Vec3::splat(0.8));
    assert_eq!(tint.eval(glam::Vec2::new(0.6, 0.1)), Vec3::splat(0.2));
}

/// Writes a Mitsuba serialized file (version 4) of two meshes: a unit quad in single precision
/// with vertex normals, and a triangle in double precision with texture coordinates.
fn write_serialized(path: &Path) {
    use std::io::Write;
    fn mesh(
        flags: u32,
        name: &str,
        positions: &[[f64; 3]],
        extra: &[f64],
        tris: &[[u32; 3]],
    ) -> Vec<u8> {
        let mut raw = Vec::new();
        raw.extend(flags.to_le_bytes());
        raw.extend(name.as_bytes());
        raw.push(0);
        raw.extend((positions.len() as u64).to_le_bytes());
        raw.extend((tris.len() as u64).to_le_bytes());
        let double = flags & 0x2000 != 0;
        let put = |x: f64, raw: &mut Vec<u8>| {
            if double {
                raw.extend(x.to_le_bytes())
            } else {
                raw.extend((x as f32).to_le_bytes())
            }
        };
        for p in positions {
            for &x in p {
                put(x, &mut raw);
            }
        }
        for &x in extra {
            put(x, &mut raw);
        }
        for t in tris {
            for i in t {
                raw.extend(i.to_le_bytes());
            }
        }
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).unwrap();
        let mut out = vec![0x1C, 0x04, 4, 0];
        out.extend(z.finish().unwrap());
        out
    }
    let quad = mesh(
        0x1001,
        "quad",
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ],
        &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
        &[[0, 1, 2], [0, 2, 3]],
    );
    let tri = mesh(
        0x2002,
        "tri",
        &[[0.0, 0.0, 2.0], [0.5, 0.0, 2.0], [0.0, 0.25, 2.0]],
        &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
        &[[0, 1, 2]],
    );
    let mut file = quad.clone();
    let second = file.len() as u64;
    file.extend(&tri);
    file.extend(0u64.to_le_bytes());
    file.extend(second.to_le_bytes());
    file.extend(2u32.to_le_bytes());
    std::fs::write(path, file).unwrap();
}

/// Mitsuba's `serialized` meshes (zlib, single and double precision, vertex normals and
/// texture coordinates, several meshes per file chosen by `shape_index`) load from XML and
/// TOML; an index past the file's meshes and a file that is not one are errors naming them.
/// (The writer above follows Mitsuba's format description; Mitsuba 3.9.1 loads the same bytes,
/// written from Python, as these two meshes: `mi.load_dict({"type": "serialized", ...})`.)
#[test]
fn serialized_meshes_load_by_index() {
    let dir = std::env::temp_dir().join(format!("lodestar-serialized-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_serialized(&dir.join("m.serialized"));
    let load = |index: &str| {
        let text = wrap(&format!(
            r#"<shape type="serialized"><string name="filename" value="m.serialized"/>{index}</shape>"#
        ));
        load_mitsuba_str(&text, "t.xml", Some(&dir), &[])
    };
    let quad = load("").unwrap();
    let mut p = mesh_positions(&quad, 0);
    p.sort_by(|a, b| a.to_array().partial_cmp(&b.to_array()).unwrap());
    let corner = Vec3::new(1.0, 1.0, 0.0);
    assert_eq!(
        p,
        [Vec3::ZERO, Vec3::ZERO, Vec3::Y, Vec3::X, corner, corner]
    );
    let tri = load(r#"<integer name="shape_index" value="1"/>"#).unwrap();
    let p = mesh_positions(&tri, 0);
    assert_eq!(
        p,
        [
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::new(0.5, 0.0, 2.0),
            Vec3::new(0.0, 0.25, 2.0)
        ]
    );
    let e = load(r#"<integer name="shape_index" value="2"/>"#)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with("t.xml:") && e.contains("holds 2 meshes"),
        "{e}"
    );
    std::fs::write(dir.join("bad.serialized"), b"not a mesh file at all").unwrap();
    let text = wrap(
        r#"<shape type="serialized"><string name="filename" value="bad.serialized"/></shape>"#,
    );
    let e = load_mitsuba_str(&text, "t.xml", Some(&dir), &[])
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("not a Mitsuba serialized mesh"), "{e}");
    // TOML: the same mesh.
    let toml = String::from(
        "[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov = 40\nresolution = [8, 8]\n\
         [[material]]\nname = \"w\"\ntype = \"diffuse\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [[shape]]\ntype = \"serialized\"\nfile = \"m.serialized\"\nshape_index = 1\nmaterial = \"w\"\n",
    );
    let scene = lodestar::scene::loader::load_str(&toml, "t.toml", Some(&dir)).unwrap();
    assert_eq!(mesh_positions(&scene, 0), p);
    std::fs::remove_dir_all(&dir).ok();
}

/// `<rfilter>`: box, tent (`radius`) and Gaussian (`stddev`) as Mitsuba 3 names them, the
/// Gaussian of standard deviation 0.5 when a film (or the whole sensor) gives none; other
/// filters and misplaced parameters are errors naming the line.
#[test]
fn film_filters_read_mitsubas_names_and_default() {
    use lodestar::filter::FilterKind;
    let with = |film: &str| {
        format!(
            r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        {film}
    </sensor>
</scene>"#
        )
    };
    let film = |rfilter: &str| {
        with(&format!(
            r#"<film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/>{rfilter}</film>"#
        ))
    };
    let kind = |text: &str| xml(text).unwrap().camera.filter.kind();
    assert_eq!(kind(&film(r#"<rfilter type="box"/>"#)), FilterKind::Box);
    assert_eq!(
        kind(&film(r#"<rfilter type="tent"/>"#)),
        FilterKind::Tent { radius: 1.0 }
    );
    assert_eq!(
        kind(&film(
            r#"<rfilter type="tent"><float name="radius" value="1.5"/></rfilter>"#
        )),
        FilterKind::Tent { radius: 1.5 }
    );
    assert_eq!(
        kind(&film(
            r#"<rfilter type="gaussian"><float name="stddev" value="0.25"/></rfilter>"#
        )),
        FilterKind::Gaussian { stddev: 0.25 }
    );
    let mitsubas = FilterKind::Gaussian { stddev: 0.5 };
    assert_eq!(kind(&film("")), mitsubas);
    assert_eq!(kind(&with("")), mitsubas);
    let e = xml_err(&film(r#"<rfilter type="mitchell"/>"#));
    assert!(
        e.contains("test.xml:5") && e.contains("rfilter 'mitchell' is not supported"),
        "{e}"
    );
    let e = xml_err(&film(
        r#"<rfilter type="tent"><float name="stddev" value="0.5"/></rfilter>"#,
    ));
    assert!(e.contains("test.xml:5") && e.contains("stddev"), "{e}");
    let e = xml_err(&film(
        r#"<rfilter type="tent"><float name="radius" value="-1"/></rfilter>"#,
    ));
    assert!(
        e.contains("test.xml:5") && e.contains("'radius' must be in (0, 8]"),
        "{e}"
    );
}

/// `shapegroup` and `instance`: each instance places the group's shapes under its
/// `to_world` (after their own), as writing them out would; the group alone draws nothing;
/// nested groups, an instance without a group and emitters in a group are errors.
#[test]
fn shapegroups_are_drawn_by_their_instances() {
    let group = r#"<shape type="shapegroup" id="g">
        <shape type="sphere"><float name="radius" value="0.25"/><point name="center" x="0" y="0" z="0.5"/></shape>
        <shape type="rectangle"><transform name="to_world"><scale value="0.3"/></transform></shape>
    </shape>"#;
    let placed = |tx: f32| {
        format!(
            r#"<shape type="instance"><ref id="g"/><transform name="to_world"><translate x="{tx}" y="0.1" z="0"/></transform></shape>"#
        )
    };
    let scene = xml(&wrap(&format!(
        "{group}\n{}\n{}",
        placed(-0.5),
        placed(0.5)
    )))
    .unwrap();
    assert_eq!(scene.shapes.len(), 4);
    let written = xml(&wrap(
        r#"<shape type="sphere"><float name="radius" value="0.25"/><point name="center" x="0" y="0" z="0.5"/><transform name="to_world"><translate x="-0.5" y="0.1" z="0"/></transform></shape>
        <shape type="rectangle"><transform name="to_world"><scale value="0.3"/><translate x="-0.5" y="0.1" z="0"/></transform></shape>
        <shape type="sphere"><float name="radius" value="0.25"/><point name="center" x="0" y="0" z="0.5"/><transform name="to_world"><translate x="0.5" y="0.1" z="0"/></transform></shape>
        <shape type="rectangle"><transform name="to_world"><scale value="0.3"/><translate x="0.5" y="0.1" z="0"/></transform></shape>"#,
    ))
    .unwrap();
    // The same surfaces: rays through the image hit at the same distances.
    for i in 0..64 {
        let r = glam::Vec2::new((i % 8) as f32 * 2.0 + 1.0, (i / 8) as f32 * 2.0 + 1.0);
        let ray = scene.camera.ray_through(r);
        let (a, b) = (scene.intersect(&ray), written.intersect(&ray));
        assert_eq!(a.is_some(), b.is_some(), "{r}");
        if let (Some(a), Some(b)) = (a, b) {
            assert!(
                (a.hit.t - b.hit.t).abs() < 1e-5 * a.hit.t,
                "{r}: {} vs {}",
                a.hit.t,
                b.hit.t
            );
        }
    }
    assert_eq!(xml(&wrap(group)).unwrap().shapes.len(), 0);
    let e = xml_err(&wrap(
        r#"<shape type="instance"><transform name="to_world"><translate x="1"/></transform></shape>"#,
    ));
    assert!(
        e.contains("an instance needs one <ref id> to a shapegroup"),
        "{e}"
    );
    let e = xml_err(&wrap(
        r#"<shape type="shapegroup" id="h"><shape type="shapegroup" id="i"/></shape>"#,
    ));
    assert!(e.contains("no nested groups"), "{e}");
    let e = xml_err(&wrap(
        r#"<shape type="shapegroup" id="h"><shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape></shape>
        <shape type="instance"><ref id="h"/></shape>"#,
    ));
    assert!(e.contains("a shape in group 'h' cannot emit"), "{e}");
}

/// `alpha_u` and `alpha_v` give roughconductor and roughdielectric anisotropic roughness
/// (equal ones an isotropic `alpha`); roughplastic, isotropic in Mitsuba, refuses them, and
/// one of the two alone is an error naming the line.
#[test]
fn anisotropic_roughness_is_read_where_mitsuba_has_it() {
    let alpha = |plugin: &str, uv: (f32, f32)| {
        let text = wrap(&format!(
            r#"<shape type="sphere"><bsdf type="{plugin}"><float name="alpha_u" value="{}"/><float name="alpha_v" value="{}"/></bsdf></shape>"#,
            uv.0, uv.1
        ));
        match &xml(&text).unwrap().materials[0].bsdf {
            Bsdf::RoughConductor { alpha, .. } | Bsdf::RoughDielectric { alpha, .. } => {
                alpha.clone()
            }
            other => panic!("{other:?}"),
        }
    };
    for plugin in ["roughconductor", "roughdielectric"] {
        assert_eq!(
            alpha(plugin, (0.05, 0.3)),
            Alpha::Anisotropic { u: 0.05, v: 0.3 },
            "{plugin}"
        );
        assert_eq!(alpha(plugin, (0.2, 0.2)), Alpha::Constant(0.2), "{plugin}");
    }
    let err = xml_err(&wrap(
        "<shape type=\"sphere\">\n<bsdf type=\"roughplastic\"><float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha_v\" value=\"0.3\"/></bsdf></shape>",
    ));
    assert!(
        err.contains("test.xml:") && err.contains("roughplastic") && err.contains("'alpha'"),
        "{err}"
    );
    let err = xml_err(&wrap(
        "<shape type=\"sphere\">\n<bsdf type=\"roughconductor\"><float name=\"alpha_u\" value=\"0.1\"/></bsdf></shape>",
    ));
    assert!(
        err.contains("test.xml:") && err.contains("'alpha_u' and 'alpha_v'"),
        "{err}"
    );
}

/// `blendbsdf` mixes its two nested BSDFs (each a material of its own, named after the blend)
/// by `weight`, a number or a texture; it needs two BSDFs and a weight, and refuses one with
/// a delta lobe, naming the line.
#[test]
fn blendbsdf_mixes_two_bsdfs() {
    let text = wrap(
        r#"<shape type="sphere"><bsdf type="blendbsdf" id="mix"><float name="weight" value="0.25"/><bsdf type="diffuse"/><bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf></bsdf></shape>"#,
    );
    let scene = xml(&text).unwrap();
    let m = scene.materials.iter().find(|m| m.name == "mix").unwrap();
    let Bsdf::Blend(b) = &m.bsdf else {
        panic!("{:?}", m.bsdf)
    };
    assert!(matches!(b.first, Bsdf::Diffuse { .. }), "{:?}", b.first);
    assert!(
        matches!(b.second, Bsdf::RoughConductor { .. }),
        "{:?}",
        b.second
    );
    assert_eq!(b.weight, lodestar::bsdf::Opacity::Constant(0.25));
    assert!(m.one_sided);
    let err = xml_err(&wrap(
        "<shape type=\"sphere\">\n<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.5\"/><bsdf type=\"diffuse\"/><bsdf type=\"dielectric\"/></bsdf></shape>",
    ));
    assert!(
        err.contains("test.xml:") && err.contains("delta lobe"),
        "{err}"
    );
    let err = xml_err(&wrap(
        "<shape type=\"sphere\">\n<bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/></bsdf></shape>",
    ));
    assert!(
        err.contains("test.xml:") && err.contains("'weight'"),
        "{err}"
    );
    let err = xml_err(&wrap(
        "<shape type=\"sphere\">\n<bsdf type=\"blendbsdf\"><float name=\"weight\" value=\"0.5\"/><bsdf type=\"diffuse\"/></bsdf></shape>",
    ));
    assert!(
        err.contains("test.xml:") && err.contains("two nested"),
        "{err}"
    );
}
