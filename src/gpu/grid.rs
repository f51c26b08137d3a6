//! The regular-grid layout of a cloth's springs on the device.
//!
//! A cloth built by [`Model::new`] is a grid: every spring joins a particle
//! to the one a fixed row/column offset away, and springs of one direction
//! share their rest length. For such a cloth the solver stores spring `s`
//! at *slot* `direction × particles + owner` (owner = its first end), and
//! the grid kernels (`override GRID` in `shaders/common/bindings.wgsl`)
//! find a particle's springs and neighbours by arithmetic on its row and
//! column instead of loading an adjacency list. Forces are computed where
//! they are summed, from the neighbours' state, so the explicit and
//! semi-implicit steps need no per-spring pass; the kernels that gather
//! every step or CG iteration take a [`GridBlock`] of particles per
//! invocation.
//!
//! The grid kernels visit a particle's springs in `INCIDENT` order, which
//! is the order of the model's adjacency (ascending spring index), so they
//! sum in the CPU reference's order and stay bit-identical to it. Slots of
//! springs that do not exist (at the border, or of a kind with zero
//! stiffness) hold a spring of zero stiffness from the owner to itself; no
//! kernel reaches them through the adjacency or `INCIDENT`.

use crate::model::Model;
use crate::params::{Params, SpringKind};

/// Directions of the springs a particle owns: `(row offset, column offset,
/// kind)` of its second end. Twin: the direction column of the grid
/// incidence table in `shaders/common/physics.wgsl`.
pub const DIRECTIONS: [(i32, i32, SpringKind); 6] = [
    (0, 1, SpringKind::Stretch),
    (1, 0, SpringKind::Stretch),
    (1, 1, SpringKind::Shear),
    (1, -1, SpringKind::Shear),
    (0, 2, SpringKind::Bend),
    (2, 0, SpringKind::Bend),
];

/// A particle's incident springs in adjacency order: `(row offset, column
/// offset of the other end, direction, the particle is the spring's second
/// end)`. Twin: the grid incidence table in `shaders/common/physics.wgsl`,
/// whose rows the grid kernels pass as literals.
pub const INCIDENT: [(i32, i32, u32, bool); 12] = [
    (-1, 0, 1, true),
    (0, -1, 0, true),
    (0, 1, 0, false),
    (1, 0, 1, false),
    (-1, -1, 2, true),
    (-1, 1, 3, true),
    (1, -1, 3, false),
    (1, 1, 2, false),
    (-2, 0, 5, true),
    (0, -2, 4, true),
    (0, 2, 4, false),
    (2, 0, 5, false),
];

/// How many rows or columns apart the ends of a grid spring lie at most
/// (twin: `GRID_REACH` in `shaders/common/coarse.wgsl`).
pub const REACH: i32 = {
    let mut reach = 0;
    let mut k = 0;
    while k < INCIDENT.len() {
        let (dr, dc, _, _) = INCIDENT[k];
        reach = max_i32(reach, max_i32(dr.abs(), dc.abs()));
        k += 1;
    }
    reach
};

const fn max_i32(a: i32, b: i32) -> i32 {
    if a > b {
        a
    } else {
        b
    }
}

// cg_apply adds the level-2 corrections of the at most 2 × 2 level-2
// aggregates that a block's stencil reaches (`near_load` in
// shaders/common/coarse.wgsl): a block's side plus the reach each way must
// fit in a level-2 aggregate's side.
const _: () =
    assert!(GridBlock::MAX as usize + 2 * REACH as usize <= crate::aggregation::LEVEL_SIDES[1]);

/// Where a grid cloth's springs live on the device.
#[derive(Clone, Debug, PartialEq)]
pub struct GridLayout {
    /// Columns.
    pub nx: u32,
    /// Rows.
    pub ny: u32,
    /// Slot of each of the model's springs.
    pub slot: Vec<u32>,
    /// Rest length of each direction \[m\], as the device holds it (0 where
    /// the direction has no springs).
    pub rest: [f32; 6],
    /// Fix-up length limit of each direction \[m\] (0: not constrained),
    /// as the device holds it.
    pub max_len: [f32; 6],
    /// Bit `k` set: springs of kind `k` exist.
    pub kinds: u32,
}

