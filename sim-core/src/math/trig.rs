//! The sine and cosine of the control loop (the robot's heading, each move's arc), computed
//! as glibc's `sinf` and `sincosf` compute them on a CPU with fused multiply-add, bit for bit,
//! without calling libm: one sample at a time for the scalar evaluator, and [`LANES`] at a time
//! in vector registers for the lockstep evaluator, with the same bits.
//!
//! Why not libm: the lockstep evaluator needs the sines of eight samples at once, and a libm
//! call per sample (three per control cycle) was about a tenth of a cycle in the rooms. The
//! results must stay those of the model as it was measured, which called glibc, so this is
//! glibc's algorithm (the `sincosf` of ARM's optimized routines, in glibc since 2.28) with its
//! constants and its operations in its order: the float widened to a double, reduced by a
//! multiple of pi/2 when it is 0.75 or more in magnitude, and a polynomial in the double,
//! rounded to a float once at the end. Where glibc's FMA build fuses a multiplication and an
//! addition, this calls [`f64::mul_add`], which rounds once as the hardware does. Inputs of
//! 120 or more in magnitude, infinities and NaN (never a heading or an arc on a legal run) are
//! passed to libm.
//!
//! The tests compare every float below 4 in magnitude (the headings and arcs of a run) with
//! libm, and every lane with the scalar function. Since the results no longer depend on which
//! build of `sincosf` glibc picks for the CPU, they are also the same on CPUs without FMA (where
//! glibc's own results differ in a few values in a billion).

use crate::math::lanes::LANES;

/// glibc's `__sincosf_table[0]`: 2^24 * 2 / pi, pi / 2, the cosine polynomial's coefficients
/// c0..c4 and the sine polynomial's s1..s3 (the second table negates every c).
const HALF_PI_INVERSE_2P24: f64 = f64::from_bits(0x4164_5f30_6dc9_c883);
const HALF_PI: f64 = f64::from_bits(0x3ff9_21fb_5444_2d18);
const TWO_POW_23: f64 = 8_388_608.0;
const TWO_POW_MINUS_24: f64 = 1.0 / 16_777_216.0;
const COSINE: [f64; 5] = [
    f64::from_bits(0x3ff0_0000_0000_0000),
    f64::from_bits(0xbfdf_ffff_fd0c_621c),
    f64::from_bits(0x3fa5_5553_e106_8f19),
    f64::from_bits(0xbf56_c087_e89a_359d),
    f64::from_bits(0x3ef9_9343_027b_f8c3),
];
const SINE: [f64; 3] = [
    f64::from_bits(0xbfc5_5554_5995_a603),
    f64::from_bits(0x3f81_1076_0523_0bc4),
    f64::from_bits(0xbf29_94eb_3774_cf24),
];

/// The top twelve bits of a float without its sign, as glibc compares magnitudes.
#[inline(always)]
fn magnitude_top12(y: f32) -> u32 {
    (y.to_bits() >> 20) & 0x7ff
}

/// Below this (2^-12), the sine is the input and the cosine 1.
const TINY_TOP12: u32 = 0x398;
/// From this (120) on, libm answers.
const LARGE_TOP12: u32 = 0x42f;

