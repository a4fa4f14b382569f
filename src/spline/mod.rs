//! 2DSD spline deformations: C1 triangular Bezier splines over a reference mesh
//! (thesis Part II, ch. 10-13; MSc dissertation ch. 3-6).
//!
//! `phi: R^2 -> R^2` maps the reference domain (the mesh, in mesh coordinates) to the
//! deformed plane. On each triangle it is a polynomial of degree `d` in Bernstein-Bezier form
//! with control points `q^t_ijk` ([`layout`]); points at a shared nominal position are stored
//! once, so `phi` is C0 by construction; the `d` quadrilateral conditions per interior edge
//! ([`c1`]) make it C1. They are integer equations because the mesh vertices lie on a
//! rational grid, and ECLES keeps them exactly during edits (see [`crate::edit`]).
//!
//! Control points are stored exactly ([`Rat`]) and mirrored in `f64` for evaluation
//! ([`eval`]). A new spline is the identity: every control point at its nominal position.
//!
//! 2.5D deformations (thesis Part III) add two scalar splines `sigma0`, `sigma1` on the same
//! layout ([`ZLayers`]); they obey the same C1 conditions with one coordinate.
//!
//! # Indices
//!
//! A control point is named by its index in [`Spline::points`] ([`ControlPoint`] where a
//! public entry point takes or returns one: edit anchors, pinned points, picking). It is not
//! a mesh vertex index ([`crate::mesh`]): a spline of degree `d` over `V` vertices and `T`
//! triangles has about `V + (d - 1) E + T (d - 1)(d - 2) / 2` control points, and the
//! control point at a vertex generally has another index than the vertex.

mod affine;
pub mod c1;
pub mod check;
pub(crate) mod eval;
pub mod frame;
mod intform;
pub mod jacobian;
pub(crate) mod layout;
pub mod mds;
mod prolong;
mod rref;
pub mod trace;

use crate::ecles::ConstraintSystem;
use crate::exact::{rat_to_f64, Int, Rat, SparseIntMatrix};
use crate::mesh::Mesh;
use c1::Quad;
use eval::EvalCache;
pub use frame::{ImageFrame, Physical};
use layout::Layout;
use num_traits::Zero;
use rayon::prelude::*;
use std::sync::Arc;

/// The bottom and top scalar splines of a 2.5D deformation (thesis ch. 17).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ZLayers {
    /// Reference prism range `[a, b]`.
    pub range: [Rat; 2],
    /// Control coefficients of `sigma0`, one per control point.
    pub z0: Vec<Rat>,
    /// Control coefficients of `sigma1`, one per control point.
    pub z1: Vec<Rat>,
}

/// The most control points a spline may have (2^22). Each exact control point takes a few
/// hundred bytes with its C1 conditions, so this caps a spline at about a gigabyte; a
/// 200 x 200 grid at degree 7 has 2 million.
pub const MAX_CONTROL_POINTS: usize = 1 << 22;

/// Number of control points of a degree-`d` spline over `mesh`: one per vertex, `d - 1` per
/// edge and `(d - 1)(d - 2) / 2` inside each triangle (thesis ch. 12-13).
pub fn control_point_count(mesh: &Mesh, d: usize) -> u128 {
    let (nv, ne, nf) =
        (mesh.num_vertices() as u128, mesh.num_edges() as u128, mesh.num_triangles() as u128);
    let d = d as u128;
    let inner = if d >= 3 { (d - 1) * (d - 2) / 2 } else { 0 };
    nv + ne * d.saturating_sub(1) + nf * inner
}

