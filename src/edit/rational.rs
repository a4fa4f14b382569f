//! Exact rationals from floating-point edit parameters: continued-fraction approximation
//! and rational rotations (`cos^2 + sin^2 = 1` exactly, from `t = tan(angle / 2)`:
//! `cos = (1 - t^2) / (1 + t^2)`, `sin = 2 t / (1 + t^2)`).

use crate::exact::{Int, Rat};
use num_traits::One;

/// An exact rational close to `v`: continued fraction with denominator at most `max_den`.
pub fn rational_approx(v: f64, max_den: i64) -> Rat {
    let (mut h0, mut h1, mut k0, mut k1) = (0i64, 1i64, 1i64, 0i64);
    let mut x = v;
    for _ in 0..64 {
        let a = x.floor();
        if a.abs() > 1e15 {
            break;
        }
        let a = a as i64;
        let (h2, k2) =
            (a.saturating_mul(h1).saturating_add(h0), a.saturating_mul(k1).saturating_add(k0));
        if k2 > max_den || k2 <= 0 {
            break;
        }
        (h0, h1, k0, k1) = (h1, h2, k1, k2);
        let frac = x - a as f64;
        if frac.abs() < 1e-15 {
            break;
        }
        x = 1.0 / frac;
    }
    if k1 == 0 {
        // No convergent: |v| is beyond 1e15 (or not finite). The nearest integer in range.
        let r = if v.is_nan() { 0 } else { v.clamp(i64::MIN as f64, i64::MAX as f64) as i64 };
        return Rat::from_integer(Int::from(r));
    }
    Rat::new(Int::from(h1), Int::from(k1))
}

/// The exact rational rotation closest to `angle` with `t = tan(angle/2)` approximated with
/// denominator at most `2^16`: returns `(cos, sin)` with `cos^2 + sin^2 = 1` exactly.
///
/// `tan(angle/2)` is unbounded near `angle = pi`, so angles with `|angle| > pi/2` (after
/// reduction to `(-pi, pi]`) are taken as a half turn composed with `angle - pi`:
/// `(cos, sin) = -(cos', sin')`, exact, so a rotation by exactly `pi` (or `3 pi`) is
/// `(-1, 0)`.
pub fn rational_rotation(angle: f64) -> (Rat, Rat) {
    use std::f64::consts::{FRAC_PI_2, PI, TAU};
    let mut a = angle % TAU;
    if a > PI {
        a -= TAU;
    } else if a <= -PI {
        a += TAU;
    }
    let half_turn = a.abs() > FRAC_PI_2;
    if half_turn {
        a -= PI.copysign(a);
    }
    let t = rational_approx((a / 2.0).tan(), 1 << 16);
    let t2 = &t * &t;
    let den = Rat::one() + &t2;
    let (c, s) = ((Rat::one() - &t2) / &den, (&t + &t) / den);
    if half_turn {
        (-c, -s)
    } else {
        (c, s)
    }
}
