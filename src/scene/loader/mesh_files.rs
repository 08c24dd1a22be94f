//! Mesh files: Wavefront OBJ (through `tobj`), PLY (ASCII and binary, read here) and Mitsuba's
//! serialized meshes (`serialized.rs`), each into
//! one triangle mesh with the vertex normals the scene asks for ([`Normals`]).

use crate::geometry::TriangleMesh;
use glam::{Vec2, Vec3};
use std::path::Path;

/// Which vertex normals a loaded mesh gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Normals {
    /// The file's vertex normals when every vertex has one; face normals otherwise.
    File,
    /// Face normals only (Mitsuba's `face_normals = true`).
    Faces,
    /// The file's vertex normals, or angle-weighted averages of the face normals when the file
    /// has none (Mitsuba's default).
    Smooth,
}

/// Load an OBJ (`kind = "obj"`), PLY (`"ply"`) or Mitsuba serialized (`"serialized"`, its mesh
/// number `index`) file.
pub(super) fn load(
    path: &Path,
    kind: &str,
    index: u32,
    normals: Normals,
) -> Result<TriangleMesh, String> {
    if !path.is_file() {
        return Err("no such file".to_string());
    }
    let mut mesh = match kind {
        "ply" => load_ply(path)?,
        "serialized" => super::serialized::load(path, index)?,
        _ => load_obj(path)?,
    };
    if mesh.indices.is_empty() {
        return Err("the file has no triangles".to_string());
    }
    if mesh.positions.iter().any(|p| !p.is_finite()) {
        return Err("the file has non-finite vertex positions".to_string());
    }
    let n = mesh.positions.len();
    if let Some(i) = mesh.indices.iter().flatten().find(|&&i| i as usize >= n) {
        return Err(format!(
            "a face refers to vertex {i}, but the file has {n} vertices (numbered from 0)"
        ));
    }
    if let Some(ns) = &mesh.normals
        && ns.iter().any(|n| *n == Vec3::ZERO || !n.is_finite())
    {
        mesh.normals = None;
    }
    if let Some(uvs) = &mut mesh.uvs {
        if uvs.iter().any(|uv| !uv.is_finite()) {
            return Err("the file has non-finite texture coordinates".to_string());
        }
        // OBJ and PLY texture coordinates have v up, images their top row first: Mitsuba's
        // readers flip v (`flip_tex_coords`, default true), and so does lodestar.
        if kind != "serialized" {
            for uv in uvs.iter_mut() {
                uv.y = 1.0 - uv.y;
            }
        }
    }
    Ok(match normals {
        Normals::File => mesh,
        Normals::Faces => TriangleMesh {
            normals: None,
            ..mesh
        },
        Normals::Smooth if mesh.normals.is_none() => mesh.with_smooth_normals(),
        Normals::Smooth => mesh,
    })
}

/// Every model of an OBJ file in one mesh, with vertex normals when all models have them.
fn load_obj(path: &Path) -> Result<TriangleMesh, String> {
    check_obj_faces(&std::fs::read(path).map_err(|e| e.to_string())?)?;
    let (models, _materials) =
        tobj::load_obj(path, &tobj::GPU_LOAD_OPTIONS).map_err(|e| e.to_string())?;
    let mut mesh = TriangleMesh {
        normals: Some(Vec::new()),
        uvs: Some(Vec::new()),
        ..Default::default()
    };
    for m in &models {
        let m = &m.mesh;
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2])),
        );
        if m.normals.len() == m.positions.len() {
            if let Some(ns) = &mut mesh.normals {
                ns.extend(
                    m.normals
                        .chunks_exact(3)
                        .map(|c| Vec3::new(c[0], c[1], c[2]).normalize_or_zero()),
                );
            }
        } else {
            mesh.normals = None;
        }
        if 3 * m.texcoords.len() == 2 * m.positions.len() {
            if let Some(uvs) = &mut mesh.uvs {
                uvs.extend(m.texcoords.chunks_exact(2).map(Vec2::from_slice));
            }
        } else {
            mesh.uvs = None;
        }
        mesh.indices.extend(
            m.indices
                .chunks_exact(3)
                .map(|c| [c[0] + base, c[1] + base, c[2] + base]),
        );
    }
    Ok(mesh)
}

