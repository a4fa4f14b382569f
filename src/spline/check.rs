//! The numbers `trimorph check` reports for a spline deformation: the C1 residuals of the
//! smoothness conditions (thesis eqs. 12.6-12.7, ch. 13: `phi` is C1 exactly when every condition's
//! residual is zero), and the det J certificate ([`crate::spline::jacobian`]) with a scan
//! of the `(k + 1)(k + 2) / 2` barycentric lattice points of step `1/k` in each triangle.

use super::jacobian::{certify, CertifyOptions, DetJ, SAMPLE_LEVEL};
use super::Spline;
use crate::exact::{rat_to_string, Rat};
use num_traits::Zero;
use serde_json::{json, Value};

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

/// The `trimorph check` report of a spline, with the per-condition `c1_residuals` list (one
/// `[x, y]` pair of exact residuals per C1 condition; long on large meshes).
pub fn check_report(s: &Spline, samples_per_side: usize) -> Value {
    check_report_with(s, samples_per_side, true)
}

/// The `trimorph check` report of a spline; the `c1_residuals` list only when `residuals`
/// (every other key is always there: `c1_nonzero_residuals` and `c1_max_abs_residual`
/// summarise the list).
pub fn check_report_with(s: &Spline, samples_per_side: usize, residuals: bool) -> Value {
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
    let worst = cert.worst.map(|(t, p)| json!({"triangle": t, "point": p}));
    let mut rep = json!({
        "degree": s.degree(),
        "vertices": m.num_vertices(),
        "triangles": m.num_triangles(),
        "interior_edges": m.num_interior_edges(),
        "control_points": s.num_points(),
        "c1_conditions": s.quads().len(),
        "c1_nonzero_residuals": nonzero,
        "c1_max_abs_residual": rat_to_string(&max_res),
        "c1_holds": nonzero == 0,
        "jacobian_samples": samples,
        "min_jacobian_det": cert.sampled_min,
        "min_jacobian_det_at": worst,
        "fold_samples": folds,
        "folds": folds > 0 || !cert.folding.is_empty(),
        "det_j_lower_bound": cert.lower_bound,
        "fold_free": cert.fold_free,
        "folding_triangles": cert.folding,
        "undecided_triangles": cert.undecided,
        "z_layers": s.z_layers().is_some(),
    });
    if residuals {
        let list: Vec<[String; 2]> =
            res.iter().map(|r| [rat_to_string(&r[0]), rat_to_string(&r[1])]).collect();
        rep["c1_residuals"] = json!(list);
    }
    rep
}

/// The one-line human summary of a [`check_report`]: whether C1 holds (with the count of
/// conditions that fail, and the largest residual), whether phi is certified fold-free, the
/// sampled minimum of det J and the certified lower bound.
pub fn summary_line(rep: &Value) -> String {
    let n = |k: &str| rep[k].as_u64().unwrap_or(0);
    let f = |k: &str| rep[k].as_f64().map_or("?".to_string(), |v| format!("{v:.6}"));
    let c1 = if rep["c1_holds"] == json!(true) {
        format!("C1 holds ({} of {} conditions exactly 0)", n("c1_conditions"), n("c1_conditions"))
    } else {
        format!(
            "C1 FAILS ({} of {} conditions nonzero, max |residual| {})",
            n("c1_nonzero_residuals"),
            n("c1_conditions"),
            rep["c1_max_abs_residual"].as_str().unwrap_or("?")
        )
    };
    let count = |k: &str| rep[k].as_array().map_or(0, Vec::len);
    let folds = if rep["fold_free"] == json!(true) {
        "certified fold-free".to_string()
    } else {
        format!(
            "NOT certified fold-free ({} folding, {} undecided triangles)",
            count("folding_triangles"),
            count("undecided_triangles")
        )
    };
    format!(
        "{c1}; {folds}; det J: sampled min {}, certified lower bound {} ({} triangles)",
        f("min_jacobian_det"),
        f("det_j_lower_bound"),
        n("triangles")
    )
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
        assert!(short.get("c1_residuals").is_none(), "{short}");
        let list = full["c1_residuals"].as_array().unwrap();
        assert_eq!(list.len() as u64, full["c1_conditions"].as_u64().unwrap());
        let mut rest = full.clone();
        rest.as_object_mut().unwrap().remove("c1_residuals");
        assert_eq!(rest, short);
    }

    #[test]
    fn summary_of_a_c1_identity_and_of_a_broken_spline() {
        let s = grid();
        let line = summary_line(&check_report_with(&s, 4, false));
        assert!(line.starts_with("C1 holds (40 of 40 conditions"), "{line}");
        assert!(line.contains("; certified fold-free;"), "{line}");
        assert!(line.contains("sampled min 1.000000, certified lower bound"), "{line}");
        // Move one control point: the conditions through it fail.
        let mut pts = s.points().to_vec();
        let p = s.quads()[0].p;
        pts[p][0] = &pts[p][0] + rat_int(3);
        let bad = Spline::from_points_unchecked(s.mesh().clone(), 5, pts, None).unwrap();
        let rep = check_report_with(&bad, 4, false);
        let line = summary_line(&rep);
        let n = rep["c1_nonzero_residuals"].as_u64().unwrap();
        assert!(n > 0);
        assert!(line.starts_with(&format!("C1 FAILS ({n} of 40 conditions nonzero")), "{line}");
    }
}
