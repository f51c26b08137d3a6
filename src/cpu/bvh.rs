//! A bounding-volume hierarchy of fixed shape over a mesh's primitives,
//! its boxes fitted again to the primitives wherever they have moved: the
//! broad phase of self-collision's triangle method
//! ([`super::triangle_contact`]).
//!
//! The shape is cut once from the primitives' rest centroids (each node's
//! primitives split at the median along the longest side of their
//! centroids' box, ties by index), so it follows the cloth's surface:
//! deforming the cloth moves boxes, not primitives between them, and a
//! refit is one pass over the nodes. Cloth folds and drapes without
//! tearing, so the tree stays tight where a tree rebuilt each step would
//! cost a sort. Queries visit the nodes in a fixed order: the same pairs
//! in the same order on every run.

use glam::DVec3;

use crate::budget::{try_vec, try_with_capacity};
use crate::error::Result;
use crate::real::{Real, Vec3};

/// The most primitives in a leaf: fewer nodes to visit and refit, at the
/// price of tests between a leaf's primitives that their own boxes would
/// have spared.
const LEAF: usize = 4;

/// A node: a leaf's primitives `order[first..first + count]`, or an
/// internal node's children (`count` 0).
#[derive(Clone, Copy, Debug)]
struct Node {
    first: u32,
    count: u32,
    left: u32,
    right: u32,
}

/// A box \[m\]: lowest and highest corner.
pub type Aabb<R> = (Vec3<R>, Vec3<R>);

/// The hierarchy. Every node comes after its parent, so a pass over the
/// nodes backwards fits children before parents.
#[derive(Clone, Debug, Default)]
pub struct Bvh<R> {
    nodes: Vec<Node>,
    /// The primitives, leaf by leaf.
    order: Vec<u32>,
    /// Each node's box, as last fitted.
    boxes: Vec<Aabb<R>>,
    /// Node pairs or nodes still to visit (kept: no allocation per query).
    stack: Vec<(u32, u32)>,
}

fn union<R: Real>(a: Aabb<R>, b: Aabb<R>) -> Aabb<R> {
    (a.0.min(b.0), a.1.max(b.1))
}

/// Whether boxes `a` and `b` overlap (touching counts).
pub fn overlap<R: Real>(a: &Aabb<R>, b: &Aabb<R>) -> bool {
    (0..3).all(|k| a.0.get(k) <= b.1.get(k) && b.0.get(k) <= a.1.get(k))
}

impl<R: Real> Bvh<R> {
    /// The hierarchy over primitives with rest centroids `centroids` \[m\].
    pub fn new(centroids: &[DVec3]) -> Result<Self> {
        const WHAT: &str = "the triangle contacts' hierarchy";
        let n = centroids.len();
        // Every leaf holds a primitive: at most `2n − 1` nodes.
        let most = (2 * n).max(1);
        let mut order = try_with_capacity(n, WHAT)?;
        order.extend(0..n as u32);
        let mut bvh = Bvh {
            nodes: try_with_capacity(most, WHAT)?,
            order,
            boxes: Vec::new(),
            stack: try_with_capacity(64, WHAT)?,
        };
        if n > 0 {
            bvh.split(centroids, 0, n);
        }
        bvh.boxes = try_vec(bvh.nodes.len(), (Vec3::ZERO, Vec3::ZERO), WHAT)?;
        Ok(bvh)
    }

