//! The bit-size study of thesis ch. 7 (figures 7.1-7.10): the largest bit size among the
//! entries of `L`, `D` and `U` after factoring random integer matrices, as a function of the
//! number of rows, the rank and the density, for the None, GCD and Turner simplifications.
//!
//! Matrices have 10-bit signed entries (uniform in `[-511, 511]`, zero excluded where a
//! nonzero is wanted). Rank-deficient matrices are products of an `m x r` and an `r x n`
//! matrix with entries in `[-e, e]`, `e = floor(sqrt(2^9 / r))`, as in section 7.3.1. Sparse
//! matrices keep each entry with probability `h`; sparse rank-deficient ones multiply sparse
//! factors whose density `q` gives the product density `1 - (1 - q^2)^r = h`.
//! Every factoring is checked against `A` before it is measured.

use super::int::Int;
use super::ldu::{Ldu, LduOptions, Simplification};
use super::matrix::SparseIntMatrix;
use crate::rng::SplitMix64;
use rayon::prelude::*;

/// How the random matrices of an experiment are made, for a given x value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Family {
    /// Dense `x` rows by `cols` columns.
    DenseRows {
        /// Number of columns.
        cols: usize,
    },
    /// Dense square `x` by `x`.
    DenseSquare,
    /// `size x size` of rank `x` (dense factors).
    LowRank {
        /// Matrix size.
        size: usize,
    },
    /// Sparse square `x` by `x` with density `h`.
    SparseSquare {
        /// Density of nonzeros.
        h: f64,
    },
    /// `size x size` sparse with density `x / 100`.
    SparseDensity {
        /// Matrix size.
        size: usize,
    },
    /// `size x size` sparse of rank `x`, density about `h`.
    SparseLowRank {
        /// Matrix size.
        size: usize,
        /// Density of the product.
        h: f64,
    },
    /// `size x size` sparse of rank `rank` with density `x / 100`.
    SparseLowRankDensity {
        /// Matrix size.
        size: usize,
        /// Rank.
        rank: usize,
    },
}

/// One experiment (one figure of ch. 7).
#[derive(Clone, Debug)]
pub struct Experiment {
    /// Short id, e.g. `fig7_1`.
    pub id: &'static str,
    /// Plot title.
    pub title: &'static str,
    /// What x is.
    pub x_label: &'static str,
    /// The x values.
    pub xs: Vec<usize>,
    /// Methods compared.
    pub methods: Vec<Simplification>,
    /// Matrix family.
    pub family: Family,
}

/// One measured point.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Experiment id.
    pub experiment: &'static str,
    /// Method.
    pub method: Simplification,
    /// The x value.
    pub x: usize,
    /// Mean over trials of the largest bit size.
    pub mean_bits: f64,
    /// Largest bit size over all trials.
    pub max_bits: u64,
    /// Mean rank found.
    pub mean_rank: f64,
    /// Number of trials.
    pub trials: usize,
}

