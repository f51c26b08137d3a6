//! Self-collision's triangle method (`[self_collision] method =
//! "triangles"`): contact between a vertex and a triangle and between two
//! edges, at a thickness independent of the mesh's resolution, with a
//! per-vertex bound on each step's motion that no two primitives can
//! cross — deterministic and gather-only, as the particle method
//! ([`super::self_collision`]) is.
//!
//! Each step, where the particle method runs (after the fix-up, or after
//! the implicit step's `x += dt v`), from the positions `x_old` the step
//! started at (which this method left with no crossing) and the predicted
//! positions `x`:
//!
//! 1. **Candidates**, at `x_old`. A search lists every pair nearer than
//!    the query radius `r` ([`TriangleTopology::query`]: the thickness and
//!    the largest rest triangle gap) and a skin ([`Candidates`]), from two
//!    bounding-volume hierarchies cut once from the rest mesh and fitted
//!    to the cloth where it is (`cpu::bvh`): each vertex against the
//!    triangles' boxes grown by that reach, and the edges against one
//!    another, their boxes grown by half of it, each pair once and listed
//!    on both edges. Pairs that share a vertex (a seam's two ends count as
//!    one) are not pairs, and a pair nearer than a thickness at rest (the
//!    cloths laid apart) touches at rest: it never collides and bounds
//!    nothing. The lists serve the rounds that follow while the cloth has
//!    deformed by less than half the skin since (a common translation does
//!    not count); each round measures their pairs at its start and lists
//!    those within `r`: per vertex the triangles (`vt`), per edge the
//!    edges (`ee`, each pair measured once), per triangle the vertices
//!    that list it (`tv`, `vt` inverted); every list in index order. Each
//!    listed pair keeps its distance, its nearest points' coefficients and
//!    its normal at `x_old`.
//! 2. **Bound**: each vertex's `bound` is [`BOUND_FRACTION`] × the
//!    distance at `x_old` of the nearest pair it is part of, or of `r`
//!    where that is nearer. A pair whose two primitives' largest bounds
//!    cannot close it to within the thickness leaves the lists (it only
//!    bounded).
//! 3. **Respond**, `iterations` Jacobi passes from a snapshot `y`: each
//!    listed pair is a constraint `Σ g_i y_i · n ≥ thickness` with its
//!    nearest points' coefficients `g` (a vertex 1; a triangle's corners
//!    −barycentric; an edge's ends `1 − s`, `s`, or their negatives on the
//!    other edge) and its normal `n` both taken at `x_old`: the side each
//!    pair was on where nothing crossed, so a prediction that carried a
//!    vertex through a triangle pushes it back, not on through. Vertex `i`
//!    takes `g_i w_i / W × (thickness − Σ g_j y_j · n)` along `n`, `W =
//!    Σ g_j² w_j` (the projection that closes the constraint, shared as
//!    the inverse masses `w` say; a vertex on a collider at the step's
//!    start, or predicted into one, counts as immovable, as the collider
//!    would undo its share).
//!    Friction removes the pair's relative tangential displacement over
//!    the step the same way, capped at `friction ×` the normal push
//!    (Coulomb). Every vertex of a pair evaluates it alike (the same
//!    function of the same data), so the pair acts equally and oppositely,
//!    and each vertex writes only itself. A vertex moves by the mean of
//!    its contacts' pushes weighted by their depths, less the mean of their
//!    friction corrections. Not the sum, as the particle method takes: a
//!    vertex over a layer has one vertex–triangle contact and several
//!    edge–edge contacts with it, all pushing it the same way, and their
//!    sum throws it off the layer (measured: layers bouncing a centimetre
//!    up, and pairs at a third of the thickness under the next landing's
//!    Jacobi overshoot). Not the plain mean either: a coarse triangle's
//!    corner resting on a fine layer has a score of shallow contacts and
//!    one deep one (the triangle's flat middle over a curved layer), and
//!    the plain mean gives the deep one a twentieth of its push.
//! 4. **No crossing**: at the last pass each free vertex's displacement
//!    since `x_old`, less a translation `c` common to every vertex, is
//!    capped at its `bound`; `c` is chosen so that every vertex the cap
//!    leaves alone, pinned or held by a collider included, already lies
//!    within its bound of it (`common_translation`: zero unless the
//!    cloth moves as a whole). Two primitives of a pair `D` apart at
//!    `x_old` then have every vertex moving less than `0.45 D` relative to
//!    `c`; a point of either (a convex combination of its vertices, moving
//!    along the straight line between its two positions) moves less than
//!    `0.45 D` relative to it, so the two points close less than `0.9 D`
//!    and never meet between `x_old` and the end of the step. Two triangles can pierce
//!    each other only after one's edge met the other's surface, a
//!    vertex–triangle or edge–edge pair first; a pair farther than `r`
//!    apart is at least `r` away, and every bound is at most `0.45 r`. So a
//!    state with no crossing steps to one with none. What this leaves out:
//!    pairs touching at rest (neither pushed nor bounded: a cell folding
//!    over its immediate neighbour, which only the springs resist, where
//!    the thickness exceeds the triangles' height), and the pins and
//!    colliders, which move vertices after this.
//!
//! 5. **Rounds**: where the bound stopped a vertex short of its
//!    prediction, another round searches again from where this one left
//!    the vertices (as safe a start as the step's) and takes them on, up
//!    to [`MAX_ROUNDS`]: a vertex in open cloth (no pair of its that could
//!    touch) towards its prediction, one with such a pair only along its
//!    layers (its way there less the part along each pair's normal that
//!    closes the pair; pursued whole, a prediction through a layer would
//!    close the pair by the bound once a round).
//!
//! The bound is what limits speed wherever the cloth does not move as a
//! whole. A translation of everything (the particle method's reference
//! particle) would let a vertex resting on a collider be dragged by the
//! cloth's fall and the collider then undo it past the bound, and let a
//! falling layer close on a resting one twice as fast; so the translation
//! is zero as soon as a part of the cloth rests, and the bound is then
//! absolute. A vertex moves at most `0.45 r` a round in open space (about
//! a third of the rest spacing: with four rounds 10 m/s for a 33² metre
//! cloth at 1/240 s) and `0.45 d` a step where another layer is `d` away,
//! so layers approach and part by at most that much a step; a cloth
//! falling or thrown whole, folded or stacked, is not slowed.