impl GridLayout {
    /// The layout of `model` under `params`, or `None` when it is not a
    /// grid whose springs all follow [`DIRECTIONS`] with one rest length and
    /// one fix-up limit (as the device holds them, in `f32`) per direction
    /// and its kind's stiffness — then the solver keeps the general
    /// adjacency kernels. A cloth of a material has constants of its own per
    /// spring (its border springs carry half a cell's width), which the
    /// grid kernels, reading one stiffness per kind, cannot hold.
    pub fn of(model: &Model, params: &Params) -> Option<GridLayout> {
        let spec = model.grid.as_ref()?;
        if !model.own_constants.is_empty() {
            return None;
        }
        let (nx, ny) = (spec.nx, spec.ny);
        let n = model.particle_count();
        if nx * ny != n || 6 * n > u32::MAX as usize / 2 {
            return None;
        }
        let mut slot = Vec::with_capacity(model.springs.len());
        let mut rest: [Option<f32>; 6] = [None; 6];
        let mut max_len: [Option<f32>; 6] = [None; 6];
        let mut kinds = 0u32;
        for (s, sp) in model.springs.iter().enumerate() {
            let (i, j) = (sp.i as usize, sp.j as usize);
            let dr = (j / nx) as i64 - (i / nx) as i64;
            let dc = (j % nx) as i64 - (i % nx) as i64;
            let dir = DIRECTIONS.iter().position(|&(r, c, kind)| {
                i64::from(r) == dr && i64::from(c) == dc && kind == sp.kind
            })?;
            for (seen, value) in [
                (&mut rest[dir], sp.rest as f32),
                (&mut max_len[dir], model.fixup_limit(s, params) as f32),
            ] {
                match *seen {
                    None => *seen = Some(value),
                    Some(v) if v.to_bits() == value.to_bits() => {}
                    Some(_) => return None,
                }
            }
            kinds |= 1 << sp.kind.index();
            slot.push((dir * n + i) as u32);
        }
        Some(GridLayout {
            nx: nx as u32,
            ny: ny as u32,
            slot,
            rest: rest.map(|r| r.unwrap_or(0.0)),
            max_len: max_len.map(|m| m.unwrap_or(0.0)),
            kinds,
        })
    }

    /// Slots on the device (six per particle).
    pub fn slots(&self) -> usize {
        6 * (self.nx as usize) * (self.ny as usize)
    }

    /// The spring slots incident to particle `p`, in `INCIDENT` order,
    /// with the other particle and whether `p` is the second end — what the
    /// grid kernels visit. The unit tests check the kernels' order against it.
    #[cfg(test)]
    pub fn incident(&self, p: usize) -> Vec<(u32, usize, bool)> {
        let (nx, ny) = (self.nx as i64, self.ny as i64);
        let n = (nx * ny) as usize;
        let (row, col) = ((p as i64) / nx, (p as i64) % nx);
        INCIDENT
            .iter()
            .filter_map(|&(dr, dc, dir, at_j)| {
                let (r, c) = (row + i64::from(dr), col + i64::from(dc));
                let kind = DIRECTIONS[dir as usize].2;
                let inside = (0..ny).contains(&r) && (0..nx).contains(&c);
                if !inside || self.kinds & (1 << kind.index()) == 0 {
                    return None;
                }
                let other = (r * nx + c) as usize;
                let owner = if at_j { other } else { p };
                Some(((dir as usize * n + owner) as u32, other, at_j))
            })
            .collect()
    }
}

/// Particles per invocation of the grid kernels that gather from their
/// neighbours every step or CG iteration (explicit step, fix-up pass, CG
/// product): a block of `cols × rows` particles loads each particle of its
/// stencil once and sums every member's springs from those values.
///
/// Each particle of a grid cloth reads twelve neighbours, so a lone
/// particle loads 13 states; a 4 × 2 block loads 36 for 8 particles. On
/// lavapipe, where every storage load is a per-lane loop, that is most of
/// a gather kernel's time (see `docs/performance.md`). On a real
/// GPU, neighbours come from cache and one particle per invocation keeps
/// every lane busy. Every adapter starts with [`GridBlock::ONE`]: a block
/// repeats each member's whole set-up (forces, contacts, filter) in the
/// kernel, which a CPU adapter's compiler (lavapipe's LLVM) takes several
/// times as long to compile — seconds per kernel variant at 2 × 2, minutes
/// at 4 × 4 with colliders — paid by every scene variant on a cold shader
/// cache, against a step about a third faster at 2 × 2 on lavapipe. A host
/// that runs long on a CPU adapter can set a block
/// ([`GpuTuningMut::set_grid_block`](super::GpuTuningMut::set_grid_block)).
/// Results do not depend on the shape: every member sums its springs in
/// `INCIDENT` order from the same values.
///
/// The kernels' gather is generated for the shape ([`GridBlock::wgsl`]):
/// WGSL has no loops the compilers keep in registers across a stencil, and
/// writing the points out by hand for each shape would repeat one pattern
/// dozens of times.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GridBlock {
    /// Columns of particles per block (1 to [`GridBlock::MAX`]).
    pub cols: u32,
    /// Rows of particles per block (1 to [`GridBlock::MAX`]).
    pub rows: u32,
}

