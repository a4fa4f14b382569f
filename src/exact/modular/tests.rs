//! Modular path against the fraction-free reference, bit for bit.

use super::*;
use crate::exact::ldu::{Ldu, LduOptions};
use crate::exact::matrix::Rat;
use proptest::prelude::*;

fn sparse(n: usize, rows: &[Vec<(usize, i64)>]) -> SparseIntMatrix {
    SparseIntMatrix::from_rows(
        n,
        rows.iter().map(|r| r.iter().map(|&(c, v)| (c, Int::from(v))).collect()).collect(),
    )
    .unwrap()
}

/// Random sparse `m x n` rows, `k` nonzeros each, entries in `[-b, b]`, plus `dep` rows that
/// are integer combinations of earlier rows (so the matrix is rank deficient).
fn arb_matrix() -> impl Strategy<Value = (usize, Vec<Vec<(usize, i64)>>)> {
    (2usize..14, 2usize..14, 1usize..4, 0usize..4).prop_flat_map(|(m, n, k, dep)| {
        let row = proptest::collection::vec((0..n, -9i64..=9), k);
        let mix = proptest::collection::vec((0..m, -3i64..=3, 0..m, -3i64..=3), dep);
        (Just(n), proptest::collection::vec(row, m), mix).prop_map(|(n, mut rows, mix)| {
            for (a, ca, b, cb) in mix {
                let mut dense = vec![0i64; n];
                for &(c, v) in rows[a].iter() {
                    dense[c] += ca * v;
                }
                for &(c, v) in rows[b].iter() {
                    dense[c] += cb * v;
                }
                rows.push(dense.into_iter().enumerate().filter(|e| e.1 != 0).collect());
            }
            // Merge repeated columns within a row.
            let rows = rows
                .into_iter()
                .map(|r| {
                    let mut d = vec![0i64; n];
                    for (c, v) in r {
                        d[c] += v;
                    }
                    d.into_iter().enumerate().filter(|e| e.1 != 0).collect()
                })
                .collect();
            (n, rows)
        })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Rank equals the fraction-free rank; every certificate holds; consistency agrees.
    #[test]
    fn certified_rank_matches_fraction_free((n, rows) in arb_matrix(), seed in 0i64..50) {
        let a = sparse(n, &rows);
        let f = Ldu::factor(&a, LduOptions::default());
        let basis = certified_basis(&a).unwrap();
        prop_assert_eq!(basis.rank(), f.rank());
        prop_assert_eq!(basis.redundant.len(), f.redundant_rows().len());
        // The canonical set: row i is redundant iff it depends on rows 0..i (ranks of the
        // prefixes by textbook rational elimination).
        let dense: Vec<Vec<num_rational::BigRational>> = (0..a.rows()).map(|i| {
            let mut r = vec![num_rational::BigRational::zero(); n];
            for (c, v) in a.row(i) {
                r[*c] = num_rational::BigRational::from_integer(v.to_big());
            }
            r
        }).collect();
        let want: Vec<usize> = (0..a.rows())
            .filter(|&i| crate::exact::reference::rank(&dense[..=i]) == crate::exact::reference::rank(&dense[..i]))
            .collect();
        prop_assert_eq!(&basis.redundant, &want);
        // b = A x for some x: consistent; perturbing a redundant row's value breaks it.
        let x: Vec<Rat> = (0..n).map(|j| Rat::new(Int::from((j as i64 * seed) % 7 - 3), Int::from(1 + j as i64 % 3))).collect();
        let b: Vec<Rat> = (0..a.rows()).map(|i| {
            a.row(i).iter().fold(Rat::zero(), |acc, (c, v)| acc + Rat::from_integer(v.clone()) * &x[*c])
        }).collect();
        let bs = ScaledVec::from_rats(&b);
        prop_assert!(basis.first_inconsistent(&bs).is_none());
        prop_assert!(f.is_consistent(&b));
        if let Some(&z) = basis.redundant.first() {
            let mut b2 = b.clone();
            b2[z] += Rat::one();
            prop_assert!(basis.first_inconsistent(&ScaledVec::from_rats(&b2)).is_some());
            prop_assert!(!f.is_consistent(&b2));
        }
    }

    /// Nonsingular solves equal the fraction-free solve bit for bit.
    #[test]
    fn nonsingular_solve_matches_fraction_free(
        k in 1usize..12, seed in 0u64..1000, scale in 1i64..1_000_000_007
    ) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::SmallRng::seed_from_u64(seed);
        // Diagonally dominated sparse rows: nonsingular.
        let rows: Vec<Vec<(usize, i64)>> = (0..k).map(|i| {
            let mut r = vec![(i, 40 + rng.gen_range(0..scale.min(1000)))];
            for _ in 0..2 {
                let c = rng.gen_range(0..k);
                if c != i && !r.iter().any(|e| e.0 == c) {
                    r.push((c, rng.gen_range(-9..=9)));
                }
            }
            r
        }).collect();
        let a = sparse(k, &rows);
        let b: Vec<Rat> = (0..k).map(|i| Rat::new(Int::from(rng.gen_range(-scale..=scale)), Int::from(1 + i as i64))).collect();
        let f = Ldu::factor(&a, LduOptions::default());
        let want = f.solve(&b).unwrap();
        let (got, _) = solve_nonsingular(&a, &[ScaledVec::from_rats(&b)]).unwrap();
        prop_assert_eq!(got[0].to_rats(), want);
    }
}

/// A solution far larger than one prime: thousands of bits, many primes, early termination
/// still exact (Hilbert-like dense 12 x 12 with big entries).
#[test]
fn many_prime_solve_is_exact() {
    let k = 12;
    let rows: Vec<Vec<(usize, Int)>> = (0..k)
        .map(|i| {
            (0..k)
                .map(|j| {
                    (
                        j,
                        Int::from(((i * 7 + j * 13) % 17) as i64 - 8)
                            * Int::from(1_000_003i64.pow(2))
                            + Int::from((i == j) as i64),
                    )
                })
                .filter(|e| !e.1.is_zero())
                .collect()
        })
        .collect();
    let a = SparseIntMatrix::from_rows(k, rows).unwrap();
    let b: Vec<Rat> = (0..k).map(|i| Rat::from_integer(Int::from(i as i64 + 1))).collect();
    let want = Ldu::factor(&a, LduOptions::default()).solve(&b).unwrap();
    let (got, stats) = solve_nonsingular(&a, &[ScaledVec::from_rats(&b)]).unwrap();
    assert_eq!(got[0].to_rats(), want);
    assert!(stats.primes > 4, "needs several primes: {stats:?}");
}

/// The exact verification catches a wrong reconstruction: a tampered candidate is rejected
/// every time, so no answer is reported; an untampered run gives the right answer.
#[test]
fn verification_rejects_an_injected_wrong_reconstruction() {
    let a = sparse(3, &[vec![(0, 2), (1, 1)], vec![(1, 3), (2, -1)], vec![(0, 1), (2, 5)]]);
    let b = ScaledVec::new(vec![Int::from(1), Int::from(2), Int::from(3)], Int::from(7));
    let off_by_one: Tamper<'_> = &|c: &mut [ScaledVec]| {
        c[0].num[1] += &Int::from(1);
    };
    match solve_nonsingular_with(&a, std::slice::from_ref(&b), Some(off_by_one)) {
        Err(ModularError::NoCertificate(_)) => {}
        other => panic!("a wrong candidate must never be reported: {other:?}"),
    }
    // Only the first candidate wrong: rejected once, then a correct one is verified.
    let once = std::sync::atomic::AtomicBool::new(false);
    let first_only = |c: &mut [ScaledVec]| {
        if !once.swap(true, std::sync::atomic::Ordering::SeqCst) {
            c[0].num[0] += &Int::from(1);
        }
    };
    let (x, stats) =
        solve_nonsingular_with(&a, std::slice::from_ref(&b), Some(&first_only)).unwrap();
    assert_eq!(stats.rejected, 1);
    assert!(verify(&a, &x[0], &b));
    let want = Ldu::factor(&a, LduOptions::default()).solve(&b.to_rats()).unwrap();
    assert_eq!(x[0].to_rats(), want);
}

