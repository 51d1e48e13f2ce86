//! The ground floor: numbers with no notion of robots or worlds. Floating-point helpers with
//! pinned bits, fast trigonometry, SIMD-style lanes, the seeded random streams and the content
//! hash.

pub(crate) mod float;
pub mod hash;
pub mod lanes;
pub mod rng;
pub(crate) mod trig;