/// Errors of spline construction and evaluation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SplineError {
    /// Degree 0 or too large.
    #[error("degree {0} is not supported (use 1 to 15; 5 or more for local edits)")]
    Degree(usize),
    /// Wrong number of control points.
    #[error("expected {expected} control points, found {found}")]
    PointCount {
        /// Expected.
        expected: usize,
        /// Found.
        found: usize,
    },
    /// The control points violate a C1 condition.
    #[error("control points violate C1 condition {quad} (edge {edge}, number {index})")]
    NotC1 {
        /// Index of the condition.
        quad: usize,
        /// Its edge.
        edge: usize,
        /// Its number along the edge.
        index: usize,
    },
    /// A prolongation's fine mesh is not nested in the spline's mesh ([`Spline::prolong`]).
    #[error("cannot prolong the spline: {0}")]
    NotNested(String),
    /// More control points than [`MAX_CONTROL_POINTS`].
    #[error(
        "a degree-{degree} spline over this mesh has {points} control points, more than the \
         {max} trimorph handles; use a coarser mesh or a lower degree",
        max = MAX_CONTROL_POINTS
    )]
    TooLarge {
        /// The degree asked for.
        degree: usize,
        /// The number of control points it would have.
        points: u128,
    },
    /// A point is outside the mesh.
    #[error("point ({x}, {y}) is outside the reference mesh")]
    Outside {
        /// x.
        x: f64,
        /// y.
        y: f64,
    },
    /// A determining set built for another spline (other C1 conditions).
    #[error("the determining set was built for another mesh or degree")]
    ForeignDeterminingSet,
}

/// The index of a control point of a [`Spline`] (its position in [`Spline::points`] and in
/// every per-point array: edit anchors, pinned points, the `"points"` of a deformation file).
/// Not a mesh vertex index; see the module docs.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(transparent)]
pub struct ControlPoint(pub usize);

impl ControlPoint {
    /// The index as a `usize`.
    pub fn index(self) -> usize {
        self.0
    }

    /// The control points of these indices.
    pub fn from_indices(indices: &[usize]) -> Vec<ControlPoint> {
        indices.iter().copied().map(ControlPoint).collect()
    }

    /// The indices of these control points (for inner loops over [`Spline::points`]).
    pub fn indices(points: &[ControlPoint]) -> Vec<usize> {
        points.iter().map(|p| p.0).collect()
    }
}

impl From<usize> for ControlPoint {
    fn from(i: usize) -> ControlPoint {
        ControlPoint(i)
    }
}

impl From<ControlPoint> for usize {
    fn from(c: ControlPoint) -> usize {
        c.0
    }
}

impl std::fmt::Display for ControlPoint {
    /// The index, as the command line and reports write it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

/// A spline deformation of the plane; see the module docs.
#[derive(Clone, Debug)]
pub struct Spline {
    // The mesh, layout and C1 system depend on the mesh and degree only: shared between a
    // spline and its copies with other control points (a fit's result, an edit's state).
    mesh: Arc<Mesh>,
    layout: Arc<Layout>,
    quads: Arc<Vec<Quad>>,
    system: Arc<ConstraintSystem>,
    points: Vec<Vec<Rat>>,
    z: Option<ZLayers>,
    cache: EvalCache,
    /// `(sigma0, sigma1)` coefficients of the 2.5D layers, in the cache's patch layout.
    z_cache: Option<EvalCache>,
    /// For each control point, its slots in the flattened patch array of the cache.
    slots: Arc<Vec<Vec<u32>>>,
    /// The image frame the spline was made for ([`frame`]), kept by copies and edits.
    frame: Option<ImageFrame>,
}

impl Spline {
    /// The identity deformation of degree `degree` over `mesh`.
    pub fn identity(mesh: Mesh, degree: usize) -> Result<Spline, SplineError> {
        let layout = Self::layout_for(&mesh, degree)?;
        let den = Int::from(degree as i64 * mesh.grid_denominator());
        let points: Vec<Vec<Rat>> = layout
            .nominal_int(&mesh)
            .into_iter()
            .map(|q| q.iter().map(|&c| Rat::new(Int::from_i128(c), den.clone())).collect())
            .collect();
        Ok(Self::assemble(mesh, layout, points, None))
    }

    /// The control-point layout of a degree-`degree` spline over `mesh`, after checking the
    /// degree and the number of control points.
    fn layout_for(mesh: &Mesh, degree: usize) -> Result<Layout, SplineError> {
        if degree == 0 || degree > 15 {
            return Err(SplineError::Degree(degree));
        }
        let points = control_point_count(mesh, degree);
        if points > MAX_CONTROL_POINTS as u128 {
            return Err(SplineError::TooLarge { degree, points });
        }
        Ok(Layout::new(mesh, degree))
    }

