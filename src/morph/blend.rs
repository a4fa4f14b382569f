//! Exact blends of two control-point sets, on common denominators.
//!
//! A frame's map is `(1 - w) P + w Q` control point by control point, for two exactly-C1
//! point sets `P`, `Q` on one mesh and a rational weight `w = p / q`. Evaluated as reduced
//! fractions, each coordinate costs several gcds of large integers (the determining set's
//! dependent points have large denominators). Here each coordinate pair is stored once over
//! its common denominator `L = lcm(den P, den Q)` as integers `P = m / L`, `Q = n / L`, so
//! that
//!
//! ```text
//!   (1 - w) P + w Q = ((q - p) m + p n) / (q L)
//! ```
//!
//! costs two products, a sum and one final reduction: the same exact value.

use crate::exact::{Int, Rat};
use num_integer::Integer;

/// Two point sets over common denominators (see the module docs).
#[derive(Clone, Debug)]
pub struct Blend {
    /// Per point and coordinate: `(m, n, L)`.
    terms: Vec<Vec<(Int, Int, Int)>>,
}

impl Blend {
    /// The blend of `p` (weight `1 - w`) and `q` (weight `w`), which must have the same
    /// shape.
    pub fn new(p: &[Vec<Rat>], q: &[Vec<Rat>]) -> Blend {
        assert_eq!(p.len(), q.len(), "one point per point");
        let terms = p
            .iter()
            .zip(q)
            .map(|(a, b)| {
                a.iter()
                    .zip(b)
                    .map(|(x, y)| {
                        let l = x.denom().lcm(y.denom());
                        let m = x.numer() * &l.div_exact(x.denom());
                        let n = y.numer() * &l.div_exact(y.denom());
                        (m, n, l)
                    })
                    .collect()
            })
            .collect();
        Blend { terms }
    }

    /// `(1 - w) P + w Q`, exactly, as reduced fractions.
    pub fn at(&self, w: &Rat) -> Vec<Vec<Rat>> {
        let (p, q) = (w.numer(), w.denom());
        let qp = q - p;
        self.terms
            .iter()
            .map(|pt| pt.iter().map(|(m, n, l)| Rat::new(&(&qp * m) + &(p * n), q * l)).collect())
            .collect()
    }

    /// [`Blend::at`] as fractions not reduced to lowest terms (no gcd): the same exact
    /// values, and so the same nearest `f64`s (`rat_to_f64` rounds the value, whatever its
    /// representation), for a frame's map that is only evaluated.
    pub fn at_raw(&self, w: &Rat) -> Vec<Vec<Rat>> {
        let (p, q) = (w.numer(), w.denom());
        let qp = q - p;
        self.terms
            .iter()
            .map(|pt| {
                pt.iter().map(|(m, n, l)| Rat::new_raw(&(&qp * m) + &(p * n), q * l)).collect()
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exact::rat_to_f64;
    use proptest::prelude::*;

    fn r(n: i64, d: i64) -> Rat {
        Rat::new(Int::from(n), Int::from(d))
    }

    proptest! {
        #[test]
        fn equals_the_reduced_fraction_blend(
            pts in proptest::collection::vec(((-500i64..500, 1i64..90), (-500i64..500, 1i64..90)), 1..8),
            wn in -20i64..20, wd in 1i64..17,
        ) {
            let p: Vec<Vec<Rat>> = pts.iter().map(|(a, _)| vec![r(a.0, a.1), r(a.1, a.0.abs() + 1)]).collect();
            let q: Vec<Vec<Rat>> = pts.iter().map(|(_, b)| vec![r(b.0, b.1), r(-b.0, b.1 + 3)]).collect();
            let w = r(wn, wd);
            let want: Vec<Vec<Rat>> = p
                .iter()
                .zip(&q)
                .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x + &(&w * &(y - x))).collect())
                .collect();
            let got = Blend::new(&p, &q).at(&w);
            prop_assert_eq!(&got, &want);
            let raw = Blend::new(&p, &q).at_raw(&w);
            prop_assert_eq!(&raw, &want);
            for (g, e) in raw.iter().flatten().zip(want.iter().flatten()) {
                prop_assert_eq!(rat_to_f64(g).to_bits(), rat_to_f64(e).to_bits());
            }
            for (g, e) in got.iter().flatten().zip(want.iter().flatten()) {
                prop_assert_eq!((g.numer(), g.denom()), (e.numer(), e.denom()));
            }
        }
    }
}