/// A rank that looks lower modulo p than over Q is never certified: rows that are
/// dependent only modulo the first prime fail their certificate.
#[test]
fn unlucky_prime_is_not_certified() {
    let p = primes(1)[0] as i64;
    // Rows (1, 0) and (p, 1)... modulo p the second is (0, 1): independent anyway; build a
    // real trap: (1, 1) and (1 + p, 1) are independent over Q but equal modulo p.
    let a = sparse(2, &[vec![(0, 1), (1, 1)], vec![(0, 1 + p), (1, 1)]]);
    let basis = certified_basis(&a).unwrap();
    assert_eq!(basis.rank(), 2, "the second prime sees the true rank");
    assert!(basis.redundant.is_empty());
}

/// The canonical redundant set survives a prime that hides a dependency in row order: the
/// first two rows are equal modulo the first prime but independent over Q, and the third is
/// their sum. Modulo that prime the second row looks redundant; its certificate fails, and
/// the next prime names the third, the row that depends on earlier ones.
#[test]
fn unlucky_prime_in_row_order_gives_the_canonical_set() {
    let p = primes(1)[0] as i64;
    let a = sparse(2, &[vec![(0, 1), (1, 1)], vec![(0, 1 + p), (1, 1)], vec![(0, 2 + p), (1, 2)]]);
    let basis = certified_basis(&a).unwrap();
    assert_eq!(basis.rank(), 2);
    assert_eq!(basis.redundant, vec![2]);
    assert_eq!(basis.independent, vec![0, 1]);
}
