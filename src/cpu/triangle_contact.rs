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
//! 1. **Candidates**, at `x_old`. Every triangle and edge goes into the
//!    cells of a hashed uniform grid that its box, grown by the query
//!    radius `r` ([`TriangleTopology::query`]: the thickness and the
//!    largest rest triangle gap), covers; the cells are as wide as such a
//!    box of the longest edge at `x_old` (at most
//!    [`MAX_EDGE_STRETCH`](crate::self_collision::MAX_EDGE_STRETCH) × the
//!    longest at rest), so a box covers at most two cells along an axis and
//!    each bucket lists its primitives in index order. Each vertex lists
//!    the triangles within `r` of it from its own cell (`vt`), each edge
//!    the edges within `r` of it from the cells its box covers, each pair
//!    in the lowest cell both boxes cover, so once (`ee`), and each
//!    triangle the vertices that list it (`tv`, `vt` inverted); every list
//!    in index order. Pairs that share a vertex (a seam's two ends count as
//!    one) are not pairs, and a pair nearer than a thickness at rest (the
//!    cloths laid apart) touches at rest: it never collides and bounds
//!    nothing. Each listed pair keeps its distance, its nearest points'
//!    coefficients and its normal at `x_old`.
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
//!    since `x_old` is capped at its `bound`. Two primitives of a pair `D`
//!    apart at `x_old` then have every vertex moving less than `0.45 D`; a
//!    point of either (a convex combination of its vertices, moving along
//!    the straight line between its two positions) moves less than
//!    `0.45 D`, so the two points close less than `0.9 D` and never meet
//!    between `x_old` and the end of the step. Two triangles can pierce
//!    each other only after one's edge met the other's surface, a
//!    vertex–triangle or edge–edge pair first; a pair farther than `r`
//!    apart is at least `r` away, and every bound is at most `0.45 r`. So a
//!    state with no crossing steps to one with none. What this leaves out:
//!    pairs touching at rest (neither pushed nor bounded: a cell folding
//!    over its immediate neighbour, which only the springs resist, where
//!    the thickness exceeds the triangles' height), edges stretched past
//!    [`MAX_EDGE_STRETCH`](crate::self_collision::MAX_EDGE_STRETCH), and the pins and colliders, which move vertices
//!    after this.
//!
//! 5. **Rounds**: where the bound stopped a vertex in open cloth (no pair
//!    of its that could touch) short of its prediction, another round
//!    searches again from where this one left the vertices (as safe a
//!    start as the step's) and takes those vertices on, up to
//!    [`MAX_ROUNDS`]; a vertex with such a pair stays where the last round
//!    left it (pursued again, a prediction through a layer would close the
//!    pair by the bound once a round).
//!
//! The bound is what limits speed, and it is absolute: a common
//! displacement (the particle method's reference particle) would let a
//! vertex resting on a collider be dragged by the cloth's fall and the
//! collider then undo it past the bound. A vertex moves at most `0.45 r` a
//! round in open space (about a third of the rest spacing: with four
//! rounds 10 m/s for a 33² metre cloth at 1/240 s) and `0.45 d` a step
//! where another layer is `d` away, so layers approach and part by at most
//! that much a step.

use super::collide::{contact, CONTACT_SLOP};
use super::self_collision::bucket;
use super::{System, Workspace};
use crate::budget::try_vec;
use crate::error::Result;
use crate::real::{Real, Vec3};
use crate::self_collision::{table_size, SelfCollisionR, TriangleTopology, BOUND_FRACTION};

/// The most cells a primitive's box spans along an axis: cells are a
/// longest edge and two query radii wide, so a box of an edge grown by a
/// radius on each side spans at most two; an edge stretched past
/// [`MAX_EDGE_STRETCH`](crate::self_collision::MAX_EDGE_STRETCH) is cut
/// to that many (what it then misses, the docs say).
const MAX_BOX_CELLS: i32 = 2;

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

