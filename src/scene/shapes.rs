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
