//! The arithmetic the filters need, so one implementation serves f32 (production) and f64
//! (references and tests).

use std::ops::{Add, Div, Mul, Sub};

pub trait Real:
    Copy
    + Send
    + Sync
    + Default
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + 'static
{
    fn of(v: f64) -> Self;
    fn f64(self) -> f64;
}

impl Real for f32 {
    #[inline]
    fn of(v: f64) -> Self {
        v as f32
    }
    #[inline]
    fn f64(self) -> f64 {
        self as f64
    }
}

impl Real for f64 {
    #[inline]
    fn of(v: f64) -> Self {
        v
    }
    #[inline]
    fn f64(self) -> f64 {
        self
    }
}

#[inline]
pub fn clamp01<T: Real>(v: T) -> T {
    // Written so that NaN maps to 0 rather than propagating.
    if v > T::of(0.0) {
        if v < T::of(1.0) { v } else { T::of(1.0) }
    } else {
        T::of(0.0)
    }
}
