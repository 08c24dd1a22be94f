//! Shared by the scene and mesh fuzzer (`examples/fuzz_scenes.rs`) and its regression tests
//! (`tests/fuzz_regressions.rs`): the seed corpus (TOML scenes, Mitsuba XML scenes, OBJ and
//! PLY meshes), a deterministic mutator (xorshift64*) with mutations for each format, the
//! scene that wraps a fuzzed mesh file, and the checks run on every input.
//!
//! Each test crate that mounts this module uses only part of it.
#![allow(dead_code)]

use lodestar::geometry::Ray;
use lodestar::scene::Scene;
use lodestar::scene::loader::{load_file, load_mitsuba_str, load_str};
use std::path::{Path, PathBuf};

/// Deterministic xorshift64* generator; the fuzzer must replay exactly from its seed.
#[derive(Clone, Debug)]
pub struct XorShift(u64);

impl XorShift {
    pub fn new(seed: u64) -> XorShift {
        // Any seed, including 0, gives a non-zero state.
        XorShift(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in `0..n` (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    pub fn chance(&mut self, num: u64, den: u64) -> bool {
        self.next_u64() % den < num
    }
}

/// What one fuzz input is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A scene file, loaded from the directory of the scene it was mutated from.
    Toml,
    /// A Mitsuba 3 XML scene, loaded like [`Kind::Toml`].
    Xml,
    /// An OBJ file, loaded as `fuzz.obj` through [`mesh_wrapper`].
    Obj,
    /// A PLY file (ascii or binary), loaded as `fuzz.ply` through [`mesh_wrapper`].
    Ply,
}

impl Kind {
    pub const ALL: [Kind; 4] = [Kind::Toml, Kind::Xml, Kind::Obj, Kind::Ply];

    /// The file extension of inputs of this kind.
    pub fn ext(self) -> &'static str {
        match self {
            Kind::Toml => "toml",
            Kind::Xml => "xml",
            Kind::Obj => "obj",
            Kind::Ply => "ply",
        }
    }

    pub fn from_ext(ext: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.ext() == ext)
    }

    /// A mesh, loaded through a wrapper scene in a scratch directory.
    pub fn is_mesh(self) -> bool {
        matches!(self, Kind::Obj | Kind::Ply)
    }
}

/// The scene around a fuzzed mesh `fuzz.obj` or `fuzz.ply` in the same directory: diffuse,
/// or (`emissive`) as an area light, which builds the mesh's triangle-area sampler too.
pub fn mesh_wrapper(kind: Kind, emissive: bool) -> String {
    let wrapper = if emissive {
        OBJ_WRAPPER_EMISSIVE
    } else {
        OBJ_WRAPPER
    };
    wrapper
        .replace("\"obj\"", &format!("\"{}\"", kind.ext()))
        .replace("\"fuzz.obj\"", &format!("\"fuzz.{}\"", kind.ext()))
}

/// A scene around a fuzzed mesh `fuzz.obj` in the same directory (diffuse).
pub const OBJ_WRAPPER: &str = r#"[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
fov = 40
resolution = [8, 8]

[[material]]
name = "white"
type = "diffuse"
albedo = [0.5, 0.5, 0.5]

[[shape]]
type = "obj"
file = "fuzz.obj"
material = "white"
"#;

/// The same mesh as an area light (builds the triangle-area sampler of the mesh too).
pub const OBJ_WRAPPER_EMISSIVE: &str = r#"[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
fov = 40
resolution = [8, 8]

[[shape]]
type = "obj"
file = "fuzz.obj"
emission = [1, 1, 1]
transform = { scale = 2, rotate = { axis = [0, 1, 0], degrees = 30 }, translate = [0.5, 0, 0] }
"#;

