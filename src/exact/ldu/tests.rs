//! Tests of the factoring: exact reconstruction, rank, solve and consistency, against an
//! independent reference (plain rational Gaussian elimination on `BigRational`).

use super::*;
use crate::exact::matrix::{rat_int, IntMatrix, Rat};
use num_bigint::BigInt;
use num_rational::BigRational;
use num_traits::{Signed, Zero};
use proptest::prelude::*;

const ALL_OPTS: [LduOptions; 6] = [
    LduOptions { simplification: Simplification::None, pivoting: Pivoting::Markowitz },
    LduOptions { simplification: Simplification::Gcd, pivoting: Pivoting::Markowitz },
    LduOptions { simplification: Simplification::Turner, pivoting: Pivoting::Markowitz },
    LduOptions { simplification: Simplification::None, pivoting: Pivoting::SmallestMagnitude },
    LduOptions { simplification: Simplification::Gcd, pivoting: Pivoting::SmallestMagnitude },
    LduOptions { simplification: Simplification::Turner, pivoting: Pivoting::SmallestMagnitude },
];

fn reference_rank(a: &IntMatrix) -> usize {
    let rows: Vec<Vec<BigRational>> = (0..a.rows())
        .map(|i| a.row(i).iter().map(|v| BigRational::from_integer(v.to_big())).collect())
        .collect();
    crate::exact::reference::rank(&rows)
}

fn check_all(a: &IntMatrix) {
    let s = a.to_sparse();
    let rank = reference_rank(a);
    let dense = super::dense::factor_dense_turner(a);
    dense.sanity_check().unwrap();
    assert_eq!(dense.rank(), rank, "dense rank");
    assert!(dense.reconstructs(&s), "dense does not rebuild");
    for opts in ALL_OPTS {
        let f = Ldu::factor(&s, opts);
        f.sanity_check().unwrap_or_else(|e| panic!("{opts:?}: {e}\n{a:?}"));
        assert_eq!(f.rank(), rank, "{opts:?} rank\n{a:?}");
        assert!(f.reconstructs(&s), "{opts:?} does not rebuild\n{a:?}\n{f:?}");
        // The independent rows have full rank; every redundant row is a combination of them.
        let ind: Vec<Vec<i64>> = f
            .independent_rows()
            .iter()
            .map(|&i| a.row(i).iter().map(|v| v.to_f64_lossy() as i64).collect())
            .collect();
        if a.max_bits() < 40 {
            assert_eq!(reference_rank(&IntMatrix::from_i64_rows(a.cols(), &ind)), rank);
        }
        if a.cols() == 0 {
            continue;
        }
        // A consistent right-hand side (b = A x0) is solved exactly.
        let x0: Vec<Vec<Rat>> = (0..a.cols()).map(|j| vec![rat_int(j as i64 % 3 - 1)]).collect();
        let b = s.mul_rat(&x0);
        let x = f.solve_multi(&b).expect("consistent");
        assert_eq!(s.mul_rat(&x), b, "{opts:?} solution does not satisfy A x = b");
        // Perturbing a redundant row's right-hand side makes it inconsistent.
        if let Some(&red) = f.redundant_rows().first() {
            let mut bad = b.clone();
            bad[red][0] += rat_int(1);
            assert!(f.solve_multi(&bad).is_err(), "{opts:?} missed an inconsistency");
        }
    }
}

#[test]
fn thesis_example_4_3_has_rank_3() {
    let a = IntMatrix::from_i64_rows(
        4,
        &[
            vec![4, 9, 16, 29],
            vec![-1, -6, -19, -16],
            vec![1, 5, 15, 19],
            vec![5, 6, -1, -12],
            vec![5, 10, 15, 20],
        ],
    );
    check_all(&a);
    // Eq. 8.17: b is consistent; the thesis's printed basic solution (8.22) applies Pc the
    // wrong way: A * (59, -95/2, 23/2, 0) != b, while A * (59, -95/2, 0, 23/2) = b.
    let b: Vec<Vec<Rat>> = [142, 42, 40, -128, 50].iter().map(|v| vec![rat_int(*v)]).collect();
    let half = |p: i64| Rat::new(p.into(), 2.into());
    let printed = vec![vec![rat_int(59)], vec![half(-95)], vec![half(23)], vec![rat_int(0)]];
    let corrected = vec![vec![rat_int(59)], vec![half(-95)], vec![rat_int(0)], vec![half(23)]];
    let s = a.to_sparse();
    assert_ne!(s.mul_rat(&printed), b);
    assert_eq!(s.mul_rat(&corrected), b);
    for opts in ALL_OPTS {
        let f = Ldu::factor(&s, opts);
        let x = f.solve_multi(&b).unwrap();
        assert_eq!(s.mul_rat(&x), b);
        // A basic solution: n - r unknowns are zero.
        assert!(x.iter().filter(|r| r[0].is_zero()).count() >= 1);
    }
}

