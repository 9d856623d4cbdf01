//! f32 lanes for the BVH kernels. Four lanes (`F4`): SSE2 on x86_64 (baseline there,
//! so no run-time detection), plain arrays elsewhere. Eight lanes (`F8`, x86_64 only):
//! AVX, for the kernels compiled with it. All follow SSE semantics exactly, including
//! NaNs: `min`/`max` return the second operand when either is NaN, and comparisons
//! with NaN are false (the `n*` forms are their negations, true on NaN). [`Lanes`] is
//! what the triangle-pack test is generic over.

#[cfg(target_arch = "x86_64")]
pub use sse::{F4, M4};

#[cfg(not(target_arch = "x86_64"))]
pub use scalar::{F4, M4};

#[cfg(target_arch = "x86_64")]
pub use avx::F8;

use std::ops::{Add, BitAnd, Div, Mul, Sub};

/// What the triangle-pack test needs of a lane type, so that one generic test runs
/// eight lanes at once (AVX) or as two halves of four (SSE2 and portable code).
pub trait Lanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    type Mask: Copy + BitAnd<Output = Self::Mask>;
    const N: usize;
    fn splat(v: f32) -> Self;
    /// The first `N` values; `a` must be aligned to the lanes' width.
    fn load(a: &[f32]) -> Self;
    fn store(self, a: &mut [f32]);
    fn ge(self, o: Self) -> Self::Mask;
    fn le(self, o: Self) -> Self::Mask;
    fn gt(self, o: Self) -> Self::Mask;
    fn lt(self, o: Self) -> Self::Mask;
    fn ne(self, o: Self) -> Self::Mask;
    fn nlt(self, o: Self) -> Self::Mask;
    fn ngt(self, o: Self) -> Self::Mask;
    fn bits(m: Self::Mask) -> u32;
    /// Per lane the larger, or `o` when either is NaN (SSE's `max`).
    fn max(self, o: Self) -> Self;
    fn sqrt(self) -> Self;
    /// `a` in the lanes where `m` holds, `b` elsewhere.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
}

