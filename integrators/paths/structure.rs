//! The structure of a path as the guider sees it: per vertex after the camera a [`Node`]
//! (surface with its delta and transmission flags, medium, or emitter and how it is reached),
//! and a hash of the nodes, which keys the guide cache's structures. Paths the guider does not
//! handle (fewer than 3 vertices, not ending on an emitter, too long) have none.
//!
//! The hash is a polynomial in the nodes, counted from the path's end:
//! `h = sum_i term(n_i) B^(L-1-i)` (mod 2^64) over the nodes n_1 .. n_{L-1} of an L-vertex
//! path (the emitter's term has B^0). So the hash of a path joined from a camera subpath and
//! a light subpath combines the two sides' partial sums without rereading either: a camera
//! prefix's Horner sum is multiplied by `B^(nodes after it)` ([`join_hashes`]), and a light
//! subpath's sum over its vertices from the emitter ([`LightSideHash`]) is added as it is.
//! vcm's tracer uses this to test every path it forms against a cache's structures before
//! the exact test (`HeldPaths::may_hold_hash`), its merges from 14 bits kept with each photon
//! ([`HeldKey`]) without reading the photon's subpath.

use crate::light::Light;
use crate::path::{MAX_VERTICES, Path, Vertex as PathVertex, VertexKind};
use crate::scene::Scene;
use glam::Vec3;

/// How the last vertex of a guided path is reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Reach {
    /// Traced like a surface vertex (area lights).
    Area,
    /// A direction to a light at infinity that the ray must escape towards (environment, sun).
    Infinite,
    /// A deterministic connection (point, spot, directional lights).
    Delta,
}

/// What a vertex of a path is; guided samples copy their guide path's nodes exactly.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Node {
    /// A scattering surface: specular or not, and whether the path crosses it here.
    Surface {
        /// Whether the BSDF there is a Dirac delta (mirror, glass).
        delta: bool,
        /// Whether the path crosses the surface (transmission) rather than reflecting.
        transmit: bool,
    },
    /// A scattering point in medium `medium` (index into `Scene::media`).
    Medium {
        /// The medium's index.
        medium: u32,
    },
    /// The emitter the path ends on.
    Emitter {
        /// Index into `Scene::lights`.
        light: u32,
        /// How a guided path reaches it.
        reach: Reach,
    },
}

/// Nodes of vertices 1 .. L-1 of a path and their hash; `None` for paths the guider does
/// not handle (fewer than 3 vertices, not ending on an emitter, or too long).
pub fn structure(scene: &Scene, path: &Path, max_len: usize) -> Option<(u64, Nodes)> {
    let mut nodes = Nodes {
        len: 0,
        items: [Node::Medium { medium: 0 }; MAX_VERTICES],
    };
    for node in nodes_of(scene, path, max_len)? {
        nodes.items[nodes.len] = node?;
        nodes.len += 1;
    }
    Some((hash_nodes(nodes.iter().copied()), nodes))
}

/// The nodes of a path's vertices 1 .. L-1, held inline: the guided estimators take them for
/// every path whose structure the cache holds, so they do not allocate. Reads as `[Node]`.
#[derive(Debug, Clone, Copy)]
pub struct Nodes {
    len: usize,
    items: [Node; MAX_VERTICES],
}

impl std::ops::Deref for Nodes {
    type Target = [Node];
    fn deref(&self) -> &[Node] {
        &self.items[..self.len]
    }
}

/// The structure hash of a path alone, without allocating: what decides whether a cache can
/// hold the path at all ([`GuideCache::holds`](crate::integrators::guided::cache::GuideCache::holds)).
pub fn signature(scene: &Scene, path: &Path, max_len: usize) -> Option<u64> {
    let vs = path.vertices();
    signature_with(scene, vs.len(), max_len, |i| vs[i])
}

/// [`signature`] of the path `head` followed by `tail` reversed (camera first), without
/// joining them: the same hash as of the joined path. `vertex` reads a vertex of either side
/// as a path vertex (BDPT's vertices: `paths::path_vertex`).
pub fn signature_of_split<V>(
    scene: &Scene,
    head: &[V],
    tail: &[V],
    max_len: usize,
    vertex: impl Fn(&V) -> PathVertex,
) -> Option<u64> {
    let (t, l) = (head.len(), head.len() + tail.len());
    signature_with(scene, l, max_len, |i| {
        vertex(if i < t { &head[i] } else { &tail[l - 1 - i] })
    })
}