/// A cell range: the lowest and highest cell a box covers.
type CellBox = ([i32; 3], [i32; 3]);

/// Primitives hashed into every cell their box covers, each bucket's
/// entries in primitive order (the build visits primitives in order and
/// sorts by bucket stably), each entry with its cell to tell apart the
/// cells a bucket mixes.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct BoxGrid<R> {
    /// Each primitive's box \[m\], lowest and highest corner.
    pub spans: Vec<(Vec3<R>, Vec3<R>)>,
    /// The cell range of each primitive's box.
    pub boxes: Vec<CellBox>,
    /// Per bucket, the start of its run in `entries`; `table + 1`.
    pub start: Vec<u32>,
    /// `(cell, primitive)`, bucket by bucket.
    pub entries: Vec<([i32; 3], u32)>,
    /// The buckets (a power of two).
    pub table: usize,
    scratch: Vec<(u32, [i32; 3], u32)>,
    cursor: Vec<u32>,
}

impl<R> Default for BoxGrid<R> {
    fn default() -> Self {
        BoxGrid {
            spans: Vec::new(),
            boxes: Vec::new(),
            start: Vec::new(),
            entries: Vec::new(),
            table: 0,
            scratch: Vec::new(),
            cursor: Vec::new(),
        }
    }
}

impl<R: Real> BoxGrid<R> {
    /// The grid of `spans`' boxes in cells of inverse size `inv` \[1/m\].
    fn build(&mut self, inv: R) {
        self.boxes.clear();
        self.boxes
            .extend(self.spans.iter().map(|&(lo, hi)| cells_of(lo, hi, inv)));
        self.scratch.clear();
        for (k, &(lo, hi)) in self.boxes.iter().enumerate() {
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        self.scratch.push((0, [x, y, z], k as u32));
                    }
                }
            }
        }
        self.table = table_size(self.scratch.len());
        self.start.clear();
        self.start.resize(self.table + 1, 0);
        for e in &mut self.scratch {
            e.0 = bucket(e.1, self.table) as u32;
            self.start[e.0 as usize + 1] += 1;
        }
        for b in 0..self.table {
            self.start[b + 1] += self.start[b];
        }
        self.entries.clear();
        self.entries.resize(self.scratch.len(), ([0; 3], 0));
        self.cursor.clone_from(&self.start);
        for &(b, cell, k) in &self.scratch {
            self.entries[self.cursor[b as usize] as usize] = (cell, k);
            self.cursor[b as usize] += 1;
        }
    }

    /// The primitives in cell `c`, in order.
    fn cell(&self, c: [i32; 3]) -> impl Iterator<Item = u32> + '_ {
        let b = bucket(c, self.table);
        self.entries[self.start[b] as usize..self.start[b + 1] as usize]
            .iter()
            .filter(move |e| e.0 == c)
            .map(|e| e.1)
    }
}

/// The triangle method's per-step state, allocated once per solver (its
/// lists grow to the most a step has needed).
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct Contacts<R> {
    /// The triangles' boxes grown by the query radius.
    pub triangles: BoxGrid<R>,
    /// The edges' boxes grown by the query radius.
    pub edges: BoxGrid<R>,
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
    /// Per triangle, a cursor of the inversion.
    count: Vec<u32>,
    /// Per vertex, whether a pair of this round's lists involves it.
    near: Vec<bool>,
}

