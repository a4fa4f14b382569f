//! The mesh pyramid: coarse meshes first, refined where the image term still pulls.
//!
//! With `K` mesh levels the spline stage starts on a regular mesh of cells `2^(K-1)` times
//! [`super::RegisterOptions::spacing`] and refines once before each of the `K - 1` finest
//! image levels (image level `l` runs on mesh level `min(l, K - 1)`). A refinement is
//! nested ([`crate::mesh::Mesh::refine`]: marked triangles split in four, green closure), so
//! the current spline is carried to the finer mesh exactly ([`Spline::prolong`]): the
//! refinement changes the space, never the map.
//!
//! **Where to refine.** The indicator of a coarse triangle `T` is what the finer space could
//! still gain there, from the image term's gradient with respect to the control points of
//! the uniformly refined spline (the same map), on the next level's images. The gradient
//! alone favours textured regions, where every misalignment shows; each control point's
//! share is therefore divided by its Gauss-Newton curvature `D_p` (as in
//! [`super::deform::jacobi`]): `eta_T = sum_{p in children(T)} |dE/dq_p|^2 / D_p`, the
//! decrease of `E` a Newton step on each point alone would bring. It is large where
//! misalignment is coherent over a region the coarse space cannot follow, and near zero
//! where the images agree or carry no structure (noise averages out in the sums
//! `sum_i dE/du_i B_p(y_i)`). The marked set is the smallest one carrying a share `theta`
//! of `sum_T eta_T` (Doerfler's bulk criterion, Doerfler 1996, "A convergent adaptive
//! algorithm for Poisson's equation"); `theta = 1` refines every triangle (the regular
//! grid of half the spacing).
//!
//! **Measured** (`benches/register_compare.py`, three real images warped by a known field,
//! mean endpoint error in px for `theta` = 1 / 0.5 / 0.3 with three mesh levels): with a
//! field from a 6 x 6 random grid (features about 85 px across), ihc 0.082 / 0.058 /
//! 0.052, cell 0.700 / 0.701 / 0.651, time-lapse 0.580 / 0.528 / 0.507 (the 0.3 column
//! with the raw gradient as indicator); with a 12 x 12 grid (`--knots 12`, features about
//! 43 px), ihc 0.092 / 0.217 / 0.556, cell 0.78 / 1.00 / 1.15, time-lapse 1.16 / 1.28 /
//! 1.61 (0.5 with the curvature, 0.3 without; the raw gradient gave 0.328 / 1.11 / 1.52
//! at 0.5). Refining part of the mesh pays where the deformation is smoother than the
//! finest cells and costs much where it is not, so the default refines everything
//! ([`super::DEFAULT_REFINE_SHARE`]).
//!
//! **Where the image sees nothing.** A coarse mesh fits the seen part of the image and
//! extrapolates the rest with its large patches (one cell across a 256 px image at the
//! defaults): a polynomial of degree 5 fitted to one half of its triangle goes wild over the
//! other. Prolonged, that extrapolation would stay in the finer spaces, since only the
//! bending acts there and it does not see an affine drift. So after each refinement (without
//! landmarks; with them the landmark fit is the start there) the variables on which no
//! sample of the image term falls (their image curvature below 10^-6 of the mean,
//! [`super::deform::image_sees`]: masked out, or outside FIXED) restart from the
//! pre-alignment, as on a single mesh, and the bending joins them smoothly to the seen part.
//! On the masked test pair of `tests/it/register.rs` (MOVING's mask keeps its left half) the
//! right half ended 21.0 px from the truth, 3.4 px now (3.5 on one mesh level; the identity
//! is 4.1 px off there). Flat but seen parts keep the prolonged map: with the threshold at
//! 1 % of the mean (dark backgrounds count as unseen) the standard pairs did not change,
//! but the time-lapse frames of the README registered worse (frame 1's NCC cost 0.0027 ->
//! 0.0039).

use super::deform::LevelTerm;
use super::image::Level;
use super::metric::Metric;
use super::samples::SampleOptions;
use super::RegisterError;
use crate::mesh::Mesh;
use crate::spline::Spline;

/// What one refinement did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RefineStep {
    /// Triangles marked by the indicator.
    pub marked: usize,
    /// Triangles split in four (marked ones and the closure's).
    pub red: usize,
    /// Triangles halved by the closure.
    pub green: usize,
}

/// After a refinement without landmarks: the variables `x` of the prolonged map, except
/// those the image term does not see (`sees` false: masked out, outside FIXED), which
/// restart from the pre-alignment's `pre` (module docs, "Where the image sees
/// nothing"). Any variables make an exactly C1 spline.
pub fn unseen_from(x: &[f64], pre: &[f64], sees: &[bool]) -> Vec<f64> {
    x.iter().zip(pre).zip(sees).map(|((a, b), s)| if *s { *a } else { *b }).collect()
}

