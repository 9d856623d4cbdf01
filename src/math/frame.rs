//! Orthonormal frames: local shading space has the normal along +z.

use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Branchless orthonormal basis from a unit normal (Duff et al. 2017, "Building an
    /// Orthonormal Basis, Revisited").
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// The angle about `n` from `from_normal(n)`'s x axis to this frame's: a frame
    /// stored as its normal and this number comes back with [`Frame::twisted`].
    /// Inlined: a call would take the frame's address, and the light pass's vertex
    /// holding it went to memory for that call on its cold branch.
    #[inline(always)]
    pub fn twist(&self) -> f32 {
        let base = Frame::from_normal(self.n);
        self.s.dot(base.t).atan2(self.s.dot(base.s))
    }

    /// `from_normal(n)` turned by `angle` about `n`; exactly `from_normal(n)` for 0.
    #[inline(always)]
    pub fn twisted(n: Vec3, angle: f32) -> Self {
        let f = Frame::from_normal(n);
        if angle == 0.0 {
            f
        } else {
            f.turned(angle)
        }
    }

    /// Inlined, though rarely taken: called, it took the frame by reference and
    /// returned one through memory, which kept the caller's frame there on every call
    /// of `twisted` (the light vertex of every `bpt` connection).
    #[inline(always)]
    fn turned(self, angle: f32) -> Self {
        let (sin, cos) = angle.sin_cos();
        let s = self.s * cos + self.t * sin;
        Frame {
            s,
            t: self.n.cross(s),
            n: self.n,
        }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_for_every_octant() {
        let dirs = [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.4, -0.866).normalize(),
            Vec3::new(-1e-7, 0.0, -1.0).normalize(),
        ];
        for n in dirs {
            let f = Frame::from_normal(n);
            assert!(f.s.dot(f.t).abs() < 1e-5);
            assert!(f.s.dot(f.n).abs() < 1e-5);
            assert!((f.s.length() - 1.0).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            let v = Vec3::new(0.2, -0.5, 0.7);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }
}
