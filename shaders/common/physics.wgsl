// Physics shared by the kernels, each function the twin of a CPU function
// in src/cpu/ with the operations written out in the same order (no
// built-in `length`, `dot` or `cross`, whose evaluation order and fused
// multiply-adds are the implementation's choice), so the f32 CPU mirror
// and the GPU round the same way wherever the hardware lets them.

#include "common/bindings.wgsl"
#include "common/bending.wgsl"

// True unless NaN or infinite, from the bits (WGSL lets compilers assume
// floats are finite, so `f == f` is not a reliable NaN test).
fn finite1(f: f32) -> bool {
    return (bitcast<u32>(f) & 0x7f800000u) != 0x7f800000u;
}

fn finite3(a: vec3<f32>) -> bool {
    return finite1(a.x) && finite1(a.y) && finite1(a.z);
}

// Twin: cpu::forces::spring_force. Force on end i of spring `sp`; end j
// gets the negative. Both ends evaluate it from i − j, so they agree bit
// for bit.
fn spring_force(sp: Spring, xi: vec3<f32>, xj: vec3<f32>, vi: vec3<f32>, vj: vec3<f32>) -> vec3<f32> {
    return spring_force_of(sp.rest, sp.k, sp.kd, xi, xj, vi, vj);
}

fn spring_force_of(
    rest: f32,
    k: f32,
    kd: f32,
    xi: vec3<f32>,
    xj: vec3<f32>,
    vi: vec3<f32>,
    vj: vec3<f32>,
) -> vec3<f32> {
    let d = xi - xj;
    let l = len3(d);
    var n = vec3<f32>(0.0);
    if (l > TINY) {
        n = d / l;
    }
    let stretch = l - rest;
    if (!has_damping()) {
        return n * (-(k * stretch));
    }
    let rate = dot3(vi - vj, n);
    return n * (-(k * stretch + kd * rate));
}

// Twin: cpu::forces::wind_triangle_force. Wind force on triangle t, already
// divided by three (each vertex's share); the vertices' state comes from
// `sec` (see state_x).
fn wind_triangle_force(t: u32, sec: u32) -> vec3<f32> {
    let base = params.triangles + 3u * t;
    let a = topo(base);
    let b = topo(base + 1u);
    let c = topo(base + 2u);
    let xa = state_x(a, sec);
    let cr = cross3(state_x(b, sec) - xa, state_x(c, sec) - xa);
    let twice_area = len3(cr);
    if (!(finite1(twice_area) && twice_area > TINY)) {
        return vec3<f32>(0.0);
    }
    let third = 1.0 / 3.0;
    let normal = cr / twice_area;
    let area = twice_area * 0.5;
    let u = (state_v(a, sec) + state_v(b, sec) + state_v(c, sec)) * third - params.wind_velocity;
    let un = dot3(u, normal);
    var f = normal * (-params.wind_drag * area * un * abs(un));
    let speed = len3(u);
    if (params.wind_lift > 0.0 && speed > TINY) {
        let dir = u / speed;
        let perp = normal - dir * dot3(normal, dir);
        f += perp * (-params.wind_lift * area * un * speed);
    }
    return f * third;
}

// A particle's incident springs on a grid cloth, in adjacency order, each
// as (row offset, column offset of the other end, direction, 1 if the
// particle is the spring's second end). Twin: grid::INCIDENT (whose test
// checks the order against the model's adjacency). The grid loops are
// written out with these as literals: lavapipe compiles a constant
// array indexed in a loop to per-lane scratch loads, four times slower.
//   (-1, 0, 1, 1)  (0, -1, 0, 1)  (0, 1, 0, 0)  (1, 0, 1, 0)
//   (-1, -1, 2, 1) (-1, 1, 3, 1)  (1, -1, 3, 0) (1, 1, 2, 0)
//   (-2, 0, 5, 1)  (0, -2, 4, 1)  (0, 2, 4, 0)  (2, 0, 5, 0)

// Spring `t` (a row of the table above) at particle p = (row, col). Where
// its other end is outside the grid, `other` is p and `slot` p's own slot
// of the direction, so loads stay in bounds.
struct Incident {
    ok: bool,
    other: u32,
    slot: u32,
    // Spring kind: 0 stretch, 1 shear, 2 bend.
    kind: u32,
    // The particle is the spring's second end (it receives −f_i).
    at_j: bool,
    rest: f32,
    // Fix-up length limit (0: none).
    max_len: f32,
}

