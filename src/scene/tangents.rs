//! MikkTSpace tangents (Mikkelsen 2008) for primitives with a normal map and no TANGENT, as
//! glTF 2.0 §3.7.2.1 asks, through the maintained `bevy_mikktspace` port. The primitive is
//! unwelded first (one vertex per triangle corner), so each corner keeps the tangent MikkTSpace
//! gives it.

use bevy_mikktspace::{generate_tangents, Geometry, TangentSpace};
use glam::{Vec2, Vec3};

struct Corners<'a> {
    positions: &'a [Vec3],
    normals: &'a [Vec3],
    uvs: &'a [Vec2],
    tangents: Vec<[f32; 4]>,
}

impl Geometry for Corners<'_> {
    fn num_faces(&self) -> usize {
        self.positions.len() / 3
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[3 * face + vert].to_array()
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.normals[3 * face + vert].to_array()
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[3 * face + vert].to_array()
    }
    fn set_tangent(&mut self, tangent: Option<TangentSpace>, face: usize, vert: usize) {
        if let Some(t) = tangent {
            self.tangents[3 * face + vert] = t.tangent_encoded();
        }
    }
}

/// Tangents (xyz, bitangent sign w) of unwelded triangle corners, three per triangle; corners
/// whose tangent frame is degenerate (no texture-space extent) get (0, 0, 0, 1), which the
/// shading code treats as "no normal map here". None if MikkTSpace refuses the mesh.
pub(super) fn mikktspace_tangents(
    positions: &[Vec3],
    normals: &[Vec3],
    uvs: &[Vec2],
) -> Option<Vec<[f32; 4]>> {
    let mut corners = Corners {
        positions,
        normals,
        uvs,
        tangents: vec![[0.0, 0.0, 0.0, 1.0]; positions.len()],
    };
    generate_tangents(&mut corners).ok()?;
    Some(corners.tangents)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quad in the XY plane with u along +X and v along −Y (glTF's v grows downwards): the
    /// tangent follows +u.
    #[test]
    fn tangents_follow_u() {
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let uv: Vec<Vec2> = p.iter().map(|q| Vec2::new(q.x, 1.0 - q.y)).collect();
        let n = [Vec3::Z; 6];
        let t = mikktspace_tangents(&p, &n, &uv).unwrap();
        for tangent in t {
            assert!(
                (Vec3::from_slice(&tangent) - Vec3::X).length() < 1e-5,
                "{tangent:?}"
            );
            // B = w · N × T = w · (0, 1, 0) must follow +v = −Y.
            assert_eq!(tangent[3], -1.0);
        }
    }
}
