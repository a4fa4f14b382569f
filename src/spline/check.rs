//! The numbers `trimorph check` reports for a spline deformation: the C1 residuals of the
//! smoothness conditions (thesis eqs. 12.6-12.7, ch. 13: `phi` is C1 exactly when every condition's
//! residual is zero), and the det J certificate ([`crate::spline::jacobian`]) with a scan
//! of the `(k + 1)(k + 2) / 2` barycentric lattice points of step `1/k` in each triangle.

use super::jacobian::{certify, CertifyOptions, DetJ, SAMPLE_LEVEL};
use super::Spline;
use crate::exact::{rat_to_string, Rat};
use num_traits::Zero;
use serde::Serialize;

/// The first control point with a coordinate that is not a finite `f64` (an exact value
/// beyond the `f64` range): `(point, axis, value)`.
pub fn non_finite_point(s: &Spline) -> Option<(usize, usize, f64)> {
    (0..s.num_points()).find_map(|p| {
        let q = s.point_f64(p);
        (0..2).find(|&a| !q[a].is_finite()).map(|a| (p, a, q[a]))
    })
}

/// One line with the certificate's numbers: the sampled minimum, the certified lower bound
/// and whether phi is certified fold-free (with the folding and undecided triangles).
pub fn det_j_line(c: &DetJ) -> String {
    let list = |v: &[usize]| {
        let shown: Vec<String> = v.iter().take(20).map(|t| t.to_string()).collect();
        let more = if v.len() > 20 { format!(", ... ({} in all)", v.len()) } else { String::new() };
        format!("[{}{more}]", shown.join(", "))
    };
    let verdict = if c.fold_free {
        "certified fold-free".to_string()
    } else {
        format!(
            "NOT certified fold-free: folding triangles {}, undecided triangles {}",
            list(&c.folding),
            list(&c.undecided)
        )
    };
    format!(
        "det J: sampled minimum {} (level-{} lattice of every triangle), certified lower bound {}; {verdict}",
        c.sampled_min, SAMPLE_LEVEL, c.lower_bound
    )
}

/// The `trimorph check` report of a spline (written as JSON by `trimorph check`, returned
/// as a dict by Python's `Deformation.check`).
///
/// The fields are declared in the alphabetical order of their keys, the order in which the
/// report has always been written (a contract: a test checks it).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CheckReport {
    /// The number of C1 conditions (thesis eqs. 12.6-12.7, two per interior edge and
    /// degree step).
    pub c1_conditions: usize,
    /// Every condition's residual is exactly zero: `phi` is C1.
    pub c1_holds: bool,
    /// The largest absolute residual, an exact rational written `p/q`.
    pub c1_max_abs_residual: String,
    /// The number of conditions with a nonzero residual.
    pub c1_nonzero_residuals: usize,
    /// One `[x, y]` pair of exact residuals per condition (only when asked for: long on
    /// large meshes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub c1_residuals: Option<Vec<[String; 2]>>,
    /// The number of control points.
    pub control_points: usize,
    /// The spline's degree.
    pub degree: usize,
    /// A certified lower bound of `det J` over the whole mesh.
    pub det_j_lower_bound: f64,
    /// `det J > 0` is proven on every triangle.
    pub fold_free: bool,
    /// The number of scanned samples with `det J <= 0`.
    pub fold_samples: usize,
    /// Triangles where the certificate found `det J <= 0`.
    pub folding_triangles: Vec<usize>,
    /// Some scanned sample folds, or the certificate found a folding triangle.
    pub folds: bool,
    /// The mesh's interior edges.
    pub interior_edges: usize,
    /// The number of scanned samples (`(k + 1)(k + 2) / 2` per triangle).
    pub jacobian_samples: usize,
    /// The sampled minimum of `det J` (the certificate's level-8 lattice, as every command
    /// reports it).
    pub min_jacobian_det: f64,
    /// Where that minimum lies.
    pub min_jacobian_det_at: Option<SampleAt>,
    /// The mesh's triangles.
    pub triangles: usize,
    /// Triangles the certificate could not decide.
    pub undecided_triangles: Vec<usize>,
    /// The mesh's vertices.
    pub vertices: usize,
    /// The spline carries z layers (a 2.5D prism deformation).
    pub z_layers: bool,
}