fn grid_row_col(p: u32) -> vec2<i32> {
    return vec2<i32>(i32(p / params.grid.x), i32(p % params.grid.x));
}

fn grid_incident(p: u32, rc: vec2<i32>, t: vec4<i32>) -> Incident {
    return grid_spring(GridPoint(true, p, rc), grid_point(rc, p, t.xy), u32(t.z), t.w != 0);
}

// A particle of a block's stencil (generated/grid_block.wgsl): inside the
// grid or not, its index and its (row, column) — where it is outside, a
// particle that exists (the block's first), so loads stay in bounds.
struct GridPoint {
    ok: bool,
    index: u32,
    rc: vec2<i32>,
}

// Particle p as a stencil point of the general (adjacency) kernels, which
// keep no rows and columns.
fn lone_point(p: u32) -> GridPoint {
    return GridPoint(true, p, vec2<i32>(0));
}

// The particle `off` (row, column) away from the block's first particle
// `o` (row, column), whose index is `oi`.
fn grid_point(o: vec2<i32>, oi: u32, off: vec2<i32>) -> GridPoint {
    let r = o.x + off.x;
    let c = o.y + off.y;
    let inside = r >= 0 && r < i32(params.grid.y) && c >= 0 && c < i32(params.grid.x);
    return GridPoint(
        inside,
        select(oi, u32(r) * params.grid.x + u32(c), inside),
        select(o, vec2<i32>(r, c), inside),
    );
}

// The spring of direction `dir` between particle `me` and `other` (`at_j`:
// `me` is its second end): it exists where `other` is inside the grid and
// springs of its kind do; its slot is dir × N + its first end.
fn grid_spring(me: GridPoint, other: GridPoint, dir: u32, at_j: bool) -> Incident {
    let kind = dir >> 1u;
    let ok = other.ok && (params.grid.z & (1u << kind)) != 0u;
    let owner = select(me.index, other.index, at_j);
    var rest = params.grid_rest_b[(dir - 4u) & 3u];
    var max_len = params.grid_max_b[(dir - 4u) & 3u];
    if (dir < 4u) {
        rest = params.grid_rest_a[dir];
        max_len = params.grid_max_a[dir];
    }
    return Incident(ok, other.index, dir * params.particle_count + owner, kind, at_j, rest, max_len);
}

// `sum` plus the force of grid spring `t` on particle p, evaluated from
// i − j as every kernel does, so both ends agree bit for bit. The
// neighbour's state comes from `sec` (see state_x).
fn grid_force_term(
    sum: vec3<f32>,
    p: u32,
    rc: vec2<i32>,
    xp: vec3<f32>,
    vp: vec3<f32>,
    t: vec4<i32>,
    sec: u32,
) -> vec3<f32> {
    let inc = grid_incident(p, rc, t);
    var vo = vec3<f32>(0.0);
    if (has_damping()) {
        vo = state_v(inc.other, sec);
    }
    return sum + grid_spring_force(inc, xp, vp, state_x(inc.other, sec), vo);
}

// The force of grid spring `inc` on the particle at `xp`, `vp` whose
// neighbour is at `xo`, `vo`, signed for the sum (see grid_term).
fn grid_spring_force(
    inc: Incident,
    xp: vec3<f32>,
    vp: vec3<f32>,
    xo: vec3<f32>,
    vo: vec3<f32>,
) -> vec3<f32> {
    let f = spring_force_of(
        inc.rest,
        params.kind_k[inc.kind],
        params.kind_kd[inc.kind],
        select(xp, xo, inc.at_j),
        select(xo, xp, inc.at_j),
        select(vp, vo, inc.at_j),
        select(vo, vp, inc.at_j),
    );
    return grid_term(f, inc);
}

// ±`y` for the sum of a grid spring, or −0 where the spring does not exist
// (adding −0 changes nothing, not even the sign of a zero): branch-free
// for SIMD lanes, which lavapipe runs markedly faster.
fn grid_term(y: vec3<f32>, inc: Incident) -> vec3<f32> {
    return select(vec3<f32>(-0.0), select(y, -y, inc.at_j), inc.ok);
}