impl Lanes for F4 {
    type Mask = M4;
    const N: usize = 4;
    #[inline(always)]
    fn splat(v: f32) -> Self {
        F4::splat(v)
    }
    #[inline(always)]
    fn load(a: &[f32]) -> Self {
        let a: &[f32; 4] = a[..4].try_into().expect("four lanes");
        debug_assert_eq!(a.as_ptr() as usize % 16, 0);
        F4::from_array(*a)
    }
    #[inline(always)]
    fn store(self, a: &mut [f32]) {
        a[..4].copy_from_slice(&self.to_array());
    }
    #[inline(always)]
    fn ge(self, o: Self) -> M4 {
        F4::ge(self, o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> M4 {
        F4::le(self, o)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> M4 {
        F4::gt(self, o)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> M4 {
        F4::lt(self, o)
    }
    #[inline(always)]
    fn ne(self, o: Self) -> M4 {
        F4::ne(self, o)
    }
    #[inline(always)]
    fn nlt(self, o: Self) -> M4 {
        F4::nlt(self, o)
    }
    #[inline(always)]
    fn ngt(self, o: Self) -> M4 {
        F4::ngt(self, o)
    }
    #[inline(always)]
    fn bits(m: M4) -> u32 {
        m.bits()
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        F4::max(self, o)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        F4::sqrt(self)
    }
    #[inline(always)]
    fn select(m: M4, a: Self, b: Self) -> Self {
        F4::select(m, a, b)
    }
}

/// Eight lanes in one AVX register, with SSE's comparison semantics (ordered
/// predicates false on NaN, the `n*` forms true on it).
///
/// Only code compiled with AVX may use it: the BVH kernels with
/// `#[target_feature(enable = "avx")]` (or AVX-512), into which these methods are
/// inlined, and nothing they call out of line (where the intrinsics would become calls
/// to functions the processor may not be able to run).
#[cfg(target_arch = "x86_64")]
mod avx {
    use super::Lanes;
    use std::arch::x86_64::*;
    use std::ops::{Add, BitAnd, Div, Mul, Sub};

    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct F8(__m256);

    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct M8(__m256);

    // SAFETY (every `unsafe` block below): the intrinsics are AVX, and the type is
    // only used where AVX was detected (see the module's comment); the load and the
    // store check their slice's length, and use unaligned forms.
    impl F8 {
        #[inline(always)]
        fn cmp<const P: i32>(self, o: F8) -> M8 {
            unsafe { M8(_mm256_cmp_ps::<P>(self.0, o.0)) }
        }
    }

    impl Lanes for F8 {
        type Mask = M8;
        const N: usize = 8;
        #[inline(always)]
        fn splat(v: f32) -> Self {
            unsafe { F8(_mm256_set1_ps(v)) }
        }
        #[inline(always)]
        fn load(a: &[f32]) -> Self {
            let a = &a[..8];
            unsafe { F8(_mm256_loadu_ps(a.as_ptr())) }
        }
        #[inline(always)]
        fn store(self, a: &mut [f32]) {
            let a = &mut a[..8];
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn ge(self, o: Self) -> M8 {
            self.cmp::<_CMP_GE_OQ>(o)
        }
        #[inline(always)]
        fn le(self, o: Self) -> M8 {
            self.cmp::<_CMP_LE_OQ>(o)
        }
        #[inline(always)]
        fn gt(self, o: Self) -> M8 {
            self.cmp::<_CMP_GT_OQ>(o)
        }
        #[inline(always)]
        fn lt(self, o: Self) -> M8 {
            self.cmp::<_CMP_LT_OQ>(o)
        }
        #[inline(always)]
        fn ne(self, o: Self) -> M8 {
            self.cmp::<_CMP_NEQ_UQ>(o)
        }
        #[inline(always)]
        fn nlt(self, o: Self) -> M8 {
            self.cmp::<_CMP_NLT_UQ>(o)
        }
        #[inline(always)]
        fn ngt(self, o: Self) -> M8 {
            self.cmp::<_CMP_NGT_UQ>(o)
        }
        #[inline(always)]
        fn bits(m: M8) -> u32 {
            unsafe { _mm256_movemask_ps(m.0) as u32 }
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            unsafe { F8(_mm256_max_ps(self.0, o.0)) }
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            unsafe { F8(_mm256_sqrt_ps(self.0)) }
        }
        #[inline(always)]
        fn select(m: M8, a: Self, b: Self) -> Self {
            unsafe { F8(_mm256_blendv_ps(b.0, a.0, m.0)) }
        }
    }

    impl BitAnd for M8 {
        type Output = M8;
        #[inline(always)]
        fn bitand(self, o: M8) -> M8 {
            unsafe { M8(_mm256_and_ps(self.0, o.0)) }
        }
    }

    macro_rules! binop {
        ($tr:ident, $f:ident, $op:ident) => {
            impl $tr for F8 {
                type Output = F8;
                #[inline(always)]
                fn $f(self, o: F8) -> F8 {
                    unsafe { F8($op(self.0, o.0)) }
                }
            }
        };
    }
    binop!(Add, add, _mm256_add_ps);
    binop!(Sub, sub, _mm256_sub_ps);
    binop!(Mul, mul, _mm256_mul_ps);
    binop!(Div, div, _mm256_div_ps);
}

#[cfg(target_arch = "x86_64")]
// SAFETY (every `unsafe` block in this module): the intrinsics are SSE and SSE2,
// which every x86_64 processor has; none touches memory.
mod sse {
    use crate::math::Vec3A;
    use std::arch::x86_64::*;
    use std::ops::{Add, BitAnd, Div, Mul, Sub};

    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct F4(__m128);

    /// Per-lane comparison result: all bits set where true.
    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct M4(__m128);

    impl F4 {
        #[inline(always)]
        pub fn splat(v: f32) -> F4 {
            unsafe { F4(_mm_set1_ps(v)) }
        }

        #[inline(always)]
        pub fn from_array(a: [f32; 4]) -> F4 {
            unsafe { F4(_mm_setr_ps(a[0], a[1], a[2], a[3])) }
        }

        /// x, y, z in lanes 0..3 (lane 3 unspecified).
        #[inline(always)]
        pub fn from_vec3a(v: Vec3A) -> F4 {
            F4(v.into())
        }

        /// Lanes 0, 1 and 2, each broadcast to all four lanes.
        #[inline(always)]
        pub fn broadcast3(self) -> [F4; 3] {
            unsafe {
                [
                    F4(_mm_shuffle_ps::<0x00>(self.0, self.0)),
                    F4(_mm_shuffle_ps::<0x55>(self.0, self.0)),
                    F4(_mm_shuffle_ps::<0xaa>(self.0, self.0)),
                ]
            }
        }

        /// Bit i set when lane i has its sign bit set (-0 and -inf included).
        #[inline(always)]
        pub fn sign_bits(self) -> u32 {
            unsafe { _mm_movemask_ps(self.0) as u32 }
        }

        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            // SAFETY: __m128 and [f32; 4] have the same size and every bit pattern is
            // valid for both.
            unsafe { std::mem::transmute::<__m128, [f32; 4]>(self.0) }
        }

        #[inline(always)]
        pub fn min(self, o: F4) -> F4 {
            unsafe { F4(_mm_min_ps(self.0, o.0)) }
        }

        #[inline(always)]
        pub fn max(self, o: F4) -> F4 {
            unsafe { F4(_mm_max_ps(self.0, o.0)) }
        }

        #[inline(always)]
        pub fn sqrt(self) -> F4 {
            unsafe { F4(_mm_sqrt_ps(self.0)) }
        }

        /// `a` where `m` holds, `b` elsewhere.
        #[inline(always)]
        pub fn select(m: M4, a: F4, b: F4) -> F4 {
            unsafe { F4(_mm_or_ps(_mm_and_ps(m.0, a.0), _mm_andnot_ps(m.0, b.0))) }
        }

        #[inline(always)]
        pub fn lt(self, o: F4) -> M4 {
            unsafe { M4(_mm_cmplt_ps(self.0, o.0)) }
        }

        #[inline(always)]
        pub fn le(self, o: F4) -> M4 {
            unsafe { M4(_mm_cmple_ps(self.0, o.0)) }
        }

        #[inline(always)]
        pub fn gt(self, o: F4) -> M4 {
            unsafe { M4(_mm_cmpgt_ps(self.0, o.0)) }
        }

        #[inline(always)]
        pub fn ge(self, o: F4) -> M4 {
            unsafe { M4(_mm_cmpge_ps(self.0, o.0)) }
        }

        #[inline(always)]
        pub fn ne(self, o: F4) -> M4 {
            unsafe { M4(_mm_cmpneq_ps(self.0, o.0)) }
        }

        /// Not less than: true where `self >= o` or either is NaN.
        #[inline(always)]
        pub fn nlt(self, o: F4) -> M4 {
            unsafe { M4(_mm_cmpnlt_ps(self.0, o.0)) }
        }

        /// Not greater than: true where `self <= o` or either is NaN.
        #[inline(always)]
        pub fn ngt(self, o: F4) -> M4 {
            unsafe { M4(_mm_cmpngt_ps(self.0, o.0)) }
        }
    }

    impl M4 {
        /// Bit i set when lane i is true.
        #[inline(always)]
        pub fn bits(self) -> u32 {
            unsafe { _mm_movemask_ps(self.0) as u32 }
        }
    }

    impl BitAnd for M4 {
        type Output = M4;
        #[inline(always)]
        fn bitand(self, o: M4) -> M4 {
            unsafe { M4(_mm_and_ps(self.0, o.0)) }
        }
    }

    macro_rules! binop {
        ($tr:ident, $f:ident, $op:ident) => {
            impl $tr for F4 {
                type Output = F4;
                #[inline(always)]
                fn $f(self, o: F4) -> F4 {
                    unsafe { F4($op(self.0, o.0)) }
                }
            }
        };
    }
    binop!(Add, add, _mm_add_ps);
    binop!(Sub, sub, _mm_sub_ps);
    binop!(Mul, mul, _mm_mul_ps);
    binop!(Div, div, _mm_div_ps);
}

/// The portable lanes; on x86_64 only compiled for the test that holds them to SSE.
#[cfg(any(test, not(target_arch = "x86_64")))]
mod scalar {
    use crate::math::Vec3A;
    use std::ops::{Add, BitAnd, Div, Mul, Sub};

    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(16))]
    pub struct F4([f32; 4]);

    #[derive(Clone, Copy, Debug)]
    pub struct M4([bool; 4]);

    #[inline(always)]
    fn lanes(a: F4, b: F4, f: impl Fn(f32, f32) -> f32) -> F4 {
        F4(std::array::from_fn(|i| f(a.0[i], b.0[i])))
    }

    #[inline(always)]
    fn cmp(a: F4, b: F4, f: impl Fn(f32, f32) -> bool) -> M4 {
        M4(std::array::from_fn(|i| f(a.0[i], b.0[i])))
    }

    impl F4 {
        #[inline(always)]
        pub fn splat(v: f32) -> F4 {
            F4([v; 4])
        }

        #[inline(always)]
        pub fn from_array(a: [f32; 4]) -> F4 {
            F4(a)
        }

        #[inline(always)]
        pub fn from_vec3a(v: Vec3A) -> F4 {
            F4([v.x, v.y, v.z, 0.0])
        }

        #[inline(always)]
        pub fn broadcast3(self) -> [F4; 3] {
            [F4([self.0[0]; 4]), F4([self.0[1]; 4]), F4([self.0[2]; 4])]
        }

        #[inline(always)]
        pub fn sign_bits(self) -> u32 {
            (0..4).fold(0, |acc, i| {
                acc | (u32::from(self.0[i].is_sign_negative()) << i)
            })
        }

        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            self.0
        }

        #[inline(always)]
        pub fn min(self, o: F4) -> F4 {
            lanes(self, o, |a, b| if a < b { a } else { b })
        }

        #[inline(always)]
        pub fn max(self, o: F4) -> F4 {
            lanes(self, o, |a, b| if a > b { a } else { b })
        }

        #[inline(always)]
        pub fn sqrt(self) -> F4 {
            F4(self.0.map(f32::sqrt))
        }

        #[inline(always)]
        pub fn select(m: M4, a: F4, b: F4) -> F4 {
            F4(std::array::from_fn(
                |i| if m.0[i] { a.0[i] } else { b.0[i] },
            ))
        }

        #[inline(always)]
        pub fn lt(self, o: F4) -> M4 {
            cmp(self, o, |a, b| a < b)
        }

        #[inline(always)]
        pub fn le(self, o: F4) -> M4 {
            cmp(self, o, |a, b| a <= b)
        }

        #[inline(always)]
        pub fn gt(self, o: F4) -> M4 {
            cmp(self, o, |a, b| a > b)
        }

        #[inline(always)]
        pub fn ge(self, o: F4) -> M4 {
            cmp(self, o, |a, b| a >= b)
        }

        #[inline(always)]
        pub fn ne(self, o: F4) -> M4 {
            cmp(self, o, |a, b| a != b)
        }

        #[inline(always)]
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        pub fn nlt(self, o: F4) -> M4 {
            cmp(self, o, |a, b| !(a < b))
        }

        #[inline(always)]
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        pub fn ngt(self, o: F4) -> M4 {
            cmp(self, o, |a, b| !(a > b))
        }
    }

    impl M4 {
        #[inline(always)]
        pub fn bits(self) -> u32 {
            (0..4).fold(0, |acc, i| acc | (u32::from(self.0[i]) << i))
        }
    }

    impl BitAnd for M4 {
        type Output = M4;
        #[inline(always)]
        fn bitand(self, o: M4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] & o.0[i]))
        }
    }

    macro_rules! binop {
        ($tr:ident, $f:ident, $op:tt) => {
            impl $tr for F4 {
                type Output = F4;
                #[inline(always)]
                fn $f(self, o: F4) -> F4 {
                    lanes(self, o, |a, b| a $op b)
                }
            }
        };
    }
    binop!(Add, add, +);
    binop!(Sub, sub, -);
    binop!(Mul, mul, *);
    binop!(Div, div, /);
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::{scalar, sse};

    /// The portable lanes must give bit-identical results to SSE, NaNs included, so
    /// that other targets traverse exactly like x86_64.
    #[test]
    fn portable_lanes_match_sse() {
        let special = [
            0.0,
            -0.0,
            1.0,
            -2.5,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1e-40,
            3.0e38,
        ];
        let mut rng = crate::math::Rng::new(5, 0, 0);
        let mut pick = || {
            let r = rng.next_f32();
            if r < 0.5 {
                special[(r * 18.0) as usize]
            } else {
                (rng.next_f32() - 0.5) * 10.0
            }
        };
        let same = |a: [f32; 4], b: [f32; 4]| {
            a.iter()
                .zip(&b)
                .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
        };
        for _ in 0..2000 {
            let a: [f32; 4] = std::array::from_fn(|_| pick());
            let b: [f32; 4] = std::array::from_fn(|_| pick());
            let (sa, sb) = (sse::F4::from_array(a), sse::F4::from_array(b));
            let (pa, pb) = (scalar::F4::from_array(a), scalar::F4::from_array(b));
            assert!(same((sa + sb).to_array(), (pa + pb).to_array()));
            assert!(same((sa - sb).to_array(), (pa - pb).to_array()));
            assert!(same((sa * sb).to_array(), (pa * pb).to_array()));
            assert!(same((sa / sb).to_array(), (pa / pb).to_array()));
            assert!(same(sa.min(sb).to_array(), pa.min(pb).to_array()));
            assert!(same(sa.max(sb).to_array(), pa.max(pb).to_array()));
            assert!(same(sa.sqrt().to_array(), pa.sqrt().to_array()));
            assert!(same(
                sse::F4::select(sa.lt(sb), sa, sb).to_array(),
                scalar::F4::select(pa.lt(pb), pa, pb).to_array()
            ));
            assert_eq!(sa.lt(sb).bits(), pa.lt(pb).bits());
            assert_eq!(sa.le(sb).bits(), pa.le(pb).bits());
            assert_eq!(sa.gt(sb).bits(), pa.gt(pb).bits());
            assert_eq!(sa.ge(sb).bits(), pa.ge(pb).bits());
            assert_eq!(sa.ne(sb).bits(), pa.ne(pb).bits());
            assert_eq!(sa.nlt(sb).bits(), pa.nlt(pb).bits());
            assert_eq!(sa.ngt(sb).bits(), pa.ngt(pb).bits());
            assert_eq!(
                (sa.lt(sb) & sa.ne(sb)).bits(),
                (pa.lt(pb) & pa.ne(pb)).bits()
            );
            assert_eq!(sa.sign_bits(), pa.sign_bits());
            assert!(same(
                sse::F4::splat(a[0]).to_array(),
                scalar::F4::splat(a[0]).to_array()
            ));
            let v = crate::math::Vec3A::new(a[0], a[1], a[2]);
            let (sv, pv) = (sse::F4::from_vec3a(v), scalar::F4::from_vec3a(v));
            for (x, y) in sv.broadcast3().iter().zip(pv.broadcast3()) {
                assert!(same(x.to_array(), y.to_array()));
            }
        }
    }

    /// Eight AVX lanes against two groups of four SSE lanes, on the same inputs.
    #[test]
    fn avx_lanes_match_sse() {
        if !std::is_x86_feature_detected!("avx") {
            return;
        }
        // SAFETY: AVX was detected just above.
        unsafe { avx_lanes_match_sse_with_avx() }
    }

    #[target_feature(enable = "avx")]
    unsafe fn avx_lanes_match_sse_with_avx() {
        use super::{Lanes, F8};
        let special = [0.0, -0.0, 1.0, -2.5, f32::INFINITY, f32::NAN, 1e-40, 3.0e38];
        let mut rng = crate::math::Rng::new(6, 0, 0);
        let mut pick = || {
            let r = rng.next_f32();
            if r < 0.5 {
                special[(r * 16.0) as usize]
            } else {
                (rng.next_f32() - 0.5) * 10.0
            }
        };
        for _ in 0..2000 {
            let a: [f32; 8] = std::array::from_fn(|_| pick());
            let b: [f32; 8] = std::array::from_fn(|_| pick());
            let (wa, wb) = (F8::load(&a), F8::load(&b));
            let half = |v: &[f32; 8], h: usize| {
                sse::F4::from_array(v[4 * h..4 * h + 4].try_into().unwrap())
            };
            let wide = |f: fn(F8, F8) -> F8| {
                let mut out = [0.0f32; 8];
                f(wa, wb).store(&mut out);
                out.map(f32::to_bits)
            };
            let narrow = |f: fn(sse::F4, sse::F4) -> sse::F4| {
                let mut out = [0u32; 8];
                for h in 0..2 {
                    let r = f(half(&a, h), half(&b, h)).to_array();
                    out[4 * h..4 * h + 4].copy_from_slice(&r.map(f32::to_bits));
                }
                out
            };
            assert_eq!(wide(|x, y| x + y), narrow(|x, y| x + y));
            assert_eq!(wide(|x, y| x - y), narrow(|x, y| x - y));
            assert_eq!(wide(|x, y| x * y), narrow(|x, y| x * y));
            let quiet = |v: [u32; 8]| v.map(|x| if f32::from_bits(x).is_nan() { 0 } else { x });
            assert_eq!(quiet(wide(|x, y| x / y)), quiet(narrow(|x, y| x / y)));
            assert_eq!(wide(Lanes::max), narrow(sse::F4::max));
            assert_eq!(quiet(wide(|x, _| x.sqrt())), quiet(narrow(|x, _| x.sqrt())));
            assert_eq!(
                wide(|x, y| F8::select(x.lt(y), x, y)),
                narrow(|x, y| sse::F4::select(x.lt(y), x, y))
            );
            let bits8 = |f: fn(F8, F8) -> <F8 as Lanes>::Mask| F8::bits(f(wa, wb));
            let bits4 = |f: fn(sse::F4, sse::F4) -> sse::M4| {
                (0..2).fold(0, |acc, h| {
                    acc | f(half(&a, h), half(&b, h)).bits() << (4 * h)
                })
            };
            assert_eq!(bits8(|x, y| x.ge(y)), bits4(|x, y| x.ge(y)));
            assert_eq!(bits8(|x, y| x.le(y)), bits4(|x, y| x.le(y)));
            assert_eq!(bits8(|x, y| x.gt(y)), bits4(|x, y| x.gt(y)));
            assert_eq!(bits8(|x, y| x.lt(y)), bits4(|x, y| x.lt(y)));
            assert_eq!(bits8(|x, y| x.ne(y)), bits4(|x, y| x.ne(y)));
            assert_eq!(bits8(|x, y| x.nlt(y)), bits4(|x, y| x.nlt(y)));
            assert_eq!(bits8(|x, y| x.ngt(y)), bits4(|x, y| x.ngt(y)));
            assert_eq!(
                bits8(|x, y| x.lt(y) & x.ne(y)),
                bits4(|x, y| x.lt(y) & x.ne(y))
            );
        }
    }
}