    /// A spline from explicit control points (checked to be C1 exactly).
    pub fn from_points(
        mesh: Mesh,
        degree: usize,
        points: Vec<Vec<Rat>>,
        z: Option<ZLayers>,
    ) -> Result<Spline, SplineError> {
        let s = Self::from_points_unchecked(mesh, degree, points, z)?;
        s.check_c1()?;
        Ok(s)
    }

    /// A spline from explicit control points *without* the C1 check (for inspection tools
    /// such as `trimorph check`, which report the residuals instead).
    pub fn from_points_unchecked(
        mesh: Mesh,
        degree: usize,
        points: Vec<Vec<Rat>>,
        z: Option<ZLayers>,
    ) -> Result<Spline, SplineError> {
        let layout = Self::layout_for(&mesh, degree)?;
        if points.len() != layout.len() {
            return Err(SplineError::PointCount { expected: layout.len(), found: points.len() });
        }
        Ok(Self::assemble(mesh, layout, points, z))
    }

    fn assemble(mesh: Mesh, layout: Layout, points: Vec<Vec<Rat>>, z: Option<ZLayers>) -> Spline {
        // The exact C1 system and the evaluation side (slots, floating-point cache) are
        // independent: built side by side.
        let ((quads, system), (slots, cache)) = rayon::join(
            || {
                let quads = c1::quads(&mesh, &layout);
                let r = c1::matrix(&quads, layout.len());
                (quads, ConstraintSystem::homogeneous(r, 2))
            },
            || {
                let mut slots = vec![Vec::new(); layout.len()];
                for (k, &p) in layout.patches().iter().flatten().enumerate() {
                    slots[p].push(k as u32);
                }
                (slots, xy_cache_of(&mesh, &layout, &points))
            },
        );
        let mut s = Spline {
            mesh: Arc::new(mesh),
            layout: Arc::new(layout),
            quads: Arc::new(quads),
            system: Arc::new(system),
            points,
            z,
            cache,
            z_cache: None,
            slots: Arc::new(slots),
            frame: None,
        };
        s.refresh_z_cache();
        s
    }

    /// The image frame the spline was made for, if recorded ([`frame`]).
    pub fn frame(&self) -> Option<&ImageFrame> {
        self.frame.as_ref()
    }

    /// Records (or clears) the image frame ([`frame`]).
    pub fn set_frame(&mut self, frame: Option<ImageFrame>) {
        self.frame = frame;
    }

    fn refresh_cache(&mut self) {
        self.cache = self.xy_cache(&self.points);
        self.refresh_z_cache();
    }

    /// The evaluation cache of `points` (nearest `f64` of each coordinate) on this mesh.
    fn xy_cache(&self, points: &[Vec<Rat>]) -> EvalCache {
        xy_cache_of(&self.mesh, &self.layout, points)
    }

    fn refresh_z_cache(&mut self) {
        self.z_cache = self.z.as_ref().map(|z| {
            let pts: Vec<[f64; 2]> = self
                .layout
                .patches()
                .iter()
                .flatten()
                .map(|&p| [rat_to_f64(&z.z0[p]), rat_to_f64(&z.z1[p])])
                .collect();
            let tris: Vec<[[f64; 2]; 3]> =
                self.mesh.triangles().iter().map(|t| t.map(|v| self.mesh.vertex(v))).collect();
            EvalCache::new(self.layout.degree(), &tris, pts)
        });
    }

    /// `(sigma0, sigma1)` on triangle `t` at barycentric coordinates `b`, or `None` for a
    /// spline without 2.5D layers (thesis eq. 17.1: the bottom and top of the deformed
    /// prism over the point).
    #[inline]
    pub fn eval_z(&self, t: usize, b: [f64; 3]) -> Option<[f64; 2]> {
        self.z_cache.as_ref().map(|c| c.value(t, b))
    }