#[test]
fn turner_last_pivot_is_the_determinant() {
    // The 4x4 example of thesis section 7.1 (det = -1800... checked by the reference).
    let a = IntMatrix::from_i64_rows(
        4,
        &[vec![8, 7, 4, 1], vec![4, 6, 7, 3], vec![6, 3, 4, 6], vec![4, 5, 8, 2]],
    );
    let f = Ldu::factor(&a.to_sparse(), LduOptions::with(Simplification::Turner));
    let last = &f.u_row(3)[0].1;
    // Determinant by cofactor expansion with BigInt.
    fn det(m: &[Vec<i64>]) -> BigInt {
        if m.len() == 1 {
            return BigInt::from(m[0][0]);
        }
        let mut s = BigInt::zero();
        for (j, v) in m[0].iter().enumerate() {
            let minor: Vec<Vec<i64>> = m[1..]
                .iter()
                .map(|r| r.iter().enumerate().filter(|(k, _)| *k != j).map(|(_, x)| *x).collect())
                .collect();
            let t = BigInt::from(*v) * det(&minor);
            if j % 2 == 0 {
                s += t
            } else {
                s -= t
            }
        }
        s
    }
    let rows: Vec<Vec<i64>> =
        (0..4).map(|i| a.row(i).iter().map(|v| v.to_f64_lossy() as i64).collect()).collect();
    assert_eq!(last.to_big().abs(), det(&rows).abs());
}

#[test]
fn empty_and_degenerate_shapes() {
    for (m, n) in [(0, 0), (0, 3), (3, 0), (1, 1)] {
        check_all(&IntMatrix::zeros(m, n));
    }
    check_all(&IntMatrix::from_i64_rows(1, &[vec![7]]));
    check_all(&IntMatrix::from_i64_rows(1, &[vec![-7]]));
    let f = Ldu::factor(&IntMatrix::zeros(3, 4).to_sparse(), LduOptions::default());
    assert_eq!(f.rank(), 0);
    assert_eq!(f.redundant_rows(), &[0, 1, 2]);
}

#[test]
fn huge_entries_promote_to_bigint() {
    let v = i64::MAX / 3;
    check_all(&IntMatrix::from_i64_rows(3, &[vec![v, 1, 2], vec![3, v, 5], vec![7, 11, v]]));
    check_all(&IntMatrix::from_i64_rows(2, &[vec![i64::MIN, i64::MAX], vec![i64::MAX, i64::MIN]]));
}

#[test]
fn none_grows_exponentially_while_gcd_and_turner_do_not() {
    // Dense 12 x 12 with small random entries: plain elimination's bit sizes roughly double
    // each step, the simplified methods' grow linearly (thesis figs. 7.1-7.3).
    let mut seed = 12345u64;
    let mut next = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 33) % 1023) as i64 - 511
    };
    let rows: Vec<Vec<i64>> = (0..12).map(|_| (0..12).map(|_| next()).collect()).collect();
    let s = IntMatrix::from_i64_rows(12, &rows).to_sparse();
    let bits = |m| Ldu::factor(&s, LduOptions::with(m)).max_bits();
    let (none, gcd, turner) =
        (bits(Simplification::None), bits(Simplification::Gcd), bits(Simplification::Turner));
    assert!(none > 4 * turner, "none {none} turner {turner}");
    assert!(gcd <= turner + 16, "gcd {gcd} turner {turner}");
    // Hadamard: a 12 x 12 minor has at most ~142 bits; D = p_(k-1) p_k at most twice that.
    assert!(turner < 2 * 142, "turner {turner}");
}

fn matrix_strategy() -> impl Strategy<Value = IntMatrix> {
    (0usize..9, 0usize..9, 0u8..4, 1usize..5).prop_flat_map(|(m, n, kind, k)| {
        let vals = prop::collection::vec(-20i64..=20, m * n);
        let left = prop::collection::vec(-5i64..=5, m * k);
        let right = prop::collection::vec(-5i64..=5, k * n);
        let mask = prop::collection::vec(0u8..4, m * n);
        (vals, left, right, mask).prop_map(move |(vals, left, right, mask)| {
            let rows: Vec<Vec<i64>> = (0..m)
                .map(|i| {
                    (0..n)
                        .map(|j| match kind {
                            // sparse: about 1 in 4 entries nonzero
                            0 => {
                                if mask[i * n + j] == 0 {
                                    vals[i * n + j]
                                } else {
                                    0
                                }
                            }
                            // rank <= k: a product of m x k and k x n
                            1 => (0..k).map(|t| left[i * k + t] * right[t * n + j]).sum(),
                            // repeated rows
                            2 => vals[(i % 2) * n + j.min(n - 1)] * if i % 3 == 0 { 2 } else { 1 },
                            _ => vals[i * n + j],
                        })
                        .collect()
                })
                .collect();
            IntMatrix::from_i64_rows(n, &rows)
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]
    #[test]
    fn factors_rebuild_a_exactly(a in matrix_strategy()) {
        check_all(&a);
    }
}