// The spring forces on particle p, summed with their signs in adjacency
// order (twin: the spring loop of cpu::forces::total_force): from the
// spring pass's S_FORCE, or on a grid computed here from the neighbours'
// state (from `sec`, see state_x). `xp` and `vp` are the particle's own
// position and velocity.
fn spring_sum(p: u32, xp: vec3<f32>, vp: vec3<f32>, sec: u32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    if (GRID) {
        let rc = grid_row_col(p);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(-1, 0, 1, 1), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(0, -1, 0, 1), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(0, 1, 0, 0), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(1, 0, 1, 0), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(-1, -1, 2, 1), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(-1, 1, 3, 1), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(1, -1, 3, 0), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(1, 1, 2, 0), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(-2, 0, 5, 1), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(0, -2, 4, 1), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(0, 2, 4, 0), sec);
        sum = grid_force_term(sum, p, rc, xp, vp, vec4<i32>(2, 0, 5, 0), sec);
        return sum;
    }
    let begin = spring_adj(p);
    let end = spring_adj(p + 1u);
    for (var k = begin; k < end; k++) {
        let e = topo(params.spring_adj_entries + k);
        let f = work[si(S_FORCE, e >> 1u)].xyz;
        // `a − f` is `a + (−f)` exactly: branch-free for SIMD lanes.
        sum += select(f, -f, (e & 1u) != 0u);
    }
    return sum;
}

// Total force on particle p (twin: cpu::forces::total_force): gravity,
// then the spring forces (spring_sum), then the linear bending force
// (common/bending.wgsl), then wind triangles in adjacency order. `xp` and `vp` are the particle's state, which the caller has
// loaded (on lavapipe every load counts, the same one twice included);
// the neighbours' comes from `sec` (see state_x).
fn total_force(p: u32, xp: vec4<f32>, vp: vec4<f32>, sec: u32) -> vec3<f32> {
    return force_with_springs(p, spring_sum(p, xp.xyz, vp.xyz, sec), vp.w, sec);
}

// Gravity on mass `m`, plus the spring forces `springs_sum`, plus the
// linear bending force, plus wind: the total force on particle p in the
// order of total_force.
fn force_with_springs(p: u32, springs_sum: vec3<f32>, m: f32, sec: u32) -> vec3<f32> {
    var f = params.gravity * m;
    f += springs_sum;
    if (has_bending()) {
        f += bending_force(p, sec);
    }
    return add_wind(p, f, sec);
}

// External force on particle p (twin: cpu::forces::external_forces):
// gravity, then wind triangles in adjacency order.
fn external_force(p: u32) -> vec3<f32> {
    return add_wind(p, params.gravity * v[p].w, STATE_BUFFERS);
}

// `f` plus the wind forces of particle p's triangles, in adjacency order.
fn add_wind(p: u32, f_in: vec3<f32>, sec: u32) -> vec3<f32> {
    var f = f_in;
    if (has_wind()) {
        let tb = tri_adj(p);
        let te = tri_adj(p + 1u);
        for (var k = tb; k < te; k++) {
            f += wind_triangle_force(topo(params.tri_adj_entries + k), sec);
        }
    }
    return f;
}

// Twin: cpu::collide::CONTACT_SLOP.
const CONTACT_SLOP: f32 = 1e-5;

// Twin: cpu::collide::Contact.
struct Contact {
    found: bool,
    normal: vec3<f32>,
    distance: f32,
    friction: f32,
    velocity: vec3<f32>,
}

// The steps particle p has finished: its clock (twin: Workspace::clock).
// Each particle keeps its own, advanced by the step's last kernel, so no
// kernel reads a count another invocation of its dispatch is changing.
fn particle_clock(p: u32) -> u32 {
    return bitcast<u32>(work[wi(W_CLOCK, p)].x);
}

// The clock advanced past `clock`, with `friction` in its yzw (the
// implicit step's friction impulse for the next step; zero in the others).
fn advance_clock(p: u32, clock: u32, friction: vec3<f32>) {
    work[wi(W_CLOCK, p)] = vec4<f32>(bitcast<f32>(clock + 1u), friction);
}

// Twin: cpu::collide::collider_time. Seconds since a collider set at step
// count `base`, at the count `clock`.
fn collider_time(clock: u32, base: u32) -> f32 {
    return f32(clock - base) * params.dt;
}

// Twins: cpu::collide::larger and smaller.
fn larger(a: f32, b: f32) -> f32 {
    return select(b, a, a > b);
}