    /// The reference mesh.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }
    /// The control-point layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }
    /// The degree `d`.
    pub fn degree(&self) -> usize {
        self.layout.degree()
    }
    /// The quadrilateral conditions.
    pub fn quads(&self) -> &[Quad] {
        &self.quads
    }
    /// The quadrilateral conditions, shared (copies of this spline share them too).
    pub(crate) fn shared_quads(&self) -> Arc<Vec<Quad>> {
        Arc::clone(&self.quads)
    }
    /// The C1 conditions as an ECLES constraint system (`R P = 0`, `d = 2`).
    pub fn system(&self) -> &ConstraintSystem {
        &self.system
    }
    /// The C1 matrix `R` (one row per quadrilateral condition).
    pub fn c1_matrix(&self) -> &SparseIntMatrix {
        self.system.matrix()
    }
    /// Number of control points.
    pub fn num_points(&self) -> usize {
        self.points.len()
    }
    /// Exact control points (`n` rows of 2).
    pub fn points(&self) -> &[Vec<Rat>] {
        &self.points
    }
    /// Control point `i` as `f64`.
    pub fn point_f64(&self, i: usize) -> [f64; 2] {
        [rat_to_f64(&self.points[i][0]), rat_to_f64(&self.points[i][1])]
    }
    /// The 2.5D layers, if any.
    pub fn z_layers(&self) -> Option<&ZLayers> {
        self.z.as_ref()
    }
    /// Sets or removes the 2.5D layers.
    pub fn set_z_layers(&mut self, z: Option<ZLayers>) {
        self.z = z;
        self.refresh_z_cache();
    }

    /// Nominal position of every control point, exactly.
    pub fn nominal(&self) -> Vec<[Rat; 2]> {
        let den = Int::from(self.degree() as i64 * self.mesh.grid_denominator());
        self.layout
            .nominal_int(&self.mesh)
            .into_iter()
            .map(|q| q.map(|c| Rat::new(Int::from_i128(c), den.clone())))
            .collect()
    }

    /// Replaces the control points (all `n`), checking the C1 conditions exactly. On error
    /// the spline is unchanged.
    pub fn set_points(&mut self, points: Vec<Vec<Rat>>) -> Result<(), SplineError> {
        if points.len() != self.points.len() {
            return Err(SplineError::PointCount {
                expected: self.points.len(),
                found: points.len(),
            });
        }
        let old = std::mem::replace(&mut self.points, points);
        if let Err(e) = self.check_c1() {
            self.points = old;
            return Err(e);
        }
        self.refresh_cache();
        Ok(())
    }

    /// Replaces the control points (all `n`) *without* the exact C1 check, for points that
    /// are C1 by construction: an affine combination `sum c_k P_k` (`sum c_k = 1`) of the
    /// exactly-C1 control points `P_k` of splines on this mesh and degree, or an affine map
    /// applied to them (the C1 conditions are linear and affine-invariant), as the morph's
    /// blends are. Callers test that claim with [`Spline::check_c1`].
    pub fn set_points_c1_by_construction(
        &mut self,
        points: Vec<Vec<Rat>>,
    ) -> Result<(), SplineError> {
        if points.len() != self.points.len() {
            return Err(SplineError::PointCount {
                expected: self.points.len(),
                found: points.len(),
            });
        }
        self.points = points;
        self.refresh_cache();
        Ok(())
    }

    /// A spline on this mesh and degree with the control points `points`, after the exact C1
    /// check of [`set_points`](Self::set_points): the same as cloning `self` and setting
    /// them, without copying `self`'s control points first.
    pub fn with_points(&self, points: Vec<Vec<Rat>>) -> Result<Spline, SplineError> {
        if points.len() != self.points.len() {
            return Err(SplineError::PointCount {
                expected: self.points.len(),
                found: points.len(),
            });
        }
        self.check_c1_of(&points)?;
        self.with_points_c1_by_construction(points)
    }

