//! Similarity metrics between the moving image's values `m_i` at the samples `y_i` and the
//! fixed image's values `f_i = F(phi(y_i))`, as costs to minimize, with their derivatives
//! `dE / d f_i`.
//!
//! Over the `N` valid samples (inside both images and their masks):
//!
//! * **`ssd`**: `E = (1/N) sum (f_i - m_i)^2 / var(m)`; `dE/df_i = 2 (f_i - m_i) / (N var m)`.
//!   Dividing by the moving values' variance makes `E` free of the intensity unit, so one
//!   bending weight suits 8-bit, 16-bit and float images. For images of one modality and
//!   one exposure.
//! * **`ncc`**: `E = 1 - r`, `r = S_fm / sqrt(S_ff S_mm)` with centred sums
//!   `S_fm = sum (f - f_bar)(m - m_bar)`;
//!   `dE/df_i = r (f_i - f_bar) / S_ff - (m_i - m_bar) / sqrt(S_ff S_mm)`. Invariant to
//!   gain and offset: one modality, different exposure. The default.
//! * **`mi`**: Mattes mutual information (Mattes et al., *PET-CT image registration in the
//!   chest using free-form deformations*, IEEE TMI 22(1), 2003, sec. II.B; as in elastix's
//!   `AdvancedMattesMutualInformation`). Values are scaled to bins,
//!   `m^_i = (m_i - m_min) / dm + 2`, `f^_i` likewise; the joint histogram is
//!   `p(a, b) = (1/N) sum_i N0(a - m^_i) N3(b - f^_i)` with the box `N0` on the moving side
//!   and the cubic B-spline `N3` on the sampled side (smooth in `f`), and
//!   `E = -MI = -sum p(a, b) ln(p(a, b) / (p_m(a) p_f(b)))`. As `p_m` does not depend on
//!   `f`, `dE/df_i = -(1/N) sum_b N3'(b - f^_i) / df * ln(p(a_i, b) / p_f(b))`. For different
//!   stains or modalities: any one-to-one (and many other) intensity relations.

use serde::Serialize;

/// The similarity metric (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Metric {
    /// Mean squared difference over the moving values' variance.
    Ssd,
    /// One minus the normalized cross-correlation.
    Ncc,
    /// Mattes mutual information, negated.
    Mi,
}

/// [`Metric::bend_scale`] of `mi`.
pub const MI_BEND_SCALE: f64 = 1000.0;

impl Metric {
    /// The names `--metric` takes.
    pub const NAMES: [&'static str; 3] = ["ssd", "ncc", "mi"];

    /// The factor the registration's bending weight is multiplied by for this metric, so that
    /// one weight (`--bend`, default 1) regularizes every metric alike.
    ///
    /// The metrics' costs are on different scales (histogram entropies against `1 - r` or
    /// the variance-scaled `ssd`), and one bending weight does not suit them all: at `ncc`'s
    /// weight, `mi` was under-regularized (on the time-lapse pair below its map came within
    /// `det J >= 0.058` of a fold, against a known map with `det J` near 1; 0.79 at the
    /// scaled weight). Measured with `benches/register_compare.py` (three real images, each
    /// warped by a known smooth field of 3 px plus noise; mean endpoint error over the image
    /// content; `mi` on FIXED inverted with gamma 0.6), the error by bending weight:
    ///
    /// | weight | ncc ihc / cell / nuclei (px) | mi ihc / cell / nuclei (px) |
    /// |---|---|---|
    /// | 1 | 0.080 / 0.74 / 0.89 | 0.171 / 2.92 / 2.94 |
    /// | 10 | | 0.158 / 2.80 / 2.79 |
    /// | 30 | 0.045 / 0.50 / 0.71 | 0.139 / 3.05 / 2.80 |
    /// | 100 | | 0.113 / 3.25 / 2.61 |
    /// | 300 | | 0.093 / 2.63 / 2.24 |
    /// | 1000 | 0.171 / 1.83 / 1.12 | 0.072 / 2.05 / 1.39 |
    /// | 3000 | | 0.057 / 2.18 / 1.09 |
    ///
    /// `ncc` is best near 30 and `mi` near 1000 to 3000: `mi` needs about 30 to 100 times
    /// the weight. `ncc` and `ssd` keep 1 (the weight their earlier results were measured
    /// with; the pairs' fields are smoother than many real ones, so the table's optimum is
    /// not taken as a default); `mi` gets [`MI_BEND_SCALE`].
    pub fn bend_scale(self) -> f64 {
        match self {
            Metric::Ssd | Metric::Ncc => 1.0,
            Metric::Mi => MI_BEND_SCALE,
        }
    }

    /// The name used in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Metric::Ssd => "ssd",
            Metric::Ncc => "ncc",
            Metric::Mi => "mi",
        }
    }
}