impl<R: Real> Contacts<R> {
    /// The state for `particles` vertices.
    pub fn new(particles: usize) -> Result<Self> {
        const WHAT: &str = "the triangle contacts";
        Ok(Contacts {
            triangles: BoxGrid::default(),
            edges: BoxGrid::default(),
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

/// The cells a box from `lo` to `hi` \[m\] covers in cells of inverse size
/// `inv`, at most [`MAX_BOX_CELLS`] along each axis.
fn cells_of<R: Real>(lo: Vec3<R>, hi: Vec3<R>, inv: R) -> CellBox {
    let cell = |x: Vec3<R>| [0, 1, 2].map(|k| (x.get(k) * inv).to_f64().floor() as i32);
    let (lo, hi) = (cell(lo), cell(hi));
    let hi = [0, 1, 2].map(|k| hi[k].min(lo[k].saturating_add(MAX_BOX_CELLS - 1)));
    (lo, hi)
}

/// The candidates and bounds at `x_old` (steps 1 and 2 of the module).
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
    let longest = topo
        .edges
        .iter()
        .map(|&[a, b]| (x_old[a as usize] - x_old[b as usize]).length())
        .fold(R::ZERO, R::max)
        .min(topo.max_edge);
    let r = topo.query;
    // Cells as wide as a grown edge's box: no box spans more than two
    // (`MAX_BOX_CELLS`); finer cells hold fewer boxes a query meets in
    // vain but put each box in more cells, and measured slower.
    let inv = R::ONE / (longest + r * R::from_f64(2.0));
    let grow = Vec3::new(r, r, r);
    let span = |corners: &[u32]| {
        let mut lo = x_old[corners[0] as usize];
        let mut hi = lo;
        for &i in &corners[1..] {
            let x = x_old[i as usize];
            lo = Vec3::new(lo.x.min(x.x), lo.y.min(x.y), lo.z.min(x.z));
            hi = Vec3::new(hi.x.max(x.x), hi.y.max(x.y), hi.z.max(x.z));
        }
        (lo, hi)
    };
    // Each primitive's box grown by the query radius, and its cells.
    let grown = |(lo, hi): (Vec3<R>, Vec3<R>)| (lo - grow, hi + grow);
    k.triangles.spans.clear();
    k.triangles
        .spans
        .extend(sys.triangles.iter().map(|t| grown(span(t))));
    k.triangles.build(inv);
    k.edges.spans.clear();
    k.edges
        .spans
        .extend(topo.edges.iter().map(|e| grown(span(e))));
    k.edges.build(inv);

    let n = x_old.len();
    k.nearest.fill(r);
    let nearest = &mut k.nearest;
    // A pair's distance at `x_old`, noted on all four vertices (the bound
    // is on the primitives' every point), and its listing: `None` where it
    // is a query radius or more apart or touches at rest.
    let mut consider =
        |pair: &Pair<R>, rest: &dyn Fn() -> Pair<R>, other: u32| -> Option<Listed<R>> {
            let gap = combine(x_old, pair.v, pair.g);
            let d = gap.length();
            if d >= r {
                return None;
            }
            let rest = rest();
            if combine(&topo.rest, rest.v, rest.g).length() < c.thickness {
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
    k.vt.clear();
    for p in 0..n {
        let cell = cells_of(x_old[p], x_old[p], inv).0;
        for t in k.triangles.cell(cell) {
            let tri = sys.triangles[t as usize];
            if adjacent(topo, &[p], &tri.map(|i| i as usize)) {
                continue;
            }
            let (lo, hi) = k.triangles.spans[t as usize];
            let xp = x_old[p];
            if [0, 1, 2]
                .iter()
                .any(|&a| xp.get(a) < lo.get(a) || xp.get(a) > hi.get(a))
            {
                continue;
            }
            let pair = vertex_triangle(x_old, p, tri);
            if let Some(l) = consider(&pair, &|| vertex_triangle(&topo.rest, p, tri), t) {
                k.vt.items.push(l);
            }
        }
        k.vt.close();
    }
    k.ee.clear();
    for (e, &ends) in topo.edges.iter().enumerate() {
        let (elo, ehi) = span(&ends);
        let (lo, hi) = cells_of(elo, ehi, inv);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let cell = [x, y, z];
                    for f in k.edges.cell(cell) {
                        let other = topo.edges[f as usize];
                        // Each pair once: in the lowest cell both boxes cover.
                        let their = k.edges.boxes[f as usize].0;
                        if f as usize == e
                            || [0, 1, 2].map(|a| lo[a].max(their[a])) != cell
                            || adjacent(topo, &ends.map(|i| i as usize), &other.map(|i| i as usize))
                        {
                            continue;
                        }
                        let (flo, fhi) = k.edges.spans[f as usize];
                        if [0, 1, 2]
                            .iter()
                            .any(|&a| elo.get(a) > fhi.get(a) || ehi.get(a) < flo.get(a))
                        {
                            continue;
                        }
                        let pe = (e as u32, ends);
                        let pf = (f, other);
                        let pair = edge_edge(x_old, pe, pf);
                        if let Some(l) = consider(&pair, &|| edge_edge(&topo.rest, pe, pf), f) {
                            k.ee.items.push(l);
                        }
                    }
                }
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
    let mut add = |v: [usize; 4], l: &Listed<R>, slot: usize| {
        if let Some((push, s, depth)) = response(&k.weight, c, y, x_old, v, l.g, l.n, slot) {
            sum += push * depth;
            depths += depth;
            slip += s;
            contacts += 1;
        }
    };
    for l in k.vt.of(p) {
        let t = sys.triangles[l.other as usize].map(|i| i as usize);
        add([p, t[0], t[1], t[2]], l, 0);
    }
    for &t in sys.triangle_adj.of(p) {
        let tri = sys.triangles[t as usize].map(|i| i as usize);
        let slot = 1 + tri.iter().position(|&i| i == p).unwrap_or(0);
        for l in k.tv.of(t as usize) {
            add([l.other as usize, tri[0], tri[1], tri[2]], l, slot);
        }
    }
    for &e in topo.vertex_edges.of(p) {
        let ends = topo.edges[e as usize];
        for l in k.ee.of(e as usize) {
            let v = edge_pair_vertices((e, ends), (l.other, topo.edges[l.other as usize]));
            let slot = v.iter().position(|&i| i == p).unwrap_or(0);
            add(v, l, slot);
        }
    }
    (contacts > 0).then(|| {
        let push = if depths > R::ZERO {
            sum / depths
        } else {
            Vec3::ZERO
        };
        y[p] + (push - slip / R::from_f64(f64::from(contacts)))
    })
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
        let topo = c.triangles.as_ref();
        for (p, near) in k.near.iter_mut().enumerate() {
            *near = !k.vt.of(p).is_empty()
                || sys
                    .triangle_adj
                    .of(p)
                    .iter()
                    .any(|&t| !k.tv.of(t as usize).is_empty())
                || topo.is_some_and(|topo| {
                    topo.vertex_edges
                        .of(p)
                        .iter()
                        .any(|&e| !k.ee.of(e as usize).is_empty())
                });
        }
        if round > 0 {
            // Only a vertex with no such pair goes on towards its
            // prediction; one in contact stays where the last round left
            // it, as with a single round (pursued again, a prediction
            // through a layer would close the pair by the bound once a
            // round).
            for (p, xp) in x.iter_mut().enumerate() {
                *xp = if k.near[p] { k.start[p] } else { k.target[p] };
            }
        }
        let mut short = false;
        for pass in 0..c.iterations {
            k.snapshot.copy_from_slice(x);
            let last = pass + 1 == c.iterations;
            for (p, xp) in x.iter_mut().enumerate() {
                if let Some(new) = respond(sys, c, k, &k.snapshot, &k.start, p) {
                    *xp = new;
                }
                if last && sys.inv_mass[p] > R::ZERO {
                    let dx = *xp - k.start[p];
                    let l2 = dx.length_squared();
                    let cap = k.bound[p];
                    if l2 > cap * cap {
                        *xp = k.start[p] + dx * (cap / l2.sqrt());
                        // Another round can take it further only if it is
                        // in open cloth.
                        short |= !k.near[p];
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
