//! Numbers for several samples at once, for the lockstep evaluator: [`Lanes`] holds one `f32`
//! per sample ("lane") and does every operation lane by lane, in the same order as on a lone
//! `f32`. The network code is written once, generic over [`Real`], and runs either on `f32`
//! (the scalar reference) or on [`Lanes`] (many samples of one genome): each lane then performs
//! exactly the scalar operations, so its results are bit-identical, and the compiler turns the
//! lane loops into vector instructions (`mulps`, `addps`, ...; no fused multiply-add, which Rust
//! never contracts on its own). Nothing here needs `unsafe`.

use std::ops::{Add, Mul, Neg, Sub};

/// Samples advanced together by the lockstep evaluator. Eight fills two SSE registers (or one
/// AVX register) per operation, and keeps the per-lane state of the widest network in cache.
pub const LANES: usize = 8;

/// A set of lanes: bit `lane` stands for lane `lane`.
pub type LaneMask = u32;

/// Every lane.
#[cfg(test)]
pub const ALL_LANES: LaneMask = {
    assert!(
        LANES <= LaneMask::BITS as usize,
        "a lane mask holds every lane"
    );
    LaneMask::MAX >> (LaneMask::BITS as usize - LANES)
};

/// The lanes of `mask`, lowest first.
#[inline(always)]
pub fn lanes_of(mut mask: LaneMask) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        let lane = mask.trailing_zeros() as usize;
        mask &= mask.wrapping_sub(1);
        (lane < LANES).then_some(lane)
    })
}

/// What the network code needs of a number: basic IEEE arithmetic, a clamp, and the bit
/// manipulation of the portable exponential.
pub trait Real:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    /// The same value in every lane.
    fn splat(value: f32) -> Self;
    /// `f32::clamp` in every lane.
    fn clamp_to(self, low: f32, high: f32) -> Self;
    /// `1 / self` in every lane.
    fn recip(self) -> Self;
    /// In every lane: the bits of `self` minus `subtract`, plus `add`, shifted left by `shift`,
    /// read back as a float (the power-of-two scaling of the portable exponential).
    fn bits_to_scale(self, subtract: u32, add: u32, shift: u32) -> Self;
}

impl Real for f32 {
    #[inline(always)]
    fn splat(value: f32) -> f32 {
        value
    }

    #[inline(always)]
    fn clamp_to(self, low: f32, high: f32) -> f32 {
        self.clamp(low, high)
    }

    #[inline(always)]
    fn recip(self) -> f32 {
        1.0 / self
    }

    #[inline(always)]
    fn bits_to_scale(self, subtract: u32, add: u32, shift: u32) -> f32 {
        f32::from_bits(self.to_bits().wrapping_sub(subtract).wrapping_add(add) << shift)
    }
}

/// One `f32` per lane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lanes(pub [f32; LANES]);

impl Lanes {
    /// Every lane 0.
    pub const ZERO: Lanes = Lanes([0.0; LANES]);

    #[inline(always)]
    fn map(self, f: impl Fn(f32) -> f32) -> Lanes {
        Lanes(self.0.map(f))
    }

    #[inline(always)]
    fn zip(self, other: Lanes, f: impl Fn(f32, f32) -> f32) -> Lanes {
        Lanes(std::array::from_fn(|lane| f(self.0[lane], other.0[lane])))
    }

    /// Lane `lane` from `other` where `take` holds it, else from `self`.
    #[inline(always)]
    pub fn select(self, take: LaneMask, other: Lanes) -> Lanes {
        Lanes(std::array::from_fn(|lane| {
            if take >> lane & 1 != 0 {
                other.0[lane]
            } else {
                self.0[lane]
            }
        }))
    }
}

impl Add for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn add(self, other: Lanes) -> Lanes {
        self.zip(other, |a, b| a + b)
    }
}

impl Sub for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn sub(self, other: Lanes) -> Lanes {
        self.zip(other, |a, b| a - b)
    }
}

impl Mul for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn mul(self, other: Lanes) -> Lanes {
        self.zip(other, |a, b| a * b)
    }
}

impl Neg for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn neg(self) -> Lanes {
        self.map(|x| -x)
    }
}

impl Real for Lanes {
    #[inline(always)]
    fn splat(value: f32) -> Lanes {
        Lanes([value; LANES])
    }

    #[inline(always)]
    fn clamp_to(self, low: f32, high: f32) -> Lanes {
        self.map(|x| x.clamp_to(low, high))
    }

    #[inline(always)]
    fn recip(self) -> Lanes {
        self.map(Real::recip)
    }

    #[inline(always)]
    fn bits_to_scale(self, subtract: u32, add: u32, shift: u32) -> Lanes {
        self.map(|x| x.bits_to_scale(subtract, add, shift))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_compute_each_lane_as_a_lone_float() {
        let a = Lanes([1.5, -0.0, f32::NAN, 3e38, -7.25, 1e-40, f32::INFINITY, 0.1]);
        let b = Lanes([2.0, 0.0, 1.0, 3e38, 0.5, 1e-40, -1.0, 0.2]);
        let same = |got: Lanes, f: &dyn Fn(f32, f32) -> f32| {
            for lane in 0..LANES {
                assert_eq!(
                    got.0[lane].to_bits(),
                    f(a.0[lane], b.0[lane]).to_bits(),
                    "lane {lane}"
                );
            }
        };
        same(a + b, &|x, y| x + y);
        same(a - b, &|x, y| x - y);
        same(a * b, &|x, y| x * y);
        same(-a, &|x, _| -x);
        same(a.clamp_to(-1.0, 2.0), &|x, _| x.clamp(-1.0, 2.0));
        same(a.recip(), &|x, _| 1.0 / x);
        same(a.bits_to_scale(3, 127, 23), &|x, _| {
            x.bits_to_scale(3, 127, 23)
        });
        let take: LaneMask = 0b0101_0101;
        let picked = a.select(take, b);
        for lane in 0..LANES {
            let expected = if take >> lane & 1 != 0 {
                b.0[lane]
            } else {
                a.0[lane]
            };
            assert_eq!(picked.0[lane].to_bits(), expected.to_bits(), "lane {lane}");
        }
    }

    #[test]
    fn a_mask_lists_its_lanes_in_order() {
        assert_eq!(lanes_of(0).count(), 0);
        assert_eq!(lanes_of(0b1010_0110).collect::<Vec<_>>(), [1, 2, 5, 7]);
        assert_eq!(
            lanes_of(ALL_LANES).collect::<Vec<_>>(),
            Vec::from_iter(0..LANES)
        );
        // Bits past the last lane are no lanes.
        assert_eq!(lanes_of(!0).count(), LANES);
    }
}
