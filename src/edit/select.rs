//! Choosing the derived points of an edit: neighbourhoods, ExpandDerived and RelMagnitude
//! (thesis section 14.2; MSc dissertation section 7.3).
//!
//! ExpandDerived, generalized to vertices of any degree and to the border. Starting from
//! `D = S`, every point of `A ∪ D` adds points by its type (fig. 14.5), until nothing changes:
//!
//! * corner and edge corner (a vertex and the points next to it on its edges): the *disk* of
//!   the vertex `v` -- all edge corners and inner corners around `v`. The C1 conditions
//!   near a vertex say that these points follow one linear map (the derivative of phi at
//!   `v`), so they must move together;
//! * edge: the medial members of its two quadrilaterals (the inner points on both sides);
//! * inner edge and inner corner: the other medial member of each quadrilateral in which
//!   the point is medial (around an interior vertex this chains all inner corners);
//! * interior: nothing (it is in no condition).
//!
//! Points that would lie on missing triangles (at the border) simply do not exist. The rules
//! are then *checked*: ECLES initialize with strong solvability. If the check fails at some
//! constraint, its non-anchor members join `D` (with the same closure) and the check runs
//! again; if they are all in `D` already, the fixed points of the relevant conditions (`F'`)
//! join instead. If `D` cannot grow any more (for example when several anchors share one
//! condition), the selection is kept with weak solvability only: every exactly affine motion
//! of the anchors (translation, rational rotation, rational scaling) is still solvable.
//!
//! RelMagnitude (eq. 14.1): `theta_s = d''_s / (d'_s + d''_s)`, with `d'` the distance to the
//! nearest anchor and `d''` to the nearest fixed point, both measured by Dijkstra on the
//! global control net with Euclidean edge lengths between nominal positions.

use crate::spline::layout::{Owner, PointType};
use crate::spline::Spline;
use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

/// The initial derived set `S`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Neighborhood {
    /// Points within this many steps of an anchor on the control net.
    Radius(usize),
    /// Every point that is not an anchor.
    All,
}

/// Per-point adjacency data used by the selection, built once per spline.
#[derive(Clone, Debug)]
pub struct SelectIndex {
    /// Control net adjacency.
    pub net: Vec<Vec<usize>>,
    /// Quadrilateral conditions each point belongs to.
    pub point_quads: Vec<Vec<usize>>,
    /// For each mesh vertex, its disk (edge corners and inner corners around it).
    pub disks: Vec<Vec<usize>>,
    /// Nominal positions as `f64`.
    pub nominal: Vec<[f64; 2]>,
}

impl SelectIndex {
    /// Builds the index of a spline.
    pub fn new(s: &Spline) -> SelectIndex {
        let lay = s.layout();
        let d = s.degree();
        let mut point_quads = vec![Vec::new(); s.num_points()];
        for (qi, q) in s.quads().iter().enumerate() {
            for m in q.members() {
                point_quads[m].push(qi);
            }
        }
        let mesh = s.mesh();
        let mut disks = vec![Vec::new(); mesh.num_vertices()];
        for p in 0..s.num_points() {
            for v in near_vertices(s, p) {
                if !matches!(lay.owner(p), Owner::Vertex(_)) {
                    disks[v].push(p);
                }
            }
        }
        let _ = d;
        let nominal =
            s.nominal().iter().map(|q| q.clone().map(|c| crate::exact::rat_to_f64(&c))).collect();
        SelectIndex { net: lay.control_net(), point_quads, disks, nominal }
    }
}

/// The mesh vertices that a point of type corner, edge corner or inner corner is next to.
fn near_vertices(s: &Spline, p: usize) -> Vec<usize> {
    let d = s.degree();
    let lay = s.layout();
    match (lay.owner(p), lay.point_type(p)) {
        (Owner::Vertex(v), _) => vec![v],
        (Owner::Edge(e, k), PointType::EdgeCorner) => {
            let ed = s.mesh().edges()[e];
            let mut out = Vec::new();
            if k == 1 {
                out.push(ed.v[0]);
            }
            if k + 1 == d {
                out.push(ed.v[1]);
            }
            out
        }
        (Owner::Face(t, m), PointType::InnerCorner) => {
            let tri = s.mesh().triangle(t);
            (0..3).filter(|&c| m[c] + 2 == d).map(|c| tri[c]).collect()
        }
        _ => Vec::new(),
    }
}

/// `S` from a neighbourhood around the anchors (anchors excluded).
pub fn neighborhood(idx: &SelectIndex, anchors: &[usize], hood: &Neighborhood) -> Vec<usize> {
    let n = idx.net.len();
    let mut is_anchor = vec![false; n];
    for &a in anchors {
        is_anchor[a] = true;
    }
    match hood {
        Neighborhood::All => (0..n).filter(|&p| !is_anchor[p]).collect(),
        Neighborhood::Radius(r) => {
            let mut dist = vec![usize::MAX; n];
            let mut queue: VecDeque<usize> = anchors.iter().copied().collect();
            for &a in anchors {
                dist[a] = 0;
            }
            let mut out = Vec::new();
            while let Some(p) = queue.pop_front() {
                if dist[p] >= *r {
                    continue;
                }
                for &q in &idx.net[p] {
                    if dist[q] == usize::MAX {
                        dist[q] = dist[p] + 1;
                        out.push(q);
                        queue.push_back(q);
                    }
                }
            }
            out.sort_unstable();
            out
        }
    }
}