/// A metric name that is none of [`Metric::NAMES`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown metric `{0}` (use ssd, ncc or mi)")]
pub struct MetricNameError(pub String);

impl std::str::FromStr for Metric {
    type Err = MetricNameError;
    fn from_str(s: &str) -> Result<Metric, MetricNameError> {
        match s {
            "ssd" => Ok(Metric::Ssd),
            "ncc" => Ok(Metric::Ncc),
            "mi" => Ok(Metric::Mi),
            other => Err(MetricNameError(other.to_string())),
        }
    }
}

/// Histogram bins of the mutual information.
pub const MI_BINS: usize = 32;

/// What a metric needs to know of the moving values besides the samples: their range and
/// variance, over all samples of the level (valid or not), so that the cost's scale does not
/// jump when samples leave the overlap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    /// Variance of the moving values.
    pub var_m: f64,
    /// Range of the moving values.
    pub m_range: (f64, f64),
    /// Range of the fixed image's values.
    pub f_range: (f64, f64),
}

/// A metric's value and its derivatives with respect to the sampled values.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Evaluation {
    /// The cost `E`.
    pub value: f64,
    /// `dE / d f_i` per sample (0 for invalid ones).
    pub d_f: Vec<f64>,
    /// Valid samples.
    pub valid: usize,
}

/// `E` and `dE/df_i` for moving values `m`, sampled values `f` and validity `ok`.
pub fn evaluate(metric: Metric, m: &[f64], f: &[f64], ok: &[bool], scale: &Scale) -> Evaluation {
    let n = ok.iter().filter(|&&b| b).count();
    let mut d_f = vec![0.0; m.len()];
    if n == 0 {
        return Evaluation { value: 0.0, d_f, valid: 0 };
    }
    let nf = n as f64;
    let value = match metric {
        Metric::Ssd => {
            let k = 1.0 / (nf * scale.var_m.max(1e-30));
            let mut e = 0.0;
            for i in 0..m.len() {
                if ok[i] {
                    let r = f[i] - m[i];
                    e += r * r;
                    d_f[i] = 2.0 * k * r;
                }
            }
            e * k
        }
        Metric::Ncc => {
            let (mut sf, mut sm) = (0.0, 0.0);
            for i in 0..m.len() {
                if ok[i] {
                    sf += f[i];
                    sm += m[i];
                }
            }
            let (fb, mb) = (sf / nf, sm / nf);
            let (mut sfm, mut sff, mut smm) = (0.0, 0.0, 0.0);
            for i in 0..m.len() {
                if ok[i] {
                    let (a, b) = (f[i] - fb, m[i] - mb);
                    sfm += a * b;
                    sff += a * a;
                    smm += b * b;
                }
            }
            if sff <= 0.0 || smm <= 0.0 {
                return Evaluation { value: 1.0, d_f, valid: n };
            }
            let den = (sff * smm).sqrt();
            let r = sfm / den;
            for i in 0..m.len() {
                if ok[i] {
                    d_f[i] = -((m[i] - mb) / den - r * (f[i] - fb) / sff);
                }
            }
            1.0 - r
        }
        Metric::Mi => mutual_information(m, f, ok, scale, nf, &mut d_f),
    };
    Evaluation { value, d_f, valid: n }
}

/// The cubic B-spline `N3(t)` and its derivative.
#[inline]
fn n3(t: f64) -> (f64, f64) {
    let a = t.abs();
    let s = t.signum();
    if a < 1.0 {
        (2.0 / 3.0 - a * a + 0.5 * a * a * a, s * (-2.0 * a + 1.5 * a * a))
    } else if a < 2.0 {
        let b = 2.0 - a;
        (b * b * b / 6.0, -s * 0.5 * b * b)
    } else {
        (0.0, 0.0)
    }
}