/// A sample of the `det J` scan: its triangle and barycentric point.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SampleAt {
    /// The barycentric point.
    pub point: [f64; 2],
    /// The triangle.
    pub triangle: usize,
}

/// The `trimorph check` report of a spline, with the per-condition `c1_residuals` list (one
/// `[x, y]` pair of exact residuals per C1 condition; long on large meshes).
pub fn check_report(s: &Spline, samples_per_side: usize) -> CheckReport {
    check_report_with(s, samples_per_side, true)
}

/// The `trimorph check` report of a spline; the `c1_residuals` list only when `residuals`
/// (every other key is always there: `c1_nonzero_residuals` and `c1_max_abs_residual`
/// summarise the list).
pub fn check_report_with(s: &Spline, samples_per_side: usize, residuals: bool) -> CheckReport {
    let res = s.c1_residuals();
    let nonzero = res.iter().filter(|r| !r[0].is_zero() || !r[1].is_zero()).count();
    let max_res = res
        .iter()
        .flat_map(|r| r.iter().cloned())
        .map(|r| if r < Rat::zero() { -r } else { r })
        .max()
        .unwrap_or_else(Rat::zero);
    let m = s.mesh();
    let cache = s.eval_cache();
    let k = samples_per_side.max(1);
    // The --samples scan counts folded samples; the minimum reported is the common one of
    // the certificate (the same number as `field --jacobian`, `edit` and the editor).
    let (mut folds, mut samples) = (0usize, 0usize);
    for t in 0..m.num_triangles() {
        for i in 0..=k {
            for j in 0..=k - i {
                let b = [i as f64 / k as f64, j as f64 / k as f64, (k - i - j) as f64 / k as f64];
                let jm = cache.jacobian(t, b);
                let det = jm[0][0] * jm[1][1] - jm[0][1] * jm[1][0];
                samples += 1;
                if det <= 0.0 {
                    folds += 1;
                }
            }
        }
    }
    let cert = certify(s, &CertifyOptions::default());
    CheckReport {
        c1_conditions: s.quads().len(),
        c1_holds: nonzero == 0,
        c1_max_abs_residual: rat_to_string(&max_res),
        c1_nonzero_residuals: nonzero,
        c1_residuals: residuals
            .then(|| res.iter().map(|r| [rat_to_string(&r[0]), rat_to_string(&r[1])]).collect()),
        control_points: s.num_points(),
        degree: s.degree(),
        det_j_lower_bound: cert.lower_bound,
        fold_free: cert.fold_free,
        fold_samples: folds,
        folds: folds > 0 || !cert.folding.is_empty(),
        folding_triangles: cert.folding,
        interior_edges: m.num_interior_edges(),
        jacobian_samples: samples,
        min_jacobian_det: cert.sampled_min,
        min_jacobian_det_at: cert.worst.map(|(triangle, point)| SampleAt { point, triangle }),
        triangles: m.num_triangles(),
        undecided_triangles: cert.undecided,
        vertices: m.num_vertices(),
        z_layers: s.z_layers().is_some(),
    }
}

impl CheckReport {
    /// The one-line human summary: whether C1 holds (with the count of conditions that
    /// fail, and the largest residual), whether phi is certified fold-free, the sampled
    /// minimum of det J and the certified lower bound.
    pub fn summary_line(&self) -> String {
        let n = self.c1_conditions;
        let c1 = if self.c1_holds {
            format!("C1 holds ({n} of {n} conditions exactly 0)")
        } else {
            format!(
                "C1 FAILS ({} of {n} conditions nonzero, max |residual| {})",
                self.c1_nonzero_residuals, self.c1_max_abs_residual
            )
        };
        let folds = if self.fold_free {
            "certified fold-free".to_string()
        } else {
            format!(
                "NOT certified fold-free ({} folding, {} undecided triangles)",
                self.folding_triangles.len(),
                self.undecided_triangles.len()
            )
        };
        // Written as before, through JSON numbers: a non-finite value shows as `?`.
        let f = |v: f64| if v.is_finite() { format!("{v:.6}") } else { "?".to_string() };
        format!(
            "{c1}; {folds}; det J: sampled min {}, certified lower bound {} ({} triangles)",
            f(self.min_jacobian_det),
            f(self.det_j_lower_bound),
            self.triangles
        )
    }
}