impl Default for GridBlock {
    fn default() -> Self {
        GridBlock::ONE
    }
}

impl GridBlock {
    /// One particle per invocation.
    pub const ONE: GridBlock = GridBlock { cols: 1, rows: 1 };
    /// Largest side: a 4 × 4 block already keeps 52 particle states live.
    pub const MAX: u32 = 4;

    /// Whether both sides are within 1 ..= [`GridBlock::MAX`].
    pub fn is_valid(&self) -> bool {
        (1..=Self::MAX).contains(&self.cols) && (1..=Self::MAX).contains(&self.rows)
    }

    /// Blocks covering an `nx × ny` grid (the last column and row of blocks
    /// may stick out).
    pub fn count(&self, nx: u32, ny: u32) -> u32 {
        nx.div_ceil(self.cols) * ny.div_ceil(self.rows)
    }

    /// The stencil of a block: every particle its members read, as (row,
    /// column) offsets from the block's first particle, in order of first
    /// use (member by member, itself first, then its `INCIDENT` row).
    pub fn stencil(&self) -> Vec<(i32, i32)> {
        let mut points: Vec<(i32, i32)> = Vec::new();
        for (r, c) in self.members() {
            let own = std::iter::once((r, c));
            let others = INCIDENT.iter().map(|&(dr, dc, _, _)| (r + dr, c + dc));
            for point in own.chain(others) {
                if !points.contains(&point) {
                    points.push(point);
                }
            }
        }
        points
    }

