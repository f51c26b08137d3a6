// Self-collision, one item each (twin: cpu::self_collision): the grid's
// build — count, scan, scatter, rank — and the Jacobi passes of the
// response, called by the self_collision_* kernels (an item per
// invocation; the scan one workgroup) and by the workgroup kernels
// (self_collision_phases, after their fix-up or prediction), so each
// piece is written once.
//
// The grid lives in the cloth's `work` sections W_SC_* (see
// src/kernel_config.rs) and its bucket counters in the status words after
// the cloth's own (sc_counter): the counts are the only atomics, and
// every sum is taken in an order fixed by particle indices, so two runs
// give the same bits.

#include "common/bindings.wgsl"
#include "common/physics.wgsl"

// Entry `k` (counted within the cloth) of `work` section `section`: the
// grid's arrays are indexed by place in the grid, not by particle.
fn sc_entry(section: u32, k: u32) -> u32 {
    return params.work_base + section * params.particle_count + k;
}

// The status word counting bucket `b`'s particles.
fn sc_counter(b: u32) -> u32 {
    return params.status_base + STATUS_WORDS + b;
}

// The cell of a point at `xp` (twin: cpu::self_collision::cell_of).
fn sc_cell(xp: vec3<f32>) -> vec3<i32> {
    return vec3<i32>(floor(xp * params.self_collision.w));
}

// The lowest of the 2 × 2 × 2 cells a particle built at `xp` visits: per
// axis its cell less one where it lies in the cell's lower half (twin:
// cpu::self_collision::cell_of; s − floor(s) is exact).
fn sc_corner(xp: vec3<f32>) -> vec3<i32> {
    let s = xp * params.self_collision.w;
    let lower = (s - floor(s)) < vec3<f32>(0.5);
    return vec3<i32>(floor(s)) - vec3<i32>(select(vec3<u32>(0u), vec3<u32>(1u), lower));
}

// Twin: cpu::self_collision::bucket (params.self_grid.y buckets, a power
// of two).
fn sc_bucket(c: vec3<i32>) -> u32 {
    let u = bitcast<vec3<u32>>(c);
    let h = (u.x * SC_HASH_X) ^ (u.y * SC_HASH_Y) ^ (u.z * SC_HASH_Z);
    return h & (params.self_grid.y - 1u);
}

// Bucket b's run in the grid: [start, end).
fn sc_run(b: u32) -> vec2<u32> {
    let e = bitcast<vec4<u32>>(work[sc_entry(W_SC_BUCKETS, b >> 1u)]);
    return select(e.xy, e.zw, (b & 1u) == 1u);
}

// Particle p's rest position, in exclusion radii (the cloths laid apart).
fn sc_rest(p: u32) -> vec3<f32> {
    return bitcast<vec3<f32>>(model[params.self_grid.w + local(p)].xyz);
}

// Particle p's seam partner's rest position (its own off seams), after
// the cloth's rest positions.
fn sc_seam_rest(p: u32) -> vec3<f32> {
    return bitcast<vec3<f32>>(model[params.self_grid.w + params.particle_count + local(p)].xyz);
}

fn sc_near(a: vec3<f32>, b: vec3<f32>) -> bool {
    let d = a - b;
    return dot3(d, d) < 1.0;
}

// Whether particles p and q never collide (twin:
// cpu::self_collision::excluded): their rest positions, or either's seam
// partner's and the other's, less than an exclusion radius apart.
fn sc_excluded(p: u32, q: u32) -> bool {
    let rp = sc_rest(p);
    let rq = sc_rest(q);
    return sc_near(rp, rq) || sc_near(sc_seam_rest(p), rq) || sc_near(rp, sc_seam_rest(q));
}

// Particle p into the grid (twin: the first loop of
// cpu::self_collision::build): its predicted position, from the section
// the fix-up or prediction left it in, copied to W_SC_A for the passes;
// its cell and bucket into W_SC_CELL; its bucket's count up by one.
fn self_collision_count_item(p: u32) {
    let xp = work[wi(atomicLoad(&status[sw(STATUS_FIXUP_RESULT)]), p)].xyz;
    work[wi(W_SC_A, p)] = vec4<f32>(xp, 0.0);
    let c = sc_cell(xp);
    let b = sc_bucket(c);
    work[wi(W_SC_CELL, p)] = bitcast<vec4<f32>>(vec4<u32>(bitcast<vec3<u32>>(c), b));
    atomicAdd(&status[sc_counter(b)], 1u);
}

var<workgroup> sc_sums: array<u32, SUM_GROUP>;

// The prefix sum of the bucket counts into each bucket's run (twin: the
// prefix sum of cpu::self_collision::build), by one workgroup: invocation
// `lid` takes a run of whole bucket pairs, the workgroup scans the runs'
// totals. Call from uniform control flow, every invocation.
fn self_collision_scan_phase(lid: u32) {
    let pairs = params.self_grid.y >> 1u;
    let chunk = (pairs + SUM_GROUP - 1u) / SUM_GROUP;
    let first = min(lid * chunk, pairs);
    let last = min(first + chunk, pairs);
    var total = 0u;
    for (var k = first; k < last; k++) {
        total += atomicLoad(&status[sc_counter(2u * k)]) + atomicLoad(&status[sc_counter(2u * k + 1u)]);
    }
    sc_sums[lid] = total;
    workgroupBarrier();
    for (var d = 1u; d < SUM_GROUP; d <<= 1u) {
        var add = 0u;
        if (lid >= d) {
            add = sc_sums[lid - d];
        }
        workgroupBarrier();
        sc_sums[lid] += add;
        workgroupBarrier();
    }
    var at = sc_sums[lid] - total;
    for (var k = first; k < last; k++) {
        let even = at + atomicLoad(&status[sc_counter(2u * k)]);
        let odd = even + atomicLoad(&status[sc_counter(2u * k + 1u)]);
        work[sc_entry(W_SC_BUCKETS, k)] = bitcast<vec4<f32>>(vec4<u32>(at, even, even, odd));
        at = odd;
    }
}