/// The reduction and the polynomial for `|y| < 120`, without branches: `(sines, cosines)`.
/// One loop body over the lanes, which the compiler turns into vector instructions (the same
/// steps written lane array by lane array stay scalar). The names follow glibc's
/// `sincosf_poly` (its `s1`, `c1`, `c2`, `s` and `c` are `s_inner`, `c_low`, `c_inner`, `s_low`
/// and `c_mid`).
///
/// Below 0.75 in magnitude glibc skips the reduction, but the reduction then finds no quarter
/// turn (n = 0) and leaves the double as it is (x - 0 * pi/2 is x, signed zeros included), so
/// one path serves both.
#[inline(always)]
fn sin_cos_reduced<const N: usize>(y: &[f32; N]) -> ([f32; N], [f32; N]) {
    let mut sines = [0.0f32; N];
    let mut cosines = [0.0f32; N];
    for lane in 0..N {
        let x = f64::from(y[lane]);
        // glibc's quarter turns, n = ((int) trunc(x * 2^24 * 2/pi) + 2^23) >> 24, computed
        // in doubles, which hold those integers exactly (the shift is a floor of a division by
        // 2^24), so that the lanes stay in vector registers.
        let truncated = (x * HALF_PI_INVERSE_2P24).trunc();
        let n = ((truncated + TWO_POW_23) * TWO_POW_MINUS_24).floor();
        let quadrant = n - 4.0 * (n * 0.25).floor();
        let reduced = (-n).mul_add(HALF_PI, x);
        // glibc's sign[n & 3] is (1, -1, -1, 1), and its second table (n & 2) is the first
        // with every c negated: multiplying by -1 is exact.
        let sign = if (quadrant == 1.0) | (quadrant == 2.0) {
            -1.0
        } else {
            1.0
        };
        let flip = if quadrant >= 2.0 { -1.0 } else { 1.0 };
        let c = COSINE.map(|c| c * flip);
        let x_signed = reduced * sign;
        let x2 = reduced * reduced;
        let x3 = x2 * x_signed;
        let x4 = x2 * x2;
        let x5 = x2 * x3;
        let x6 = x2 * x4;
        let s_inner = x2.mul_add(SINE[2], SINE[1]);
        let c_inner = x2.mul_add(c[4], c[3]);
        let c_low = x2.mul_add(c[1], c[0]);
        let s_low = x3.mul_add(SINE[0], x_signed);
        let c_mid = x4.mul_add(c[2], c_low);
        let sine = s_inner.mul_add(x5, s_low) as f32;
        let cosine = c_inner.mul_add(x6, c_mid) as f32;
        // An odd number of quarter turns swaps the two.
        let odd = (quadrant == 1.0) | (quadrant == 3.0);
        sines[lane] = if odd { cosine } else { sine };
        cosines[lane] = if odd { sine } else { cosine };
    }
    (sines, cosines)
}

/// `(sin y, cos y)`, bit for bit glibc's `sincosf` (FMA build); its sine is glibc's `sinf`.
#[multiversion::multiversion(targets("x86_64+fma"))]
pub fn sin_cos(y: f32) -> (f32, f32) {
    let top12 = magnitude_top12(y);
    if top12 < TINY_TOP12 {
        (y, 1.0)
    } else if top12 < LARGE_TOP12 {
        let ([sine], [cosine]) = sin_cos_reduced(&[y]);
        (sine, cosine)
    } else {
        (y.sin(), y.cos())
    }
}