    /// The members' offsets from the block's first particle, row by row.
    fn members(&self) -> impl Iterator<Item = (i32, i32)> + '_ {
        let (rows, cols) = (self.rows as i32, self.cols as i32);
        (0..rows).flat_map(move |r| (0..cols).map(move |c| (r, c)))
    }

    /// The WGSL of `grid_block(block)`, which `#include
    /// "generated/grid_block.wgsl"` brings into a kernel (see
    /// [`super::shaders`]). The kernel defines what is gathered through
    /// six hooks: the type `BlockData` of a particle's loaded values and
    /// `block_load(point)` that loads them, once per stencil point (`point`:
    /// a `GridPoint`); the
    /// type `SpringData` and `spring_load(spring, first, second)`, once per
    /// spring the members touch (`spring`: an `Incident` seen from its
    /// first end — see `shaders/common/physics.wgsl` — whose `ok` does not
    /// say whether the first end exists; `first`, `second`: the ends'
    /// values); the accumulator type `BlockAcc`, `block_start(p, own)` and
    /// `block_term(acc, own, other, spring, data)` (`spring` seen from the
    /// member), member by member in `INCIDENT` order; and `block_end(p,
    /// own, acc)`, which uses the sum. Hooks whose result is unused cost
    /// nothing: the compilers drop dead loads.
    pub fn wgsl(&self) -> String {
        use std::fmt::Write;
        let points = self.stencil();
        let at = |p: (i32, i32)| points.iter().position(|&q| q == p).unwrap_or(0);
        let mut s = String::new();
        // Writing to a String cannot fail; `let _` keeps no unwrap here.
        let _ = writeln!(
            s,
            "// Generated by wgcloth::gpu::grid::GridBlock::wgsl for blocks of \
             {} × {} particles.\n\
             const BLOCK_COLS: u32 = {}u;\n\
             const BLOCK_ROWS: u32 = {}u;\n\n\
             // On a grid, gathers block `i` (if there is one) and returns \
             true: the invocation is done. Otherwise returns whether `i` is \
             past the particles (the general kernels' test).\n\
             fn grid_gather_done(i: u32) -> bool {{\n    \
             if (GRID) {{\n        \
             if (i < {}) {{\n            \
             grid_block(i);\n        \
             }}\n        \
             return true;\n    \
             }}\n    \
             return i >= params.particle_count;\n\
             }}\n\n\
             // The (row, column) of block `block`'s first particle \
             (blocks row-major over the grid; params.grid.w blocks).\n\
             fn grid_block_origin(block: u32) -> vec2<i32> {{\n    \
             let across = (params.grid.x + BLOCK_COLS - 1u) / BLOCK_COLS;\n    \
             return vec2<i32>(i32((block / across) * BLOCK_ROWS), \
             i32((block % across) * BLOCK_COLS));\n\
             }}\n\n\
             // Gathers the members of block `block`.\n\
             fn grid_block(block: u32) {{\n    \
             let o = grid_block_origin(block);\n    \
             let oi = u32(o.x) * params.grid.x + u32(o.y);",
            self.cols,
            self.rows,
            self.cols,
            self.rows,
            // One particle per invocation: as many invocations as
            // particles, whatever block the solver's other kernels take
            // (the CG kernels always gather this way).
            if *self == GridBlock::ONE {
                "params.particle_count"
            } else {
                "params.grid.w"
            }
        );
        for (k, &(dr, dc)) in points.iter().enumerate() {
            let _ = writeln!(
                s,
                "    let pt{k} = grid_point(o, oi, vec2<i32>({dr}, {dc}));\n    \
                 let ld{k} = block_load(pt{k});"
            );
        }
        // Each spring the members touch, once: (first end, second end,
        // direction), as stencil points, in order of first use.
        let mut springs: Vec<(usize, usize, u32)> = Vec::new();
        let spring_of = |(r, c): (i32, i32), (dr, dc, dir, at_j): (i32, i32, u32, bool)| {
            let (me, other) = (at((r, c)), at((r + dr, c + dc)));
            if at_j {
                (other, me, dir)
            } else {
                (me, other, dir)
            }
        };
        for member in self.members() {
            for &row in &INCIDENT {
                let spring = spring_of(member, row);
                if !springs.contains(&spring) {
                    springs.push(spring);
                }
            }
        }
        for (k, &(first, second, dir)) in springs.iter().enumerate() {
            let _ = writeln!(
                s,
                "    let sd{k} = spring_load(grid_spring(pt{first}, pt{second}, {dir}u, false), \
                 ld{first}, ld{second});"
            );
        }
        for member in self.members() {
            let me = at(member);
            let _ = writeln!(
                s,
                "    if (pt{me}.ok) {{\n        \
                 var acc = block_start(pt{me}.index, ld{me});"
            );
            for &row in &INCIDENT {
                let (dr, dc, dir, at_j) = row;
                let other = at((member.0 + dr, member.1 + dc));
                let k = springs
                    .iter()
                    .position(|&sp| sp == spring_of(member, row))
                    .unwrap_or(0);
                let _ = writeln!(
                    s,
                    "        acc = block_term(acc, ld{me}, ld{other}, \
                     grid_spring(pt{me}, pt{other}, {dir}u, {at_j}), sd{k});"
                );
            }
            let _ = writeln!(s, "        block_end(pt{me}.index, ld{me}, acc);\n    }}");
        }
        s.push_str("}\n");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{decode_incidence, ClothSpec, Orientation, Pin};
    use crate::params::SpringParams;

    fn grid(nx: usize, ny: usize, stiff: [f64; 3], orientation: Orientation) -> Model {
        let spec = ClothSpec {
            nx,
            ny,
            size: [0.7, 1.3],
            origin: glam::DVec3::new(-0.35, 1.0, -0.65),
            orientation,
            mass: 0.4,
            pins: vec![Pin::Index(0)],
        };
        let m = |k: f64| SpringParams {
            stiffness: k,
            damping: 0.01,
            max_stretch: None,
        };
        match Model::new(&spec, &stiff.map(m)) {
            Ok(model) => model,
            Err(e) => panic!("{nx}×{ny}: {e}"),
        }
    }

    /// The grid kernels' enumeration is the model's adjacency, spring for
    /// spring and in order, for grids small enough to have every border
    /// case and with each kind missing in turn.
    #[test]
    fn incident_order_is_the_adjacency_order() {
        for (nx, ny) in [(2, 2), (3, 2), (2, 5), (4, 4), (5, 7), (9, 3)] {
            for stiff in [
                [1.0, 1.0, 1.0],
                [1.0, 0.0, 1.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 1.0],
            ] {
                for orientation in [Orientation::Horizontal, Orientation::Vertical] {
                    let model = grid(nx, ny, stiff, orientation);
                    let Some(layout) = GridLayout::of(&model, &Params::default()) else {
                        panic!("{nx}×{ny} {stiff:?}: not a grid layout");
                    };
                    for p in 0..model.particle_count() {
                        let want: Vec<(u32, usize, bool)> = model
                            .particle_springs
                            .of(p)
                            .iter()
                            .map(|&e| {
                                let (s, at_j) = decode_incidence(e);
                                let sp = &model.springs[s];
                                let other = if at_j { sp.i } else { sp.j };
                                (layout.slot[s], other as usize, at_j)
                            })
                            .collect();
                        assert_eq!(
                            layout.incident(p),
                            want,
                            "{nx}×{ny} {stiff:?}, particle {p}"
                        );
                    }
                }
            }
        }
    }

    /// A block's stencil holds each of its members and their neighbours
    /// once, and nothing else: 13 points for one particle, 52 for 4 × 4.
    #[test]
    fn a_block_stencil_is_its_members_and_their_neighbours() {
        for cols in 1..=GridBlock::MAX {
            for rows in 1..=GridBlock::MAX {
                let block = GridBlock { cols, rows };
                let stencil = block.stencil();
                let mut want: Vec<(i32, i32)> = Vec::new();
                for (r, c) in block.members() {
                    want.push((r, c));
                    want.extend(INCIDENT.iter().map(|&(dr, dc, _, _)| (r + dr, c + dc)));
                }
                want.sort_unstable();
                want.dedup();
                let mut got = stencil.clone();
                got.sort_unstable();
                assert_eq!(got.len(), stencil.len(), "{block:?}: a point twice");
                assert_eq!(got, want, "{block:?}");
            }
        }
        assert_eq!(GridBlock::ONE.stencil().len(), 13);
        assert_eq!(GridBlock { cols: 4, rows: 4 }.stencil().len(), 52);
        assert_eq!(GridBlock { cols: 4, rows: 4 }.count(129, 129), 33 * 33);
    }

    #[test]
    fn slots_are_distinct_and_in_range() {
        let model = grid(6, 5, [1.0; 3], Orientation::Horizontal);
        let Some(layout) = GridLayout::of(&model, &Params::default()) else {
            panic!("not a grid layout");
        };
        let mut seen = vec![false; layout.slots()];
        for &s in &layout.slot {
            assert!(!seen[s as usize], "slot {s} twice");
            seen[s as usize] = true;
        }
    }

    #[test]
    fn a_model_from_parts_has_no_grid_layout() {
        let model = grid(3, 3, [1.0; 3], Orientation::Horizontal);
        let parts = match Model::from_parts(
            model.rest_positions.clone(),
            model.mass.clone(),
            model.pinned.clone(),
            model.springs.clone(),
            model.triangles.clone(),
        ) {
            Ok(m) => m,
            Err(e) => panic!("{e}"),
        };
        assert!(GridLayout::of(&parts, &Params::default()).is_none());
    }

    #[test]
    fn uneven_rest_lengths_keep_the_general_kernels() {
        let mut model = grid(4, 4, [1.0; 3], Orientation::Horizontal);
        model.springs[0].rest *= 1.01;
        assert!(GridLayout::of(&model, &Params::default()).is_none());
    }

    /// Every built-in scene of one grid cloth gets the grid kernels, and a
    /// mesh scene or a world of several cloths the general ones.
    #[test]
    fn built_in_scenes_are_grids() {
        for &name in crate::Scene::builtin_names() {
            let scene = match crate::Scene::builtin(name) {
                Ok(s) => s,
                Err(e) => panic!("{name}: {e}"),
            };
            let model = match scene.model() {
                Ok(m) => m,
                Err(e) => panic!("{name}: {e}"),
            };
            let grid = GridLayout::of(&model, &scene.params).is_some();
            let one_grid = matches!(&scene.cloths[..], [c] if c.mesh.is_none());
            assert_eq!(grid, one_grid, "{name}");
        }
    }
}