/// The repository root (this file is `tests/fuzz_support/mod.rs`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The seed corpus: every shipped scene (TOML and XML) and mesh file, with its kind.
pub fn corpus() -> Vec<(Kind, PathBuf)> {
    let root = repo_root();
    let mut out = Vec::new();
    for (dir, ext, kind) in [
        ("scenes", "toml", Kind::Toml),
        ("tests/data", "toml", Kind::Toml),
        ("scenes/mitsuba", "xml", Kind::Xml),
        ("scenes/meshes", "obj", Kind::Obj),
        ("tests/data/meshes", "obj", Kind::Obj),
        ("tests/data/meshes", "ply", Kind::Ply),
    ] {
        let mut files: Vec<PathBuf> = std::fs::read_dir(root.join(dir))
            .unwrap_or_else(|e| panic!("cannot list {dir}: {e}"))
            .map(|e| e.expect("directory entry").path())
            .filter(|p| p.extension().is_some_and(|e| e == ext))
            .collect();
        files.sort();
        out.extend(files.into_iter().map(|p| (kind, p)));
    }
    out
}

/// Values that break naive code: huge, tiny, negative, zero, non-finite, integer overflow.
pub const ABSURD: &[&str] = &[
    "1e9",
    "-1",
    "nan",
    "inf",
    "-inf",
    "0",
    "-0",
    "1e308",
    "-1e308",
    "1e38",
    "3.5e38",
    "1e-45",
    "1e-30",
    "16384",
    "16385",
    "4096",
    "100000",
    "1000000",
    "4294967295",
    "4294967296",
    "2147483648",
    "18446744073709551616",
    "-4294967296",
    "1e30",
    "NaN",
    "0.0",
    "1",
    "-1e-38",
];

/// Tokens to splice in that break the syntax.
const JUNK: &[&str] = &[
    "[",
    "]",
    "\"",
    "{",
    "}",
    "=",
    "\n",
    "#",
    ",",
    "[[shape]]",
    "[[light]]",
    "[camera]",
    "é",
    "\u{0}",
    "'",
    "\\",
    "/",
    "f 1 2 3",
    "v 0 0 0",
    "vn 0 0 0",
    "f -1 -2 -3",
    "f 1/1/1 2/2/2",
    "usemtl x",
    "mtllib x.mtl",
    "o",
    "g",
    "f 0 0 0",
    "f 99999999 1 2",
    "v nan nan nan",
    // Mitsuba XML.
    "<",
    ">",
    "/>",
    "</shape>",
    "<shape type=\"ply\"><string name=\"filename\" value=\"x.ply\"/></shape>",
    "<ref id=\"nothing\"/>",
    "<ref id=\"white\"/>",
    "<default name=\"spp\" value=\"$spp\"/>",
    "<default name=\"a\" value=\"1\"/>",
    "$a",
    "$undefined",
    "<transform name=\"to_world\"><scale value=\"0\"/></transform>",
    "<matrix value=\"1 0 0 0 0 1 0 0 0 0 1 0 0 0 0\"/>",
    "<rotate x=\"1\" angle=\"nan\"/>",
    "<lookat origin=\"0,0,0\" target=\"0,0,0\" up=\"0,1,0\"/>",
    "<rgb name=\"radiance\" value=\"1e38, 1e38, 1e38\"/>",
    "<float name=\"fov\" value=\"180\"/>",
    "<integer name=\"width\" value=\"-1\"/>",
    "<bsdf type=\"twosided\"><bsdf type=\"twosided\"/></bsdf>",
    "<emitter type=\"area\"/>",
    "<![CDATA[",
    "<!--",
    "&amp;",
    "&bogus;",
    "version=\"0.1.0\"",
    // PLY headers.
    "element vertex 4294967295\n",
    "element face 1000000000\n",
    "element vertex -1\n",
    "property list uchar int vertex_indices\n",
    "property list uint uint vertex_indices\n",
    "property list float float vertex_indices\n",
    "property double x\n",
    "property float nx\n",
    "format binary_big_endian 1.0\n",
    "format binary_little_endian 1.0\n",
    "format ascii 1.0\n",
    "end_header\n",
    "\u{ff}\u{ff}\u{ff}\u{7f}",
];

