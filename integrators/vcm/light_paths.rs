//! Where a pass's light subpaths are kept: per row of path indices their connectible vertices
//! (connections and merging), their light-tracing splats, and, when recorded (inspection,
//! guided-vcm's claims), every vertex and the light-tracing paths claimed; the photons merging
//! reads (`Photon`). Traced by `light.rs` (`LightPaths::trace`).

use super::vertex::MisVertex;
use super::{ClaimHead, Claimed};
use crate::integrators::paths::structure::HeldKey;
use crate::math::Spectrum;
use crate::path::Vertex as PathVertex;
use crate::scene::Scene;
use glam::Vec3;

/// The light subpaths of one row of path indices.
#[derive(Default)]
pub struct LightRow<'a> {
    pub vertices: Vec<MisVertex<'a>>,
    /// The row's i-th path has vertices `starts[i] .. starts[i + 1]`.
    pub starts: Vec<u32>,
    /// Light-tracing contributions (pixel, value), in path order; the i-th path's are
    /// `splat_starts[i] .. splat_starts[i + 1]`.
    pub splats: Vec<(u32, Spectrum)>,
    pub(super) splat_starts: Vec<u32>,
    /// Every vertex of every path, light first, when recorded (inspection, claims); the i-th
    /// path's are `full_starts[i] .. full_starts[i + 1]`.
    pub(super) full: Vec<PathVertex>,
    pub(super) full_starts: Vec<u32>,
    /// Beside `vertices` when claims are tested: each stored vertex's [`HeldKey`]s, of the
    /// subpath before it (for merges at it) and up to it (for connections to it).
    pub(super) keys: Vec<[HeldKey; 2]>,
    /// Light-tracing paths claimed by the pass's [`HeldPaths`](crate::integrators::unguided::HeldPaths), each the pinhole and a
    /// prefix of its light subpath in `full`; the i-th path's are
    /// `claimed_starts[i] .. claimed_starts[i + 1]`.
    pub(super) claimed: Vec<ClaimHead>,
    pub(super) claimed_starts: Vec<u32>,
    /// Rays the row's paths took.
    pub(super) rays: u64,
}

impl LightRow<'_> {
    pub(super) fn clear(&mut self) {
        self.vertices.clear();
        self.starts.clear();
        self.starts.push(0);
        self.splats.clear();
        self.splat_starts.clear();
        self.splat_starts.push(0);
        self.full.clear();
        self.keys.clear();
        self.full_starts.clear();
        self.full_starts.push(0);
        self.claimed.clear();
        self.claimed_starts.clear();
        self.claimed_starts.push(0);
    }

    /// Close the path just traced.
    pub(super) fn end_path(&mut self) {
        self.starts.push(self.vertices.len() as u32);
        self.splat_starts.push(self.splats.len() as u32);
        self.full_starts.push(self.full.len() as u32);
        self.claimed_starts.push(self.claimed.len() as u32);
    }
}

/// What merging needs of a stored light vertex (global index `index`), kept in the hash
/// grid beside its position.
#[derive(Clone, Copy, Default)]
pub struct Photon {
    /// Unit direction towards the light walk's previous vertex.
    pub wo: Vec3,
    /// Throughput of the light subpath up to the vertex.
    pub beta: Spectrum,
    /// The vertex's recursive MIS quantity `d_vcm` (`vertex::Mis`).
    pub d_vcm: f32,
    /// The vertex's recursive MIS quantity `d_vm`, relative to a merge here.
    pub d_vm: f32,
    /// Segments from the light, saturated at 65535 (a subpath that deep needs `max_depth`
    /// above it and has probability below 1e-280 under roulette capped at 0.99, so merging's
    /// depth test, `depth + t > max_depth`, is exact in practice).
    pub depth: u16,
    /// The structure hash's low bits of the subpath before this vertex, when claims are
    /// tested (what a merge here tests first; `HeldKey`).
    pub held: HeldKey,
    /// Global index of the light vertex among the pass's stored vertices.
    pub index: u32,
}

impl Photon {
    /// What merging needs of light vertex `v`, global index `index`.
    pub fn of(v: &MisVertex, index: usize, held: HeldKey) -> Photon {
        Photon {
            wo: v.wo,
            beta: v.beta,
            d_vcm: v.mis.d_vcm,
            d_vm: v.mis.d_vm,
            depth: v.depth.min(u16::MAX as u32) as u16,
            held,
            index: index as u32,
        }
    }
}