    /// The node over `order[first..end]`, and its descendants; returns its
    /// index.
    fn split(&mut self, centroids: &[DVec3], first: usize, end: usize) -> u32 {
        let id = self.nodes.len() as u32;
        let leaf = Node {
            first: first as u32,
            count: (end - first) as u32,
            left: 0,
            right: 0,
        };
        self.nodes.push(leaf);
        if end - first <= LEAF {
            return id;
        }
        let run = &mut self.order[first..end];
        let (lo, hi) = run.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &k| {
                let c = centroids[k as usize];
                (lo.min(c), hi.max(c))
            },
        );
        let side = hi - lo;
        let axis = if side.x >= side.y && side.x >= side.z {
            0
        } else if side.y >= side.z {
            1
        } else {
            2
        };
        let mid = run.len() / 2;
        run.select_nth_unstable_by(mid, |&a, &b| {
            centroids[a as usize][axis]
                .total_cmp(&centroids[b as usize][axis])
                .then(a.cmp(&b))
        });
        let left = self.split(centroids, first, first + mid);
        let right = self.split(centroids, first + mid, end);
        self.nodes[id as usize] = Node {
            first: 0,
            count: 0,
            left,
            right,
        };
        id
    }

    /// Fits every box to its primitives' boxes, `primitive(k)` for
    /// primitive `k`.
    pub fn refit(&mut self, mut primitive: impl FnMut(u32) -> Aabb<R>) {
        for id in (0..self.nodes.len()).rev() {
            let node = self.nodes[id];
            self.boxes[id] = if node.count > 0 {
                let leaf = &self.order[node.first as usize..(node.first + node.count) as usize];
                leaf[1..]
                    .iter()
                    .fold(primitive(leaf[0]), |b, &k| union(b, primitive(k)))
            } else {
                union(
                    self.boxes[node.left as usize],
                    self.boxes[node.right as usize],
                )
            };
        }
    }

    fn leaf(&self, node: Node) -> &[u32] {
        &self.order[node.first as usize..(node.first + node.count) as usize]
    }

    /// Calls `pair(a, b)` once for each pair of distinct primitives whose
    /// leaves' boxes overlap (`a` before `b` in the leaf order), in a
    /// fixed order; the caller tests the primitives themselves.
    pub fn self_pairs(&mut self, mut pair: impl FnMut(u32, u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = std::mem::take(&mut self.stack);
        stack.clear();
        stack.push((0, 0));
        while let Some((a, b)) = stack.pop() {
            let (na, nb) = (self.nodes[a as usize], self.nodes[b as usize]);
            if a == b {
                if na.count > 0 {
                    let leaf = self.leaf(na);
                    for (i, &p) in leaf.iter().enumerate() {
                        for &q in &leaf[i + 1..] {
                            pair(p, q);
                        }
                    }
                } else {
                    stack.push((na.right, na.right));
                    stack.push((na.left, na.right));
                    stack.push((na.left, na.left));
                }
                continue;
            }
            if !overlap(&self.boxes[a as usize], &self.boxes[b as usize]) {
                continue;
            }
            match (na.count > 0, nb.count > 0) {
                (true, true) => {
                    for &p in self.leaf(na) {
                        for &q in self.leaf(nb) {
                            pair(p, q);
                        }
                    }
                }
                // Descend the first where it is internal, else the second.
                (false, _) => {
                    stack.push((na.right, b));
                    stack.push((na.left, b));
                }
                (true, false) => {
                    stack.push((a, nb.right));
                    stack.push((a, nb.left));
                }
            }
        }
        self.stack = stack;
    }

    /// Calls `hit(k)` for each primitive `k` whose leaf's box overlaps
    /// `query`, in a fixed order; the caller tests the primitive itself.
    pub fn overlapping(&mut self, query: &Aabb<R>, mut hit: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = std::mem::take(&mut self.stack);
        stack.clear();
        stack.push((0, 0));
        while let Some((a, _)) = stack.pop() {
            if !overlap(&self.boxes[a as usize], query) {
                continue;
            }
            let node = self.nodes[a as usize];
            if node.count > 0 {
                for &k in self.leaf(node) {
                    hit(k);
                }
            } else {
                stack.push((node.right, 0));
                stack.push((node.left, 0));
            }
        }
        self.stack = stack;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pairs and the hits are those of every leaf whose box overlaps,
    /// against a test of every pair: points on a folded strip, boxes
    /// grown by a radius, every 37th by one as long as the strip (an edge
    /// stretched across the cloth is found wherever it reaches).
    #[test]
    fn queries_find_what_every_pair_finds() {
        let n = 200;
        let rest: Vec<DVec3> = (0..n)
            .map(|i| DVec3::new(i as f64 * 0.01, 0.0, 0.0))
            .collect();
        // Folded in three, layers 5 mm apart.
        let now: Vec<Vec3<f64>> = (0..n)
            .map(|i| {
                let (layer, s) = (i / 70, i % 70);
                let along = if layer % 2 == 0 { s } else { 69 - s };
                Vec3::from_f64(DVec3::new(along as f64 * 0.01, layer as f64 * 0.005, 0.0))
            })
            .collect();
        let grown = |k: u32| {
            let p = now[k as usize];
            let radius = if k.is_multiple_of(37) { 0.7 } else { 0.012 };
            let g = Vec3::new(radius, radius, radius);
            (p - g, p + g)
        };
        let mut bvh = Bvh::<f64>::new(&rest).expect("hierarchy");
        bvh.refit(grown);
        let mut found = Vec::new();
        bvh.self_pairs(|a, b| {
            if overlap(&grown(a), &grown(b)) {
                found.push((a.min(b), a.max(b)));
            }
        });
        let mut expected = Vec::new();
        for a in 0..n as u32 {
            for b in a + 1..n as u32 {
                if overlap(&grown(a), &grown(b)) {
                    expected.push((a, b));
                }
            }
        }
        let count = found.len();
        found.sort_unstable();
        found.dedup();
        assert_eq!(found.len(), count, "a pair found twice");
        assert_eq!(found, expected);
        assert!(
            expected.len() > 2 * n,
            "the layers meet: {}",
            expected.len()
        );

        let q = grown(100);
        let mut hits = Vec::new();
        bvh.overlapping(&q, |k| {
            if overlap(&grown(k), &q) {
                hits.push(k);
            }
        });
        hits.sort_unstable();
        let all: Vec<u32> = (0..n as u32).filter(|&k| overlap(&grown(k), &q)).collect();
        assert_eq!(hits, all);
    }
}
