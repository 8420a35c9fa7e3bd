//! Decoding fuzz bytes: a cursor that yields zeros once the input is used up, adversarial scalar
//! values, and a small deterministic generator for bulk "ordinary" data (so a short input can
//! describe a long, well-excited sample sequence).

use aerosid_core::Real;

/// A cursor over the fuzz input.
#[derive(Debug, Clone)]
pub struct Input<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Input<'a> {
    /// A cursor at the start of `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Self { data, pos: 0 }
    }

    /// Bytes not yet read.
    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    /// Whether every byte was read.
    pub fn is_empty(&self) -> bool {
        self.remaining() == 0
    }

    /// The next byte (0 past the end).
    pub fn u8(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos = (self.pos + 1).min(self.data.len());
        b
    }

    /// Two bytes, little-endian.
    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }

    /// Four bytes, little-endian.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }

    /// Eight bytes, little-endian.
    pub fn u64(&mut self) -> u64 {
        (u64::from(self.u32())) | (u64::from(self.u32()) << 32)
    }

    /// Fills `out` (zeros past the end).
    pub fn fill(&mut self, out: &mut [u8]) {
        for b in out {
            *b = self.u8();
        }
    }

    /// The rest of the input.
    pub fn rest(&mut self) -> &'a [u8] {
        let r = &self.data[self.pos..];
        self.pos = self.data.len();
        r
    }
}

/// xorshift64*: deterministic bulk values from a seed taken from the input.
#[derive(Debug, Clone)]
pub struct Gen(u64);

impl Gen {
    /// A generator; seed 0 is replaced by a fixed non-zero one.
    pub fn new(seed: u64) -> Self {
        Self(if seed == 0 { 0x9E37_79B9_7F4A_7C15 } else { seed })
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in `[-1, 1)`.
    pub fn sym(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    /// Roughly standard normal (sum of four uniforms, variance 1).
    pub fn normal(&mut self) -> f64 {
        (self.sym() + self.sym() + self.sym() + self.sym()) * (3.0f64 / 4.0).sqrt()
    }
}

/// The kinds of adversarial scalar the decoder produces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Special {
    /// An ordinary value (from two input bytes).
    Ordinary,
    /// NaN.
    Nan,
    /// +∞.
    PosInf,
    /// −∞.
    NegInf,
    /// A subnormal.
    Subnormal,
    /// ±1e30.
    Huge,
    /// +0.
    Zero,
    /// −0.
    NegZero,
    /// Exactly the input bound.
    AtBound,
    /// The next value above the input bound.
    AboveBound,
    /// A tiny normal (`MIN_POSITIVE·10^k`).
    Tiny,
    /// A normal number whose square underflows.
    SquareUnderflows,
    /// Any bit pattern (four input bytes as an `f32`, widened or kept).
    Bits,
}

/// Decodes one scalar: a class byte, then its payload. Half of the classes are ordinary values
/// (`i16/1024·scale`), the rest the adversarial kinds of [`Special`].
pub fn scalar<T: Real>(inp: &mut Input<'_>, scale: f64, bound: f64) -> (T, Special) {
    let class = inp.u8();
    let special = match class % 26 {
        0 => Special::Nan,
        1 => Special::PosInf,
        2 => Special::NegInf,
        3 => Special::Subnormal,
        4 => Special::Huge,
        5 => Special::Zero,
        6 => Special::NegZero,
        7 => Special::AtBound,
        8 => Special::AboveBound,
        9 => Special::Tiny,
        10 => Special::SquareUnderflows,
        11 => Special::Bits,
        _ => Special::Ordinary,
    };
    let neg = class & 0x80 != 0;
    let sign = |v: T| if neg { -v } else { v };
    let v = match special {
        Special::Ordinary => T::lit(f64::from(inp.u16() as i16) / 1024.0 * scale),
        Special::Nan => T::lit(f64::NAN),
        Special::PosInf => T::lit(f64::INFINITY),
        Special::NegInf => T::lit(f64::NEG_INFINITY),
        Special::Subnormal => sign(T::MIN_POSITIVE.scale_pow2(-1 - i32::from(inp.u8() % 20))),
        Special::Huge => sign(T::lit(1e30)),
        Special::Zero => T::zero(),
        Special::NegZero => -T::zero(),
        Special::AtBound => sign(T::lit(bound)),
        Special::AboveBound => sign(above(T::lit(bound))),
        Special::Tiny => sign(T::MIN_POSITIVE * T::lit(10f64.powi(i32::from(inp.u8() % 6)))),
        Special::SquareUnderflows => sign(T::SQRT_MIN_POSITIVE * T::lit(10f64.powi(-i32::from(inp.u8() % 8)))),
        Special::Bits => T::lit(f64::from(f32::from_bits(inp.u32()))),
    };
    (v, special)
}

/// A value of `T` one or two units in the last place above the positive finite `x` (∞ above the
/// largest finite value); `x` itself if it is not finite and positive.
pub fn above<T: Real>(x: T) -> T {
    if !(x.finite() && x > T::zero()) {
        return x;
    }
    let mut step = (x * T::EPS).maxr(T::MIN_POSITIVE);
    // `x + ε·x` may round back to `x` for values just below a power of two: double until it moves.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(a > b)`: also true for a NaN, on purpose
    while !(x + step > x) {
        step *= T::lit(2.0);
    }
    x + step
}
