//! Four f32 lanes for the BVH kernels: SSE2 on x86_64 (baseline there, so no run-time
//! detection), plain arrays elsewhere. Both follow SSE semantics exactly, including
//! NaNs: `min`/`max` return the second operand when either is NaN, and comparisons
//! with NaN are false (the `n*` forms are their negations, true on NaN).

#[cfg(target_arch = "x86_64")]
pub use sse::{F4, M4};

#[cfg(not(target_arch = "x86_64"))]
pub use scalar::{F4, M4};

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

        /// Every lane set to the smallest lane (NaN lanes must have been replaced).
        #[inline(always)]
        pub fn hmin(self) -> F4 {
            let a = unsafe { _mm_min_ps(self.0, _mm_shuffle_ps::<0b10_11_00_01>(self.0, self.0)) };
            unsafe { F4(_mm_min_ps(a, _mm_shuffle_ps::<0b01_00_11_10>(a, a))) }
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
        pub fn eq(self, o: F4) -> M4 {
            unsafe { M4(_mm_cmpeq_ps(self.0, o.0)) }
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

        /// `a` where the mask is set, `b` elsewhere.
        #[inline(always)]
        pub fn select(m: M4, a: F4, b: F4) -> F4 {
            unsafe { F4(_mm_or_ps(_mm_and_ps(m.0, a.0), _mm_andnot_ps(m.0, b.0))) }
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
        pub fn hmin(self) -> F4 {
            let a = self.min(F4([self.0[1], self.0[0], self.0[3], self.0[2]]));
            a.min(F4([a.0[2], a.0[3], a.0[0], a.0[1]]))
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
        pub fn eq(self, o: F4) -> M4 {
            cmp(self, o, |a, b| a == b)
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

        #[inline(always)]
        pub fn select(m: M4, a: F4, b: F4) -> F4 {
            F4(std::array::from_fn(
                |i| if m.0[i] { a.0[i] } else { b.0[i] },
            ))
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
            let finite = a.map(|x| if x.is_nan() { 7.0 } else { x });
            assert!(same(
                sse::F4::from_array(finite).hmin().to_array(),
                scalar::F4::from_array(finite).hmin().to_array()
            ));
            assert_eq!(sa.lt(sb).bits(), pa.lt(pb).bits());
            assert_eq!(sa.le(sb).bits(), pa.le(pb).bits());
            assert_eq!(sa.gt(sb).bits(), pa.gt(pb).bits());
            assert_eq!(sa.ge(sb).bits(), pa.ge(pb).bits());
            assert_eq!(sa.eq(sb).bits(), pa.eq(pb).bits());
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
            let (sm, pm) = (sa.lt(sb), pa.lt(pb));
            assert!(same(
                sse::F4::select(sm, sa, sb).to_array(),
                scalar::F4::select(pm, pa, pb).to_array()
            ));
        }
    }
}
