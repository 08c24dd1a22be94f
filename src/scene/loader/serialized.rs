//! Mitsuba's `.serialized` meshes: a little-endian file of one or more meshes, each a header
//! (`u16` 0x041C, `u16` version 3 or 4) followed by a zlib stream of `u32` flags (0x0001 vertex
//! normals, 0x0002 texture coordinates, 0x0008 vertex colours, 0x0010 face normals, 0x2000
//! double precision), in version 4 a NUL-terminated name, `u64` vertex and triangle counts,
//! positions, the optional per-vertex arrays in that order, and `u32` vertex indices; the file
//! ends with each mesh's byte offset (`u64`, version 3: `u32`) and the `u32` mesh count.
//! Texture coordinates and colours are read past (lodestar has no textures yet).

use crate::geometry::TriangleMesh;
use glam::{Vec2, Vec3};
use std::io::Read;
use std::path::Path;

const HEADER: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const DOUBLE: u32 = 0x2000;

/// Mesh number `index` of the file at `path`, with its vertex normals when it has them.
pub(super) fn load(path: &Path, index: u32) -> Result<TriangleMesh, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let short = || "the file ends early".to_string();
    let u16_at = |o: usize| -> Result<u16, String> {
        Ok(u16::from_le_bytes(
            bytes.get(o..o + 2).ok_or_else(short)?.try_into().unwrap(),
        ))
    };
    if bytes.len() < 8 || u16_at(0)? != HEADER {
        return Err("not a Mitsuba serialized mesh (no 0x041C header)".to_string());
    }
    let version = u16_at(2)?;
    if version != 3 && version != 4 {
        return Err(format!(
            "serialized format version {version} (expected 3 or 4)"
        ));
    }
    let start = if index == 0 {
        0
    } else {
        let count_at = bytes.len() - 4;
        let count = u32::from_le_bytes(bytes[count_at..].try_into().unwrap());
        if index >= count {
            return Err(format!(
                "shape_index {index}: the file holds {count} meshes (0 to {})",
                count.saturating_sub(1)
            ));
        }
        let back = (count - index) as usize;
        let offset = if version == 4 {
            let at = count_at.checked_sub(8 * back).ok_or_else(short)?;
            u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize
        } else {
            let at = count_at.checked_sub(4 * back).ok_or_else(short)?;
            u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize
        };
        if offset + 4 > bytes.len() || u16_at(offset)? != HEADER {
            return Err(format!(
                "shape_index {index}: no mesh at its offset {offset}"
            ));
        }
        offset
    };
    let mut z = flate2::read::ZlibDecoder::new(&bytes[start + 4..]);
    let mut read = |n: usize| -> Result<Vec<u8>, String> {
        let mut buf = vec![0u8; n];
        z.read_exact(&mut buf)
            .map_err(|e| format!("mesh {index}: cannot decompress: {e}"))?;
        Ok(buf)
    };
    let flags = u32::from_le_bytes(read(4)?.try_into().unwrap());
    if version == 4 {
        while read(1)?[0] != 0 {}
    }
    let vertices = u64::from_le_bytes(read(8)?.try_into().unwrap());
    let triangles = u64::from_le_bytes(read(8)?.try_into().unwrap());
    if vertices > u32::MAX as u64 || triangles > (1 << 28) {
        return Err(format!(
            "mesh {index}: {vertices} vertices and {triangles} triangles is more than lodestar reads"
        ));
    }
    let (nv, nt) = (vertices as usize, triangles as usize);
    let double = flags & DOUBLE != 0;
    let mut floats = |count: usize| -> Result<Vec<f32>, String> {
        if double {
            Ok(read(8 * count)?
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap()) as f32)
                .collect())
        } else {
            Ok(read(4 * count)?
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                .collect())
        }
    };
    let to_vec3 = |v: Vec<f32>| -> Vec<Vec3> { v.chunks_exact(3).map(Vec3::from_slice).collect() };
    let positions = to_vec3(floats(3 * nv)?);
    let normals = if flags & HAS_NORMALS != 0 {
        Some(to_vec3(floats(3 * nv)?))
    } else {
        None
    };
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        Some(
            floats(2 * nv)?
                .chunks_exact(2)
                .map(Vec2::from_slice)
                .collect(),
        )
    } else {
        None
    };
    if flags & HAS_COLORS != 0 {
        floats(3 * nv)?;
    }
    let indices = read(12 * nt)?
        .chunks_exact(12)
        .map(|c| [0, 4, 8].map(|o| u32::from_le_bytes(c[o..o + 4].try_into().unwrap())))
        .collect();
    Ok(TriangleMesh {
        positions,
        normals,
        uvs,
        indices,
        grid: None,
    })
}
