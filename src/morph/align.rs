//! Bringing `B` into `A`'s frame: the least-squares similarity from `B`'s landmarks to `A`'s.
//!
//! **Math** (Umeyama 1991, "Least-squares estimation of transformation parameters between
//! two point patterns", IEEE TPAMI 13(4), eq. 40-42; in the plane a rotation with a uniform
//! scale is multiplication by one complex number, which gives the closed form below).
//! With weights `w_i`, points `x_i` (in `B`'s pixels) and `y_i` (in `A`'s pixels), centroids
//! `x̄`, `ȳ` and centred points `x'_i = x_i - x̄`, `y'_i = y_i - ȳ` read as complex numbers,
//!
//! ```text
//! S(p) = z p + t,   z = a + i b = sum w_i conj(x'_i) y'_i / sum w_i |x'_i|^2,   t = ȳ - z x̄
//! ```
//!
//! minimizes `sum w_i |S(x_i) - y_i|^2` over rotations, uniform scales `|z| > 0` and
//! translations. In matrix form `S(p) = [[a, -b], [b, a]] p + t`: scale `|z|`, rotation
//! `arg z` (counter-clockwise in the usual x right, y *down* pixel axes, i.e. clockwise
//! on screen), no reflection. Umeyama's cross-covariance `Sigma_xy` has `det < 0` when the
//! best map reverses orientation; [`umeyama`] then compares with the best mirrored
//! similarity (`z conj(p) + t`) and refuses the pair ([`AlignError::Mirrored`]) when that
//! fits better: a mirrored pair needs `B` flipped first.
//!
//! **Exactness.** `a`, `b`, `t` are rounded to multiples of `2^-`[`ALIGN_BITS`] (at most
//! `2^-25` px per 1,000 px of coordinate: [`ALIGN_TOLERANCE`] bounds it) and then used
//! *exactly*: [`Similarity::apply_exact`] maps control points in rationals, so an aligned
//! spline is exactly C1 whenever the spline is, and [`Similarity::inverse_exact`] is the
//! exact inverse of those rounded coefficients.

use crate::exact::{parse_rat, rat_to_f64, rat_to_string, Rat};
use crate::fit::param::grid_rat;
use serde::Serialize;

/// The coefficients of a [`Similarity`] are multiples of `2^-ALIGN_BITS`.
pub const ALIGN_BITS: u32 = 24;

/// Largest change (pixels, per pixel of coordinate magnitude, plus a constant) that
/// rounding the coefficients to [`ALIGN_BITS`] makes: `|Δz| |p| + |Δt| <= 2^-24 (|p| + 1)`.
pub const ALIGN_TOLERANCE: f64 = 1.0 / (1u64 << ALIGN_BITS) as f64;

/// Why no similarity was found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AlignError {
    /// Fewer than 2 points.
    #[error("aligning B to A needs at least 2 landmark pairs, found {0}")]
    TooFew(usize),
    /// All of `B`'s points coincide (or a weight is not positive).
    #[error("B's landmarks all coincide, so they fix no rotation or scale; spread them out or use --no-align")]
    Degenerate,
    /// A stored similarity ([`Similarity::from_json`]) is malformed.
    #[error("stored similarity: {0}")]
    Stored(String),
    /// The pair is a mirror image.
    #[error(
        "B's landmarks are a mirror image of A's (a reflection fits them with rms {mirrored:.3} \
         px, the best rotation only {proper:.3} px); flip image B (and its landmarks) or use \
         --no-align"
    )]
    Mirrored {
        /// Residual rms of the best proper similarity.
        proper: f64,
        /// Residual rms of the best mirrored similarity.
        mirrored: f64,
    },
}

/// The key of a morph's `phi_ab.json` that holds its similarity ([`Similarity::to_json`];
/// an extra key, which the deformation format allows), so that `--phi-ab` gives the same
/// morph back.
pub const SIMILARITY_KEY: &str = "morph_similarity";

/// `S(p) = [[a, -b], [b, a]] p + t`, exactly (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Similarity {
    /// `a`, `b`, `t_x`, `t_y`, exactly.
    exact: [Rat; 4],
    /// The same as `f64`.
    f: [f64; 4],
    /// Residual rms of the landmarks (pixels of `A`), 0 for [`Similarity::identity`].
    rms: f64,
}

/// A similarity as printed and reported.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SimilarityReport {
    /// Uniform scale `|z|`.
    pub scale: f64,
    /// Rotation `arg z` in degrees (x right, y down).
    pub rotation_deg: f64,
    /// Translation `t` (pixels of `A`).
    pub translation: [f64; 2],
    /// `[[a, -b, t_x], [b, a, t_y]]`.
    pub matrix: [[f64; 3]; 2],
    /// Residual rms of the landmarks after the similarity (pixels of `A`).
    pub rms: f64,
}

