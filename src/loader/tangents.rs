//! MikkTSpace tangents for meshes that need them (normal maps, anisotropy) and do not supply them, with
//! bevy_mikktspace (the algorithm normal-map bakers use, so maps line up): the mesh is
//! unwelded per triangle corner, since MikkTSpace may give one vertex different tangents
//! in different triangles.

use crate::scene::MeshDesc;
use bevy_mikktspace::{Geometry, TangentSpace, generate_tangents};
use glam::{DVec3, Vec2, Vec3, Vec4};

/// One triangle corner per vertex, for the generator.
struct Corners {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    tangents: Vec<Vec4>,
}

impl Geometry for Corners {
    fn num_faces(&self) -> usize {
        self.positions.len() / 3
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[3 * face + vert].into()
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.normals[3 * face + vert].into()
    }

    /// glTF's v runs down the image; MikkTSpace, like the bakers, expects it up.
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        let uv = self.uvs[3 * face + vert];
        [uv.x, 1.0 - uv.y]
    }

    fn set_tangent(&mut self, tangent_space: Option<TangentSpace>, face: usize, vert: usize) {
        if let Some(t) = tangent_space {
            self.tangents[3 * face + vert] = Vec4::from(t.tangent_encoded());
        }
    }
}

/// The attribute at every corner.
fn pick<T: Copy>(v: &Option<Vec<T>>, corners: &[usize]) -> Option<Vec<T>> {
    v.as_ref().map(|v| corners.iter().map(|&i| v[i]).collect())
}

/// The mesh unwelded per corner with MikkTSpace tangents (bitangent sign in w). Corners
/// the generator leaves out (degenerate UVs) get a zero tangent: no normal mapping there.
pub fn generate(mesh: MeshDesc, positions: Vec<DVec3>) -> (MeshDesc, Vec<DVec3>) {
    let corners: Vec<usize> = mesh.indices.iter().map(|&i| i as usize).collect();
    let world: Vec<DVec3> = corners.iter().map(|&i| positions[i]).collect();
    let flat: Vec<Vec3> = world.iter().map(|p| p.as_vec3()).collect();
    let face_normals: Vec<Vec3> =
        flat.chunks_exact(3).flat_map(|t| [(t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero(); 3]).collect();
    let uvs = pick(&mesh.uvs, &corners).unwrap_or_else(|| vec![Vec2::ZERO; corners.len()]);
    let mut g = Corners {
        positions: flat,
        normals: pick(&mesh.normals, &corners).unwrap_or(face_normals),
        uvs,
        tangents: vec![Vec4::ZERO; corners.len()],
    };
    let tangents = generate_tangents(&mut g).is_ok().then_some(g.tangents);
    let mesh = MeshDesc {
        normals: pick(&mesh.normals, &corners),
        uvs: Some(g.uvs),
        uvs1: pick(&mesh.uvs1, &corners),
        colors: pick(&mesh.colors, &corners),
        tangents,
        indices: (0..corners.len() as u32).collect(),
        ..mesh
    };
    (mesh, world)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_upright_quad_gets_tangent_x_and_a_mirrored_one_flips_w() {
        // glTF UVs: v = 0 at the top of the image, so an upright texture has v falling with y.
        let quad = |u_sign: f32| MeshDesc {
            positions: vec![],
            normals: Some(vec![Vec3::Z; 4]),
            uvs: Some(vec![Vec2::ZERO, Vec2::new(u_sign, 0.0), Vec2::new(u_sign, -1.0), Vec2::new(0.0, -1.0)]),
            indices: vec![0, 1, 2, 0, 2, 3],
            ..MeshDesc::default()
        };
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        let (m, world) = generate(quad(1.0), p.clone());
        assert_eq!(world.len(), 6);
        for t in m.tangents.unwrap() {
            assert!((t.truncate() - Vec3::X).length() < 1e-5 && t.w == 1.0, "{t}");
        }
        let (m, _) = generate(quad(-1.0), p);
        for t in m.tangents.unwrap() {
            assert!((t.truncate() + Vec3::X).length() < 1e-5 && t.w == -1.0, "{t}");
        }
    }
}