fn smaller(a: f32, b: f32) -> f32 {
    return select(b, a, a < b);
}

// Twin: cpu::collide::closest_on_segment.
fn closest_on_segment(a: vec3<f32>, b: vec3<f32>, xp: vec3<f32>) -> vec3<f32> {
    let d = b - a;
    let dd = dot3(d, d);
    var t = 0.0;
    if (dd > 0.0) {
        t = smaller(larger(dot3(xp - a, d) / dd, 0.0), 1.0);
    }
    return a + d * t;
}

// Twin: cpu::collide::ball.
fn ball(xp: vec3<f32>, centre: vec3<f32>, radius: f32, friction: f32, velocity: vec3<f32>) -> Contact {
    let d = xp - centre;
    let l = len3(d);
    var n = vec3<f32>(0.0, 1.0, 0.0);
    if (l > TINY) {
        n = d / l;
    }
    return Contact(true, n, l - radius, friction, velocity);
}

// Twin: cpu::collide::contact. The deepest collider closer than `slop`,
// the colliders where they are at the particle clock `clock`.
fn find_contact(xp: vec3<f32>, slop: f32, clock: u32) -> Contact {
    var best = Contact(false, vec3<f32>(0.0, 1.0, 0.0), 0.0, 0.0, vec3<f32>(0.0));
    if (has_ground()) {
        let d = xp.y - params.ground_height;
        if (d < slop) {
            best = Contact(true, vec3<f32>(0.0, 1.0, 0.0), d, params.ground_friction, vec3<f32>(0.0));
        }
    }
    if (has_spheres()) {
        let ts = collider_time(clock, params.motion.y);
        for (var k = 0u; k < params.sphere_count; k++) {
            let sph = params.spheres[k];
            let centre = sph.center + unseen3(sph.velocity * ts);
            let c = ball(xp, centre, sph.radius, sph.friction, sph.velocity);
            if (c.distance < slop && (!best.found || c.distance < best.distance)) {
                best = c;
            }
        }
        let tc = collider_time(clock, params.motion.z);
        for (var k = 0u; k < params.motion.x; k++) {
            let cap = params.capsules[k];
            let shift = unseen3(cap.velocity * tc);
            let q = closest_on_segment(cap.a + shift, cap.b + shift, xp);
            let c = ball(xp, q, cap.radius, cap.friction, cap.velocity);
            if (c.distance < slop && (!best.found || c.distance < best.distance)) {
                best = c;
            }
        }
        if (has_mesh_colliders()) {
            let tm = collider_time(clock, params.mesh.y);
            for (var k = 0u; k < params.mesh.x; k++) {
                let c = mesh_contact(xp, params.meshes[k], tm);
                if (c.found && c.distance < slop && (!best.found || c.distance < best.distance)) {
                    best = c;
                }
            }
        }
    }
    return best;
}

// Twin: cpu::collide::rotate. `v` rotated by the unit quaternion `q`.
fn rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let u = q.xyz;
    let t = cross3(u, v) * 2.0;
    return v + unseen3(t * q.w) + cross3(u, t);
}

// Twins: cpu::collide::lerp and bilerp.
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    return a + unseen1((b - a) * t);
}

fn bilerp(a: f32, b: f32, c: f32, d: f32, u: f32, v: f32) -> f32 {
    return lerp(lerp(a, b, u), lerp(c, d, u), v);
}

// Sample `i` (0-based, x fastest) of the distance grid whose samples
// start at vec4 index `at` of `model`.
fn grid_sample(at: u32, i: u32) -> f32 {
    let w = 4u * at + i;
    return bitcast<f32>(model[w >> 2u][w & 3u]);
}

