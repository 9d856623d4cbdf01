//! The cube shape's meshes: a plain one of 12 triangles, and Mitsuba's of 24 vertices
//! (each face its own four, with their (u, v)) for shapes that read texture
//! coordinates. Imports only `meshes` and `math`.

use super::meshes::MeshData;
use crate::math::{Vec2, Vec3};

const POSITIONS: [[f32; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// Counter-clockwise seen from outside.
const INDICES: [[u32; 3]; 12] = [
    [0, 2, 1],
    [0, 3, 2],
    [4, 5, 6],
    [4, 6, 7],
    [0, 1, 5],
    [0, 5, 4],
    [3, 7, 6],
    [3, 6, 2],
    [0, 4, 7],
    [0, 7, 3],
    [1, 2, 6],
    [1, 6, 5],
];

/// The cube as 8 shared vertices, without texture coordinates.
pub fn plain() -> MeshData {
    MeshData {
        positions: POSITIONS.iter().map(|p| Vec3::from(*p)).collect(),
        normals: None,
        uvs: None,
        indices: INDICES.to_vec(),
    }
}

/// Mitsuba's cube: each face's four corners (object space) with their (u, v).
const FACES: [[([f32; 3], [f32; 2]); 4]; 6] = [
    [
        ([1., -1., -1.], [0., 1.]),
        ([1., -1., 1.], [1., 1.]),
        ([-1., -1., 1.], [1., 0.]),
        ([-1., -1., -1.], [0., 0.]),
    ],
    [
        ([1., 1., -1.], [0., 1.]),
        ([-1., 1., -1.], [1., 1.]),
        ([-1., 1., 1.], [1., 0.]),
        ([1., 1., 1.], [0., 0.]),
    ],
    [
        ([1., -1., -1.], [0., 1.]),
        ([1., 1., -1.], [1., 1.]),
        ([1., 1., 1.], [1., 0.]),
        ([1., -1., 1.], [0., 0.]),
    ],
    [
        ([1., -1., 1.], [0., 1.]),
        ([1., 1., 1.], [1., 1.]),
        ([-1., 1., 1.], [1., 0.]),
        ([-1., -1., 1.], [0., 0.]),
    ],
    [
        ([-1., -1., 1.], [0., 1.]),
        ([-1., 1., 1.], [1., 1.]),
        ([-1., 1., -1.], [1., 0.]),
        ([-1., -1., -1.], [0., 0.]),
    ],
    [
        ([1., 1., -1.], [0., 1.]),
        ([1., -1., -1.], [1., 1.]),
        ([-1., -1., -1.], [1., 0.]),
        ([-1., 1., -1.], [0., 0.]),
    ],
];

/// Mitsuba's cube as a mesh: 24 vertices, each face its own four with their (u, v),
/// split as Mitsuba splits them.
pub fn textured() -> MeshData {
    let corners = FACES.iter().flatten();
    MeshData {
        positions: corners.clone().map(|(p, _)| Vec3::from(*p)).collect(),
        normals: None,
        uvs: Some(corners.map(|(_, uv)| Vec2::from(*uv)).collect()),
        indices: (0..6u32)
            .flat_map(|f| [[0, 1, 2], [3, 0, 2]].map(|t| t.map(|k| 4 * f + k)))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_faces_wind_outwards_and_cover_the_unit_square() {
        for face in FACES {
            let p = face.map(|(p, _)| Vec3::from(p));
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let centre = (p[0] + p[2]) * 0.5;
            assert!(n.dot(centre) > 0.0, "{face:?}");
            let mut uvs: Vec<[f32; 2]> = face.iter().map(|(_, uv)| *uv).collect();
            uvs.sort_by(|a, b| a.partial_cmp(b).unwrap());
            assert_eq!(uvs, [[0., 0.], [0., 1.], [1., 0.], [1., 1.]]);
        }
    }
}