impl Similarity {
    /// The identity.
    pub fn identity() -> Similarity {
        Similarity::from_coefficients([1.0, 0.0, 0.0, 0.0], 0.0)
    }

    fn from_coefficients(c: [f64; 4], rms: f64) -> Similarity {
        let exact = c.map(|v| grid_rat(v, ALIGN_BITS));
        let f = [0, 1, 2, 3].map(|k| rat_to_f64(&exact[k]));
        Similarity { exact, f, rms }
    }

    /// The similarity with the exact coefficients `[a, b, t_x, t_y]` (as
    /// [`Similarity::exact_coefficients`] gives them), for instance read back from a morph's
    /// `phi_ab.json`, with the landmarks' residual rms `rms` it reports;
    /// [`AlignError::Degenerate`] when `a = b = 0`.
    pub fn from_exact(c: [Rat; 4], rms: f64) -> Result<Similarity, AlignError> {
        if c[0] == Rat::from_integer(0.into()) && c[1] == Rat::from_integer(0.into()) {
            return Err(AlignError::Degenerate);
        }
        let f = [0, 1, 2, 3].map(|k| rat_to_f64(&c[k]));
        Ok(Similarity { exact: c, f, rms })
    }

    /// `[a, b, t_x, t_y]`, exactly.
    pub fn exact_coefficients(&self) -> &[Rat; 4] {
        &self.exact
    }

    /// The similarity as stored under [`SIMILARITY_KEY`]: `{"maps": ..., "a", "b", "tx",
    /// "ty": exact rationals as strings, "rms": the landmarks' residual rms in pixels}`.
    pub(crate) fn to_json(&self) -> serde_json::Value {
        let [a, b, tx, ty] = self.exact.clone().map(|r| rat_to_string(&r));
        serde_json::json!({
            "maps": "B's pixels -> A's pixels: S(p) = [[a, -b], [b, a]] p + (tx, ty)",
            "a": a,
            "b": b,
            "tx": tx,
            "ty": ty,
            "rms": self.rms,
        })
    }

    /// The similarity of [`Similarity::to_json`]'s object, exactly.
    pub(crate) fn from_json(v: &serde_json::Value) -> Result<Similarity, AlignError> {
        let coef = |k: &str| -> Result<Rat, AlignError> {
            let t = v.get(k).and_then(|x| x.as_str()).ok_or_else(|| {
                AlignError::Stored(format!("\"{k}\": expected an exact number as a string"))
            })?;
            parse_rat(t).map_err(|e| AlignError::Stored(format!("\"{k}\": {e}")))
        };
        let c = [coef("a")?, coef("b")?, coef("tx")?, coef("ty")?];
        let rms = v.get("rms").and_then(serde_json::Value::as_f64).unwrap_or(0.0);
        Similarity::from_exact(c, rms)
    }

    /// `[a, b, t_x, t_y]` as `f64` (the exact values rounded).
    pub fn coefficients(&self) -> [f64; 4] {
        self.f
    }

    /// Whether this is exactly the identity.
    pub fn is_identity(&self) -> bool {
        self.f == [1.0, 0.0, 0.0, 0.0]
    }

    /// `S(p)` in `f64`.
    pub fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        let [a, b, tx, ty] = self.f;
        [a * p[0] - b * p[1] + tx, b * p[0] + a * p[1] + ty]
    }

    /// `S(p)` exactly.
    pub fn apply_exact(&self, p: &[Rat]) -> Vec<Rat> {
        let [a, b, tx, ty] = &self.exact;
        vec![a * &p[0] - b * &p[1] + tx, b * &p[0] + a * &p[1] + ty]
    }

    /// `S^-1(p) = conj(z) (p - t) / |z|^2`, exactly.
    pub fn inverse_exact(&self, p: &[Rat]) -> Vec<Rat> {
        let [a, b, tx, ty] = &self.exact;
        let n = a * a + b * b;
        let (u, v) = (&p[0] - tx, &p[1] - ty);
        vec![(a * &u + b * &v) / &n, (a * &v - b * &u) / &n]
    }

    /// `S^-1(p)` in `f64`.
    pub fn inverse(&self, p: [f64; 2]) -> [f64; 2] {
        let [a, b, tx, ty] = self.f;
        let n = a * a + b * b;
        let (u, v) = (p[0] - tx, p[1] - ty);
        [(a * u + b * v) / n, (a * v - b * u) / n]
    }

    /// Scale, rotation, translation and the landmarks' residual.
    pub fn report(&self) -> SimilarityReport {
        let [a, b, tx, ty] = self.f;
        SimilarityReport {
            scale: a.hypot(b),
            rotation_deg: b.atan2(a).to_degrees(),
            translation: [tx, ty],
            matrix: [[a, -b, tx], [b, a, ty]],
            rms: self.rms,
        }
    }
}

