//! The single validator all builders go through: snapping, combinatorial and geometric checks,
//! and construction of the adjacency tables.

use std::collections::HashMap;

use super::{Edge, Locator, Mesh, MeshError, MeshOptions, SnapReport};

/// `|coordinate * grid|` must stay below this.
const COORD_LIMIT: f64 = (1u64 << 40) as f64;

/// Twice the signed area of `(a, b, c)`, exact (positive when counter-clockwise).
pub(super) fn orient(a: [i64; 2], b: [i64; 2], c: [i64; 2]) -> i128 {
    let (ax, ay) = (a[0] as i128, a[1] as i128);
    (b[0] as i128 - ax) * (c[1] as i128 - ay) - (b[1] as i128 - ay) * (c[0] as i128 - ax)
}

/// Whether `p`, known to be collinear with `a` and `b`, lies on the closed segment `ab`.
pub(super) fn on_segment(a: [i64; 2], b: [i64; 2], p: [i64; 2]) -> bool {
    a[0].min(b[0]) <= p[0]
        && p[0] <= a[0].max(b[0])
        && a[1].min(b[1]) <= p[1]
        && p[1] <= a[1].max(b[1])
}

/// Whether the closed segments `p1p2` and `q1q2` have a common point (exact).
pub(super) fn segments_intersect(p1: [i64; 2], p2: [i64; 2], q1: [i64; 2], q2: [i64; 2]) -> bool {
    let d1 = orient(q1, q2, p1).signum();
    let d2 = orient(q1, q2, p2).signum();
    let d3 = orient(p1, p2, q1).signum();
    let d4 = orient(p1, p2, q2).signum();
    if d1 * d2 < 0 && d3 * d4 < 0 {
        return true;
    }
    (d1 == 0 && on_segment(q1, q2, p1))
        || (d2 == 0 && on_segment(q1, q2, p2))
        || (d3 == 0 && on_segment(p1, p2, q1))
        || (d4 == 0 && on_segment(p1, p2, q2))
}

/// The validated snapping denominator.
pub(super) fn check_grid(opts: MeshOptions) -> Result<i64, MeshError> {
    if opts.grid < 1 {
        return Err(MeshError::InvalidGrid { grid: opts.grid });
    }
    Ok(opts.grid)
}

/// Snapped points: integer numerators and the report.
pub(super) struct Snapped {
    pub grid: i64,
    pub ints: Vec<[i64; 2]>,
    pub report: SnapReport,
}

/// Snaps every coordinate to `round(x * grid) / grid`, checking finiteness, range and
/// distinctness after snapping.
pub(super) fn snap_points(points: &[[f64; 2]], grid: i64) -> Result<Snapped, MeshError> {
    let g = grid as f64;
    let mut ints = Vec::with_capacity(points.len());
    let (mut moved, mut max_shift) = (0, 0.0f64);
    for (vertex, p) in points.iter().enumerate() {
        if !p[0].is_finite() || !p[1].is_finite() {
            return Err(MeshError::NotFinite { vertex });
        }
        let mut q = [0i64; 2];
        for k in 0..2 {
            let s = p[k] * g;
            if s.abs() >= COORD_LIMIT {
                return Err(MeshError::CoordinateOutOfRange { vertex, value: p[k] });
            }
            q[k] = s.round() as i64;
        }
        let shift = (q[0] as f64 / g - p[0]).hypot(q[1] as f64 / g - p[1]);
        if shift > 0.0 {
            moved += 1;
            max_shift = max_shift.max(shift);
        }
        ints.push(q);
    }
    let mut seen: HashMap<[i64; 2], usize> = HashMap::with_capacity(ints.len());
    for (i, q) in ints.iter().enumerate() {
        if let Some(&first) = seen.get(q) {
            let (x, y) = (q[0] as f64 / g, q[1] as f64 / g);
            return Err(MeshError::Duplicate { first, second: i, x, y });
        }
        seen.insert(*q, i);
    }
    Ok(Snapped { grid, ints, report: SnapReport { grid, moved, max_shift } })
}

/// Errors unless some three points are not collinear.
pub(super) fn check_not_collinear(ints: &[[i64; 2]]) -> Result<(), MeshError> {
    if ints.len() >= 3 {
        let (a, b) = (ints[0], ints[1]);
        if ints[2..].iter().any(|&c| orient(a, b, c) != 0) {
            return Ok(());
        }
    }
    Err(MeshError::AllCollinear)
}