/// All stored light vertices of a pass, path by path, in the rows the light pass traced
/// them in. Rows keep their memory from pass to pass and are read where they were written:
/// at 512 x 512 a pass's light vertices are tens of megabytes, and allocating them afresh
/// every pass cost vcm about 7 % of its time in page faults, copying them into one array 2 %.
/// A vertex's global index counts row by row (row 0's vertices first).
#[derive(Default)]
pub struct LightPaths<'a> {
    pub(super) rows: Vec<LightRow<'a>>,
    /// Paths per row.
    pub(super) row_len: usize,
    /// Global index of each row's first vertex, and the total at the end.
    pub(super) offsets: Vec<u32>,
    /// The light path of each stored vertex, by global index (when `full` is recorded).
    pub(super) path_of: Vec<u32>,
    /// The pinhole as a path vertex (the head of every claimed light-tracing path).
    pub(super) pinhole: PathVertex,
}

impl<'a> LightPaths<'a> {
    /// Rays the last [`Self::trace`] took.
    pub fn rays(&self) -> u64 {
        self.rows.iter().map(|r| r.rays).sum()
    }

    pub(super) fn index(&mut self) {
        self.offsets.clear();
        self.path_of.clear();
        let mut total = 0u32;
        for (r, row) in self.rows.iter().enumerate() {
            self.offsets.push(total);
            total += row.vertices.len() as u32;
            if row.full.is_empty() {
                continue;
            }
            for (i, w) in row.starts.windows(2).enumerate() {
                let k = (r * self.row_len + i) as u32;
                self.path_of.extend((w[0]..w[1]).map(|_| k));
            }
        }
        self.offsets.push(total);
    }

    /// The stored vertices of light path `k`.
    #[inline]
    pub fn path(&self, k: usize) -> &[MisVertex<'a>] {
        let (row, i) = (&self.rows[k / self.row_len], k % self.row_len);
        &row.vertices[row.starts[i] as usize..row.starts[i + 1] as usize]
    }

    /// Every stored vertex with its global index.
    pub fn vertices(&self) -> impl Iterator<Item = (usize, &MisVertex<'a>)> {
        self.rows.iter().zip(&self.offsets).flat_map(|(row, &o)| {
            row.vertices
                .iter()
                .enumerate()
                .map(move |(i, v)| (o as usize + i, v))
        })
    }

    /// Every stored vertex with its global index and the [`HeldKey`] of the subpath before
    /// it (`HeldKey::NONE` when no claims were tested).
    pub fn vertices_with_keys(&self) -> impl Iterator<Item = (usize, &MisVertex<'a>, HeldKey)> {
        self.rows.iter().zip(&self.offsets).flat_map(|(row, &o)| {
            row.vertices.iter().enumerate().map(move |(i, v)| {
                let key = row.keys.get(i).map_or(HeldKey::NONE, |k| k[0]);
                (o as usize + i, v, key)
            })
        })
    }

    /// The [`HeldKey`]s of the subpaths up to each stored vertex of light path `k`, beside
    /// [`Self::path`] (empty when no claims were tested).
    #[inline]
    pub fn connect_keys(&self, k: usize) -> &[[HeldKey; 2]] {
        let (row, i) = (&self.rows[k / self.row_len], k % self.row_len);
        if row.keys.is_empty() {
            return &[];
        }
        &row.keys[row.starts[i] as usize..row.starts[i + 1] as usize]
    }

    /// The light-tracing splats, in path order, row by row.
    pub fn splats(&self) -> impl Iterator<Item = &[(u32, Spectrum)]> {
        self.rows.iter().map(|row| row.splats.as_slice())
    }

    /// The light-tracing splats of light path `k`.
    pub fn splats_of(&self, k: usize) -> &[(u32, Spectrum)] {
        let (row, i) = (&self.rows[k / self.row_len], k % self.row_len);
        &row.splats[row.splat_starts[i] as usize..row.splat_starts[i + 1] as usize]
    }

    /// The claimed light-tracing paths of light path `k`.
    pub fn claimed_of(&self, k: usize) -> impl ExactSizeIterator<Item = Claimed<'_>> + '_ {
        let (row, i) = (&self.rows[k / self.row_len], k % self.row_len);
        let claims =
            &row.claimed[row.claimed_starts[i] as usize..row.claimed_starts[i + 1] as usize];
        let pinhole = std::slice::from_ref(&self.pinhole);
        claims
            .iter()
            .map(move |c| c.claimed(pinhole, &row.full[c.span()], true))
    }

    /// Every vertex of light path `k`, light first (recorded for inspection and claims only).
    pub fn full(&self, k: usize) -> &[PathVertex] {
        let (row, i) = (&self.rows[k / self.row_len], k % self.row_len);
        &row.full[row.full_starts[i] as usize..row.full_starts[i + 1] as usize]
    }

    /// The light path of the stored vertex of global index `index` (recorded with `full`).
    pub fn path_of_vertex(&self, index: usize) -> usize {
        self.path_of[index] as usize
    }
}

/// The pinhole of `scene`'s camera as a path vertex.
pub(super) fn pinhole(scene: &Scene) -> PathVertex {
    PathVertex {
        p: scene.camera.position,
        ..PathVertex::EMPTY
    }
}