    /// A spline on this mesh and degree whose free points (in the determining set `mds`,
    /// built for this spline) take their values from `points` and whose dependent points are
    /// recomputed from them exactly ([`mds::Mds::recompute_verified`]); the dependents'
    /// entries of `points` are overwritten. Every C1 condition is checked exactly, as by
    /// [`with_points`](Self::with_points), but on the integer numerators of the recomputed
    /// values (no gcd per condition), which is much cheaper for large splines.
    ///
    /// # Errors
    /// [`SplineError::PointCount`], [`SplineError::ForeignDeterminingSet`], or
    /// [`SplineError::NotC1`] if a condition fails (a set that does not determine the
    /// spline; never for a set built by [`mds::Mds::new`] on this spline).
    pub fn with_determined_points(
        &self,
        mds: &mds::Mds,
        mut points: Vec<Vec<Rat>>,
    ) -> Result<Spline, SplineError> {
        if points.len() != self.points.len() {
            return Err(SplineError::PointCount {
                expected: self.points.len(),
                found: points.len(),
            });
        }
        if !mds.is_for(&self.quads) {
            return Err(SplineError::ForeignDeterminingSet);
        }
        mds.recompute_verified(&mut points).map_err(|qi| {
            let q = self.quads[qi];
            SplineError::NotC1 { quad: qi, edge: q.edge, index: q.index }
        })?;
        self.with_points_c1_by_construction(points)
    }

    /// A spline on this mesh and degree with the control points `points`, C1 by construction
    /// as for [`Spline::set_points_c1_by_construction`]; the same as cloning `self` and
    /// setting them, without copying `self`'s control points first.
    pub fn with_points_c1_by_construction(
        &self,
        points: Vec<Vec<Rat>>,
    ) -> Result<Spline, SplineError> {
        if points.len() != self.points.len() {
            return Err(SplineError::PointCount {
                expected: self.points.len(),
                found: points.len(),
            });
        }
        let cache = self.xy_cache(&points);
        Ok(Spline {
            mesh: self.mesh.clone(),
            layout: self.layout.clone(),
            quads: self.quads.clone(),
            system: self.system.clone(),
            points,
            z: self.z.clone(),
            cache,
            z_cache: self.z_cache.clone(),
            slots: self.slots.clone(),
            frame: self.frame.clone(),
        })
    }

    /// Writes some control points without a C1 check (the editor uses this after ECLES has
    /// guaranteed the conditions).
    pub(crate) fn write_points(
        &mut self,
        idx: &[usize],
        values: Vec<Vec<Rat>>,
        approx: &[[f64; 2]],
    ) {
        for ((&i, v), &q) in idx.iter().zip(values).zip(approx) {
            for &slot in &self.slots[i] {
                self.cache.set_slot(slot as usize, q);
            }
            self.points[i] = v;
        }
    }

    /// Bounded exactness (see [`mds`]): rounds the free points among `region` to multiples
    /// of `2^-bits` and recomputes the dependents in `region` exactly. `region` must be
    /// closed under [`mds::Mds::close`], so no point outside it changes.
    pub fn bound_region(&mut self, mds: &mds::Mds, region: &[bool], bits: u32) {
        let mut vals = std::mem::take(&mut self.points);
        for p in 0..vals.len() {
            if region[p] && matches!(mds.role(p), mds::Role::Free) {
                for x in vals[p].iter_mut() {
                    *x = mds::round_to_grid(x, bits);
                }
            }
        }
        mds.recompute(&mut vals, region);
        let idx: Vec<usize> = (0..vals.len()).filter(|&p| region[p]).collect();
        let approx: Vec<[f64; 2]> =
            idx.iter().map(|&p| [rat_to_f64(&vals[p][0]), rat_to_f64(&vals[p][1])]).collect();
        let values: Vec<Vec<Rat>> = idx.iter().map(|&p| vals[p].clone()).collect();
        self.points = vals;
        self.write_points(&idx, values, &approx);
    }

