//! Tests of [`super`]: solves rebuilt from their factors, refactoring, patterns.
use super::*;

/// `refactor` with a spare factor gives exactly the fresh factor's solution, for new
/// values (the spare's old values do not leak), and drops a spare of another pattern.
#[test]
fn refactor_reuses_buffers_and_gives_the_fresh_result() {
    let n = 5;
    let entries: Vec<(usize, usize)> = (0..n)
        .flat_map(|i| [(i, i)].into_iter().chain((i + 1 < n).then_some((i + 1, i))))
        .collect();
    let vals = |d: f64| -> Vec<f64> {
        entries.iter().map(|&(r, c)| if r == c { d } else { -1.0 }).collect()
    };
    let p = Pattern::new(n, &entries).unwrap();
    let other = Pattern::new(n, &entries).unwrap();
    let solve = |f: &Factor| {
        let mut b: Vec<f64> = (0..n).map(|i| i as f64 + 1.0).collect();
        f.solve(&mut b);
        b
    };
    let first = p.factor(&vals(4.0)).unwrap();
    let fresh = p.factor(&vals(3.0)).unwrap();
    let reused = p.refactor(&vals(3.0), Some(first)).unwrap();
    assert_eq!(solve(&reused), solve(&fresh));
    let foreign = other.refactor(&vals(3.0), Some(reused)).unwrap();
    assert_eq!(solve(&foreign), solve(&fresh));
}

#[test]
fn solves_a_small_spd_system_and_rebuilds_the_right_hand_side() {
    // Tridiagonal 2, -1 plus a corner coupling; entries given in both triangles and
    // with duplicates to check mirroring and summation.
    let n = 6;
    let mut entries = Vec::new();
    let mut vals = Vec::new();
    for i in 0..n {
        entries.push((i, i));
        vals.push(1.5);
        entries.push((i, i));
        vals.push(1.5);
        if i + 1 < n {
            entries.push((i, i + 1));
            vals.push(-1.0);
        }
    }
    entries.push((n - 1, 0));
    vals.push(0.25);
    let p = Pattern::new(n, &entries).unwrap();
    let f = p.factor(&vals).unwrap();
    let x_true: Vec<f64> = (0..n).map(|i| i as f64 - 2.5).collect();
    let mut b = vec![0.0; n];
    for (&(r, c), &v) in entries.iter().zip(&vals) {
        b[r] += v * x_true[c];
        if r != c {
            b[c] += v * x_true[r];
        }
    }
    f.solve(&mut b);
    for (a, e) in b.iter().zip(&x_true) {
        assert!((a - e).abs() < 1e-12, "{a} vs {e}");
    }
}

proptest::proptest! {
    /// Random overlapping cliques: the pattern built from the cliques is the pattern
    /// built from their listed entries (same columns, same positions), with and without
    /// the diagonal, and factors the same values to the same factor.
    #[test]
    fn clique_patterns_equal_entry_patterns(
        n in 1usize..30,
        raw in proptest::collection::vec(proptest::collection::vec(0usize..30, 1..8), 0..12),
        diagonal in proptest::bool::ANY,
    ) {
        let cliques: Vec<Vec<usize>> = raw
            .iter()
            .map(|c| {
                let mut c: Vec<usize> = c.iter().map(|&v| v % n).collect();
                c.sort_unstable();
                c.dedup();
                c
            })
            .collect();
        let mut entries = lower_clique_entries(&cliques);
        if diagonal {
            entries.extend((0..n).map(|i| (i, i)));
        }
        let a = Pattern::from_cliques(n, &cliques, diagonal).unwrap();
        let b = Pattern::new(n, &entries).unwrap();
        proptest::prop_assert_eq!(&a.pos, &b.pos);
        proptest::prop_assert_eq!(a.symbolic.col_ptr(), b.symbolic.col_ptr());
        proptest::prop_assert_eq!(a.symbolic.row_idx(), b.symbolic.row_idx());
        // Values that make the matrix positive definite: 1 off the diagonal, and a
        // diagonal larger than any row sum.
        if diagonal {
            let vals: Vec<f64> = entries
                .iter()
                .enumerate()
                .map(|(i, &(r, c))| if i >= entries.len() - n { 100.0 } else if r == c { 2.0 } else { 0.5 })
                .collect();
            let (fa, fb) = (a.factor(&vals).unwrap(), b.factor(&vals).unwrap());
            proptest::prop_assert_eq!(fa.values, fb.values);
        }
    }

    /// Random diagonally dominant matrices given as shuffled, mirrored and repeated
    /// entries: the solve matches the matrix assembled densely.
    #[test]
    fn assembly_sums_duplicates_in_any_order(
        n in 1usize..12,
        raw in proptest::collection::vec((0usize..12, 0usize..12, -1.0f64..1.0), 0..60),
    ) {
        let mut entries: Vec<(usize, usize)> = Vec::new();
        let mut vals = Vec::new();
        let mut dense = vec![0.0; n * n];
        for &(r, c, v) in &raw {
            let (r, c) = (r % n, c % n);
            entries.push((r, c));
            vals.push(v);
            let (a, b) = if r >= c { (r, c) } else { (c, r) };
            dense[a * n + b] += v;
            if a != b {
                dense[b * n + a] += v;
            }
        }
        for i in 0..n {
            entries.push((i, i));
            vals.push(2.0 * raw.len() as f64 + 1.0);
            dense[i * n + i] += 2.0 * raw.len() as f64 + 1.0;
        }
        let f = Pattern::new(n, &entries).unwrap().factor(&vals).unwrap();
        let x_true: Vec<f64> = (0..n).map(|i| i as f64 * 0.5 - 1.0).collect();
        let mut b: Vec<f64> =
            (0..n).map(|i| (0..n).map(|j| dense[i * n + j] * x_true[j]).sum()).collect();
        f.solve(&mut b);
        for (a, e) in b.iter().zip(&x_true) {
            proptest::prop_assert!((a - e).abs() < 1e-10, "{} vs {}", a, e);
        }
    }
}