/// Byte ranges of the numbers in `text`: maximal runs of digits, signs, '.', 'e', 'E'
/// that contain a digit.
fn number_spans(text: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let is_num = |b: u8| b.is_ascii_digit() || b == b'.' || b == b'-' || b == b'+';
        if is_num(text[i]) {
            let start = i;
            while i < text.len() && (is_num(text[i]) || text[i] == b'e' || text[i] == b'E') {
                i += 1;
            }
            if text[start..i].iter().any(u8::is_ascii_digit) {
                spans.push((start, i));
            }
        } else {
            i += 1;
        }
    }
    spans
}

/// Byte ranges of the XML tags in `text`: from a '<' to the next '>'.
fn tag_spans(text: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut start = None;
    for (i, &b) in text.iter().enumerate() {
        match b {
            b'<' => start = Some(i),
            b'>' => {
                if let Some(a) = start.take() {
                    spans.push((a, i + 1));
                }
            }
            _ => {}
        }
    }
    spans
}

/// Line start offsets (each line includes its newline).
fn lines(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, &b) in text.iter().enumerate() {
        if b == b'\n' {
            out.push((start, i + 1));
            start = i + 1;
        }
    }
    if start < text.len() {
        out.push((start, text.len()));
    }
    out
}

/// Apply one random mutation. `donor` is another corpus file to splice lines from.
pub fn mutate_once(rng: &mut XorShift, data: &mut Vec<u8>, donor: &[u8]) {
    match rng.below(14) {
        // Overwrite a few bytes with a binary value that breaks naive readers (binary PLY
        // bodies: counts, indices and coordinates), in either byte order.
        12 => {
            const VALUES: [[u8; 4]; 8] = [
                [0xff, 0xff, 0xff, 0xff], // u32::MAX, -1, f32 NaN
                [0x7f, 0x80, 0x00, 0x00], // f32 +inf (big endian)
                [0x00, 0x00, 0x80, 0x7f], // f32 +inf (little endian)
                [0x7f, 0x7f, 0xff, 0xff], // f32::MAX (big endian)
                [0xff, 0xff, 0x7f, 0x7f], // f32::MAX (little endian)
                [0x80, 0x00, 0x00, 0x00], // i32::MIN (big endian)
                [0x00, 0x00, 0x00, 0x80], // i32::MIN (little endian)
                [0x00, 0x00, 0x00, 0x00],
            ];
            if !data.is_empty() {
                let at = rng.below(data.len());
                let v = VALUES[rng.below(VALUES.len())];
                let n = [1, 2, 4][rng.below(3)].min(data.len() - at);
                data[at..at + n].copy_from_slice(&v[..n]);
            }
        }
        // XML elements: delete, duplicate (possibly many times) or move one tag.
        13 => {
            let tags = tag_spans(data);
            if !tags.is_empty() {
                let (a, b) = tags[rng.below(tags.len())];
                let tag = data[a..b].to_vec();
                match rng.below(3) {
                    0 => {
                        data.drain(a..b);
                    }
                    1 => {
                        let times = if rng.chance(1, 8) {
                            1 + rng.below(300)
                        } else {
                            1
                        };
                        data.splice(b..b, tag.repeat(times));
                    }
                    _ => {
                        data.drain(a..b);
                        let rest = tag_spans(data);
                        let at = rest.get(rng.below(rest.len().max(1))).map_or(0, |t| t.0);
                        data.splice(at..at, tag);
                    }
                }
            }
        }
        // Replace a number by an absurd value (the most productive mutation: weighted x3).
        0..=2 => {
            let spans = number_spans(data);
            if !spans.is_empty() {
                let (a, b) = spans[rng.below(spans.len())];
                let v = ABSURD[rng.below(ABSURD.len())];
                data.splice(a..b, v.bytes());
            }
        }
        // Flip a bit / set a byte.
        3 => {
            if !data.is_empty() {
                let i = rng.below(data.len());
                if rng.chance(1, 2) {
                    data[i] ^= 1 << rng.below(8);
                } else {
                    data[i] = rng.next_u64() as u8;
                }
            }
        }
        // Delete a line.
        4 => {
            let ls = lines(data);
            if !ls.is_empty() {
                let (a, b) = ls[rng.below(ls.len())];
                data.drain(a..b);
            }
        }
        // Duplicate a line or a block of lines, possibly many times.
        5 => {
            let ls = lines(data);
            if !ls.is_empty() {
                let i = rng.below(ls.len());
                let j = (i + rng.below(8)).min(ls.len() - 1);
                let block = data[ls[i].0..ls[j].1].to_vec();
                let times = if rng.chance(1, 8) {
                    1 + rng.below(200)
                } else {
                    1
                };
                let at = ls[j].1;
                let mut ins = Vec::with_capacity(block.len() * times);
                for _ in 0..times {
                    ins.extend_from_slice(&block);
                }
                data.splice(at..at, ins);
            }
        }
        // Truncate.
        6 => {
            if !data.is_empty() {
                let n = rng.below(data.len());
                data.truncate(n);
            }
        }
        // Swap two lines.
        7 => {
            let ls = lines(data);
            if ls.len() >= 2 {
                let (x, y) = (rng.below(ls.len()), rng.below(ls.len()));
                let (x, y) = (x.min(y), x.max(y));
                if x != y {
                    let (a, b) = (ls[x], ls[y]);
                    let mut out = data[..a.0].to_vec();
                    out.extend_from_slice(&data[b.0..b.1]);
                    out.extend_from_slice(&data[a.1..b.0]);
                    out.extend_from_slice(&data[a.0..a.1]);
                    out.extend_from_slice(&data[b.1..]);
                    *data = out;
                }
            }
        }
        // Splice in a line from another corpus file.
        8 => {
            let ls = lines(donor);
            if !ls.is_empty() {
                let (a, b) = ls[rng.below(ls.len())];
                let ls = lines(data);
                let at = ls.get(rng.below(ls.len().max(1))).map_or(0, |l| l.0);
                let ins = donor[a..b].to_vec();
                data.splice(at..at, ins);
            }
        }
        // Insert junk.
        9 => {
            let at = rng.below(data.len() + 1);
            let j = JUNK[rng.below(JUNK.len())];
            data.splice(at..at, j.bytes());
        }
        // Negate or scale a number by a power of ten.
        10 => {
            let spans = number_spans(data);
            if !spans.is_empty() {
                let (a, b) = spans[rng.below(spans.len())];
                let s = String::from_utf8_lossy(&data[a..b]).to_string();
                let v = if rng.chance(1, 2) {
                    format!("-{s}")
                } else {
                    format!("{s}e{}", rng.below(80) as i32 - 40)
                };
                data.splice(a..b, v.bytes());
            }
        }
        // Replace a quoted string by another quoted string of the same file.
        _ => {
            let q: Vec<usize> = data
                .iter()
                .enumerate()
                .filter(|(_, b)| **b == b'"')
                .map(|(i, _)| i)
                .collect();
            if q.len() >= 4 {
                let k = rng.below(q.len() / 2) * 2;
                let m = rng.below(q.len() / 2) * 2;
                let repl = data[q[m]..=q[m + 1]].to_vec();
                data.splice(q[k]..=q[k + 1], repl);
            }
        }
    }
}

