//! Procedural meshes for analytic tests (spheres for furnaces and enclosures).

use super::MeshDesc;
use glam::Vec3;
use std::f32::consts::PI;

/// A UV sphere of `stacks` x `slices` quads with smooth normals; its front faces point
/// outwards, or inwards when `inward` is set.
pub fn uv_sphere(center: Vec3, radius: f32, stacks: u32, slices: u32, inward: bool, material: u32) -> MeshDesc {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..=stacks {
        let theta = PI * i as f32 / stacks as f32;
        for j in 0..=slices {
            let phi = 2.0 * PI * j as f32 / slices as f32;
            let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            positions.push(center + radius * n);
            normals.push(if inward { -n } else { n });
        }
    }
    let row = slices + 1;
    let mut indices = Vec::new();
    for i in 0..stacks {
        for j in 0..slices {
            let (a, b, c, d) = (i * row + j, i * row + j + 1, (i + 1) * row + j + 1, (i + 1) * row + j);
            let mut quad = [a, b, c, a, c, d];
            if inward {
                quad = [a, c, b, a, d, c];
            }
            indices.extend_from_slice(&quad);
        }
    }
    MeshDesc { name: "sphere".into(), positions, normals: Some(normals), indices, material, ..MeshDesc::default() }
}

/// An axis-aligned box from `min` to `max` with flat faces (12 triangles); its front faces
/// point outwards, or inwards when `inward` is set.
pub fn cuboid(min: Vec3, max: Vec3, inward: bool, material: u32) -> MeshDesc {
    let corner = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    };
    let positions = (0..8).map(corner).collect();
    // Counter-clockwise seen from outside: -x, +x, -y, +y, -z, +z.
    let faces: [[u32; 4]; 6] = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let mut indices = Vec::new();
    for [a, b, c, d] in faces {
        let quad = if inward { [a, c, b, a, d, c] } else { [a, b, c, a, c, d] };
        indices.extend_from_slice(&quad);
    }
    MeshDesc { name: "box".into(), positions, indices, material, ..MeshDesc::default() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_faces_point_outwards() {
        let b = cuboid(Vec3::ZERO, Vec3::ONE, false, 0);
        let centre = Vec3::splat(0.5);
        for t in b.indices.chunks(3) {
            let p = [t[0], t[1], t[2]].map(|i| b.positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(n.dot(p[0] - centre) > 0.0, "face {t:?} points inwards");
        }
    }
}