/// [`sin_cos`] of every lane: the same bits, eight lanes in the vector registers at once.
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
pub fn sin_cos_lanes(y: &[f32; LANES]) -> ([f32; LANES], [f32; LANES]) {
    let (mut sines, mut cosines) = sin_cos_reduced(y);
    for lane in 0..LANES {
        let top12 = magnitude_top12(y[lane]);
        if top12 < TINY_TOP12 {
            (sines[lane], cosines[lane]) = (y[lane], 1.0);
        } else if top12 >= LARGE_TOP12 {
            (sines[lane], cosines[lane]) = (y[lane].sin(), y[lane].cos());
        }
    }
    (sines, cosines)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// libm's `sinf`, `cosf` and `sincosf`, each on its own: the compiler turns a sine and a
    /// cosine of the same value in one function into one `sincosf` call, and the control loop
    /// called both `sincosf` (headings) and `sinf` (half turns).
    #[inline(never)]
    fn libm_sin(y: f32) -> f32 {
        y.sin()
    }

    #[inline(never)]
    fn libm_cos(y: f32) -> f32 {
        y.cos()
    }

    #[inline(never)]
    fn libm_sin_cos(y: f32) -> (f32, f32) {
        y.sin_cos()
    }

    fn assert_libm(y: f32) {
        let (sine, cosine) = sin_cos(y);
        let (libm_sine, libm_cosine) = libm_sin_cos(y);
        let at = format!("{y:e} [{:#x}]", y.to_bits());
        assert_eq!(sine.to_bits(), libm_sine.to_bits(), "sincosf({at})");
        assert_eq!(cosine.to_bits(), libm_cosine.to_bits(), "sincosf({at})");
        assert_eq!(sine.to_bits(), libm_sin(y).to_bits(), "sinf({at})");
        assert_eq!(cosine.to_bits(), libm_cos(y).to_bits(), "cosf({at})");
    }

    /// Whether this machine's libm is the one the algorithm is copied from: glibc picks its
    /// FMA build of `sincosf` on CPUs with FMA, and another build elsewhere.
    fn libm_is_the_reference(test: &str) -> bool {
        crate::cpu_feature_for_test("fma", std::arch::is_x86_feature_detected!("fma"), test)
    }

    /// Every input of the classes glibc treats apart, and their borders: tiny, below 0.75,
    /// the reduction's quarter turns on both sides of each multiple of pi/4, near 120 and
    /// beyond, signed zeros, subnormals, infinities and NaN.
    #[test]
    fn sin_cos_is_libm_at_the_borders() {
        if !libm_is_the_reference("sin_cos_is_libm_at_the_borders") {
            return;
        }
        let mut inputs = vec![0.0f32, -0.0, 1e-45, -1e-45, 1e-40, f32::MIN_POSITIVE, 2e-12];
        for bits in [
            0x3980_0000u32,
            0x3f40_0000,
            0x3f49_0fdb,
            0x42f0_0000,
            0x7f80_0000,
        ] {
            for delta in 0..4u32 {
                inputs.extend([f32::from_bits(bits - delta), f32::from_bits(bits + delta)]);
            }
        }
        for k in -160..=160 {
            let quarter = k as f32 * std::f32::consts::FRAC_PI_4;
            inputs.extend([quarter, quarter.next_up(), quarter.next_down()]);
        }
        inputs.extend([1e10, 3.4e38, f32::INFINITY]);
        for y in inputs.iter().flat_map(|&y| [y, -y]) {
            assert_libm(y);
        }
        let (sine, cosine) = sin_cos(f32::NAN);
        assert!(sine.is_nan() && cosine.is_nan());
    }

    /// A spread of the floats below 4 in magnitude (every heading and arc of a run): every
    /// 1,009th bit pattern, about two million floats. The exhaustive run is the ignored test
    /// below.
    #[test]
    fn sin_cos_is_libm_below_four() {
        if !libm_is_the_reference("sin_cos_is_libm_below_four") {
            return;
        }
        for bits in (0..4.0f32.to_bits()).step_by(1009) {
            let y = f32::from_bits(bits);
            assert_libm(y);
            assert_libm(-y);
        }
    }

    /// Every float below 4 in magnitude, about 2.2 billion (minutes in a release build):
    /// `cargo test --release -p hevo-sim-core --lib trig -- --ignored`.
    #[test]
    #[ignore = "minutes in a release build; the spread above runs by default"]
    fn sin_cos_is_libm_for_every_float_below_four() {
        if !libm_is_the_reference("sin_cos_is_libm_for_every_float_below_four") {
            return;
        }
        for bits in 0..4.0f32.to_bits() {
            let y = f32::from_bits(bits);
            assert_libm(y);
            assert_libm(-y);
        }
    }

    proptest::proptest! {
        /// Every lane gives the scalar function's bits, whatever the other lanes hold.
        #[test]
        fn lanes_are_the_scalar_function(
            y in proptest::array::uniform8(proptest::prop_oneof![
                -4.0f32..4.0,
                -200.0f32..200.0,
                proptest::num::f32::ANY,
            ])
        ) {
            let (sines, cosines) = sin_cos_lanes(&y);
            for lane in 0..LANES {
                let (sine, cosine) = sin_cos(y[lane]);
                proptest::prop_assert_eq!(sines[lane].to_bits(), sine.to_bits());
                proptest::prop_assert_eq!(cosines[lane].to_bits(), cosine.to_bits());
            }
        }
    }
}