/// A mutated copy of `seed`: 1 to 8 stacked mutations.
pub fn mutate(rng: &mut XorShift, seed: &[u8], donor: &[u8]) -> Vec<u8> {
    let mut data = seed.to_vec();
    let most = if rng.chance(1, 4) { 8 } else { 2 };
    let n = 1 + rng.below(most);
    for _ in 0..n {
        mutate_once(rng, &mut data, donor);
    }
    data
}

/// What loading one input gave; a panic is not an outcome but a failure of the loader.
#[derive(Debug)]
pub enum Outcome {
    Loaded,
    /// A clean error, with its message.
    Rejected(String),
}

/// Checks on a scene the loader accepted: things every integrator takes for granted.
fn check_scene(scene: &Scene) -> Result<(), String> {
    let cam = &scene.camera;
    let res = cam.resolution;
    for (x, y) in [
        (0.0, 0.0),
        (res.x as f32, res.y as f32),
        (0.5 * res.x as f32, 0.5),
    ] {
        let r: Ray = cam.generate_ray(glam::Vec2::new(x, y));
        if !(r.o.is_finite() && r.d.is_finite()) {
            return Err(format!(
                "accepted a scene whose camera ray is not finite: {r:?}"
            ));
        }
        // Traversal must not panic on whatever geometry was accepted.
        let _ = scene.intersect(&r);
    }
    for (i, l) in scene.lights.iter().enumerate() {
        let p = l.power();
        if !(p.is_finite() && p >= 0.0) {
            return Err(format!("accepted a scene whose light {i} has power {p}"));
        }
    }
    if !(scene.center.is_finite() && scene.radius.is_finite()) {
        return Err(format!(
            "accepted a scene with a non-finite bounding sphere: center {}, radius {}",
            scene.center, scene.radius
        ));
    }
    Ok(())
}