impl std::fmt::Display for Similarity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let r = self.report();
        write!(
            f,
            "scale {:.4}, rotation {:.2} deg, translation ({:.2}, {:.2}) px; landmark rms \
             after alignment {:.2} px",
            r.scale, r.rotation_deg, r.translation[0], r.translation[1], r.rms
        )
    }
}

/// The weighted least-squares similarity `S` with `S(x_i) ≈ y_i` (see the module docs).
pub fn umeyama(x: &[[f64; 2]], y: &[[f64; 2]], w: &[f64]) -> Result<Similarity, AlignError> {
    let n = x.len().min(y.len()).min(w.len());
    if n < 2 {
        return Err(AlignError::TooFew(n));
    }
    let sw: f64 = w[..n].iter().sum();
    if sw.is_nan() || sw <= 0.0 || w[..n].iter().any(|&v| v.is_nan() || v <= 0.0) {
        return Err(AlignError::Degenerate);
    }
    let mean = |p: &[[f64; 2]]| [0, 1].map(|k| (0..n).map(|i| w[i] * p[i][k]).sum::<f64>() / sw);
    let (xb, yb) = (mean(x), mean(y));
    // Sums over conj(x') y' (proper) and x' y' (mirrored: conj applied to p).
    let (mut re, mut im, mut mre, mut mim, mut xx, mut yy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let (u, v) = (x[i][0] - xb[0], x[i][1] - xb[1]);
        let (p, q) = (y[i][0] - yb[0], y[i][1] - yb[1]);
        re += w[i] * (u * p + v * q);
        im += w[i] * (u * q - v * p);
        mre += w[i] * (u * p - v * q);
        mim += w[i] * (u * q + v * p);
        xx += w[i] * (u * u + v * v);
        yy += w[i] * (p * p + q * q);
    }
    let spread = xx.max(yy).max(1.0);
    if xx.is_nan() || xx <= 1e-12 * spread {
        return Err(AlignError::Degenerate);
    }
    // Residual of the best fit: sum |y'|^2 - |sum conj(x') y'|^2 / sum |x'|^2.
    let rms = |r: f64, i: f64| ((yy - (r * r + i * i) / xx).max(0.0) / sw).sqrt();
    let (proper, mirrored) = (rms(re, im), rms(mre, mim));
    // Umeyama's det(Sigma_xy) < 0 test, confirmed by the residuals.
    if (mre * mre + mim * mim) > (re * re + im * im) && mirrored < proper {
        return Err(AlignError::Mirrored { proper, mirrored });
    }
    let (a, b) = (re / xx, im / xx);
    let t = [yb[0] - (a * xb[0] - b * xb[1]), yb[1] - (b * xb[0] + a * xb[1])];
    let mut s = Similarity::from_coefficients([a, b, t[0], t[1]], 0.0);
    // The residual of the rounded similarity, as used.
    let ss: f64 = (0..n)
        .map(|i| {
            let m = s.apply(x[i]);
            w[i] * ((m[0] - y[i][0]).powi(2) + (m[1] - y[i][1]).powi(2))
        })
        .sum();
    s.rms = (ss / sw).sqrt();
    Ok(s)
}

impl serde::Serialize for Similarity {
    /// The object stored under [`SIMILARITY_KEY`] (exact coefficients as strings).
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.to_json().serialize(s)
    }
}

impl<'de> serde::Deserialize<'de> for Similarity {
    /// The object stored under [`SIMILARITY_KEY`], exactly.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = serde_json::Value::deserialize(d)?;
        Similarity::from_json(&v).map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pts() -> Vec<[f64; 2]> {
        vec![[10.0, 20.0], [200.0, 35.0], [120.0, 300.0], [40.0, 250.0], [310.0, 280.0]]
    }

    fn known(scale: f64, deg: f64, t: [f64; 2]) -> impl Fn([f64; 2]) -> [f64; 2] {
        let (a, b) = (scale * deg.to_radians().cos(), scale * deg.to_radians().sin());
        move |p| [a * p[0] - b * p[1] + t[0], b * p[0] + a * p[1] + t[1]]
    }