// Twin: cpu::collide::mesh_contact. The contact of `xp` with mesh collider
// `m` `t` seconds after it was set; not found outside its grid. The grid's
// header in `model`: origin [m] and cell [m], then the lattice points
// along x, y, z; its samples follow.
fn mesh_contact(xp: vec3<f32>, m: MeshCollider, t: f32) -> Contact {
    let none = Contact(false, vec3<f32>(0.0, 1.0, 0.0), 0.0, 0.0, vec3<f32>(0.0));
    let r = xp - (m.position + unseen3(m.velocity * t));
    let local = rotate(m.rotation, r);
    let head = bitcast<vec4<f32>>(model[m.grid]);
    let dims = model[m.grid + 1u].xyz;
    let at = (local - head.xyz) / head.w;
    let top = vec3<f32>(dims - 1u);
    // Written so that NaN is outside too.
    if (!(all(at >= vec3<f32>(0.0)) && all(at < top))) {
        return none;
    }
    let corner = vec3<u32>(at);
    let f = at - vec3<f32>(corner);
    let s = m.grid + 2u;
    let i = corner.x + dims.x * (corner.y + dims.y * corner.z);
    let dy = dims.x;
    let dz = dims.x * dims.y;
    let s000 = grid_sample(s, i);
    let s100 = grid_sample(s, i + 1u);
    let s010 = grid_sample(s, i + dy);
    let s110 = grid_sample(s, i + dy + 1u);
    let s001 = grid_sample(s, i + dz);
    let s101 = grid_sample(s, i + dz + 1u);
    let s011 = grid_sample(s, i + dz + dy);
    let s111 = grid_sample(s, i + dz + dy + 1u);
    let x0 = bilerp(s000, s010, s001, s011, f.y, f.z);
    let x1 = bilerp(s100, s110, s101, s111, f.y, f.z);
    let gy = bilerp(s010 - s000, s110 - s100, s011 - s001, s111 - s101, f.x, f.z);
    let gz = bilerp(s001 - s000, s101 - s100, s011 - s010, s111 - s110, f.x, f.y);
    let grad = vec3<f32>(x1 - x0, gy, gz);
    let l = len3(grad);
    var outward = vec3<f32>(0.0, 1.0, 0.0);
    if (l > TINY) {
        outward = grad / l;
    }
    let q = m.rotation;
    return Contact(
        true,
        rotate(vec4<f32>(-q.xyz, q.w), outward),
        lerp(x0, x1, f.x) - m.thickness,
        m.friction,
        m.velocity + cross3(m.angular_velocity, r),
    );
}

// Twin: cpu::collide::after_contact.
fn after_contact(c: Contact, tangential: vec3<f32>, vn: f32) -> vec3<f32> {
    let speed = len3(tangential);
    let loss = c.friction * (-vn);
    var kept = 0.0;
    if (speed > loss && speed > TINY) {
        kept = (speed - loss) / speed;
    }
    return c.velocity + unseen3(tangential * kept);
}

// Twin: cpu::collide::ENTRY_BISECTIONS.
const ENTRY_BISECTIONS: u32 = 20u;

// Twin: cpu::collide::mesh_entry. Where the path `start` → `xp` of a
// particle that started outside mesh collider `m` and ended inside it
// (the collider `t` seconds after it was set) entered it: the contact
// there, its distance that of `xp` from the face's plane. Not found when
// it started inside or ended outside.
fn mesh_entry(start: vec3<f32>, xp: vec3<f32>, m: MeshCollider, t: f32) -> Contact {
    let none = Contact(false, vec3<f32>(0.0, 1.0, 0.0), 0.0, 0.0, vec3<f32>(0.0));
    if (!mesh_inside(xp, m, t) || mesh_inside(start, m, t)) {
        return none;
    }
    var outside = 0.0;
    var within = 1.0;
    for (var k = 0u; k < ENTRY_BISECTIONS; k++) {
        let mid = (outside + within) * 0.5;
        if (mesh_inside(start + unseen3((xp - start) * mid), m, t)) {
            within = mid;
        } else {
            outside = mid;
        }
    }
    let entry = start + unseen3((xp - start) * outside);
    var c = mesh_contact(entry, m, t);
    c.distance = dot3(xp - entry, c.normal);
    return c;
}

// Whether `xp` lies within mesh collider `m`'s thickness.
fn mesh_inside(xp: vec3<f32>, m: MeshCollider, t: f32) -> bool {
    let c = mesh_contact(xp, m, t);
    return c.found && c.distance < 0.0;
}

// Twin: cpu::collide::resolve. Particle (x, v) moved out of contact `c`
// onto its surface; returns (x, v).
fn resolve(c: Contact, x_in: vec3<f32>, v_in: vec3<f32>) -> array<vec3<f32>, 2> {
    var vp = v_in;
    let relative = vp - c.velocity;
    let vn = dot3(relative, c.normal);
    if (vn < 0.0) {
        vp = after_contact(c, relative - c.normal * vn, vn);
    }
    return array<vec3<f32>, 2>(x_in - c.normal * c.distance, vp);
}