#[test]
fn many_right_hand_sides_in_blocks_match_one_at_a_time() {
    let n = 7;
    let mut entries = Vec::new();
    let mut vals = Vec::new();
    for i in 0..n {
        entries.push((i, i));
        vals.push(4.0);
        if i > 0 {
            entries.push((i, i - 1));
            vals.push(-1.0);
        }
    }
    let f = Pattern::new(n, &entries).unwrap().factor(&vals).unwrap();
    let cols = 2 * SOLVE_BLOCK + 3;
    let mut many: Vec<f64> = (0..n * cols).map(|i| (i % 11) as f64 - 5.0).collect();
    let mut single = many.clone();
    f.solve_many(&mut many, n, cols);
    for c in 0..cols {
        f.solve(&mut single[c * n..(c + 1) * n]);
    }
    assert_eq!(many, single);
}

#[test]
fn an_indefinite_matrix_is_reported() {
    let p = Pattern::new(2, &[(0, 0), (1, 1), (1, 0)]).unwrap();
    assert_eq!(p.factor(&[1.0, 1.0, 2.0]).unwrap_err(), SparseError::NotPositiveDefinite);
}

/// A 2D grid system (`g x g` unknowns): each unknown coupled to those within `reach`
/// steps in both directions, diagonally dominant.
fn grid_system(g: usize, reach: usize) -> (usize, Vec<(usize, usize)>, Vec<f64>) {
    let n = g * g;
    let (mut entries, mut vals) = (Vec::new(), Vec::new());
    let side = 2 * reach + 1;
    for i in 0..g {
        for j in 0..g {
            let p = i * g + j;
            entries.push((p, p));
            vals.push((side * side) as f64);
            for di in 0..=reach {
                for dj in 0..side {
                    let (ii, jj) = (i + di, (j + dj).wrapping_sub(reach));
                    if (di, dj) <= (0, reach) || ii >= g || jj >= g {
                        continue;
                    }
                    entries.push((p, ii * g + jj));
                    vals.push(-1.0);
                }
            }
        }
    }
    (n, entries, vals)
}

/// `B^T A^-1 B` by sparse forward substitution equals the product with full solves,
/// for simplicial and supernodal factors and for columns in any order (some empty).
#[test]
fn inverse_gram_matches_full_solves() {
    let mut kinds = Vec::new();
    for (g, reach) in [(4, 1), (9, 1), (20, 2), (30, 3)] {
        let (n, entries, vals) = grid_system(g, reach);
        let f = Pattern::new(n, &entries).unwrap().factor(&vals).unwrap();
        kinds.push(matches!(f.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_)));
        let k = 2 * SOLVE_BLOCK + 5;
        let cols: Vec<Vec<(usize, f64)>> = (0..k)
            .map(|j| {
                if j % 17 == 5 {
                    return Vec::new();
                }
                let c = (j * 7919) % n;
                let mut col = vec![(c, 1.0 + j as f64 * 0.01)];
                if c + 1 < n {
                    col.push((c + 1, -0.5));
                }
                col.push(((c * 31 + 3) % n, 0.25));
                col
            })
            .collect();
        let gram = f.inverse_gram(&cols);
        let mut dense = vec![0.0; n * k];
        for (j, col) in cols.iter().enumerate() {
            for &(r, v) in col {
                dense[j * n + r] += v;
            }
        }
        f.solve_many(&mut dense, n, k);
        for i in 0..k {
            for j in 0..k {
                let want: f64 = cols[i].iter().map(|&(r, v)| v * dense[j * n + r]).sum();
                let got = gram[i * k + j];
                assert!(
                    (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                    "{i},{j}: {got} vs {want}"
                );
                assert_eq!(got, gram[j * k + i]);
            }
        }
    }
    assert!(kinds.contains(&true) && kinds.contains(&false), "both factor kinds: {kinds:?}");
}