fn signature_with(
    scene: &Scene,
    l: usize,
    max_len: usize,
    at: impl Fn(usize) -> PathVertex,
) -> Option<u64> {
    let mut nodes = nodes_with(scene, l, max_len, at)?;
    let mut failed = false;
    let h = hash_nodes(nodes.by_ref().map_while(|n| {
        failed |= n.is_none();
        n
    }));
    (!failed).then_some(h)
}

/// Node of each vertex 1 .. L-1 (`None` items for a vertex the guider does not handle).
fn nodes_of<'a>(
    scene: &'a Scene,
    path: &'a Path,
    max_len: usize,
) -> Option<impl Iterator<Item = Option<Node>> + 'a> {
    let vs = path.vertices();
    nodes_with(scene, vs.len(), max_len, move |i| vs[i])
}

/// [`nodes_of`] the path of `l` vertices whose vertex i is `at(i)`.
fn nodes_with<'a>(
    scene: &'a Scene,
    l: usize,
    max_len: usize,
    at: impl Fn(usize) -> PathVertex + 'a,
) -> Option<impl Iterator<Item = Option<Node>> + 'a> {
    if l < 3 || l > max_len {
        return None;
    }
    Some((1..l).map(move |v| {
        let next = (v + 1 < l).then(|| at(v + 1).p);
        node_at(scene, &at(v), at(v - 1).p, next)
    }))
}

/// Whether material `material`'s BSDF is a delta one (a node's `delta`): a property of the
/// surface, not of the lobe a path takes there, so that a path's structure is known from its
/// vertices as they are reached (smooth plastic is not delta, whichever lobe is taken).
#[inline]
fn delta_bsdf(scene: &Scene, material: u32) -> bool {
    scene.materials[material as usize].bsdf.is_delta()
}

/// The node of path vertex `x` between neighbours at `a` and `b` (`None`: `x` ends the
/// path): a surface needs both (whether the path crosses it), an emitter must end the path,
/// a camera has none.
#[inline]
pub fn node_at(scene: &Scene, x: &PathVertex, a: Vec3, b: Option<Vec3>) -> Option<Node> {
    Some(match x.kind {
        VertexKind::Surface { material, .. } => {
            let transmit = ((a - x.p).dot(x.n) > 0.0) != ((b? - x.p).dot(x.n) > 0.0);
            Node::Surface {
                delta: delta_bsdf(scene, material),
                transmit,
            }
        }
        VertexKind::Medium { medium } => Node::Medium { medium },
        VertexKind::Emitter { light, .. } => {
            if b.is_some() {
                return None;
            }
            Node::Emitter {
                light,
                reach: reach(&scene.lights[light as usize]),
            }
        }
        VertexKind::Camera => return None,
    })
}

/// How a guided path reaches `light`: traced (area), by escaping (environment, sun), or by
/// a deterministic connection (delta lights).
pub fn reach(light: &Light) -> Reach {
    match light {
        Light::Area(_) => Reach::Area,
        Light::Environment(_) | Light::EnvMap(_) | Light::Sun(_) => Reach::Infinite,
        Light::Point(_) | Light::Spot(_) | Light::Directional(_) => Reach::Delta,
    }
}

/// Hashes a structure hash to itself: those are well mixed already (sums of splitmix64
/// terms), so the maps keyed by them ([`SigMap`], [`SigSet`]) skip SipHash on every lookup.
#[derive(Default, Clone, Copy)]
pub struct SigHasher(u64);

impl std::hash::Hasher for SigHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = self.0.rotate_left(8) ^ b as u64;
        }
    }

    fn write_u64(&mut self, n: u64) {
        self.0 = n;
    }
}

/// A map keyed by structure hash.
pub type SigMap<V> = std::collections::HashMap<u64, V, std::hash::BuildHasherDefault<SigHasher>>;
/// A set of structure hashes.
pub type SigSet = std::collections::HashSet<u64, std::hash::BuildHasherDefault<SigHasher>>;

/// The base B of the structure hash (odd, so that its powers never vanish mod 2^64).
pub const HASH_BASE: u64 = 0x9e37_79b9_7f4a_7c15;