    /// Exact residual of every quadrilateral condition (all zero for a C1 spline).
    pub fn c1_residuals(&self) -> Vec<[Rat; 2]> {
        self.quads
            .iter()
            .map(|q| {
                let mut acc = [Rat::zero(), Rat::zero()];
                for (&m, &c) in q.members().iter().zip(&q.coef) {
                    let c = Rat::from_integer(Int::from(c));
                    for a in 0..2 {
                        acc[a] += &c * &self.points[m][a];
                    }
                }
                acc
            })
            .collect()
    }

    /// Checks every C1 condition exactly. Each condition is summed on a common denominator
    /// in `i128` when the numbers fit, else in reduced fractions (same exact answer, see
    /// `intform`); the first violated condition is reported.
    pub fn check_c1(&self) -> Result<(), SplineError> {
        self.check_c1_of(&self.points)
    }

    /// [`check_c1`](Self::check_c1) of other control points on this mesh and degree.
    fn check_c1_of(&self, points: &[Vec<Rat>]) -> Result<(), SplineError> {
        let bad = self.quads.par_iter().position_first(|q| {
            (0..2).any(|a| {
                let terms = q.members().map(|m| &points[m][a]);
                let t = [
                    (q.coef[0], terms[0]),
                    (q.coef[1], terms[1]),
                    (q.coef[2], terms[2]),
                    (q.coef[3], terms[3]),
                ];
                !intform::comb_is_zero(&t)
            })
        });
        match bad {
            None => Ok(()),
            Some(qi) => {
                let q = self.quads[qi];
                Err(SplineError::NotC1 { quad: qi, edge: q.edge, index: q.index })
            }
        }
    }

    /// The evaluation cache (per-triangle frames and `f64` control points).
    pub fn eval_cache(&self) -> &EvalCache {
        &self.cache
    }

    /// phi(p), or `None` outside the mesh. `hint` is a triangle to try first.
    pub fn eval(&self, p: [f64; 2], hint: Option<usize>) -> Option<[f64; 2]> {
        let (t, b) = self.mesh.locate(p, hint)?;
        Some(self.cache.value(t, b))
    }

    /// phi(p) and its Jacobian, with the triangle used, or `None` outside the mesh.
    pub fn eval_jacobian(
        &self,
        p: [f64; 2],
        hint: Option<usize>,
    ) -> Option<([f64; 2], [[f64; 2]; 2], usize)> {
        let (t, b) = self.mesh.locate(p, hint)?;
        Some((self.cache.value(t, b), self.cache.jacobian(t, b), t))
    }

    /// phi at many points, in parallel; `None` for points outside the mesh. Consecutive
    /// points are located from the previous point's triangle (coherent queries are fast).
    pub fn eval_many(&self, pts: &[[f64; 2]], out: &mut [Option<[f64; 2]>]) {
        assert_eq!(pts.len(), out.len(), "output length");
        out.par_chunks_mut(4096).zip(pts.par_chunks(4096)).for_each(|(o, p)| {
            let mut hint = None;
            for (oi, pi) in o.iter_mut().zip(p) {
                *oi = match self.mesh.locate(*pi, hint) {
                    Some((t, b)) => {
                        hint = Some(t);
                        Some(self.cache.value(t, b))
                    }
                    None => None,
                };
            }
        });
    }
}

#[cfg(test)]
pub(crate) mod tests;

/// The evaluation cache of `points` (nearest `f64` of each coordinate) on `mesh`.
fn xy_cache_of(mesh: &Mesh, layout: &Layout, points: &[Vec<Rat>]) -> EvalCache {
    // Each control point converted once (a vertex's point is in every patch around it).
    let per_point: Vec<[f64; 2]> =
        points.par_iter().map(|q| [rat_to_f64(&q[0]), rat_to_f64(&q[1])]).collect();
    let pts: Vec<[f64; 2]> = layout.patches().iter().flatten().map(|&p| per_point[p]).collect();
    let tris: Vec<[[f64; 2]; 3]> =
        mesh.triangles().iter().map(|t| t.map(|v| mesh.vertex(v))).collect();
    EvalCache::new(layout.degree(), &tris, pts)
}