/// Checks the faces of an OBJ file before `tobj` reads it, so that a bad one is an error that
/// names its line: every face has at least three vertices, each written `v`, `v/vt`, `v//vn`
/// or `v/vt/vn`, and every index refers to an existing position, texture coordinate or normal.
/// Indices count from 1; negative ones count back from the last element defined before the
/// face (-1 is the last), positive ones may refer to elements defined further down.
/// `tobj` would read index 0 as "none" and ignore `vt` and `vn` indices in a file without
/// texture coordinates or normals.
fn check_obj_faces(bytes: &[u8]) -> Result<(), String> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        format!("line {}: the file is not UTF-8 text", line + 1)
    })?;
    const KINDS: [(&str, &str); 3] = [
        ("vertex", "vertices"),
        ("texture coordinate", "texture coordinates"),
        ("normal", "normals"),
    ];
    // Positions, texture coordinates and normals defined so far.
    let mut counts = [0u64; 3];
    // The largest positive index of each kind and its line, checked against the totals at the
    // end.
    let mut largest = [(0u64, 0usize); 3];
    for (k, line) in text.lines().enumerate() {
        let at = k + 1;
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => counts[0] += 1,
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            Some("f") => {
                let corners: Vec<&str> = words.collect();
                if corners.len() < 3 {
                    return Err(format!(
                        "line {at}: a face needs at least 3 vertices, this one has {}",
                        corners.len()
                    ));
                }
                for corner in corners {
                    let parts: Vec<&str> = corner.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(format!(
                            "line {at}: '{corner}' is not a face vertex (expected v, v/vt, v//vn \
                             or v/vt/vn)"
                        ));
                    }
                    // Where in the face an index is, when the vertex has more than one.
                    let of = if parts.len() > 1 {
                        format!(" of '{corner}'")
                    } else {
                        String::new()
                    };
                    for (kind, part) in parts.iter().enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        let (one, many) = KINDS[kind];
                        let i: i64 = part
                            .parse()
                            .map_err(|_| format!("line {at}: '{part}'{of} is not a {one} index"))?;
                        if i == 0 {
                            return Err(format!(
                                "line {at}: {one} index 0{of} (indices count from 1, or back \
                                 from -1 for the last)"
                            ));
                        }
                        if i > 0 {
                            if i as u64 > largest[kind].0 {
                                largest[kind] = (i as u64, at);
                            }
                        } else if i.unsigned_abs() > counts[kind] {
                            return Err(format!(
                                "line {at}: {one} index {i}{of}, but only {} {many} are \
                                 defined before it",
                                counts[kind]
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    for (kind, &(i, at)) in largest.iter().enumerate() {
        if i > counts[kind] {
            let (one, many) = KINDS[kind];
            return Err(format!(
                "line {at}: {one} index {i}, but the file has {} {many}",
                counts[kind]
            ));
        }
    }
    Ok(())
}

/// A PLY scalar type.
#[derive(Debug, Clone, Copy)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

/// A property of a PLY element: a scalar, or a list (count type, item type).
struct Property {
    name: String,
    count: Option<Scalar>,
    item: Scalar,
}

struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

/// Why [`Body::next`] read no value.
enum BodyError {
    /// The data ended.
    End,
    /// An ASCII word that is not a number.
    NotANumber(String),
}

/// Reads scalars from the body of a PLY file, ASCII or binary.
struct Body<'a> {
    bytes: &'a [u8],
    pos: usize,
    format: Format,
}

impl Body<'_> {
    /// Nothing but (ASCII) white space may follow the last element: more data means an
    /// element count in the header is too small.
    fn expect_end(&self) -> Result<(), String> {
        let rest = &self.bytes[self.pos.min(self.bytes.len())..];
        let extra = match self.format {
            Format::Ascii => rest.iter().any(|b| !b.is_ascii_whitespace()),
            Format::Little | Format::Big => !rest.is_empty(),
        };
        if extra {
            return Err(format!(
                "{} bytes after the last element: the header's element counts do not match \
                 the data",
                rest.len()
            ));
        }
        Ok(())
    }

    fn next(&mut self, t: Scalar) -> Result<f64, BodyError> {
        if self.format == Format::Ascii {
            while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            let start = self.pos;
            while self.pos < self.bytes.len() && !self.bytes[self.pos].is_ascii_whitespace() {
                self.pos += 1;
            }
            let word = std::str::from_utf8(&self.bytes[start..self.pos]).unwrap_or("");
            if word.is_empty() {
                return Err(BodyError::End);
            }
            return word
                .parse::<f64>()
                .map_err(|_| BodyError::NotANumber(word.to_string()));
        }
        let n = t.size();
        let Some(raw) = self.bytes.get(self.pos..self.pos + n) else {
            return Err(BodyError::End);
        };
        self.pos += n;
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(raw);
        if self.format == Format::Big {
            b[..n].reverse();
        }
        Ok(match t {
            Scalar::I8 => b[0] as i8 as f64,
            Scalar::U8 => b[0] as f64,
            Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(b),
        })
    }
}

/// Largest list (polygon) a PLY face may have.
const MAX_POLYGON: usize = 1 << 16;

/// A PLY file's `vertex` (x, y, z, optional nx, ny, nz) and `face` (vertex_indices, polygons
/// fanned into triangles) elements; other elements and properties are read past.
fn load_ply(path: &Path) -> Result<TriangleMesh, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let header_end = bytes
        .windows(10)
        .position(|w| w == b"end_header")
        .ok_or("not a PLY file (no 'end_header')")?;
    let header = std::str::from_utf8(&bytes[..header_end])
        .map_err(|_| "the PLY header is not text".to_string())?;
    let mut body_start = header_end + 10;
    while body_start < bytes.len() && bytes[body_start] != b'\n' {
        body_start += 1;
    }
    body_start += 1;
    let mut lines = header.lines();
    if lines.next().map(str::trim) != Some("ply") {
        return Err("not a PLY file (it must start with 'ply')".to_string());
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for (k, line) in lines.enumerate() {
        let at = k + 2;
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    other => return Err(format!("header line {at}: unknown format '{other}'")),
                })
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count
                    .parse()
                    .map_err(|_| format!("header line {at}: bad element count '{count}'"))?,
                properties: Vec::new(),
            }),
            ["property", "list", count, item, name] => {
                let (Some(count), Some(item)) = (Scalar::parse(count), Scalar::parse(item)) else {
                    return Err(format!("header line {at}: unknown property type"));
                };
                let e = elements
                    .last_mut()
                    .ok_or(format!("header line {at}: property before any element"))?;
                e.properties.push(Property {
                    name: name.to_string(),
                    count: Some(count),
                    item,
                });
            }
            ["property", t, name] => {
                let item =
                    Scalar::parse(t).ok_or(format!("header line {at}: unknown type '{t}'"))?;
                let e = elements
                    .last_mut()
                    .ok_or(format!("header line {at}: property before any element"))?;
                e.properties.push(Property {
                    name: name.to_string(),
                    count: None,
                    item,
                });
            }
            _ => return Err(format!("header line {at}: cannot read '{}'", line.trim())),
        }
    }
    let format = format.ok_or("the PLY header has no 'format' line")?;
    let mut body = Body {
        bytes: &bytes[body_start.min(bytes.len())..],
        pos: 0,
        format,
    };
    // Every element needs at least one byte (or one word) per item: bound the counts by the
    // file size before allocating.
    for e in &elements {
        if e.count > bytes.len() {
            return Err(format!(
                "element '{}' claims {} items, more than the file can hold",
                e.name, e.count
            ));
        }
    }
    let mut mesh = TriangleMesh::default();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for e in &elements {
        let find = |n: &str| e.properties.iter().position(|p| p.name == n);
        let xyz = [find("x"), find("y"), find("z")];
        let nxyz = [find("nx"), find("ny"), find("nz")];
        let has_normals = nxyz.iter().all(Option::is_some);
        // Texture coordinates under the names Mitsuba reads.
        let uv = [
            ("u", "v"),
            ("s", "t"),
            ("texture_u", "texture_v"),
            ("texture_s", "texture_t"),
        ]
        .iter()
        .find_map(|(a, b)| Some((find(a)?, find(b)?)));
        let list = find("vertex_indices").or(find("vertex_index"));
        if e.name == "vertex" && xyz.iter().any(Option::is_none) {
            return Err("the 'vertex' element has no x, y and z".to_string());
        }
        if e.name == "face" && list.is_none() {
            return Err("the 'face' element has no 'vertex_indices' list".to_string());
        }
        let mut values = vec![0.0f64; e.properties.len()];
        let mut polygon: Vec<u32> = Vec::new();
        for item in 0..e.count {
            let next = |body: &mut Body, t: Scalar| {
                body.next(t).map_err(|err| match err {
                    BodyError::End => format!(
                        "the file ends in item {item} of element '{}', whose header count is \
                         {}: the count is wrong or the file is cut short",
                        e.name, e.count
                    ),
                    BodyError::NotANumber(w) => {
                        format!("'{w}' in element '{}' is not a number", e.name)
                    }
                })
            };
            polygon.clear();
            for (i, p) in e.properties.iter().enumerate() {
                match p.count {
                    None => values[i] = next(&mut body, p.item)?,
                    Some(ct) => {
                        let n = next(&mut body, ct)?;
                        if !(n >= 0.0 && n as usize <= MAX_POLYGON) {
                            return Err(format!("a list of {n} items in element '{}'", e.name));
                        }
                        for _ in 0..n as usize {
                            let v = next(&mut body, p.item)?;
                            if Some(i) == list {
                                if !(v >= 0.0 && v <= u32::MAX as f64) {
                                    return Err(format!(
                                        "vertex index {v} in a face (expected a vertex number \
                                         from 0)"
                                    ));
                                }
                                polygon.push(v as u32);
                            }
                        }
                    }
                }
            }
            if e.name == "vertex" {
                let v = |k: [Option<usize>; 3]| {
                    Vec3::from(k.map(|i| values[i.expect("checked above")] as f32))
                };
                mesh.positions.push(v(xyz));
                if has_normals {
                    normals.push(v(nxyz).normalize_or_zero());
                }
                if let Some((a, b)) = uv {
                    uvs.push(Vec2::new(values[a] as f32, values[b] as f32));
                }
            } else if e.name == "face" {
                for k in 1..polygon.len().saturating_sub(1) {
                    mesh.indices.push([polygon[0], polygon[k], polygon[k + 1]]);
                }
            }
        }
    }
    body.expect_end()?;
    if !normals.is_empty() {
        mesh.normals = Some(normals);
    }
    if !uvs.is_empty() {
        mesh.uvs = Some(uvs);
    }
    Ok(mesh)
}