/// ExpandDerived's closure under the type rules (see the module docs). `in_d` marks `D`
/// (updated); anchors are never added. Returns the points added.
pub fn expand(
    s: &Spline,
    idx: &SelectIndex,
    is_anchor: &[bool],
    in_d: &mut [bool],
    seeds: &[usize],
) {
    let lay = s.layout();
    let quads = s.quads();
    let mut stack: Vec<usize> = seeds.to_vec();
    let push = |p: usize, in_d: &mut [bool], stack: &mut Vec<usize>| {
        if !is_anchor[p] && !in_d[p] {
            in_d[p] = true;
            stack.push(p);
        }
    };
    while let Some(p) = stack.pop() {
        match lay.point_type(p) {
            PointType::Corner | PointType::EdgeCorner => {
                for v in near_vertices(s, p) {
                    for &q in &idx.disks[v] {
                        push(q, in_d, &mut stack);
                    }
                }
                // Edge corners are also extreme members of the next condition along their
                // edge, and inner corners medial members; cover those quads' medials too.
                if lay.point_type(p) == PointType::EdgeCorner {
                    for &qi in &idx.point_quads[p] {
                        let q = quads[qi];
                        if q.p == p || q.n == p {
                            push(q.l, in_d, &mut stack);
                            push(q.r, in_d, &mut stack);
                        }
                    }
                }
            }
            PointType::Edge => {
                for &qi in &idx.point_quads[p] {
                    let q = quads[qi];
                    push(q.l, in_d, &mut stack);
                    push(q.r, in_d, &mut stack);
                }
            }
            PointType::InnerEdge | PointType::InnerCorner => {
                for &qi in &idx.point_quads[p] {
                    let q = quads[qi];
                    if q.l == p {
                        push(q.r, in_d, &mut stack);
                    } else if q.r == p {
                        push(q.l, in_d, &mut stack);
                    }
                }
            }
            PointType::Interior => {}
        }
    }
}

/// RelMagnitude (eq. 14.1) for the derived points, in the order of `derived`.
pub fn rel_magnitude(idx: &SelectIndex, anchors: &[usize], derived: &[usize]) -> Vec<f64> {
    let n = idx.net.len();
    // Region: A ∪ D and the fixed points next to it (the nearest fixed point of a derived
    // point is reached through the region, so d'' is exact there).
    let mut role = vec![0u8; n]; // 0 outside, 1 anchor, 2 derived, 3 fixed border
    for &a in anchors {
        role[a] = 1;
    }
    for &p in derived {
        role[p] = 2;
    }
    let mut border = Vec::new();
    for &p in anchors.iter().chain(derived) {
        for &q in &idx.net[p] {
            if role[q] == 0 {
                role[q] = 3;
                border.push(q);
            }
        }
    }
    let dist_from = |sources: &[usize]| -> std::collections::HashMap<usize, f64> {
        let mut dist: std::collections::HashMap<usize, f64> = std::collections::HashMap::new();
        let mut heap = BinaryHeap::new();
        for &s in sources {
            dist.insert(s, 0.0);
            heap.push((Reverse(OrdF64(0.0)), s));
        }
        while let Some((Reverse(OrdF64(dp)), p)) = heap.pop() {
            if dist.get(&p).is_some_and(|&x| x < dp) {
                continue;
            }
            for &q in &idx.net[p] {
                if role[q] == 0 {
                    continue;
                }
                let (a, b) = (idx.nominal[p], idx.nominal[q]);
                let nd = dp + ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
                if dist.get(&q).is_none_or(|&x| nd < x) {
                    dist.insert(q, nd);
                    heap.push((Reverse(OrdF64(nd)), q));
                }
            }
        }
        dist
    };
    let da = dist_from(anchors);
    let df = dist_from(&border);
    derived
        .iter()
        .map(|p| {
            let a = da.get(p).copied().unwrap_or(f64::INFINITY);
            let f = df.get(p).copied().unwrap_or(f64::INFINITY);
            if f.is_infinite() && a.is_finite() {
                1.0
            } else if a.is_infinite() {
                0.0
            } else if a + f == 0.0 {
                0.5
            } else {
                f / (a + f)
            }
        })
        .collect()
}

/// An `f64` with a total order (for the Dijkstra heap; never NaN here).
#[derive(Clone, Copy, Debug, PartialEq)]
struct OrdF64(f64);
impl Eq for OrdF64 {}
impl PartialOrd for OrdF64 {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for OrdF64 {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}