// Particle p into its bucket's run, at the place its count's decrement
// gives (any order; self_collision_rank_item orders it). The counts end at
// zero, ready for the next step's build.
fn self_collision_scatter_item(p: u32) {
    let b = bitcast<u32>(work[wi(W_SC_CELL, p)].w);
    let k = sc_run(b).x + atomicSub(&status[sc_counter(b)], 1u) - 1u;
    work[sc_entry(W_SC_UNORDERED, k)] = vec4<f32>(bitcast<f32>(p), 0.0, 0.0, 0.0);
}

// Particle p to its place in index order within its bucket's run (twin:
// the scatter of cpu::self_collision::build): after the particles of
// lower index, with its cell for the passes' comparison.
fn self_collision_rank_item(p: u32) {
    let cell = bitcast<vec4<u32>>(work[wi(W_SC_CELL, p)]);
    let run = sc_run(cell.w);
    var rank = 0u;
    for (var k = run.x; k < run.y; k++) {
        rank += u32(bitcast<u32>(work[sc_entry(W_SC_UNORDERED, k)].x) < p);
    }
    work[sc_entry(W_SC_ORDER, run.x + rank)] = bitcast<vec4<f32>>(vec4<u32>(p, cell.xyz));
}

// One Jacobi pass for particle p (twin: cpu::self_collision::respond):
// its contacts from section `src`, its new position into `dst`; on the
// `last` pass also the cap on its displacement since the step's start (x)
// relative to the reference particle's. Returns whether it moved the particle
// (a contact or the cap), as the CPU's `moved`.
fn self_collision_respond_item(p: u32, src: u32, dst: u32, last: bool) -> bool {
    let xp = work[wi(src, p)].xyz;
    let start = x[p];
    let wp = start.w;
    var out = xp;
    var moved = false;
    if (wp > 0.0) {
        let t = params.self_collision.x;
        let friction = params.self_collision.y;
        let t2 = t * t;
        let corner = sc_corner(work[wi(W_SC_A, p)].xyz);
        var sum = vec3<f32>(0.0);
        var slip = vec3<f32>(0.0);
        var contacts = 0u;
        // The 2 × 2 × 2 cells from the corner, x fastest (cpu's
        // NEIGHBOUR_CELLS).
        for (var d = 0u; d < 8u; d++) {
            let cell = corner + vec3<i32>(vec3<u32>(d & 1u, (d >> 1u) & 1u, d >> 2u));
            let run = sc_run(sc_bucket(cell));
            for (var k = run.x; k < run.y; k++) {
                let e = bitcast<vec4<u32>>(work[sc_entry(W_SC_ORDER, k)]);
                let q = e.x;
                if (q == p || any(bitcast<vec3<i32>>(e.yzw) != cell)) {
                    continue;
                }
                let xq = work[wi(src, q)].xyz;
                let diff = xp - xq;
                let d2 = dot3(diff, diff);
                if (d2 >= t2 || d2 <= 0.0 || sc_excluded(p, q)) {
                    continue;
                }
                let dist = sqrt(d2);
                let n = diff / dist;
                let other = x[q];
                let share = wp / (wp + other.w);
                let push = (t - dist) * share;
                sum += unseen3(n * push);
                let rel = (xp - start.xyz) - (xq - other.xyz);
                let tangent = rel - unseen3(n * dot3(rel, n));
                let slide = len3(tangent);
                if (slide > 0.0) {
                    let limit = friction * push / slide;
                    slip += unseen3(tangent * select(limit, share, share < limit));
                }
                contacts += 1u;
            }
        }
        if (contacts > 0u) {
            // The pushes summed, the friction corrections averaged (never
            // past the slide: see the twin).
            out = xp + (sum - slip / f32(contacts));
            moved = true;
        }
        if (last) {
            // The cap on the displacement relative to the reference
            // particle's (params.self_grid.z) in this pass's snapshot.
            let r = params.particle_base + params.self_grid.z;
            let carried = work[wi(src, r)].xyz - x[r].xyz;
            let cap = params.self_collision.z;
            let dx = (out - start.xyz) - carried;
            let l2 = dot3(dx, dx);
            if (l2 > cap * cap) {
                out = (start.xyz + carried) + unseen3(dx * (cap / sqrt(l2)));
                moved = true;
            }
        }
    }
    work[wi(dst, p)] = vec4<f32>(out, 0.0);
    return moved;
}

// Records that a self-collision pass moved something: the step's end
// rebuilds the velocities (explicit, semi-implicit: as after the fix-up)
// or adds Δx / dt (implicit).
fn self_collision_moved() {
    atomicStore(&status[sw(STATUS_FIXUP_MOVED)], 1u);
}

// Pass k's sections: it reads W_SC_A (the first), then W_SC_B and W_SC_C
// in turn, so W_SC_A keeps the passes' start; the last writes the
// section the step's end reads (STATUS_FIXUP_RESULT).
fn sc_pass_src(k: u32) -> u32 {
    return select(select(W_SC_C, W_SC_B, (k & 1u) == 1u), W_SC_A, k == 0u);
}
fn sc_pass_dst(k: u32, last: bool) -> u32 {
    if (last) {
        return atomicLoad(&status[sw(STATUS_FIXUP_RESULT)]);
    }
    return select(W_SC_C, W_SC_B, (k & 1u) == 0u);
}