/// Validates `tris` over the snapped vertices and builds the mesh.
pub(super) fn assemble(s: Snapped, tris: Vec<[usize; 3]>) -> Result<Mesh, MeshError> {
    let Snapped { grid, ints, report } = s;
    let n = ints.len();
    if tris.is_empty() {
        return Err(MeshError::Empty);
    }
    for (t, tri) in tris.iter().enumerate() {
        if let Some(&index) = tri.iter().find(|&&v| v >= n) {
            return Err(MeshError::VertexIndex { triangle: t, index, count: n });
        }
        match orient(ints[tri[0]], ints[tri[1]], ints[tri[2]]).signum() {
            0 => return Err(MeshError::Degenerate { triangle: t }),
            -1 => return Err(MeshError::Clockwise { triangle: t }),
            _ => {}
        }
    }
    let (edges, tri_edges) = build_edges(&tris)?;
    let mut edge_start = vec![0usize; n + 1];
    for e in &edges {
        edge_start[e.v[0] + 1] += 1;
    }
    for i in 0..n {
        edge_start[i + 1] += edge_start[i];
    }
    let tri_nbrs: Vec<[Option<usize>; 3]> = (0..tris.len())
        .map(|t| {
            tri_edges[t].map(|e| {
                let [l, r] = edges[e].tris;
                if l == Some(t) {
                    r
                } else {
                    l
                }
            })
        })
        .collect();
    let n_interior_edges =
        edges.iter().filter(|e| e.tris[0].is_some() && e.tris[1].is_some()).count();

    // Incidence (CSR), then ordered fans.
    let mut vt_start = vec![0usize; n + 1];
    for tri in &tris {
        for &v in tri {
            vt_start[v + 1] += 1;
        }
    }
    if let Some(vertex) = (0..n).find(|&v| vt_start[v + 1] == 0) {
        return Err(MeshError::UnusedVertex { vertex });
    }
    for i in 0..n {
        vt_start[i + 1] += vt_start[i];
    }
    let mut fill = vt_start.clone();
    let mut incident = vec![0usize; 3 * tris.len()];
    for (t, tri) in tris.iter().enumerate() {
        for &v in tri {
            incident[fill[v]] = t;
            fill[v] += 1;
        }
    }
    let mut vt_list = Vec::with_capacity(incident.len());
    let mut border_vertex = vec![false; n];
    for v in 0..n {
        let inc = &incident[vt_start[v]..vt_start[v + 1]];
        border_vertex[v] = order_fan(v, inc, &tris, &tri_nbrs, &ints, &mut vt_list)?;
    }

    let verts: Vec<[f64; 2]> =
        ints.iter().map(|q| [q[0] as f64 / grid as f64, q[1] as f64 / grid as f64]).collect();
    let mut lo = verts[0];
    let mut hi = verts[0];
    for p in &verts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let locator = Locator::new(&verts, &tris, (lo, hi));
    check_vertices_outside(&ints, &verts, &tris, &locator)?;
    check_border(&ints, &edges)?;
    Ok(Mesh {
        grid,
        snap: report,
        verts_int: ints,
        verts,
        tris,
        edges,
        edge_start,
        tri_edges,
        tri_nbrs,
        vt_start,
        vt_list,
        border_vertex,
        n_interior_edges,
        bbox: (lo, hi),
        locator,
    })
}

/// Builds the sorted edge table and the local-edge table; checks edge manifoldness and
/// orientation consistency.
fn build_edges(tris: &[[usize; 3]]) -> Result<(Vec<Edge>, Vec<[usize; 3]>), MeshError> {
    // (lo, hi, forward = traversed lo -> hi, triangle, local edge)
    let mut half: Vec<(usize, usize, bool, usize, usize)> = Vec::with_capacity(3 * tris.len());
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[(k + 1) % 3], tri[(k + 2) % 3]);
            half.push((a.min(b), a.max(b), a < b, t, k));
        }
    }
    half.sort_unstable();
    let mut edges = Vec::with_capacity(half.len() / 2 + 2);
    let mut tri_edges = vec![[0usize; 3]; tris.len()];
    let mut i = 0;
    while i < half.len() {
        let (lo, hi) = (half[i].0, half[i].1);
        let mut j = i;
        while j < half.len() && half[j].0 == lo && half[j].1 == hi {
            j += 1;
        }
        if j - i > 2 {
            return Err(MeshError::NonManifoldEdge { a: lo, b: hi });
        }
        if j - i == 2 && half[i].2 == half[i + 1].2 {
            let (a, b) = if half[i].2 { (lo, hi) } else { (hi, lo) };
            return Err(MeshError::InconsistentOrientation { a, b });
        }
        let mut e = Edge { v: [lo, hi], tris: [None, None] };
        for h in &half[i..j] {
            e.tris[usize::from(!h.2)] = Some(h.3);
            tri_edges[h.3][h.4] = edges.len();
        }
        edges.push(e);
        i = j;
    }
    Ok((edges, tri_edges))
}