use super::collide::{contact, CONTACT_SLOP};
use super::{System, Workspace};
use crate::budget::{try_collect, try_vec};
use crate::error::Result;
use crate::real::{Real, Vec3};
use crate::self_collision::{
    box_of, boxes_apart, SelfCollisionR, TriangleTopology, BOUND_FRACTION,
};
use glam::DVec3;

use super::bvh::{overlap, Aabb, Bvh};

/// A listed pair: the other primitive, and the pair's nearest points'
/// coefficients `g` and unit normal `n` at the step's start.
#[derive(Clone, Copy, Debug)]
#[doc(hidden)]
pub struct Listed<R> {
    /// The other primitive: a triangle in `vt`, a vertex in `tv`, an edge
    /// in `ee`.
    pub other: u32,
    /// The coefficients of the pair's vertices ([`Pair`]).
    pub g: [R; 4],
    /// From the second primitive's nearest point to the first's.
    pub n: Vec3<R>,
    /// The distance \[m\] between them.
    pub d: R,
}

/// Lists with their starts: entry `k`'s items are `items[start[k]..start[k + 1]]`.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct Lists<T> {
    /// `len + 1` offsets.
    pub start: Vec<u32>,
    /// The items.
    pub items: Vec<T>,
}

impl<T> Default for Lists<T> {
    fn default() -> Self {
        Lists {
            start: Vec::new(),
            items: Vec::new(),
        }
    }
}

impl<T> Lists<T> {
    /// Entry `k`'s items.
    pub fn of(&self, k: usize) -> &[T] {
        &self.items[self.start[k] as usize..self.start[k + 1] as usize]
    }

    fn clear(&mut self) {
        self.start.clear();
        self.start.push(0);
        self.items.clear();
    }

    fn close(&mut self) {
        self.start.push(self.items.len() as u32);
    }

    /// Keeps the items of entry `k` for which `keep(k, item)`, in order.
    fn retain(&mut self, mut keep: impl FnMut(usize, &T) -> bool) {
        let mut to = 0;
        for k in 0..self.start.len() - 1 {
            let (from, end) = (self.start[k] as usize, self.start[k + 1] as usize);
            self.start[k] = to as u32;
            for i in from..end {
                if keep(k, &self.items[i]) {
                    self.items.swap(to, i);
                    to += 1;
                }
            }
        }
        if let Some(last) = self.start.last_mut() {
            *last = to as u32;
        }
        self.items.truncate(to);
    }
}

/// The triangle method's per-step state, allocated once per solver (its
/// lists grow to the most a step has needed).
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct Contacts<R> {
    /// The hierarchy of the triangles, their boxes grown by the search's
    /// reach.
    triangle_tree: Bvh<R>,
    /// The hierarchy of the edges, their boxes grown by half the reach
    /// (two overlap where the edges may lie within the reach).
    edge_tree: Bvh<R>,
    /// Each triangle's box grown by the reach, as last searched.
    triangle_boxes: Vec<Aabb<R>>,
    /// Each edge's box grown by half the reach, as last searched.
    edge_boxes: Vec<Aabb<R>>,
    /// Per vertex, the triangles near it.
    pub vt: Lists<Listed<R>>,
    /// Per triangle, the vertices near it (`vt` inverted).
    pub tv: Lists<Listed<R>>,
    /// Per edge, the edges near it.
    pub ee: Lists<Listed<R>>,
    /// Per vertex, the largest displacement this step \[m\].
    pub bound: Vec<R>,
    /// Per vertex, the inverse mass \[1/kg\] its contacts share pushes by:
    /// 0 where it is pinned, touches a collider at the round's start or is
    /// predicted into one.
    pub weight: Vec<R>,
    /// The snapshot a pass reads.
    pub snapshot: Vec<Vec3<R>>,
    /// Where the step would take the vertices (the prediction).
    pub target: Vec<Vec3<R>>,
    /// Where a round starts: the step's start, then where the last round
    /// left the vertices (with no crossing, as the step's start).
    pub start: Vec<Vec3<R>>,
    /// Per vertex, the distance \[m\] of its nearest pair (the bound's).
    nearest: Vec<R>,
    /// Per list, a cursor of the inversions (`tv`, the edges' lists).
    count: Vec<u32>,
    /// Per vertex, whether a pair of this round's lists involves it.
    near: Vec<bool>,
    /// Per item of `candidates.ee`, its pair measured this round.
    measured: Vec<Option<Listed<R>>>,
    /// The search's pairs of edges, each `(lower, higher)`.
    edge_pairs: Vec<(u32, u32)>,
    /// The candidates: per vertex the triangles, per edge the edges,
    /// within the query radius and its skin where they were built
    /// ([`Candidates`]).
    pub candidates: Candidates<R>,
}