/// The mesh level image level `level` runs on, with `mesh_levels` mesh levels.
pub fn mesh_level(level: u32, mesh_levels: u32) -> u32 {
    level.min(mesh_levels.max(1) - 1)
}

/// The coarsest mesh of a pyramid of `mesh_levels` over a `w x h` frame whose finest cells
/// are about `spacing` pixels: cells `2^(mesh_levels - 1)` times larger, snapped to a grid
/// `2^(mesh_levels - 1)` times coarser (so the finest mesh snaps to 1/16 px, as a mesh of
/// [`super::frame_mesh`] does).
pub fn coarse_mesh(
    w: usize,
    h: usize,
    spacing: f64,
    mesh_levels: u32,
) -> Result<Mesh, RegisterError> {
    let k = mesh_levels.clamp(1, 8) - 1;
    let big = spacing * f64::from(1u32 << k);
    super::frame_mesh_on(w, h, big, (16 >> k).max(1))
}

/// The marks of Doerfler's criterion: the largest `eta`s until they carry `theta` of the sum.
pub fn doerfler(eta: &[f64], theta: f64) -> Vec<bool> {
    let total: f64 = eta.iter().sum();
    let mut marked = vec![false; eta.len()];
    if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return marked;
    }
    let mut order: Vec<usize> = (0..eta.len()).collect();
    order.sort_by(|&a, &b| eta[b].total_cmp(&eta[a]));
    let mut sum = 0.0;
    for t in order {
        if sum >= theta * total {
            break;
        }
        sum += eta[t];
        marked[t] = true;
    }
    marked
}

/// A control point's curvature in the indicator is at least this share of the mean: a point
/// under flat image (curvature near 0) would otherwise divide its gradient by nothing.
pub const CURVATURE_FLOOR: f64 = 1e-3;

/// The indicator `eta_T` of every triangle of `s` ([module docs](self)).
pub fn indicator(
    s: &Spline,
    fixed: &Level,
    moving: &Level,
    metric: Metric,
    samples: SampleOptions,
) -> Result<Vec<f64>, RegisterError> {
    let nt = s.mesh().num_triangles();
    let all = s.mesh().refine(&vec![true; nt])?;
    let fine = s.prolong(all.mesh, &all.parent)?;
    let term = LevelTerm::new(&fine, fixed, moving, metric, samples);
    let pts: Vec<[f64; 2]> = (0..fine.num_points()).map(|p| fine.point_f64(p)).collect();
    let (_, g, _) = term.eval(&pts, true);
    // The Gauss-Newton diagonal per point and coordinate.
    let d = super::deform::image_curvature(&term, &pts);
    let mean = d.iter().map(|v| v[0] + v[1]).sum::<f64>() / (2.0 * d.len().max(1) as f64);
    let floor = (CURVATURE_FLOOR * mean).max(1e-300);
    let mut eta = vec![0.0; nt];
    for (t, patch) in fine.layout().patches().iter().enumerate() {
        eta[all.parent[t]] += patch
            .iter()
            .map(|&p| {
                g[p][0] * g[p][0] / d[p][0].max(floor) + g[p][1] * g[p][1] / d[p][1].max(floor)
            })
            .sum::<f64>();
    }
    Ok(eta)
}

/// Refines the exact spline `s` where the indicator on the images `fixed`/`moving` is
/// large (`theta < 1`), or everywhere (`theta >= 1`), and carries it over exactly.
pub fn refine(
    s: &Spline,
    (fixed, moving): (&Level, &Level),
    metric: Metric,
    samples: SampleOptions,
    theta: f64,
) -> Result<(Spline, RefineStep), RegisterError> {
    let nt = s.mesh().num_triangles();
    let marked = if theta >= 1.0 {
        vec![true; nt]
    } else {
        doerfler(&indicator(s, fixed, moving, metric, samples)?, theta)
    };
    let r = s.mesh().refine(&marked)?;
    let step =
        RefineStep { marked: marked.iter().filter(|&&m| m).count(), red: r.red, green: r.green };
    Ok((s.prolong(r.mesh, &r.parent)?, step))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn doerfler_marks_the_fewest_largest_carrying_the_share() {
        let eta = [1.0, 5.0, 0.0, 3.0, 1.0];
        assert_eq!(doerfler(&eta, 0.5), [false, true, false, false, false]);
        assert_eq!(doerfler(&eta, 0.6), [false, true, false, true, false]);
        assert_eq!(doerfler(&eta, 1.0), [true, true, false, true, true]);
        assert_eq!(doerfler(&[0.0, 0.0], 0.5), [false, false]);
    }

    #[test]
    fn mesh_levels_map_the_finest_image_levels_to_the_finer_meshes() {
        assert_eq!((0..4).map(|l| mesh_level(l, 3)).collect::<Vec<_>>(), [0, 1, 2, 2]);
        assert_eq!((0..4).map(|l| mesh_level(l, 1)).collect::<Vec<_>>(), [0, 0, 0, 0]);
    }
}
