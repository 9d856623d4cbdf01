//! A stored light-subpath vertex: where connections, merges and virtual lights attach.

use super::media::Owner;
use super::partial::{Partial, Site};
use super::vertex::{mis_sigma, Media, MediumPoint, Scatterer};
use super::walk::Surface;
use super::Pass;
use crate::material::textured::MaterialRef;
use crate::math::{Frame, Rgb, Vec2, Vec3};

// Connections stream over these: `vol` lives in what was padding.
const _: () = assert!(std::mem::size_of::<LightVertex>() == 128);

/// `LightVertex::material` of a scattering point in a medium.
pub(crate) const MEDIUM_VERTEX: u32 = u32::MAX;

/// `LightVertex::medium` of a vertex in vacuum.
pub(crate) const NO_MEDIUM: u32 = u32::MAX;

/// A stored light-subpath vertex (where connections and merges attach).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightVertex {
    pub p: Vec3,
    /// Error bound and normals of a surface vertex (zero for a medium vertex).
    pub p_err: Vec3,
    pub ng: Vec3,
    pub ns: Vec3,
    /// The shading frame's twist about `ns` (`Frame::twisted`): zero unless the
    /// material is anisotropic.
    pub twist: f32,
    /// Towards the previous vertex (where the light came from), world space.
    pub wo: Vec3,
    pub throughput: Rgb,
    /// The surface's material, or MEDIUM_VERTEX.
    pub material: u32,
    /// Texture coordinates of a surface vertex (zero where no texture is read).
    pub uv: Vec2,
    /// The medium the light arrived in (NO_MEDIUM: vacuum): a medium vertex's own,
    /// and at a surface the one on the side `wo` points to.
    pub medium: u32,
    /// Russian-roulette continuation probability of the material (or of the medium's
    /// albedo there).
    pub cont: f32,
    /// Segments from the light to this vertex.
    pub len: u32,
    pub q: Partial,
    /// The share of `q.dvc` that merges in media contribute (the media's of
    /// [`Walk::parts`], over dvc): a ratio in [0, 1], so f32 keeps it, in what was
    /// padding.
    ///
    /// [`Walk::parts`]: super::walk::Walk::parts
    pub vol: f32,
}

impl LightVertex {
    /// The part of `q`'s dvc and dvm that merges in media contribute.
    #[inline(always)]
    pub fn vol(&self) -> f64 {
        self.vol as f64 * self.q.dvc
    }

    /// The medium of a medium vertex (None at a surface).
    #[inline]
    pub fn scattering_medium(&self) -> Option<u32> {
        (self.material == MEDIUM_VERTEX).then_some(self.medium)
    }

    /// The medium the light arrived in (None: vacuum).
    #[inline]
    pub fn arrival_medium(&self) -> Option<u32> {
        (self.medium != NO_MEDIUM).then_some(self.medium)
    }
}

impl LightVertex {
    /// Where a merge at the vertex would sit.
    #[inline(always)]
    pub fn site(&self) -> Site {
        if self.material == MEDIUM_VERTEX {
            Site::Medium
        } else {
            Site::Surface
        }
    }

    /// What scatters at the vertex, for connections (only surfaces without media); a
    /// textured surface's material is kept in `owner`.
    #[inline(always)]
    pub fn scatterer<'a, 's: 'a, M: Media>(
        &self,
        pass: &Pass<'s>,
        owner: &'a mut Owner<'s>,
    ) -> Scatterer<'a, M> {
        if M::ON && self.material == MEDIUM_VERTEX {
            let medium = &pass.scene.media[self.medium as usize];
            let m: MediumPoint<'a> = MediumPoint {
                phase: medium.phase(),
                wo: self.wo,
                sigma: mis_sigma(pass, self.medium, self.p),
                cont: self.cont,
            };
            if let Some(m) = M::wrap(m) {
                return Scatterer::Medium(m);
            }
        }
        let m = match pass.scene.plain_material(self.material) {
            Some(m) => m,
            None => owner.keep(self.material_on(pass.scene)),
        };
        let frame = Frame::twisted(self.ns, self.twist);
        Scatterer::Surface(Surface {
            m,
            frame,
            ng: self.ng,
            wo: frame.to_local(self.wo),
            cont: self.cont,
        })
    }
}

impl LightVertex {
    /// The material of a textured or shadowed surface vertex. Out of line, its frame
    /// rebuilt here: handing the caller's frame to `Scene::material_on` kept it (and
    /// the connection's scatterer) in memory on every connection.
    #[cold]
    #[inline(never)]
    fn material_on<'a>(&self, scene: &'a crate::scene::Scene) -> MaterialRef<'a> {
        let frame = Frame::twisted(self.ns, self.twist);
        scene.material_on(self.material, self.uv, self.ng, &frame)
    }
}