/// Pairs that may come within the query radius `r` before the lists are
/// built again: every pair nearer than `r + skin` at the positions they
/// were built at, excluding the adjacent and those touching at rest, each
/// list in index order. A pair left out was `r + skin` or more apart then,
/// and while no vertex has moved more than `skin / 2` relative to the
/// others (a displacement less a common translation), no two points of
/// it have closed by `skin`: it is still `r` or more apart. So a round
/// searches the hierarchies only when the cloth has deformed by half a
/// skin since the last search, and otherwise only measures its listed
/// pairs. The skin is worn only where it pays ([`SKIN_FRACTION`]).
#[derive(Clone, Debug, Default)]
#[doc(hidden)]
pub struct Candidates<R> {
    /// Per vertex, the triangles that may come near it.
    pub vt: Lists<u32>,
    /// Per edge, the edges that may come near it.
    pub ee: Lists<u32>,
    /// Per item of `ee` listing `f` in edge `e`'s list, with `f < e`: the
    /// place of `e` in `f`'s list (each pair is measured once, from its
    /// lower edge); `u32::MAX` where `f > e`.
    pub mirror: Vec<u32>,
    /// Where the lists were built \[m\] (empty before the first search).
    pub at: Vec<Vec3<R>>,
    /// The skin they were built with \[m\].
    pub skin: R,
    /// The rounds that have used them.
    pub uses: u32,
    /// How many times the lists were built.
    pub builds: u64,
}

impl<R: Real> Contacts<R> {
    /// The state for `topo`'s vertices and edges and `triangles` (the
    /// hierarchies cut from their rest positions).
    pub fn new(triangles: &[[u32; 3]], topo: &TriangleTopology<R>) -> Result<Self> {
        const WHAT: &str = "the triangle contacts";
        let particles = topo.rest.len();
        let rest = |i: u32| DVec3::from_array(topo.rest[i as usize].to_f64());
        let centroid = |corners: &[u32]| {
            corners.iter().map(|&i| rest(i)).sum::<DVec3>() / corners.len() as f64
        };
        let triangle_centroids = try_collect(triangles.iter().map(|t| centroid(t)), WHAT)?;
        let edge_centroids = try_collect(topo.edges.iter().map(|e| centroid(e)), WHAT)?;
        let empty = (Vec3::ZERO, Vec3::ZERO);
        Ok(Contacts {
            triangle_tree: Bvh::new(&triangle_centroids)?,
            edge_tree: Bvh::new(&edge_centroids)?,
            triangle_boxes: try_vec(triangles.len(), empty, WHAT)?,
            edge_boxes: try_vec(topo.edges.len(), empty, WHAT)?,
            vt: Lists::default(),
            tv: Lists::default(),
            ee: Lists::default(),
            bound: try_vec(particles, R::ZERO, WHAT)?,
            weight: try_vec(particles, R::ZERO, WHAT)?,
            snapshot: try_vec(particles, Vec3::ZERO, WHAT)?,
            target: try_vec(particles, Vec3::ZERO, WHAT)?,
            start: try_vec(particles, Vec3::ZERO, WHAT)?,
            nearest: try_vec(particles, R::ZERO, WHAT)?,
            count: Vec::new(),
            near: try_vec(particles, false, WHAT)?,
            measured: Vec::new(),
            edge_pairs: Vec::new(),
            candidates: Candidates::default(),
        })
    }
}