/// The ten experiments of figures 7.1-7.10; `quick` uses fewer x values.
pub fn experiments(quick: bool) -> Vec<Experiment> {
    use Simplification::*;
    let step = |hi: usize, s: usize| (2..=hi).step_by(s).collect::<Vec<_>>();
    let (s1, s2) = if quick { (4, 6) } else { (1, 2) };
    vec![
        Experiment {
            id: "fig7_1",
            title: "Fig 7.1: no simplification, dense, 15 columns",
            x_label: "rows m",
            xs: step(if quick { 10 } else { 14 }, if quick { 2 } else { 1 }),
            methods: vec![None, Gcd, Turner],
            family: Family::DenseRows { cols: 15 },
        },
        Experiment {
            id: "fig7_2",
            title: "Fig 7.2: GCD, dense square",
            x_label: "size m = n",
            xs: step(40, s1),
            methods: vec![Gcd],
            family: Family::DenseSquare,
        },
        Experiment {
            id: "fig7_3",
            title: "Fig 7.3: GCD vs Turner, dense, 20 columns",
            x_label: "rows m",
            xs: step(40, s1),
            methods: vec![Gcd, Turner],
            family: Family::DenseRows { cols: 20 },
        },
        Experiment {
            id: "fig7_4",
            title: "Fig 7.4: rank deficient 20x20",
            x_label: "rank r",
            xs: step(20, s2 / 2 + 1),
            methods: vec![Gcd, Turner],
            family: Family::LowRank { size: 20 },
        },
        Experiment {
            id: "fig7_5",
            title: "Fig 7.5: sparse square, density 0.10",
            x_label: "size m = n",
            xs: step(40, s1),
            methods: vec![Gcd, Turner],
            family: Family::SparseSquare { h: 0.10 },
        },
        Experiment {
            id: "fig7_6",
            title: "Fig 7.6: sparse square, density 0.25",
            x_label: "size m = n",
            xs: step(40, s1),
            methods: vec![Gcd, Turner],
            family: Family::SparseSquare { h: 0.25 },
        },
        Experiment {
            id: "fig7_7",
            title: "Fig 7.7: sparse 20x20 by density",
            x_label: "density h (%)",
            xs: (5..=100).step_by(if quick { 19 } else { 5 }).collect(),
            methods: vec![Gcd, Turner],
            family: Family::SparseDensity { size: 20 },
        },
        Experiment {
            id: "fig7_8",
            title: "Fig 7.8: sparse rank deficient 20x20, density 0.10",
            x_label: "rank r",
            xs: step(20, s2 / 2 + 1),
            methods: vec![Gcd, Turner],
            family: Family::SparseLowRank { size: 20, h: 0.10 },
        },
        Experiment {
            id: "fig7_9",
            title: "Fig 7.9: sparse rank deficient 20x20, density 0.25",
            x_label: "rank r",
            xs: step(20, s2 / 2 + 1),
            methods: vec![Gcd, Turner],
            family: Family::SparseLowRank { size: 20, h: 0.25 },
        },
        Experiment {
            id: "fig7_10",
            title: "Fig 7.10: sparse rank 10, 20x20, by density",
            x_label: "density h (%)",
            xs: (5..=100).step_by(if quick { 19 } else { 5 }).collect(),
            methods: vec![Gcd, Turner],
            family: Family::SparseLowRankDensity { size: 20, rank: 10 },
        },
    ]
}

fn entry(rng: &mut SplitMix64, bound: i64) -> i64 {
    loop {
        let v = rng.range_i64(-bound, bound);
        if v != 0 {
            return v;
        }
    }
}

fn product(rng: &mut SplitMix64, m: usize, r: usize, n: usize, q: f64) -> Vec<Vec<i64>> {
    let e = ((512.0 / r.max(1) as f64).sqrt().floor() as i64).max(1);
    let pick = |rng: &mut SplitMix64| if rng.unit() < q { entry(rng, e) } else { 0 };
    let a: Vec<Vec<i64>> = (0..m).map(|_| (0..r).map(|_| pick(rng)).collect()).collect();
    let b: Vec<Vec<i64>> = (0..r).map(|_| (0..n).map(|_| pick(rng)).collect()).collect();
    (0..m).map(|i| (0..n).map(|j| (0..r).map(|k| a[i][k] * b[k][j]).sum()).collect()).collect()
}

fn factor_density(h: f64, r: usize) -> f64 {
    (1.0 - (1.0 - h).powf(1.0 / r.max(1) as f64)).sqrt()
}

/// A random matrix of `family` for x value `x`.
pub fn random_matrix(family: Family, x: usize, rng: &mut SplitMix64) -> SparseIntMatrix {
    let dense = |rng: &mut SplitMix64, m: usize, n: usize, h: f64| -> Vec<Vec<i64>> {
        (0..m)
            .map(|_| (0..n).map(|_| if rng.unit() < h { entry(rng, 511) } else { 0 }).collect())
            .collect()
    };
    let rows = match family {
        Family::DenseRows { cols } => dense(rng, x, cols, 1.0),
        Family::DenseSquare => dense(rng, x, x, 1.0),
        Family::LowRank { size } => product(rng, size, x, size, 1.0),
        Family::SparseSquare { h } => dense(rng, x, x, h),
        Family::SparseDensity { size } => dense(rng, size, size, x as f64 / 100.0),
        Family::SparseLowRank { size, h } => product(rng, size, x, size, factor_density(h, x)),
        Family::SparseLowRankDensity { size, rank } => {
            product(rng, size, rank, size, factor_density(x as f64 / 100.0, rank))
        }
    };
    let n = rows.first().map_or(0, Vec::len);
    let rows = rows
        .into_iter()
        .map(|r| {
            r.into_iter()
                .enumerate()
                .filter(|(_, v)| *v != 0)
                .map(|(j, v)| (j, Int::from(v)))
                .collect()
        })
        .collect();
    SparseIntMatrix::from_rows(n, rows).expect("in range")
}

