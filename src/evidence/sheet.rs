//! Test sheets: an irregular triangle mesh of a rectangle, shared by the
//! bending evidence and the tests.

/// A deterministic pseudo-random number in [-1, 1) (SplitMix64).
pub fn noise(seed: u64) -> f64 {
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// An irregular triangle mesh of the `width × 1` m rectangle hanging in the
/// xy-plane from `y = 0`: rows of nearly equilateral triangles, every
/// other row shifted by half a side, inner vertices moved along their row
/// by up to `JITTER` of a side; `rows` rows of vertices. Returns the OBJ text and
/// its triangles.
pub fn irregular_sheet(width: f64, rows: usize) -> (String, Vec<[usize; 3]>) {
    let (positions, triangles) = irregular_layout(width, rows);
    let mut obj = String::new();
    for p in &positions {
        obj.push_str(&format!("v {} {} 0\n", p[0], p[1]));
    }
    for t in &triangles {
        obj.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    (obj, triangles)
}

/// The OBJ text of [`irregular_sheet`]'s mesh with texture coordinates:
/// `place` takes each vertex's `[x, y]` on the sheet to its position and
/// its `[u, v]`.
pub fn textured_irregular_sheet(
    width: f64,
    rows: usize,
    place: impl Fn([f64; 2]) -> ([f64; 3], [f64; 2]),
) -> String {
    let (positions, triangles) = irregular_layout(width, rows);
    let mut obj = String::new();
    for &p in &positions {
        let ([x, y, z], [u, v]) = place(p);
        obj.push_str(&format!("v {x} {y} {z}\nvt {u} {v}\n"));
    }
    for t in &triangles {
        let [a, b, c] = t.map(|k| k + 1);
        obj.push_str(&format!("f {a}/{a} {b}/{b} {c}/{c}\n"));
    }
    obj
}

/// [`irregular_sheet`]'s vertices `[x, y]` and triangles.
fn irregular_layout(width: f64, rows: usize) -> (Vec<[f64; 2]>, Vec<[usize; 3]>) {
    /// How far inner vertices move, as a fraction of the side.
    const JITTER: f64 = 0.1;
    let dy = 1.0 / (rows - 1) as f64;
    let side = dy * 2.0 / 3f64.sqrt();
    let mut positions: Vec<[f64; 2]> = Vec::new();
    let mut row_of: Vec<Vec<usize>> = Vec::new();
    for r in 0..rows {
        let shift = if r % 2 == 1 { 0.5 } else { 0.0 };
        let mut xs = vec![0.0];
        let mut k = 1.0 - shift;
        while (k + 0.5) * side < width {
            xs.push(k * side);
            k += 1.0;
        }
        xs.push(width);
        let mut row = Vec::new();
        for (c, &x) in xs.iter().enumerate() {
            let n = positions.len();
            let edge = c == 0 || c == xs.len() - 1;
            let jx = if edge {
                0.0
            } else {
                JITTER * side * noise(n as u64)
            };
            positions.push([x + jx, -(r as f64) * dy]);
            row.push(n);
        }
        row_of.push(row);
    }
    // Zip each pair of rows into triangles, advancing along the row whose
    // next vertex lies further left.
    let mut triangles = Vec::new();
    for pair in row_of.windows(2) {
        let (top, bottom) = (&pair[0], &pair[1]);
        let (mut i, mut j) = (0, 0);
        while i + 1 < top.len() || j + 1 < bottom.len() {
            let take_top = j + 1 == bottom.len()
                || (i + 1 < top.len() && positions[top[i + 1]][0] < positions[bottom[j + 1]][0]);
            if take_top {
                // Counter-clockwise seen from +z.
                triangles.push([top[i], bottom[j], top[i + 1]]);
                i += 1;
            } else {
                triangles.push([top[i], bottom[j], bottom[j + 1]]);
                j += 1;
            }
        }
    }
    (positions, triangles)
}