/// Barycentric weights of the point of triangle `a b c` nearest `p`
/// (Ericson, *Real-Time Collision Detection*, 5.1.5: the Voronoi region of
/// `p`, then its projection).
pub fn nearest_on_triangle<R: Real>(p: Vec3<R>, a: Vec3<R>, b: Vec3<R>, c: Vec3<R>) -> [R; 3] {
    let (o, i) = (R::ZERO, R::ONE);
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= o && d2 <= o {
        return [i, o, o];
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= o && d4 <= d3 {
        return [o, i, o];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= o && d1 >= o && d3 <= o {
        let v = d1 / (d1 - d3);
        return [i - v, v, o];
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= o && d5 <= d6 {
        return [o, o, i];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= o && d2 >= o && d6 <= o {
        let w = d2 / (d2 - d6);
        return [i - w, o, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= o && d4 - d3 >= o && d5 - d6 >= o {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [o, i - w, w];
    }
    let denom = i / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    [i - v - w, v, w]
}

fn clamp01<R: Real>(v: R) -> R {
    v.max(R::ZERO).min(R::ONE)
}

/// Parameters `(s, u)` of the nearest points `p1 + s (q1 − p1)` and `p2 +
/// u (q2 − p2)` of two segments (Ericson 5.1.9; a segment of zero length
/// is its first end, parallel segments take `s = 0`).
pub fn nearest_on_segments<R: Real>(p1: Vec3<R>, q1: Vec3<R>, p2: Vec3<R>, q2: Vec3<R>) -> (R, R) {
    let o = R::ZERO;
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.dot(d1);
    let e = d2.dot(d2);
    let f = d2.dot(r);
    if a <= o && e <= o {
        return (o, o);
    }
    if a <= o {
        return (o, clamp01(f / e));
    }
    let c = d1.dot(r);
    if e <= o {
        return (clamp01(-c / a), o);
    }
    let b = d1.dot(d2);
    let denom = a * e - b * b;
    let mut s = if denom > o {
        clamp01((b * f - c * e) / denom)
    } else {
        o
    };
    let mut u = (b * s + f) / e;
    if u < o {
        u = o;
        s = clamp01(-c / a);
    } else if u > R::ONE {
        u = R::ONE;
        s = clamp01((b - c) / a);
    }
    (s, u)
}

/// A pair's four vertices and the coefficients `g` of its closest points'
/// difference `Σ g_i x_i` (a vertex–triangle pair's: the vertex and the
/// triangle's corners; an edge–edge pair's: the lower-numbered edge's ends
/// and the other's).
#[derive(Clone, Copy, Debug)]
pub struct Pair<R> {
    /// The vertices.
    pub v: [usize; 4],
    /// The coefficients.
    pub g: [R; 4],
}

/// Vertex `q` against triangle `t` at positions `x` (nearest point by
/// [`nearest_on_triangle`]).
pub fn vertex_triangle<R: Real>(x: &[Vec3<R>], q: usize, t: [u32; 3]) -> Pair<R> {
    let c = t.map(|i| i as usize);
    let b = nearest_on_triangle(x[q], x[c[0]], x[c[1]], x[c[2]]);
    Pair {
        v: [q, c[0], c[1], c[2]],
        g: [R::ONE, -b[0], -b[1], -b[2]],
    }
}

/// The vertices of edges `e` and `f`, the lower-numbered edge first
/// whichever the caller holds, so that both compute the same bits.
fn edge_pair_vertices(e: (u32, [u32; 2]), f: (u32, [u32; 2])) -> [usize; 4] {
    let (a, b) = if e.0 <= f.0 { (e.1, f.1) } else { (f.1, e.1) };
    [a[0], a[1], b[0], b[1]].map(|i| i as usize)
}

/// Edge `e` against edge `f` (each its index and ends) at positions `x`.
pub fn edge_edge<R: Real>(x: &[Vec3<R>], e: (u32, [u32; 2]), f: (u32, [u32; 2])) -> Pair<R> {
    let v = edge_pair_vertices(e, f);
    let (s, u) = nearest_on_segments(x[v[0]], x[v[1]], x[v[2]], x[v[3]]);
    Pair {
        v,
        g: [R::ONE - s, s, u - R::ONE, -u],
    }
}

/// `Σ g_i x_i` over a pair's vertices `v`.
fn combine<R: Real>(x: &[Vec3<R>], v: [usize; 4], g: [R; 4]) -> Vec3<R> {
    (x[v[0]] * g[0] + x[v[1]] * g[1]) + (x[v[2]] * g[2] + x[v[3]] * g[3])
}

/// Vertex slot `k`'s response to the pair of vertices `v`, coefficients
/// `g` and normal `n` at the snapshot `y`, the step having started at
/// `x_old`: its push, its friction correction and the pair's depth \[m\]
/// (how far it is inside the thickness), or `None` where the pair lies a
/// thickness or more apart along `n` (or has no weight).
#[allow(
    clippy::too_many_arguments,
    reason = "a pair's data, each a plain value"
)]
fn response<R: Real>(
    weight: &[R],
    c: &SelfCollisionR<R>,
    y: &[Vec3<R>],
    x_old: &[Vec3<R>],
    v: [usize; 4],
    g: [R; 4],
    n: Vec3<R>,
    k: usize,
) -> Option<(Vec3<R>, Vec3<R>, R)> {
    let d = combine(y, v, g).dot(n);
    if d >= c.thickness {
        return None;
    }
    let w = v.map(|i| weight[i]);
    let big_w =
        (g[0] * g[0] * w[0] + g[1] * g[1] * w[1]) + (g[2] * g[2] * w[2] + g[3] * g[3] * w[3]);
    if big_w <= R::ZERO {
        return None;
    }
    let share = g[k] * w[k] / big_w;
    let depth = c.thickness - d;
    let push = n * (depth * share);
    let moved = v.map(|i| y[i] - x_old[i]);
    let rel = (moved[0] * g[0] + moved[1] * g[1]) + (moved[2] * g[2] + moved[3] * g[3]);
    let tangent = rel - n * rel.dot(n);
    let slide = tangent.length();
    let slip = if slide > R::ZERO {
        tangent * (share * R::ONE.min(c.friction * depth / slide))
    } else {
        Vec3::ZERO
    };
    Some((push, slip, depth))
}

/// Whether two primitives with vertices `a` and `b` share one (a seam's
/// two ends counting as one vertex).
fn adjacent(topo: &TriangleTopology<impl Real>, a: &[usize], b: &[usize]) -> bool {
    let partner = |i: usize| topo.partner[i] as usize;
    a.iter().any(|&i| {
        b.iter()
            .any(|&j| i == j || partner(i) == j || i == partner(j))
    })
}

/// The skin of the candidate lists ([`Candidates`]), as a fraction of the
/// query radius, where it is worn: where the last lists' rounds deformed
/// the cloth by less than the skin allows a round (half of it), so that
/// it lasts a round or more — a cloth settling or resting (the three
/// layers of `layers` settling on a ball search half as often, for a
/// quarter less time). Where it deforms faster (a sheet swinging from its
/// pins at 1/50 s, a centimetre a round), lists built with it cost more
/// to build and to measure than they save, and each search lists only
/// the pairs within the radius. A quarter measured best of 0.125, 0.25
/// and 0.5 on the settling layers (the swinging sheet wears none).
pub const SKIN_FRACTION: f64 = 0.25;

/// The share of the skin the cloth may deform by before the lists are
/// built again: the rest is a margin for the rounding of the distances
/// that decided which pairs were listed (relative errors of a few `f32`
/// ulps of the coordinates, far below a tenth of a skin of millimetres
/// at any scene's scale).
const SKIN_SLACK: f64 = 0.9;

/// The middle of the box of `displacements` \[m\]; `None` where there are
/// none or one is not finite.
fn middle<R: Real>(mut displacements: impl Iterator<Item = Vec3<R>>) -> Option<Vec3<R>> {
    let first = displacements.next()?;
    let (mut lo, mut hi) = (first, first);
    for u in std::iter::once(first).chain(displacements) {
        if !u.is_finite() {
            return None;
        }
        (lo, hi) = (lo.min(u), hi.max(u));
    }
    Some((lo + hi) * R::from_f64(0.5))
}

/// The largest displacement \[m\] of a vertex from `at` to `x` relative to
/// a common translation (the middle of the displacements' box): two points
/// of the cloth have closed by at most twice it. `None` where a position
/// is not finite.
fn deformation<R: Real>(at: &[Vec3<R>], x: &[Vec3<R>]) -> Option<R> {
    let common = middle(at.iter().zip(x).map(|(&a, &b)| b - a))?;
    let most = at
        .iter()
        .zip(x)
        .map(|(&a, &b)| (b - a - common).length())
        .fold(R::ZERO, R::max);
    most.is_finite().then_some(most)
}

/// The candidate lists at `x` (module step 1's search): every pair of a
/// vertex and a triangle or of two edges nearer than `reach` (the query
/// radius and the skin), neither adjacent nor touching at rest.
fn search<R: Real>(
    sys: &System<R>,
    c: &SelfCollisionR<R>,
    topo: &TriangleTopology<R>,
    x: &[Vec3<R>],
    reach: R,
    k: &mut Contacts<R>,
) {
    let grown = |corners: &[u32], by: R| {
        let (lo, hi) = box_of(x, corners);
        let g = Vec3::new(by, by, by);
        (lo - g, hi + g)
    };
    // A pair is a candidate where it is nearer than the reach and does not
    // touch at rest (measured only where the rest boxes do not tell).
    let t = c.thickness;
    let candidate = |pair: &Pair<R>, apart: bool, rest: &dyn Fn() -> Pair<R>| {
        combine(x, pair.v, pair.g).length() < reach
            && (apart || {
                let rest = rest();
                combine(&topo.rest, rest.v, rest.g).length() >= t
            })
    };
    let list = &mut k.candidates;
    for (b, t) in k.triangle_boxes.iter_mut().zip(&sys.triangles) {
        *b = grown(t, reach);
    }
    let boxes = &k.triangle_boxes;
    k.triangle_tree.refit(|t| boxes[t as usize]);
    list.vt.clear();
    for (p, &xp) in x.iter().enumerate() {
        let from = list.vt.items.len();
        k.triangle_tree.overlapping(&(xp, xp), |t| {
            let tri = sys.triangles[t as usize];
            if !overlap(&boxes[t as usize], &(xp, xp))
                || adjacent(topo, &[p], &tri.map(|i| i as usize))
            {
                return;
            }
            let pair = vertex_triangle(x, p, tri);
            let rest_p = (topo.rest[p], topo.rest[p]);
            let apart = boxes_apart(rest_p, topo.triangle_rest_boxes[t as usize], c.thickness);
            if candidate(&pair, apart, &|| vertex_triangle(&topo.rest, p, tri)) {
                list.vt.items.push(t);
            }
        });
        // In index order, whichever leaves held them.
        list.vt.items[from..].sort_unstable();
        list.vt.close();
    }

    // Each pair of edges once, then listed on both.
    let half = reach * R::from_f64(0.5);
    for (b, e) in k.edge_boxes.iter_mut().zip(&topo.edges) {
        *b = grown(e, half);
    }
    let boxes = &k.edge_boxes;
    k.edge_tree.refit(|e| boxes[e as usize]);
    let pairs = &mut k.edge_pairs;
    pairs.clear();
    k.edge_tree.self_pairs(|a, b| {
        let (e, f) = (a.min(b), a.max(b));
        let (ends, other) = (topo.edges[e as usize], topo.edges[f as usize]);
        if !overlap(&boxes[e as usize], &boxes[f as usize])
            || adjacent(topo, &ends.map(|i| i as usize), &other.map(|i| i as usize))
        {
            return;
        }
        let (pe, pf) = ((e, ends), (f, other));
        let rest = &topo.edge_rest_boxes;
        let apart = boxes_apart(rest[e as usize], rest[f as usize], t);
        if candidate(&edge_edge(x, pe, pf), apart, &|| {
            edge_edge(&topo.rest, pe, pf)
        }) {
            pairs.push((e, f));
        }
    });
    pairs.sort_unstable();
    // Both edges of each pair list the other. The pairs run by their lower
    // edge, then the higher, so an edge's list takes the lower edges it
    // pairs with first, in order, then the higher, in order: every list in
    // index order. The higher edge's item points to the lower's, where
    // the pair is measured.
    let ee = &mut list.ee;
    ee.start.clear();
    ee.start.resize(topo.edges.len() + 1, 0);
    for &(e, f) in pairs.iter() {
        ee.start[e as usize + 1] += 1;
        ee.start[f as usize + 1] += 1;
    }
    for e in 0..topo.edges.len() {
        ee.start[e + 1] += ee.start[e];
    }
    let total = 2 * pairs.len();
    ee.items.clear();
    ee.items.resize(total, 0);
    list.mirror.clear();
    list.mirror.resize(total, u32::MAX);
    k.count.clone_from(&ee.start);
    for &(e, f) in pairs.iter() {
        let low = k.count[e as usize];
        let high = k.count[f as usize];
        k.count[e as usize] += 1;
        k.count[f as usize] += 1;
        ee.items[low as usize] = f;
        ee.items[high as usize] = e;
        list.mirror[high as usize] = low;
    }
    list.at.clear();
    list.at.extend_from_slice(x);
    list.builds += 1;
}

/// The listed pairs and the bounds at `x_old` (steps 1 and 2 of the
/// module), from the candidate lists, searched again first where the cloth
/// has deformed past their skin since they were built.
pub fn find<R: Real>(
    sys: &System<R>,
    c: &SelfCollisionR<R>,
    x_old: &[Vec3<R>],
    x: &[Vec3<R>],
    clock: u32,
    k: &mut Contacts<R>,
) {
    let Some(topo) = &c.triangles else {
        return;
    };
    // A vertex on a collider at the step's start, or predicted into one, is
    // the collider's to move: the contact pushes the other side all the
    // way (the collider would undo its share, after the bound).
    let slop = R::from_f64(CONTACT_SLOP);
    for (p, w) in k.weight.iter_mut().enumerate() {
        let held = contact(sys, x_old[p], slop, clock).is_some()
            || contact(sys, x[p], R::ZERO, clock).is_some();
        *w = if held { R::ZERO } else { sys.inv_mass[p] };
    }
    let r = topo.query;
    let list = &mut k.candidates;
    let slack = R::from_f64(SKIN_SLACK);
    let deformed = if list.at.len() == x_old.len() {
        deformation(&list.at, x_old)
    } else {
        None
    };
    if deformed.is_some_and(|m| m * R::from_f64(2.0) <= list.skin * slack) {
        list.uses += 1;
    } else {
        // Worn where the last lists' rounds deformed the cloth, on
        // average, by less than a full skin allows (and at the first
        // search).
        let full = r * R::from_f64(SKIN_FRACTION);
        let slow = match deformed {
            Some(m) => m * R::from_f64(2.0) <= full * slack * R::from_usize(list.uses as usize),
            None => list.at.is_empty(),
        };
        let skin = if slow { full } else { R::ZERO };
        search(sys, c, topo, x_old, r + skin, k);
        k.candidates.skin = skin;
        k.candidates.uses = 1;
    }
    k.nearest.fill(r);
    let nearest = &mut k.nearest;
    // A pair's distance at `x_old`, noted on all four vertices (the bound
    // is on the primitives' every point), and its listing: `None` where it
    // is a query radius or more apart.
    let mut consider = |pair: &Pair<R>, other: u32| -> Option<Listed<R>> {
        let gap = combine(x_old, pair.v, pair.g);
        let d = gap.length();
        if d >= r {
            return None;
        }
        for &i in &pair.v {
            nearest[i] = nearest[i].min(d);
        }
        (d > R::ZERO).then(|| Listed {
            other,
            g: pair.g,
            n: gap / d,
            d,
        })
    };
    let list = &k.candidates;
    k.vt.clear();
    for p in 0..x_old.len() {
        for &t in list.vt.of(p) {
            let pair = vertex_triangle(x_old, p, sys.triangles[t as usize]);
            if let Some(l) = consider(&pair, t) {
                k.vt.items.push(l);
            }
        }
        k.vt.close();
    }
    // Each edge pair measured once, from its lower edge (the same bits
    // from either: `edge_edge` orders the pair), and noted on both.
    k.measured.clear();
    for (e, &ends) in topo.edges.iter().enumerate() {
        let from = list.ee.start[e] as usize;
        for (i, &f) in list.ee.of(e).iter().enumerate() {
            let mut measured = None;
            if list.mirror[from + i] == u32::MAX {
                let pair = edge_edge(x_old, (e as u32, ends), (f, topo.edges[f as usize]));
                measured = consider(&pair, f);
            }
            k.measured.push(measured);
        }
    }
    k.ee.clear();
    for e in 0..topo.edges.len() {
        let from = list.ee.start[e] as usize;
        for (i, &f) in list.ee.of(e).iter().enumerate() {
            let item = from + i;
            let measured = match list.mirror[item] {
                u32::MAX => k.measured[item],
                mirror => k.measured[mirror as usize].map(|l| Listed { other: f, ..l }),
            };
            if let Some(l) = measured {
                k.ee.items.push(l);
            }
        }
        k.ee.close();
    }
    let fraction = R::from_f64(BOUND_FRACTION);
    for (b, &d) in k.bound.iter_mut().zip(&k.nearest) {
        *b = fraction * d;
    }
    // Only a pair whose primitives' bounds let it close to within the
    // thickness can touch this step: the others only bound.
    let bound = &k.bound;
    let reach = |v: &[u32]| v.iter().map(|&i| bound[i as usize]).fold(R::ZERO, R::max);
    let t = c.thickness;
    k.vt.retain(|p, l| l.d - (bound[p] + reach(&sys.triangles[l.other as usize])) < t);
    k.ee.retain(|e, l| l.d - (reach(&topo.edges[e]) + reach(&topo.edges[l.other as usize])) < t);
    invert(&k.vt, sys.triangles.len(), &mut k.count, &mut k.tv);
}

/// `tv`: per triangle, the vertices whose `vt` lists it, in vertex order.
fn invert<R: Real>(
    vt: &Lists<Listed<R>>,
    triangles: usize,
    count: &mut Vec<u32>,
    tv: &mut Lists<Listed<R>>,
) {
    count.clear();
    count.resize(triangles + 1, 0);
    for l in &vt.items {
        count[l.other as usize + 1] += 1;
    }
    for t in 0..triangles {
        count[t + 1] += count[t];
    }
    tv.start.clone_from(count);
    tv.items.clear();
    tv.items.extend_from_slice(&vt.items);
    for p in 0..vt.start.len() - 1 {
        for l in vt.of(p) {
            let slot = &mut count[l.other as usize];
            tv.items[*slot as usize] = Listed {
                other: p as u32,
                ..*l
            };
            *slot += 1;
        }
    }
}

/// Calls `pair(v, l, slot)` for each listed pair vertex `p` is part of, in
/// a fixed order: the pair's vertices `v`, its listing `l` and `p`'s place
/// in `v`.
fn each_pair<R: Real>(
    sys: &System<R>,
    topo: &TriangleTopology<R>,
    k: &Contacts<R>,
    p: usize,
    mut pair: impl FnMut([usize; 4], &Listed<R>, usize),
) {
    for l in k.vt.of(p) {
        let t = sys.triangles[l.other as usize].map(|i| i as usize);
        pair([p, t[0], t[1], t[2]], l, 0);
    }
    for &t in sys.triangle_adj.of(p) {
        let tri = sys.triangles[t as usize].map(|i| i as usize);
        let slot = 1 + tri.iter().position(|&i| i == p).unwrap_or(0);
        for l in k.tv.of(t as usize) {
            pair([l.other as usize, tri[0], tri[1], tri[2]], l, slot);
        }
    }
    for &e in topo.vertex_edges.of(p) {
        let ends = topo.edges[e as usize];
        for l in k.ee.of(e as usize) {
            let v = edge_pair_vertices((e, ends), (l.other, topo.edges[l.other as usize]));
            let slot = v.iter().position(|&i| i == p).unwrap_or(0);
            pair(v, l, slot);
        }
    }
}

/// What is left of vertex `p`'s way `d` \[m\] to its prediction once every
/// part of it that closes one of its pairs (along the pair's normal at
/// the round's start) is taken out: the way along its layers.
fn along_layers<R: Real>(
    sys: &System<R>,
    topo: &TriangleTopology<R>,
    k: &Contacts<R>,
    p: usize,
    mut d: Vec3<R>,
) -> Vec3<R> {
    each_pair(sys, topo, k, p, |_, l, slot| {
        let dn = d.dot(l.n);
        if l.g[slot] * dn < R::ZERO {
            d -= l.n * dn;
        }
    });
    d
}

/// Vertex `p`'s new position after one pass from the snapshot `y` (step 3
/// of the module), `None` without a contact.
pub fn respond<R: Real>(
    sys: &System<R>,
    c: &SelfCollisionR<R>,
    k: &Contacts<R>,
    y: &[Vec3<R>],
    x_old: &[Vec3<R>],
    p: usize,
) -> Option<Vec3<R>> {
    let topo = c.triangles.as_ref()?;
    if k.weight[p] <= R::ZERO {
        return None;
    }
    let mut sum = Vec3::ZERO;
    let mut depths = R::ZERO;
    let mut slip = Vec3::ZERO;
    let mut contacts = 0u32;
    each_pair(sys, topo, k, p, |v, l, slot| {
        if let Some((push, s, depth)) = response(&k.weight, c, y, x_old, v, l.g, l.n, slot) {
            sum += push * depth;
            depths += depth;
            slip += s;
            contacts += 1;
        }
    });
    (contacts > 0).then(|| {
        let push = if depths > R::ZERO {
            sum / depths
        } else {
            Vec3::ZERO
        };
        y[p] + (push - slip / R::from_f64(f64::from(contacts)))
    })
}

/// The translation \[m\] a round's bound is relative to (module step 4):
/// the middle of the box of the free vertices' predicted displacements
/// from the round's start, shortened until no vertex the bound would
/// leave where it is predicted (within its bound of the round's start),
/// and no pinned vertex or vertex on or predicted into a collider, lies
/// farther from it than from the start: zero where any part of the cloth
/// rests or moves against the rest, or where one of those fixed vertices
/// is predicted past its bound. So it never drags a vertex, nor lets a
/// moving layer close on a resting one faster than the absolute bound
/// would (measured: relative to the translation within the vertices'
/// bounds alone, layers landing on one another came to 0.47 of a
/// thickness, against 0.6); and a cloth falling or thrown whole, layers
/// and all, is not slowed.
fn common_translation<R: Real>(sys: &System<R>, k: &Contacts<R>, x: &[Vec3<R>]) -> Vec3<R> {
    let moved = |p: usize| x[p] - k.start[p];
    let free = |p: usize| sys.inv_mass[p] > R::ZERO && k.weight[p] > R::ZERO;
    // None where a displacement is not finite.
    let Some(wanted) = middle((0..x.len()).filter(|&p| free(p)).map(moved)) else {
        return Vec3::ZERO;
    };
    let cc = wanted.dot(wanted);
    if !(cc > R::ZERO && cc.is_finite()) {
        return Vec3::ZERO;
    }
    // The largest share `t` of it with `|u − t c| ≤ |u|` for each such
    // vertex: `t ≤ 2 u·c / c·c`.
    let mut share = R::ONE;
    for p in 0..x.len() {
        let u = moved(p);
        let b = k.bound[p];
        let within = u.dot(u) <= b * b;
        if free(p) && !within {
            continue;
        }
        if !within {
            return Vec3::ZERO;
        }
        share = share.min(R::from_f64(2.0) * u.dot(wanted) / cc);
    }
    wanted * share.max(R::ZERO)
}

/// The most detection rounds a step takes: a round ends where a vertex's
/// bound stops it short of where the step would take it, and the next
/// searches again from there. Four lift the speed limit to four bounds a
/// step (10 m/s for a 33² metre cloth at 1/240 s) and cost four searches
/// only in the steps that need them.
pub const MAX_ROUNDS: u32 = 4;

/// The triangle method on the predicted positions `x`, the step having
/// started at `w.x_old`: rounds of candidates, passes and the bound, each
/// from where the last left the vertices (the first from `x_old`), until
/// no vertex is stopped short or [`MAX_ROUNDS`] have run. Returns whether
/// it moved any vertex from its prediction.
pub fn apply<R: Real>(sys: &System<R>, x: &mut [Vec3<R>], w: &mut Workspace<R>) -> bool {
    let (Some(c), Some(k)) = (&sys.self_collision, &mut w.contacts) else {
        return false;
    };
    let Some(topo) = &c.triangles else {
        return false;
    };
    k.target.copy_from_slice(x);
    k.start.copy_from_slice(&w.x_old);
    for round in 0..MAX_ROUNDS {
        if round > 0 {
            k.start.copy_from_slice(x);
        }
        // Lent out for the search, which fills the rest of `k` (a move,
        // no allocation).
        let (start, target) = (std::mem::take(&mut k.start), std::mem::take(&mut k.target));
        find(sys, c, &start, &target, w.clock, k);
        (k.start, k.target) = (start, target);
        // A vertex with a pair that could touch this round.
        let mut near = std::mem::take(&mut k.near);
        for (p, near) in near.iter_mut().enumerate() {
            *near = false;
            each_pair(sys, topo, k, p, |_, _, _| *near = true);
        }
        k.near = near;
        if round > 0 {
            // A vertex with no such pair goes on towards its prediction;
            // one in contact only along its layers (pursued whole, a
            // prediction through a layer closed the pair by the bound
            // once a round, to within rounding of touching).
            for (p, xp) in x.iter_mut().enumerate() {
                *xp = if k.near[p] {
                    k.start[p] + along_layers(sys, topo, k, p, k.target[p] - k.start[p])
                } else {
                    k.target[p]
                };
            }
        }
        let shift = common_translation(sys, k, x);
        let mut short = false;
        for pass in 0..c.iterations {
            k.snapshot.copy_from_slice(x);
            let last = pass + 1 == c.iterations;
            for (p, xp) in x.iter_mut().enumerate() {
                if let Some(new) = respond(sys, c, k, &k.snapshot, &k.start, p) {
                    *xp = new;
                }
                if last && sys.inv_mass[p] > R::ZERO {
                    let dx = *xp - k.start[p] - shift;
                    let l2 = dx.length_squared();
                    let cap = k.bound[p];
                    if l2 > cap * cap {
                        *xp = (k.start[p] + shift) + dx * (cap / l2.sqrt());
                        short = true;
                    }
                }
            }
        }
        if !short {
            break;
        }
    }
    // Moved where a round left a vertex short or a contact pushed it: a
    // step whose rounds carried every vertex all the way is the step
    // without self-collision, to the bit.
    x.iter().zip(&k.target).any(|(a, b)| a != b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::CpuSolver;
    use crate::params::ContactMethod;

    /// A listed pair's every field, as bits.
    fn bits(l: &Listed<f32>) -> [u32; 9] {
        let [g0, g1, g2, g3] = l.g.map(f32::to_bits);
        [
            l.other,
            g0,
            g1,
            g2,
            g3,
            l.n.x.to_bits(),
            l.n.y.to_bits(),
            l.n.z.to_bits(),
            l.d.to_bits(),
        ]
    }

    fn all(lists: &Lists<Listed<f32>>) -> (Vec<u32>, Vec<[u32; 9]>) {
        (lists.start.clone(), lists.items.iter().map(bits).collect())
    }

    /// The pairs listed from candidate lists built rounds ago are those a
    /// search from scratch lists, in the same order, to the bit: the heap
    /// (a 33² cloth falling into folds on the floor, in `f32`) at every
    /// step of its first second, while its lists are both kept and built
    /// again along the way.
    #[test]
    fn reused_candidates_list_what_a_search_lists() {
        let Ok(mut scene) = crate::Scene::builtin("heap") else {
            panic!("the heap is built in");
        };
        if let Some(c) = &mut scene.params.self_collision {
            c.method = ContactMethod::Triangles;
        } else {
            panic!("the heap has self-collision");
        }
        let model = scene.model().expect("the heap's model");
        let mut solver = CpuSolver::<f32>::new(&model, &scene.params).expect("solver");
        let (mut kept, mut built) = (0, 0);
        for step in 1..=240 {
            solver.step().expect("step");
            let sys = &solver.sys;
            let c = sys.self_collision.as_ref().expect("self-collision");
            let x = &solver.state.x;
            let clock = solver.work.clock;
            let mut reused = solver.work.contacts.clone().expect("the triangle method");
            let before = reused.candidates.builds;
            find(sys, c, x, x, clock, &mut reused);
            if reused.candidates.builds == before {
                kept += 1;
            } else {
                built += 1;
            }
            let topo = c.triangles.as_ref().expect("the triangle method");
            let mut fresh = Contacts::new(&sys.triangles, topo).expect("state");
            find(sys, c, x, x, clock, &mut fresh);
            let bound = |k: &Contacts<f32>| k.bound.iter().map(|b| b.to_bits()).collect::<Vec<_>>();
            for (what, same) in [
                ("vt", all(&reused.vt) == all(&fresh.vt)),
                ("tv", all(&reused.tv) == all(&fresh.tv)),
                ("ee", all(&reused.ee) == all(&fresh.ee)),
                ("bound", bound(&reused) == bound(&fresh)),
            ] {
                assert!(same, "step {step}: the {what} differ from a search's");
            }
        }
        assert!(kept > 0 && built > 0, "kept {kept}, built {built}");
    }

    fn v(x: f64, y: f64, z: f64) -> Vec3<f64> {
        Vec3::from_f64(glam::DVec3::new(x, y, z))
    }

    #[test]
    fn nearest_points_are_the_regions_expected() {
        let (a, b, c) = (v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0));
        assert_eq!(
            nearest_on_triangle(v(0.25, 0.25, 1.0), a, b, c),
            [0.5, 0.25, 0.25]
        );
        assert_eq!(
            nearest_on_triangle(v(-1.0, -1.0, 0.0), a, b, c),
            [1.0, 0.0, 0.0]
        );
        assert_eq!(
            nearest_on_triangle(v(0.5, -1.0, 0.5), a, b, c),
            [0.5, 0.5, 0.0]
        );
        assert_eq!(
            nearest_on_triangle(v(1.0, 1.0, 0.0), a, b, c),
            [0.0, 0.5, 0.5]
        );
        let (s, u) = nearest_on_segments(a, b, v(0.5, -1.0, 1.0), v(0.5, 1.0, 1.0));
        assert_eq!((s, u), (0.5, 0.5));
        let (s, u) = nearest_on_segments(a, b, v(2.0, 0.0, 1.0), v(3.0, 0.0, 1.0));
        assert_eq!((s, u), (1.0, 0.0));
    }
}
