//! The exact spline of an affine map.
//!
//! An affine map `A(x, y) = (a x + b y + c, d x + e y + f)` is a polynomial of degree 1, so
//! on every triangle its Bernstein-Bezier control points of any degree are `A` applied to
//! the nominal positions (degree elevation keeps a linear polynomial's control points on the
//! domain points; thesis Part II ch. 10). The result is C1 across every edge whatever the
//! mesh: the quadrilateral conditions are linear and hold for the identity, so they hold for
//! any affine image of it.
//!
//! The nominal positions are integer numerators `n` over `D = degree * grid`
//! ([`Layout::nominal_int`]); with each coefficient row on its common denominator `E`
//! (`a = a' / E`, ...), every coordinate is `(a' n_x + b' n_y + c' D) / (E D)`: integer
//! products and one gcd per value, in checked `i128` when it fits and in exact integers of
//! any size otherwise.

use super::{Spline, SplineError};
use crate::exact::{Int, Rat};
use crate::mesh::Mesh;
use num_integer::Integer;
use rayon::prelude::*;

impl Spline {
    /// The spline of the affine map `x -> (a[0][0] x + a[0][1] y + a[0][2],
    /// a[1][0] x + a[1][1] y + a[1][2])` over `mesh`, exactly (see the module docs). It is
    /// C1 by construction, so no check is run.
    ///
    /// ```
    /// use trimorph::exact::Rat;
    /// use trimorph::mesh::{Mesh, MeshOptions};
    /// use trimorph::spline::Spline;
    /// let mesh = Mesh::grid(2, 2, 10.0, 10.0, MeshOptions::default()).unwrap();
    /// let r = |n: i64, d: i64| Rat::new(n.into(), d.into());
    /// let a = [[r(1, 2), r(-1, 3), r(7, 1)], [r(1, 5), r(3, 4), r(-2, 1)]];
    /// let s = Spline::affine(mesh, 5, &a).unwrap();
    /// s.check_c1().unwrap();
    /// let p = s.eval([4.0, 6.0], None).unwrap();
    /// assert!((p[0] - (2.0 - 2.0 + 7.0)).abs() < 1e-12 && (p[1] - (0.8 + 4.5 - 2.0)).abs() < 1e-12);
    /// ```
    pub fn affine(mesh: Mesh, degree: usize, a: &[[Rat; 3]; 2]) -> Result<Spline, SplineError> {
        let layout = Self::layout_for(&mesh, degree)?;
        let nominal = layout.nominal_int(&mesh);
        let den = degree as i128 * mesh.grid_denominator() as i128;
        let rows = [row_on_common_denominator(&a[0]), row_on_common_denominator(&a[1])];
        // One gcd per value: independent, so on rayon's workers.
        let points =
            nominal.par_iter().map(|n| rows.iter().map(|r| r.apply(n, den)).collect()).collect();
        Ok(Self::assemble(mesh, layout, points, None))
    }
}

/// One coefficient row `(a, b, c)` as integers over a common denominator `e > 0`.
struct Row {
    num: [Int; 3],
    e: Int,
    /// The same in `i128`, when every part fits.
    small: Option<([i128; 3], i128)>,
}

fn row_on_common_denominator(r: &[Rat; 3]) -> Row {
    let e = r.iter().fold(Int::from(1), |l, c| l.lcm(c.denom()));
    let num = [0, 1, 2].map(|k| r[k].numer() * &e.div_exact(r[k].denom()));
    let small = (|| {
        let n = [0, 1, 2].map(|k| super::intform::int_i128(&num[k]));
        Some(([n[0]?, n[1]?, n[2]?], super::intform::int_i128(&e)?))
    })();
    Row { num, e, small }
}

impl Row {
    /// `(a' n_x + b' n_y + c' den) / (e den)`, reduced.
    fn apply(&self, n: &[i128; 2], den: i128) -> Rat {
        if let Some(([a, b, c], e)) = self.small {
            let value = (|| {
                a.checked_mul(n[0])?
                    .checked_add(b.checked_mul(n[1])?)?
                    .checked_add(c.checked_mul(den)?)
                    .zip(e.checked_mul(den))
            })();
            if let Some((num, d)) = value {
                return Rat::new(Int::from_i128(num), Int::from_i128(d));
            }
        }
        let num = &(&(&self.num[0] * &Int::from_i128(n[0]))
            + &(&self.num[1] * &Int::from_i128(n[1])))
            + &(&self.num[2] * &Int::from_i128(den));
        Rat::new(num, &self.e * &Int::from_i128(den))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::MeshOptions;
    use proptest::prelude::*;

    fn r(n: i64, d: i64) -> Rat {
        Rat::new(Int::from(n), Int::from(d))
    }

    /// The reference: the identity's exact points mapped with fraction arithmetic.
    fn by_fractions(mesh: &Mesh, degree: usize, a: &[[Rat; 3]; 2]) -> Vec<Vec<Rat>> {
        let id = Spline::identity(mesh.clone(), degree).unwrap();
        id.points()
            .iter()
            .map(|p| (0..2).map(|k| &a[k][0] * &p[0] + &a[k][1] * &p[1] + &a[k][2]).collect())
            .collect()
    }

    #[test]
    fn huge_coefficients_take_the_big_integer_path_with_the_same_values() {
        let mesh = Mesh::grid(3, 2, 511.0, 300.0, MeshOptions::default()).unwrap();
        let big = Rat::new(Int::from_i128(i128::MAX / 3), Int::from_i128((1i128 << 100) + 7));
        let a = [[big.clone(), r(1, 3), r(5, 1)], [r(-2, 7), big, r(1, 1 << 40)]];
        let s = Spline::affine(mesh.clone(), 5, &a).unwrap();
        assert_eq!(s.points(), &by_fractions(&mesh, 5, &a)[..]);
        s.check_c1().unwrap();
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
        /// Random affine maps with small and 2^24-grid coefficients on meshes of several
        /// sizes and degrees: the integer path gives exactly the fraction values, and the
        /// result passes the exact C1 check.
        #[test]
        fn matches_fraction_arithmetic_and_is_c1(
            c in proptest::collection::vec((-(1i64 << 30)..(1i64 << 30), 0u32..25), 6),
            nx in 1usize..4, ny in 1usize..4, degree in 2usize..7,
        ) {
            let mesh = Mesh::grid(nx, ny, 97.0, 61.0, MeshOptions::default()).unwrap();
            let q = |k: usize| r(c[k].0, 1i64 << c[k].1);
            let a = [[q(0), q(1), q(2)], [q(3), q(4), q(5)]];
            let s = Spline::affine(mesh.clone(), degree, &a).unwrap();
            prop_assert_eq!(s.points(), &by_fractions(&mesh, degree, &a)[..]);
            prop_assert!(s.check_c1().is_ok());
        }
    }
}
