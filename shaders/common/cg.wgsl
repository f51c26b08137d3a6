// Shared by the CG kernels (implicit integrator and the scalable
// semi-implicit filter). Twins: cpu::implicit and cpu::mat3.

// Twin: implicit::Filter::apply. `f` is W_Z's w (kind), `n` W_FILTER's xyz.
fn filter_apply(kind: f32, n: vec3<f32>, a: vec3<f32>) -> vec3<f32> {
    if (kind == FILTER_FIXED) {
        return vec3<f32>(0.0);
    }
    if (kind == FILTER_PLANE) {
        return a - n * dot3(a, n);
    }
    return a;
}

fn filter_of(p: u32, a: vec3<f32>) -> vec3<f32> {
    return filter_apply(work[wi(W_Z, p)].w, work[wi(W_FILTER, p)].xyz, a);
}

// Twin: mat3::Sym3::mul with the preconditioner of particle p
// (diag = xx, yy, zz; off = xy, xz, yz).
fn precond_mul(p: u32, a: vec3<f32>) -> vec3<f32> {
    let d = work[wi(W_PRE_DIAG, p)].xyz;
    let o = work[wi(W_PRE_OFF, p)].xyz;
    return vec3<f32>(
        d.x * a.x + o.x * a.y + o.y * a.z,
        o.x * a.x + d.y * a.y + o.z * a.z,
        o.y * a.x + o.z * a.y + d.z * a.z,
    );
}

// Twin: SpringBlock::apply, B d = a d + b n (n·d); block = (n, a), b.
fn block_apply(s: u32, d: vec3<f32>) -> vec3<f32> {
    let blk = spring_work[si(S_BLOCK, s)];
    let b = spring_work[si(S_KV_B, s)].w;
    return d * blk.w + blk.xyz * (b * dot3(blk.xyz, d));
}

// (A a)_p, unfiltered, for the vector in work section `sec`: m a_p, then
// ±B_s (a_i − a_j) over the incident springs in adjacency order — the order
// in which the CPU's scatter reaches particle p.
fn apply_a(sec: u32, p: u32) -> vec3<f32> {
    var acc = work[wi(sec, p)].xyz * v[p].w;
    let begin = topo[p];
    let end = topo[p + 1u];
    for (var k = begin; k < end; k++) {
        let e = topo[params.spring_adj_entries + k];
        let s = e >> 1u;
        let sp = springs[s];
        let y = block_apply(s, work[wi(sec, sp.i)].xyz - work[wi(sec, sp.j)].xyz);
        if ((e & 1u) == 0u) {
            acc += y;
        } else {
            acc -= y;
        }
    }
    return acc;
}

var<workgroup> scratch: array<f32, WORKGROUP>;
var<workgroup> shared_value: f32;
var<workgroup> shared_flag: u32;

// Twin: implicit::tree_sum inside one block: writes this workgroup's sum of
// `value` to partials[slot]. Every invocation of the workgroup must call it.
fn reduce_to_partial(value: f32, lid: u32, wid: u32, slot: u32) {
    scratch[lid] = value;
    workgroupBarrier();
    for (var s = WORKGROUP / 2u; s > 0u; s = s >> 1u) {
        if (lid < s) {
            scratch[lid] += scratch[lid + s];
        }
        workgroupBarrier();
    }
    if (lid == 0u) {
        partials[slot * params.partial_count + wid] = scratch[0];
    }
}

// Sum of the partials of `slot`, in sequence (twin: the block loop of
// tree_sum). Call from one invocation.
fn sum_partials(slot: u32) -> f32 {
    var total = 0.0;
    for (var k = 0u; k < params.partial_count; k++) {
        total += partials[slot * params.partial_count + k];
    }
    return total;
}

// Whether CG has stopped before the iteration reading δ from `rs_slot`:
// converged (δ ≤ tol² δ0, the CPU loop's condition negated) or broken down.
// The same for every invocation of the dispatch, and sticky: once any
// kernel sees it, the status word keeps every later iteration stopped
// (their δ slots hold stale values).
fn cg_stopped(lid: u32, rs_slot: u32) -> bool {
    if (lid == 0u) {
        var stop = atomicLoad(&status[STATUS_CG_STOPPED]);
        if (stop == 0u) {
            let delta = sum_partials(rs_slot);
            let delta0 = sum_partials(P_D0);
            if (!(delta > params.cg_tolerance_sq * delta0)) {
                stop = 1u;
                atomicStore(&status[STATUS_CG_STOPPED], 1u);
            }
        }
        shared_flag = stop;
    }
    return workgroupUniformLoad(&shared_flag) != 0u;
}