/// Runs one experiment with `trials` matrices per x value (the same matrices for every
/// method), in parallel. Deterministic for a given `seed`, on every platform and with every
/// version of the dependencies (the draws are [`SplitMix64`]'s, see [`crate::rng`]).
///
/// # Panics
/// Panics if a factoring fails to rebuild its matrix (a bug, never expected).
pub fn run(exp: &Experiment, trials: usize, seed: u64) -> Vec<Point> {
    let mut out = Vec::new();
    for &x in &exp.xs {
        let per_trial: Vec<Vec<(u64, usize)>> = (0..trials)
            .into_par_iter()
            .map(|t| {
                let mut rng = SplitMix64::new(seed ^ ((x as u64) << 32) ^ t as u64);
                let a = random_matrix(exp.family, x, &mut rng);
                exp.methods
                    .iter()
                    .map(|&m| {
                        let f = Ldu::factor(&a, LduOptions::with(m));
                        assert!(f.reconstructs(&a), "factoring failed to rebuild A");
                        (f.max_bits(), f.rank())
                    })
                    .collect()
            })
            .collect();
        for (k, &method) in exp.methods.iter().enumerate() {
            let bits: Vec<u64> = per_trial.iter().map(|v| v[k].0).collect();
            let ranks: Vec<usize> = per_trial.iter().map(|v| v[k].1).collect();
            out.push(Point {
                experiment: exp.id,
                method,
                x,
                mean_bits: bits.iter().sum::<u64>() as f64 / trials.max(1) as f64,
                max_bits: bits.iter().copied().max().unwrap_or(0),
                mean_rank: ranks.iter().sum::<usize>() as f64 / trials.max(1) as f64,
                trials,
            });
        }
    }
    out
}

/// CSV text of measured points (with a header line).
pub fn to_csv(points: &[Point]) -> String {
    let mut s = String::from("experiment,method,x,mean_bits,max_bits,mean_rank,trials\n");
    for p in points {
        s.push_str(&format!(
            "{},{},{},{:.2},{},{:.2},{}\n",
            p.experiment, p.method, p.x, p.mean_bits, p.max_bits, p.mean_rank, p.trials
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Computed independently (a Python SplitMix64 with the same draws: one `unit` per
    /// entry, then `range_i64(-511, 511)` until non-zero).
    const PINNED: [[i64; 3]; 3] = [[251, -57, 269], [24, 301, 108], [31, -341, 323]];

    #[test]
    fn low_rank_family_has_the_requested_rank() {
        let mut rng = SplitMix64::new(7);
        for r in [1, 3, 7] {
            let a = random_matrix(Family::LowRank { size: 12 }, r, &mut rng);
            let f = Ldu::factor(&a, LduOptions::default());
            assert!(f.rank() <= r);
            assert!(f.rank() >= r.saturating_sub(1), "rank {} for r {r}", f.rank());
        }
    }

    /// The study's matrices depend on the seed only, not on a dependency's version: the
    /// first dense 3 x 3 matrix of seed 1 is pinned (entries in [-511, 511], none zero).
    #[test]
    fn study_matrices_are_pinned_by_their_seed() {
        let a = random_matrix(Family::DenseSquare, 3, &mut SplitMix64::new(1));
        let got: Vec<Vec<i64>> =
            (0..3).map(|i| (0..3).map(|j| a.get(i, j).as_i64().unwrap()).collect()).collect();
        assert_eq!(got, PINNED);
    }

    #[test]
    fn none_is_exponential_gcd_and_turner_linear() {
        let exp = Experiment {
            id: "t",
            title: "t",
            x_label: "m",
            xs: vec![5, 10],
            methods: vec![Simplification::None, Simplification::Gcd, Simplification::Turner],
            family: Family::DenseSquare,
        };
        let pts = run(&exp, 4, 1);
        let get = |m, x| pts.iter().find(|p| p.method == m && p.x == x).unwrap().mean_bits;
        // None: bit sizes double per step, so 5 more rows give far more than 2x.
        assert!(get(Simplification::None, 10) > 8.0 * get(Simplification::None, 5));
        for m in [Simplification::Gcd, Simplification::Turner] {
            let ratio = get(m, 10) / get(m, 5);
            assert!(ratio < 3.5, "{m}: ratio {ratio}");
        }
        assert!(to_csv(&pts).lines().count() == 1 + 6);
    }
}
