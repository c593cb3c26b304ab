//! Trigonometry built from `+ - * /` only.
//!
//! The committed assets are compared byte for byte with a fresh run (tests/regenerate.rs), so
//! every number must come out identical on every platform. `f64::sin` and friends call the
//! platform's libm, whose last-bit rounding differs between glibc, musl and macOS; IEEE 754
//! guarantees exact rounding only for the basic operations and `sqrt`, which is all this uses.

pub const PI: f64 = std::f64::consts::PI;
pub const TAU: f64 = std::f64::consts::TAU;
const FRAC_PI_2: f64 = std::f64::consts::FRAC_PI_2;
const FRAC_PI_6: f64 = std::f64::consts::FRAC_PI_6;

/// Taylor series on |x| <= pi/4; the x^17 term is below 5e-17 there.
fn sin_kernel(x: f64) -> f64 {
    let x2 = x * x;
    let mut term = x;
    let mut sum = x;
    for k in 1..9 {
        let k = k as f64;
        term = -term * x2 / ((2.0 * k) * (2.0 * k + 1.0));
        sum += term;
    }
    sum
}

fn cos_kernel(x: f64) -> f64 {
    let x2 = x * x;
    let mut term = 1.0;
    let mut sum = 1.0;
    for k in 1..9 {
        let k = k as f64;
        term = -term * x2 / ((2.0 * k - 1.0) * (2.0 * k));
        sum += term;
    }
    sum
}

/// (sin x, cos x).
pub fn sin_cos(x: f64) -> (f64, f64) {
    // `round` is exact, so the reduction is as reproducible as the kernels.
    let q = (x / FRAC_PI_2).round();
    let r = x - q * FRAC_PI_2;
    let (s, c) = (sin_kernel(r), cos_kernel(r));
    match (q as i64).rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

pub fn sin(x: f64) -> f64 {
    sin_cos(x).0
}

pub fn cos(x: f64) -> f64 {
    sin_cos(x).1
}

/// atan on [0, tan(pi/12)]: the series converges fast enough (x^29 term < 1e-17).
fn atan_kernel(x: f64) -> f64 {
    let x2 = x * x;
    let mut power = x;
    let mut sum = x;
    for k in 1..15 {
        power *= -x2;
        sum += power / (2 * k + 1) as f64;
    }
    sum
}

pub fn atan(x: f64) -> f64 {
    if x < 0.0 {
        return -atan(-x);
    }
    if x > 1.0 {
        return FRAC_PI_2 - atan(1.0 / x);
    }
    const TAN_PI_12: f64 = 0.267_949_192_431_122_7;
    const SQRT_3: f64 = 1.732_050_807_568_877_2;
    if x > TAN_PI_12 {
        // atan x = pi/6 + atan((x*sqrt3 - 1) / (x + sqrt3))
        return FRAC_PI_6 + atan_kernel((x * SQRT_3 - 1.0) / (x + SQRT_3));
    }
    atan_kernel(x)
}

pub fn atan2(y: f64, x: f64) -> f64 {
    if x == 0.0 && y == 0.0 {
        return 0.0;
    }
    if x.abs() >= y.abs() {
        let a = atan(y / x);
        if x > 0.0 {
            a
        } else if y >= 0.0 {
            a + PI
        } else {
            a - PI
        }
    } else {
        let a = atan(x / y);
        if y > 0.0 {
            FRAC_PI_2 - a
        } else {
            -FRAC_PI_2 - a
        }
    }
}

/// An angle in [0, 2pi).
pub fn angle(y: f64, x: f64) -> f64 {
    let a = atan2(y, x);
    if a < 0.0 { a + TAU } else { a }
}

pub fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

pub fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_libm_closely() {
        for i in -2000..2000 {
            let x = i as f64 * 0.0137;
            assert!((sin(x) - x.sin()).abs() < 1e-14, "sin {x}");
            assert!((cos(x) - x.cos()).abs() < 1e-14, "cos {x}");
            assert!((atan(x) - x.atan()).abs() < 1e-14, "atan {x}");
            for j in -5..5 {
                let y = j as f64 * 0.731;
                assert!((atan2(y, x) - y.atan2(x)).abs() < 1e-14, "atan2 {y} {x}");
            }
        }
    }
}