/// `-MI` and its derivatives (module docs).
fn mutual_information(
    m: &[f64],
    f: &[f64],
    ok: &[bool],
    scale: &Scale,
    nf: f64,
    d_f: &mut [f64],
) -> f64 {
    const PAD: f64 = 2.0;
    let bins = MI_BINS;
    let inner = (bins as f64) - 2.0 * PAD - 1.0;
    let (m_lo, m_hi) = scale.m_range;
    let (f_lo, f_hi) = scale.f_range;
    let dm = ((m_hi - m_lo) / inner).max(1e-30);
    let df = ((f_hi - f_lo) / inner).max(1e-30);
    let m_bin =
        |v: f64| (((v - m_lo) / dm + PAD).round() as isize).clamp(0, bins as isize - 1) as usize;
    let f_pos = |v: f64| ((v - f_lo) / df + PAD).clamp(1.0, bins as f64 - 2.0);
    let mut joint = vec![0.0f64; bins * bins];
    for i in 0..m.len() {
        if !ok[i] {
            continue;
        }
        let a = m_bin(m[i]);
        let t = f_pos(f[i]);
        let b0 = t.floor() as isize - 1;
        for b in b0.max(0)..=(b0 + 3).min(bins as isize - 1) {
            joint[a * bins + b as usize] += n3(b as f64 - t).0;
        }
    }
    joint.iter_mut().for_each(|v| *v /= nf);
    let mut pm = vec![0.0; bins];
    let mut pf = vec![0.0; bins];
    for a in 0..bins {
        for b in 0..bins {
            pm[a] += joint[a * bins + b];
            pf[b] += joint[a * bins + b];
        }
    }
    let mut mi = 0.0;
    let mut log_ratio = vec![0.0; bins * bins];
    for a in 0..bins {
        for b in 0..bins {
            let p = joint[a * bins + b];
            if p > 1e-300 && pf[b] > 0.0 {
                mi += p * (p / (pm[a] * pf[b])).ln();
                log_ratio[a * bins + b] = (p / pf[b]).ln();
            }
        }
    }
    for i in 0..m.len() {
        if !ok[i] {
            continue;
        }
        let a = m_bin(m[i]);
        let t = f_pos(f[i]);
        // Clamped positions do not move with f: no derivative there.
        let raw = (f[i] - f_lo) / df + PAD;
        if raw != t {
            continue;
        }
        let b0 = t.floor() as isize - 1;
        let mut s = 0.0;
        for b in b0.max(0)..=(b0 + 3).min(bins as isize - 1) {
            // d N3(b - t) / d f = -N3'(b - t) / df.
            s -= n3(b as f64 - t).1 / df * log_ratio[a * bins + b as usize];
        }
        d_f[i] = -s / nf;
    }
    -mi
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data() -> (Vec<f64>, Vec<f64>, Vec<bool>, Scale) {
        let m: Vec<f64> = (0..400).map(|i| ((i as f64) * 0.37).sin() * 0.5 + 0.5).collect();
        let f: Vec<f64> = m
            .iter()
            .enumerate()
            .map(|(i, v)| 0.8 * v * v + 0.05 * ((i as f64) * 1.7).cos())
            .collect();
        let ok: Vec<bool> = (0..400).map(|i| i % 17 != 3).collect();
        let scale = Scale { var_m: 0.12, m_range: (0.0, 1.0), f_range: (-0.1, 0.9) };
        (m, f, ok, scale)
    }

    #[test]
    fn metric_derivatives_match_finite_differences() {
        let (m, f, ok, scale) = data();
        for metric in [Metric::Ssd, Metric::Ncc, Metric::Mi] {
            let e = evaluate(metric, &m, &f, &ok, &scale);
            for i in [0usize, 5, 77, 200, 399] {
                let h = 1e-6;
                let mut fp = f.clone();
                fp[i] += h;
                let mut fm = f.clone();
                fm[i] -= h;
                let num = (evaluate(metric, &m, &fp, &ok, &scale).value
                    - evaluate(metric, &m, &fm, &ok, &scale).value)
                    / (2.0 * h);
                let tol = 1e-6 * (1.0 + num.abs());
                assert!((num - e.d_f[i]).abs() < tol, "{metric:?} {i}: {num} vs {}", e.d_f[i]);
            }
        }
    }

    #[test]
    fn metrics_are_best_for_equal_images_and_mi_sees_an_inversion() {
        let (m, _, ok, scale) = data();
        let s = Scale { f_range: scale.m_range, ..scale };
        assert!(evaluate(Metric::Ssd, &m, &m, &ok, &s).value < 1e-12);
        assert!(evaluate(Metric::Ncc, &m, &m, &ok, &s).value < 1e-12);
        let inv: Vec<f64> = m.iter().map(|v| 1.0 - v).collect();
        let shuffled: Vec<f64> = (0..m.len()).map(|i| m[(i * 7 + 3) % m.len()]).collect();
        let mi_inv = evaluate(Metric::Mi, &m, &inv, &ok, &s).value;
        let mi_shuf = evaluate(Metric::Mi, &m, &shuffled, &ok, &s).value;
        assert!(mi_inv < mi_shuf - 0.5, "{mi_inv} {mi_shuf}");
        assert_eq!("ncc".parse::<Metric>(), Ok(Metric::Ncc));
        assert!("x".parse::<Metric>().is_err());
    }
}
