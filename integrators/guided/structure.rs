//! The structure of a path as the guider sees it: per vertex after the camera a [`Node`]
//! (surface with its delta and transmission flags, medium, or emitter and how it is reached),
//! and the FNV-1a hash of the nodes, which keys the guide cache's structures. Paths the guider
//! does not handle (fewer than 3 vertices, not ending on an emitter, too long) have none.

use crate::light::Light;
use crate::path::{Path, Vertex as PathVertex, VertexKind};
use crate::scene::Scene;
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
        delta: bool,
        transmit: bool,
    },
    Medium {
        medium: u32,
    },
    Emitter {
        light: u32,
        reach: Reach,
    },
}

/// Nodes of vertices 1 .. L-1 of a path and their hash; `None` for paths the guider does
/// not handle (fewer than 3 vertices, not ending on an emitter, or too long).
pub fn structure(scene: &Scene, path: &Path, max_len: usize) -> Option<(u64, Vec<Node>)> {
    let nodes = nodes_of(scene, path, max_len)?.collect::<Option<Vec<Node>>>()?;
    Some((hash_nodes(nodes.iter().copied()), nodes))
}

/// The structure hash of a path alone, without allocating: what decides whether a cache can
/// hold the path at all ([`GuideCache::holds`](super::cache::GuideCache::holds)).
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
        let x = at(v);
        Some(match x.kind {
            VertexKind::Surface { delta, .. } => {
                if v + 1 >= l {
                    return None;
                }
                let (a, b) = (at(v - 1).p - x.p, at(v + 1).p - x.p);
                let transmit = (a.dot(x.n) > 0.0) != (b.dot(x.n) > 0.0);
                Node::Surface { delta, transmit }
            }
            VertexKind::Medium { medium } => Node::Medium { medium },
            VertexKind::Emitter { light, .. } => {
                if v + 1 != l {
                    return None;
                }
                Node::Emitter {
                    light,
                    reach: reach(&scene.lights[light as usize]),
                }
            }
            VertexKind::Camera => return None,
        })
    }))
}

pub fn reach(light: &Light) -> Reach {
    match light {
        Light::Area(_) => Reach::Area,
        Light::Environment(_) | Light::Sun(_) => Reach::Infinite,
        Light::Point(_) | Light::Spot(_) | Light::Directional(_) => Reach::Delta,
    }
}

/// FNV-1a over the nodes (a fast first test; equal hashes are confirmed node by node).
pub fn hash_nodes(nodes: impl Iterator<Item = Node>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |x: u64| {
        h ^= x;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    };
    for n in nodes {
        match n {
            Node::Surface { delta, transmit } => eat(1 + 2 * delta as u64 + 4 * transmit as u64),
            Node::Medium { medium } => eat(8 + ((medium as u64) << 8)),
            Node::Emitter { light, reach } => eat(16 + reach as u64 + ((light as u64) << 8)),
        }
    }
    h
}