// Twin: cpu::collide::collide for one free particle at `x_in`, `v_in` at
// the end of the step that starts at `clock` from `start`; returns (x, v).
fn collide_particle(start: vec3<f32>, x_in: vec3<f32>, v_in: vec3<f32>, clock: u32) -> array<vec3<f32>, 2> {
    var r = array<vec3<f32>, 2>(x_in, v_in);
    if (has_ground() || has_spheres()) {
        if (has_mesh_colliders()) {
            let tm = collider_time(clock + 1u, params.mesh.y);
            for (var k = 0u; k < params.mesh.x; k++) {
                let c = mesh_entry(start, r[0], params.meshes[k], tm);
                if (c.found) {
                    r = resolve(c, r[0], r[1]);
                }
            }
        }
        for (var round = 0u; round < 2u; round++) {
            let c = find_contact(r[0], 0.0, clock + 1u);
            if (!c.found) {
                break;
            }
            r = resolve(c, r[0], r[1]);
        }
    }
    return r;
}

// Twin: cpu::motion::pin_velocity. Pinned particle p at `xp` in the step
// that starts at `clock`: towards its goal, or still.
fn pin_velocity(p: u32, clock: u32, xp: vec3<f32>) -> vec3<f32> {
    let goal = work[wi(W_PIN_TARGET, p)];
    let remaining = bitcast<u32>(goal.w) - clock;
    if (remaining - 1u < MAX_FRAME_STEPS) {
        return (goal.xyz - xp) / (f32(remaining) * params.dt);
    }
    return vec3<f32>(0.0);
}

// Twin: cpu::motion::pin_step; returns (x, v) at the step's end: the goal
// itself on its last step.
fn pin_step(p: u32, clock: u32, xp: vec3<f32>) -> array<vec3<f32>, 2> {
    let vp = pin_velocity(p, clock, xp);
    let goal = work[wi(W_PIN_TARGET, p)];
    if (bitcast<u32>(goal.w) - clock == 1u) {
        return array<vec3<f32>, 2>(goal.xyz, vp);
    }
    return array<vec3<f32>, 2>(xp + vp * params.dt, vp);
}

// Twin: contact_velocity in cpu::implicit. The velocity of the collider a
// particle at `xp` touches at the start of the step.
fn contact_velocity(xp: vec3<f32>, clock: u32) -> vec3<f32> {
    let c = find_contact(xp, CONTACT_SLOP, clock);
    return select(vec3<f32>(0.0), c.velocity, c.found);
}

// Writes the end-of-step state of particle p, unless it is not finite: then
// the last finite state stays (a renderer never receives NaN vertices) and
// the step is recorded for the host. `inv_mass` and `mass` are the w of
// x[p] and v[p], which stay. Returns whether the new state was stored.
fn store_state(p: u32, xp: vec3<f32>, vp: vec3<f32>, inv_mass: f32, mass: f32) -> bool {
    if (!finite_or_reported(p, xp, vp)) {
        return false;
    }
    x[p] = vec4<f32>(unsigned_zero3(xp), inv_mass);
    v[p] = vec4<f32>(unsigned_zero3(vp), mass);
    return true;
}

// `a` with a zero's sign made + (−0 + 0 = +0; every other value as it
// is), through a zero the compiler cannot see (unseen3), so it cannot
// drop the addition. A compiler may drop an addition of a zero it can
// see or fold a product by a constant, which leaves −0 where IEEE
// arithmetic gives +0 (a particle stopped on the ground by a specialised
// kernel); the stored state carries no signed zero on any path (twin:
// cpu::unsigned_zeros).
fn unsigned_zero3(a: vec3<f32>) -> vec3<f32> {
    return a + unseen3(vec3<f32>(0.0));
}

// Whether particle p's new state is finite; if not, records the step (the
// first bad step and, within it, the lowest particle of the cloth) for
// the host.
fn finite_or_reported(p: u32, xp: vec3<f32>, vp: vec3<f32>) -> bool {
    if (finite3(xp) && finite3(vp)) {
        return true;
    }
    let step = atomicLoad(&status[sw(STATUS_STEP)]);
    let first = atomicMin(&status[sw(STATUS_BAD_STEP)], step);
    if (step <= first) {
        atomicMin(&status[sw(STATUS_BAD_PARTICLE)], local(p));
    }
    return false;
}