/// Orders the triangles `inc` around `v` counter-clockwise (appending them to `out`), checking
/// that they form one fan that does not fold over itself. Returns whether `v` is a border
/// vertex.
fn order_fan(
    v: usize,
    inc: &[usize],
    tris: &[[usize; 3]],
    nbrs: &[[Option<usize>; 3]],
    ints: &[[i64; 2]],
    out: &mut Vec<usize>,
) -> Result<bool, MeshError> {
    let local = |t: usize| tris[t].iter().position(|&w| w == v).expect("incident triangle");
    // The counter-clockwise walk turns from side v-a to side v-b of triangle (v, a, b); a
    // border start has no triangle across v-a (local edge i + 2).
    let mut starts = inc.iter().copied().filter(|&t| nbrs[t][(local(t) + 2) % 3].is_none());
    let border_start = starts.next();
    if starts.next().is_some() {
        return Err(MeshError::NonManifoldVertex { vertex: v });
    }
    let start = border_start.unwrap_or_else(|| *inc.iter().min().expect("used vertex"));
    let first = out.len();
    let pv = ints[v];
    let d = {
        let i = local(start);
        let a = ints[tris[start][(i + 1) % 3]];
        [a[0] - pv[0], a[1] - pv[1]]
    };
    let cross = |u: [i64; 2], w: [i64; 2]| orient([0, 0], u, w);
    let mut turns = 0;
    let mut cur = start;
    loop {
        if out.len() - first >= inc.len() {
            return Err(MeshError::NonManifoldVertex { vertex: v });
        }
        out.push(cur);
        let i = local(cur);
        let (a, b) = (ints[tris[cur][(i + 1) % 3]], ints[tris[cur][(i + 2) % 3]]);
        let (u, w) = ([a[0] - pv[0], a[1] - pv[1]], [b[0] - pv[0], b[1] - pv[1]]);
        // Does the cone (u, w] contain the start direction d again?
        if cross(u, d) > 0 && cross(d, w) >= 0 {
            turns += 1;
        }
        match nbrs[cur][(i + 1) % 3] {
            Some(next) if next != start => cur = next,
            _ => break,
        }
    }
    if out.len() - first != inc.len() {
        return Err(MeshError::NonManifoldVertex { vertex: v });
    }
    let border = border_start.is_some();
    if turns != usize::from(!border) {
        return Err(MeshError::FoldedVertex { vertex: v });
    }
    Ok(border)
}

/// Errors if a vertex lies in a (closed) triangle that does not use it.
fn check_vertices_outside(
    ints: &[[i64; 2]],
    verts: &[[f64; 2]],
    tris: &[[usize; 3]],
    locator: &Locator,
) -> Result<(), MeshError> {
    for (v, p) in verts.iter().enumerate() {
        for t in locator.bucket_triangles(*p) {
            let tri = tris[t];
            if tri.contains(&v) {
                continue;
            }
            let [a, b, c] = tri.map(|w| ints[w]);
            let q = ints[v];
            if orient(a, b, q) >= 0 && orient(b, c, q) >= 0 && orient(c, a, q) >= 0 {
                return Err(MeshError::Overlap { vertex: v, triangle: t });
            }
        }
    }
    Ok(())
}

/// Errors if two border edges without a common vertex intersect (sweep over x).
fn check_border(ints: &[[i64; 2]], edges: &[Edge]) -> Result<(), MeshError> {
    let mut border: Vec<(i64, i64, [usize; 2])> = edges
        .iter()
        .filter(|e| e.tris[0].is_none() || e.tris[1].is_none())
        .map(|e| {
            let (x0, x1) = (ints[e.v[0]][0], ints[e.v[1]][0]);
            (x0.min(x1), x0.max(x1), e.v)
        })
        .collect();
    border.sort_unstable();
    for i in 0..border.len() {
        let (_, xmax, e) = border[i];
        for &(xmin2, _, f) in &border[i + 1..] {
            if xmin2 > xmax {
                break;
            }
            if e.iter().any(|v| f.contains(v)) {
                continue;
            }
            if segments_intersect(ints[e[0]], ints[e[1]], ints[f[0]], ints[f[1]]) {
                return Err(MeshError::BorderIntersection { first: e, second: f });
            }
        }
    }
    Ok(())
}