/// The term of one node in the structure hash: a mix of its code (kind, flags, medium or
/// light), so that close codes give unrelated terms.
#[inline]
pub fn term(n: Node) -> u64 {
    let code = match n {
        Node::Surface { delta, transmit } => 1 + 2 * delta as u64 + 4 * transmit as u64,
        Node::Medium { medium } => 8 + ((medium as u64) << 8),
        Node::Emitter { light, reach } => 16 + reach as u64 + ((light as u64) << 8),
    };
    // splitmix64's finaliser.
    let mut z = code.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// `B^k` (mod 2^64).
#[inline]
pub fn base_pow(k: usize) -> u64 {
    HASH_BASE.wrapping_pow(k as u32)
}

/// The structure hash of the nodes in path order: `sum_i term(n_i) B^(count-1-i)`, by
/// Horner's rule (equal hashes are confirmed node by node where it matters).
pub fn hash_nodes(nodes: impl Iterator<Item = Node>) -> u64 {
    nodes.fold(0, push_node)
}

/// Horner's step: the hash of a node sequence extended by `n`.
#[inline]
pub fn push_node(h: u64, n: Node) -> u64 {
    h.wrapping_mul(HASH_BASE).wrapping_add(term(n))
}

/// The hash of sequence a followed by sequence b, from a's hash and b's (b having
/// `b_len` nodes).
#[inline]
pub fn join_hashes(a: u64, b: u64, b_len: usize) -> u64 {
    a.wrapping_mul(base_pow(b_len)).wrapping_add(b)
}

/// A light subpath's part of the structure hash, built vertex by vertex from the emitter:
/// light vertex j sits j nodes before the path's end whatever the camera side, so its term
/// enters with `B^j`. A vertex's node needs its camera-side neighbour (whether the path
/// crosses the surface), so after pushing vertices 0 ..= j the sum holds the settled
/// vertices 0 .. j-1 and vertex j is pending.
#[derive(Clone, Copy, Debug)]
pub struct LightSideHash {
    /// Sum of the settled vertices' terms.
    hash: u64,
    /// Number of settled vertices.
    count: usize,
    /// The pending vertex and its emitter-side neighbour's position (`None`: it is the
    /// emitter, which ends the path).
    pending: Option<(PathVertex, Option<Vec3>)>,
    /// False once a settled vertex has no node (no path through it is handled).
    valid: bool,
}

impl Default for LightSideHash {
    fn default() -> Self {
        LightSideHash {
            hash: 0,
            count: 0,
            pending: None,
            valid: true,
        }
    }
}

impl LightSideHash {
    /// Extend the subpath by `x` (the emitter first).
    pub fn push(&mut self, scene: &Scene, x: &PathVertex) {
        if let Some((last, before)) = self.pending {
            match node_at(scene, &last, x.p, before) {
                Some(n) => self.hash = self.hash.wrapping_add(shifted(n, self.count)),
                None => self.valid = false,
            }
            self.count += 1;
            self.pending = Some((*x, Some(last.p)));
        } else {
            self.pending = Some((*x, None));
        }
    }

    /// The light side's hash (one term per vertex pushed) when a camera-side vertex at `next` follows
    /// the pending vertex; `None` if no path through these vertices is handled.
    pub fn closed_by(&self, scene: &Scene, next: Vec3) -> Option<u64> {
        let (last, before) = self.pending?;
        let n = node_at(scene, &last, next, before)?;
        self.valid
            .then(|| self.hash.wrapping_add(shifted(n, self.count)))
    }

    /// What a photon keeps to be tested without its subpath: [`Self::closed_by`]'s low
    /// bits for a camera-side vertex that does not cross the pending vertex's surface, and
    /// whether one that does would change them ([`HeldKey`]).
    pub fn key(&self, scene: &Scene) -> HeldKey {
        let Some((last, before)) = self.pending else {
            return HeldKey::NONE;
        };
        if !self.valid {
            return HeldKey::NONE;
        }
        let (n, crossing) = match last.kind {
            VertexKind::Surface { material, .. } => {
                let delta = delta_bsdf(scene, material);
                (
                    Node::Surface {
                        delta,
                        transmit: false,
                    },
                    Some(delta),
                )
            }
            // The node does not depend on the camera side (a point stands in for it).
            _ => match node_at(scene, &last, last.p, before) {
                Some(n) => (n, None),
                None => return HeldKey::NONE,
            },
        };
        HeldKey::new(self.hash.wrapping_add(shifted(n, self.count)), crossing)
    }
}

/// The structure hash of a light side that is the emitter vertex `y` alone (its term; `None`
/// if `y` is no emitter).
pub fn emitter_hash(scene: &Scene, y: &PathVertex) -> Option<u64> {
    node_at(scene, y, y.p, None).map(term)
}

/// A camera subpath's part of the structure hash: Horner's sum over its settled vertices
/// (x_1 on; the camera has no node), the last vertex pushed pending until the vertex after
/// it is known. [`Self::joined`] completes it with a light side into a whole path's hash.
#[derive(Clone, Copy, Debug)]
pub struct CameraSideHash {
    hash: u64,
    /// Vertices pushed (the camera included).
    len: usize,
    /// The position of the vertex before the last one pushed, and the last one.
    before: Vec3,
    last: Option<PathVertex>,
    valid: bool,
}

impl Default for CameraSideHash {
    fn default() -> Self {
        CameraSideHash {
            hash: 0,
            len: 0,
            before: Vec3::ZERO,
            last: None,
            valid: true,
        }
    }
}

impl CameraSideHash {
    /// Extend the subpath by `x` (the camera first).
    pub fn push(&mut self, scene: &Scene, x: &PathVertex) {
        if let Some(last) = self.last {
            if self.len >= 2 {
                match node_at(scene, &last, self.before, Some(x.p)) {
                    Some(n) => self.hash = push_node(self.hash, n),
                    None => self.valid = false,
                }
            }
            self.before = last.p;
        }
        self.last = Some(*x);
        self.len += 1;
    }

    /// The hashes of the whole path: this side, then a light side of `light_len` vertices
    /// with hash `light` whose vertex next to this side is at `next` (`None`: unknown, and
    /// both sides of the last vertex's surface are given). One or two values, none if no
    /// such path is handled (fewer than 3 or more than `max_len` vertices).
    pub fn joined(
        &self,
        scene: &Scene,
        next: Option<Vec3>,
        light: u64,
        light_len: usize,
        max_len: usize,
    ) -> ([u64; 2], usize) {
        let l = self.len + light_len;
        if !self.valid || l < 3 || l > max_len {
            return ([0; 2], 0);
        }
        let Some(last) = self.last.filter(|_| self.len >= 2) else {
            return ([light; 2], 1);
        };
        let join = |n: Node| join_hashes(push_node(self.hash, n), light, light_len);
        match (next, last.kind) {
            (None, VertexKind::Surface { material, .. }) => {
                let delta = delta_bsdf(scene, material);
                (
                    [false, true].map(|transmit| join(Node::Surface { delta, transmit })),
                    2,
                )
            }
            // A medium's node does not depend on its neighbours.
            (None, _) => match node_at(scene, &last, self.before, Some(last.p)) {
                Some(n) => ([join(n); 2], 1),
                None => ([0; 2], 0),
            },
            (Some(next), _) => match node_at(scene, &last, self.before, Some(next)) {
                Some(n) => ([join(n); 2], 1),
                None => ([0; 2], 0),
            },
        }
    }
}

/// `term(n) B^k`.
#[inline]
fn shifted(n: Node, k: usize) -> u64 {
    term(n).wrapping_mul(base_pow(k))
}

/// The low [`HeldKey::BITS`] bits of a light side's hash ([`LightSideHash::key`]), in two
/// bytes beside a photon: enough to rule out, without reading the photon's subpath, the
/// structures a cache does not hold (`HeldPaths::may_hold_hash` tests the same low bits).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct HeldKey(u16);

impl HeldKey {
    /// Bits of the hash kept.
    pub const BITS: u32 = 14;
    const MASK: u16 = (1 << Self::BITS) - 1;
    /// No path through the subpath is handled.
    pub const NONE: HeldKey = HeldKey(3 << Self::BITS);

    /// The low bits of `h`, and `crossing`: `Some(delta)` if the pending vertex is a surface
    /// (of that delta flag) whose node changes when the camera side crosses it.
    fn new(h: u64, crossing: Option<bool>) -> HeldKey {
        let class = match crossing {
            None => 0,
            Some(false) => 1,
            Some(true) => 2,
        };
        HeldKey((h as u16 & Self::MASK) | (class << Self::BITS))
    }

    /// Whether the key is [`HeldKey::NONE`]: no path through the subpath is handled.
    pub fn is_none(self) -> bool {
        self == Self::NONE
    }

    /// The light side's hash (low bits) for each side the camera vertex may lie on: one
    /// value, or two for a surface; `settled` is the subpath's vertex count less one (the
    /// pending vertex's power of B).
    pub fn hashes(self, settled: usize) -> ([u64; 2], usize) {
        let h = (self.0 & Self::MASK) as u64;
        let delta = match self.0 >> Self::BITS {
            1 => false,
            2 => true,
            _ => return ([h, h], 1),
        };
        let (n0, n1) = (
            Node::Surface {
                delta,
                transmit: false,
            },
            Node::Surface {
                delta,
                transmit: true,
            },
        );
        let other = h
            .wrapping_sub(shifted(n0, settled))
            .wrapping_add(shifted(n1, settled));
        ([h, other], 2)
    }
}