    #[test]
    fn recovers_a_known_similarity_up_to_the_rounding_tolerance() {
        let f = known(0.62, 17.0, [35.5, -12.25]);
        let x = pts();
        let y: Vec<_> = x.iter().map(|&p| f(p)).collect();
        let s = umeyama(&x, &y, &[1.0; 5]).unwrap();
        let r = s.report();
        assert!((r.scale - 0.62).abs() < 4.0 * ALIGN_TOLERANCE, "{r:?}");
        assert!((r.rotation_deg - 17.0).abs() < 1e-5, "{r:?}");
        for (p, q) in x.iter().zip(&y) {
            let m = s.apply(*p);
            let tol = ALIGN_TOLERANCE * 4.0 * (p[0].abs() + p[1].abs() + 1.0);
            assert!((m[0] - q[0]).abs() < tol && (m[1] - q[1]).abs() < tol, "{m:?} {q:?}");
        }
        assert!(r.rms < 1e-4);
    }

    #[test]
    fn a_mirror_image_is_refused() {
        let x = pts();
        // Reflect across the vertical axis, then rotate a little.
        let f = known(1.0, 5.0, [400.0, 0.0]);
        let y: Vec<_> = x.iter().map(|&p| f([-p[0], p[1]])).collect();
        let e = umeyama(&x, &y, &[1.0; 5]).unwrap_err();
        assert!(matches!(e, AlignError::Mirrored { .. }), "{e}");
        assert!(e.to_string().contains("mirror image"), "{e}");
    }

    #[test]
    fn degenerate_inputs_are_refused() {
        assert_eq!(umeyama(&[[1.0, 1.0]], &[[2.0, 2.0]], &[1.0]), Err(AlignError::TooFew(1)));
        let same = [[3.0, 4.0]; 3];
        assert_eq!(umeyama(&same, &pts()[..3], &[1.0; 3]), Err(AlignError::Degenerate));
    }

    #[test]
    fn exact_inverse_undoes_the_exact_map() {
        let f = known(1.7, -33.0, [5.0, 9.0]);
        let x = pts();
        let y: Vec<_> = x.iter().map(|&p| f(p)).collect();
        let s = umeyama(&x, &y, &[1.0; 5]).unwrap();
        let p = vec![Rat::new(7.into(), 3.into()), Rat::new((-11).into(), 5.into())];
        assert_eq!(s.inverse_exact(&s.apply_exact(&p)), p);
        let q = s.inverse(s.apply([12.5, -3.0]));
        assert!((q[0] - 12.5).abs() < 1e-9 && (q[1] + 3.0).abs() < 1e-9);
    }

    #[test]
    fn stored_similarities_read_back_exactly_and_bad_ones_are_refused() {
        let f = known(0.6, 12.0, [8.5, 36.0]);
        let x = pts();
        let y: Vec<_> = x.iter().map(|&p| f(p)).collect();
        let s = umeyama(&x, &y, &[1.0; 5]).unwrap();
        let v = s.to_json();
        let back = Similarity::from_json(&serde_json::from_str(&v.to_string()).unwrap()).unwrap();
        assert_eq!(back, s);
        for (k, bad) in [("a", serde_json::json!(1.5)), ("tx", serde_json::json!("1/0"))] {
            let mut w = v.clone();
            w[k] = bad;
            let e = Similarity::from_json(&w).unwrap_err().to_string();
            assert!(e.contains(&format!("\"{k}\"")), "{e}");
        }
        let mut z = v.clone();
        (z["a"], z["b"]) = (serde_json::json!("0"), serde_json::json!("0"));
        assert!(matches!(Similarity::from_json(&z), Err(AlignError::Degenerate)));
    }

    proptest! {
        #[test]
        fn similarity_of_noiseless_points_is_recovered(
            scale in 0.2f64..5.0, deg in -179.0f64..179.0, tx in -500.0f64..500.0,
            ty in -500.0f64..500.0,
        ) {
            let f = known(scale, deg, [tx, ty]);
            let x = pts();
            let y: Vec<_> = x.iter().map(|&p| f(p)).collect();
            let s = umeyama(&x, &y, &[1.0; 5]).unwrap();
            for (p, q) in x.iter().zip(&y) {
                let m = s.apply(*p);
                let tol = ALIGN_TOLERANCE * 4.0 * (p[0].abs() + p[1].abs() + 1.0);
                prop_assert!((m[0] - q[0]).abs() < tol && (m[1] - q[1]).abs() < tol);
            }
        }
    }
}