/// Largest accepted absolute coordinate (mesh units = pixels) of an edit's arguments, of a
/// control point after an edit, and of a loaded file's control points (and z values).
/// Frames are at most a few 10^4 pixels wide: anything beyond this is a typing error or an
/// attack, and beyond ~10^308 the page would see `null` coordinates.
pub const MAX_COORD: f64 = 1e6;

/// `x` is finite and at most [`MAX_COORD`] in absolute value.
pub fn within_coord(x: f64) -> bool {
    x.is_finite() && x.abs() <= MAX_COORD
}

/// The first control point (or z value) of `s` beyond [`MAX_COORD`] or not finite.
pub fn absurd_point(s: &Spline) -> Option<String> {
    let bad = |x: f64| !within_coord(x);
    if let Some(i) = (0..s.num_points()).find(|&i| s.point_f64(i).into_iter().any(bad)) {
        return Some(format!("control point {i} is at {:?}", s.point_f64(i)));
    }
    let z = s.z_layers()?;
    for (name, vals) in [("z0", &z.z0), ("z1", &z.z1)] {
        if let Some(i) = vals.iter().position(|v| bad(crate::exact::rat_to_f64(v))) {
            return Some(format!(
                "{name} of control point {i} is {}",
                crate::exact::rat_to_f64(&vals[i])
            ));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::rat_int;
    use crate::mesh::{Mesh, MeshOptions};

    fn grid() -> Spline {
        let mesh = Mesh::grid(2, 2, 40.0, 40.0, MeshOptions::default()).unwrap();
        Spline::identity(mesh, 5).unwrap()
    }

    #[test]
    fn residual_list_only_on_request_and_other_keys_equal() {
        let s = grid();
        let (short, full) = (check_report_with(&s, 4, false), check_report(&s, 4));
        let text = serde_json::to_value(&short).unwrap();
        assert!(text.get("c1_residuals").is_none(), "{text}");
        let list = full.c1_residuals.as_ref().unwrap();
        assert_eq!(list.len(), full.c1_conditions);
        assert_eq!(CheckReport { c1_residuals: None, ..full }, short);
    }

    #[test]
    fn summary_of_a_c1_identity_and_of_a_broken_spline() {
        let s = grid();
        let line = check_report_with(&s, 4, false).summary_line();
        assert!(line.starts_with("C1 holds (40 of 40 conditions"), "{line}");
        assert!(line.contains("; certified fold-free;"), "{line}");
        assert!(line.contains("sampled min 1.000000, certified lower bound"), "{line}");
        // Move one control point: the conditions through it fail.
        let mut pts = s.points().to_vec();
        let p = s.quads()[0].p;
        pts[p][0] = &pts[p][0] + rat_int(3);
        let bad = Spline::from_points_unchecked(s.mesh().clone(), 5, pts, None).unwrap();
        let rep = check_report_with(&bad, 4, false);
        let line = rep.summary_line();
        let n = rep.c1_nonzero_residuals;
        assert!(n > 0);
        assert!(line.starts_with(&format!("C1 FAILS ({n} of 40 conditions nonzero")), "{line}");
    }

    /// The report is written with its keys in alphabetical order, as it was when it was
    /// built as a JSON map: the fields must stay declared in that order.
    #[test]
    fn keys_are_written_in_alphabetical_order() {
        let rep = check_report(&grid(), 2);
        let text = serde_json::to_string(&rep).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
        assert_eq!(keys.len(), 20, "{keys:?}");
        // The document's own order (serde_json's map sorts, so read the text itself).
        let mut at: Vec<(usize, &String)> =
            keys.iter().map(|k| (text.find(&format!("\"{k}\":")).unwrap(), *k)).collect();
        at.sort();
        let written: Vec<&String> = at.into_iter().map(|(_, k)| k).collect();
        let mut sorted = written.clone();
        sorted.sort();
        assert_eq!(written, sorted);
    }
}
