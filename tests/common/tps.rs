//! A thin-plate spline baseline (interpolating), implemented here independently of trimorph.

use trimorph::fit::landmarks::Landmark;
use trimorph::geom::Point;

/// Thin-plate spline through the landmarks: `f(p) = a + A p + sum_i w_i U(|p - s_i|)`,
/// `U(r) = r^2 log r`, solved per coordinate from the standard bordered system.
pub struct Tps {
    src: Vec<[f64; 2]>,
    coef: [Vec<f64>; 2],
}

impl Tps {
    fn u(r: f64) -> f64 {
        if r <= 0.0 {
            0.0
        } else {
            r * r * r.ln()
        }
    }

    pub fn new(lms: &[Landmark]) -> Tps {
        let n = lms.len();
        let m = n + 3;
        let mut a = vec![vec![0.0; m]; m];
        for i in 0..n {
            for j in 0..n {
                let (p, q) = (lms[i].src, lms[j].src);
                a[i][j] = Self::u((p[0] - q[0]).hypot(p[1] - q[1]));
            }
            let row = [1.0, lms[i].src[0], lms[i].src[1]];
            for k in 0..3 {
                a[i][n + k] = row[k];
                a[n + k][i] = row[k];
            }
        }
        let solve = |rhs: Vec<f64>| -> Vec<f64> {
            let mut a = a.clone();
            let mut b = rhs;
            for c in 0..m {
                let p = (c..m).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs())).unwrap();
                a.swap(c, p);
                b.swap(c, p);
                for r in c + 1..m {
                    let f = a[r][c] / a[c][c];
                    let (top, bot) = a.split_at_mut(r);
                    for (x, y) in bot[0][c..m].iter_mut().zip(&top[c][c..m]) {
                        *x -= f * y;
                    }
                    b[r] -= f * b[c];
                }
            }
            let mut x = vec![0.0; m];
            for r in (0..m).rev() {
                let s: f64 = (r + 1..m).map(|k| a[r][k] * x[k]).sum();
                x[r] = (b[r] - s) / a[r][r];
            }
            x
        };
        let rhs = |c: usize| {
            let mut v: Vec<f64> = lms.iter().map(|l| l.dst[c]).collect();
            v.extend([0.0; 3]);
            v
        };
        Tps { src: lms.iter().map(|l| l.src).collect(), coef: [solve(rhs(0)), solve(rhs(1))] }
    }

    /// The distances `|tps(s) - t|` of held-out landmarks (pixels), in their order.
    pub fn errors(&self, held: &[Landmark]) -> Vec<f64> {
        held.iter()
            .map(|l| {
                let m = self.eval(l.src);
                (m[0] - l.dst[0]).hypot(m[1] - l.dst[1])
            })
            .collect()
    }

    pub fn eval(&self, p: [f64; 2]) -> [f64; 2] {
        let n = self.src.len();
        [0, 1].map(|c| {
            let w = &self.coef[c];
            let mut v = w[n] + w[n + 1] * p[0] + w[n + 2] * p[1];
            for (i, s) in self.src.iter().enumerate() {
                v += w[i] * Self::u((p[0] - s[0]).hypot(p[1] - s[1]));
            }
            v
        })
    }
}

/// The TPS as a map of the plane, so the library's generic resampling takes it
/// (`trimorph::warp::pull_back_map`); defined everywhere, without an inverse.
impl trimorph::warp::Map2 for Tps {
    fn value(&self, p: Point) -> Option<Point> {
        Some(self.eval(p.to_array()).into())
    }

    /// `d/dp [r^2 log r] = (2 log r + 1) (p - s)` (0 at `r = 0`).
    fn jacobian(&self, p: Point) -> Option<[[f64; 2]; 2]> {
        let p = p.to_array();
        let n = self.src.len();
        Some([0, 1].map(|c| {
            let w = &self.coef[c];
            let mut g = [w[n + 1], w[n + 2]];
            for (i, s) in self.src.iter().enumerate() {
                let d = [p[0] - s[0], p[1] - s[1]];
                let r = d[0].hypot(d[1]);
                if r > 0.0 {
                    let k = w[i] * (2.0 * r.ln() + 1.0);
                    g = [g[0] + k * d[0], g[1] + k * d[1]];
                }
            }
            g
        }))
    }
}