/// Render an accepted scene with every integrator at 1 spp on a 6 x 6 image (the scene's own
/// camera, resolution replaced) with `--check`'s validation on: the image must be finite and
/// no sample, splat, density or weight invalid. Off by default in the fuzzer
/// (`FUZZ_RENDER=1`): it tests the integrators on odd scenes, not the loader.
pub fn render_check(mut scene: Scene) -> Result<(), String> {
    use lodestar::integrators::{IntegratorParams, Options, build};
    use lodestar::render::{Budget, RenderContext};
    let c = scene.camera;
    scene.camera = lodestar::camera::Camera::new(
        c.position,
        c.position + c.forward,
        c.up,
        c.fov_y_degrees,
        glam::UVec2::new(6, 6),
    );
    for name in lodestar::integrators::REGISTRY.iter().map(|e| e.name) {
        let params = IntegratorParams {
            max_depth: 6,
            options: Options::default(),
        };
        let mut integrator = build(name, &params).map_err(|e| e.to_string())?;
        let ctx = RenderContext::new(&scene, 7, false);
        lodestar::check::enable();
        let mean = integrator.render(&ctx, Budget::Spp(1)).image.mean();
        lodestar::check::disable();
        let (_, violations) = lodestar::check::report();
        if !mean.is_finite() {
            return Err(format!("{name} rendered an image of mean {mean}"));
        }
        if let Some((integrator, kind, tally)) = violations.iter().find(|v| v.2.count > 0) {
            return Err(format!(
                "{name}: --check found {} violations ({integrator} {kind:?})",
                tally.count
            ));
        }
    }
    Ok(())
}

/// Load one input. `path` holds its bytes; for scenes (TOML, XML) `dir` resolves mesh paths,
/// for meshes the file is copied as `fuzz.obj` / `fuzz.ply` into `dir` and loaded by
/// [`mesh_wrapper`]. `Err` is a finding: the loader accepted something it should not have.
pub fn run_input(kind: Kind, path: &Path, dir: &Path, emissive: bool) -> Result<Outcome, String> {
    let result = match kind {
        Kind::Toml | Kind::Xml => match std::fs::read(path) {
            Ok(bytes) => match String::from_utf8(bytes) {
                Ok(text) if kind == Kind::Toml => {
                    load_str(&text, &path.display().to_string(), Some(dir))
                }
                Ok(text) => load_mitsuba_str(&text, &path.display().to_string(), Some(dir), &[]),
                Err(_) => load_file(path),
            },
            Err(e) => return Err(format!("cannot read {}: {e}", path.display())),
        },
        Kind::Obj | Kind::Ply => {
            let target = dir.join(format!("fuzz.{}", kind.ext()));
            if target != path {
                std::fs::copy(path, &target).map_err(|e| format!("copy: {e}"))?;
            }
            load_str(&mesh_wrapper(kind, emissive), "<mesh wrapper>", Some(dir))
        }
    };
    match result {
        Ok(scene) => {
            check_scene(&scene)?;
            if std::env::var_os("FUZZ_RENDER").is_some() {
                render_check(scene)?;
            }
            Ok(Outcome::Loaded)
        }
        Err(e) => {
            let msg = e.message().to_string();
            if msg.contains('\n') || msg.is_empty() {
                return Err(format!("error message is not one non-empty line: {msg:?}"));
            }
            Ok(Outcome::Rejected(msg))
        }
    }
}
